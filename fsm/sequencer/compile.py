"""The loader's side of sequences and the step-common keys: a ``Sequence``'s steps become a chain region (its
blocking steps linked by ``Finished`` transitions), its non-blocking sequences and exception sequences regions
of their own; monitors, timeouts, preconditions and exit conditions are checked and compiled; and once the
machine is built, references (exception sequences, Join, ResetTimeout, pause buttons) are bound.

Everything reported here is located (JSON pointer, and line:column through the loader) and found at load
time, never while the machine runs.
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from fsm.document import MachineSpec, StateSpec, TransitionSpec
from fsm.jsonpos import escape
from fsm.params import BEHAVIORS

if TYPE_CHECKING:
    from fsm.document import Source
    from fsm.machine import Machine
    from fsm.state import State

_CALLER = ("abortCallerOfOwner", "restartCallerOfOwner")
_ABORTS = ("abortOwner",)


@dataclass
class SequenceLayout:
    """Where a Sequence's regions come from: ``subs[0]`` the chain, then one per non-blocking sequence (with the
    index of the blocking step after which it starts, -1: at once), then one per exception sequence."""

    detached_after: list[int] = field(default_factory=list)
    detached_ids: list[str] = field(default_factory=list)
    exception_ids: list[str] = field(default_factory=list)
    #: every step spec in document order (blocking or not), with its pointer
    steps: list[StateSpec] = field(default_factory=list)
    exceptions: list[StateSpec] = field(default_factory=list)


@dataclass
class Watch:
    """A state's step-common keys, compiled: conditions as ``(holds(ctx), condition specs)``."""

    precondition: Any = None
    until: Any = None
    #: (holds, condition specs, MonitorParams, pointer) per monitor
    monitors: list[tuple[Any, list[Any], Any, str]] = field(default_factory=list)


# -- parsing --------------------------------------------------------------------------------------------------
def parse_sequence(loader: Any, spec: StateSpec, source: Source, ptr: str, depth: int) -> None:
    """Parse a Sequence's steps and exceptions into ``spec.subs`` and ``spec.sequence``."""
    params = spec.params
    layout = SequenceLayout()
    chain_states: list[StateSpec] = []
    detached: list[tuple[int, StateSpec, str]] = []
    first_at: dict[str, str] = {}
    complete = True

    def unique(st_id: Any, p: str) -> None:
        if not isinstance(st_id, str):
            return
        if st_id in first_at:
            loader._add(f"duplicate id '{st_id}' (first used at {first_at[st_id]})", source, p + "/id",
                        element=f"state '{st_id}'",
                        hint="the steps and exception sequences of one sequence need unique ids")
        else:
            first_at[st_id] = p

    for i, raw in enumerate(params.steps):  # type: ignore[attr-defined]
        p = f"{ptr}/steps/{i}"
        if not isinstance(raw, dict):
            loader._add("a step is a state element (an object with 'id' and 'type')", source, p,
                        element=f"sequence '{spec.id}'", hint='{"id": "wait", "type": "Wait", "seconds": 1}')
            complete = False
            continue
        unique(raw.get("id"), p)
        st = loader._parse_state(raw, source, p, depth + 1)
        if st is None:
            complete = False
            continue
        layout.steps.append(st)
        if getattr(st.cls, "compiles_steps", False) and getattr(st.params, "blocking", True) is False:
            detached.append((len(chain_states) - 1, st, p))
        else:
            chain_states.append(st)
    for i, raw in enumerate(getattr(params, "exceptions", None) or ()):
        p = f"{ptr}/exceptions/{i}"
        if not isinstance(raw, dict):
            loader._add("an exception sequence is a Sequence element", source, p, element=f"sequence '{spec.id}'")
            continue
        unique(raw.get("id"), p)
        st = loader._parse_state(raw, source, p, depth + 1)
        if st is None:
            continue
        if not getattr(st.cls, "compiles_steps", False):
            loader._add(f"an exception sequence must be a Sequence, not {st.cls.type_name}", source, p + "/type",
                        element=f"state '{st.id}'", hint='{"id": "recover", "type": "Sequence", "steps": [...]}')
            continue
        if getattr(st.params, "blocking", True) is False:
            loader._add("an exception sequence runs while its owner waits: it cannot be non-blocking", source,
                        p + "/blocking", element=f"state '{st.id}'", hint="remove \"blocking\": false")
        layout.exceptions.append(st)
    if not chain_states and complete:
        loader._add("a sequence needs at least one blocking step", source, ptr + "/steps",
                    element=f"sequence '{spec.id}'",
                    hint='end it with {"id": "join", "type": "Join", "sequences": [...]} to wait for its '
                         "non-blocking sequences")
    if not chain_states:
        spec.subs = []
        return
    finished = loader.registry.transitions.get("Finished")
    transitions: list[TransitionSpec] = []
    if finished is not None:
        for a, b in zip(chain_states, chain_states[1:]):
            tparams = finished.Params.model_validate({"type": "Finished", "from": a.id, "to": b.id})
            transitions.append(TransitionSpec(finished, tparams, b.pointer, source))
    chain = MachineSpec(source=source, pointer=ptr, name=None, initial=chain_states[0].id,
                        initial_pointer=ptr + "/steps", states=chain_states, transitions=transitions, vars={},
                        edges=[(a.id, b.id) for a, b in zip(chain_states, chain_states[1:])], complete=complete)
    subs: list[tuple[str | None, MachineSpec | None, str]] = [(None, chain, "")]
    for after, st, p in detached:
        subs.append((None, _single(st, source), p[len(ptr):]))
        layout.detached_after.append(after)
        layout.detached_ids.append(st.id)
    for st in layout.exceptions:
        subs.append((None, _single(st, source), st.pointer[len(ptr):]))
        layout.exception_ids.append(st.id)
    spec.subs = subs
    spec.sequence = layout


def _single(st: StateSpec, source: Source) -> MachineSpec:
    """A region holding one state (a non-blocking or exception sequence)."""
    return MachineSpec(source=source, pointer=st.pointer, name=None, initial=st.id, initial_pointer=st.pointer,
                       states=[st], transitions=[], vars={}, edges=[], complete=True)


# -- outcomes -------------------------------------------------------------------------------------------------
def extra_outcomes(params: Any) -> set[str]:
    """Outcomes the step-common keys add to what a state's type can finish with."""
    out: set[str] = set()
    if getattr(params, "precondition", None) is not None:
        out.add("precondition_failed")
    if getattr(params, "until", None) is not None:
        out.add("succeeded")
    for m in getattr(params, "monitors", None) or ():
        if m.behavior == "abortOwner":
            out.add("aborted")
    if getattr(params, "timeout", None) is not None and params.timeout_behavior == "abortOwner":
        out.add("timeout")
    return out


def child_outcomes(st: StateSpec) -> set[str]:
    """Outcomes a composite gets from its children's ``...CallerOfOwner`` aborts."""
    out: set[str] = set()
    for _name, sub, _ in st.subs:
        for child in sub.states if sub is not None else ():
            p = child.params
            if any(m.behavior == "abortCallerOfOwner" for m in getattr(p, "monitors", None) or ()):
                out.add("aborted")
            if getattr(p, "timeout", None) is not None and p.timeout_behavior == "abortCallerOfOwner":
                out.add("timeout")
    return out


# -- checks over the whole tree -----------------------------------------------------------------------------
def check_tree(loader: Any, root: MachineSpec) -> None:
    """What needs the enclosing sequences: exception names, caller behaviours, Join, ResetTimeout, steps that
    can never finish."""

    def walk(level: MachineSpec, prefix: str, caller: StateSpec | None, seqs: list[tuple[StateSpec, str]],
             using: tuple[str, ...]) -> None:
        for st in level.states:
            path = f"{prefix}/{st.id}" if prefix else st.id
            _check_state(loader, st, path, caller, seqs, using)
            inner = seqs + [(st, path)] if st.sequence is not None else seqs
            if st.sequence is not None:
                _check_steps(loader, st, path, seqs)
            for i, (_name, sub, _) in enumerate(st.subs):
                if sub is None:
                    continue
                now_using = using
                if st.sequence is not None and i > len(st.sequence.detached_after):
                    now_using = using + (st.sequence.exception_ids[i - 1 - len(st.sequence.detached_after)],)
                walk(sub, path, st, inner, now_using)

    walk(root, "", None, [], ())


def _check_state(loader: Any, st: StateSpec, path: str, caller: StateSpec | None,
                 seqs: list[tuple[StateSpec, str]], using: tuple[str, ...]) -> None:
    p = st.params
    known = [eid for s, _ in seqs + ([(st, path)] if st.sequence is not None else [])
             for eid in s.sequence.exception_ids]
    refs: list[tuple[str, str, str]] = []  # (exception id, behavior, pointer)
    for i, m in enumerate(getattr(p, "monitors", None) or ()):
        refs.append((m.exception, m.behavior, f"{st.pointer}/monitors/{i}"))
    if getattr(p, "timeout", None) is not None:
        refs.append((p.timeout_exception, p.timeout_behavior, st.pointer))
    elif getattr(p, "timeout_exception", None) is not None:
        loader._add("timeout_exception without a timeout", st.source, st.pointer + "/timeout_exception",
                    element=f"state '{st.id}'", hint="add \"timeout\": SECONDS or remove timeout_exception")
    for exc, behavior, ptr in refs:
        is_timeout = ptr == st.pointer
        if exc is not None:
            key = "/timeout_exception" if is_timeout else "/exception"
            if exc not in known:
                close = difflib.get_close_matches(exc, known, n=2)
                hint = ("did you mean " + " or ".join(f"'{c}'" for c in close) + "?" if close else
                        "declare it in \"exceptions\" of this sequence or an enclosing one" if not known else
                        "exception sequences here: " + ", ".join(sorted(set(known))))
                loader._add(f"no exception sequence '{exc}'", st.source, ptr + key, element=f"state '{st.id}'",
                            hint=hint)
            elif exc in using:
                loader._add(f"exception sequence '{exc}' would start itself: it is used inside itself",
                            st.source, ptr + key, element=f"state '{st.id}'",
                            hint="an exception sequence cannot be the exception of its own steps")
        if behavior in _CALLER and caller is None:
            key = "/timeout_behavior" if is_timeout else "/behavior"
            loader._add(f"'{behavior}' acts on the state that contains '{st.id}', but '{st.id}' is at the top "
                        "level: it has no caller", st.source, ptr + key, element=f"state '{st.id}'",
                        hint="use abortOwner / restartOwner, or put it inside a sequence")


def _check_steps(loader: Any, st: StateSpec, path: str, seqs: list[tuple[StateSpec, str]]) -> None:
    """Join and ResetTimeout references; blocking steps that can never finish."""
    layout: SequenceLayout = st.sequence
    started: dict[str, bool] = {}  # non-blocking sequence ids placed before the current step, here and outside
    for holder, _ in seqs:
        for step in holder.sequence.steps:
            if getattr(step.params, "blocking", True) is False:
                started.setdefault(step.id, True)
    blocking_ids = {s.id for s, _ in seqs for s in s.sequence.steps} | {s.id for s in layout.steps}
    for step in layout.steps:
        cls = step.cls
        p = step.params
        if getattr(cls, "compiles_steps", False) and getattr(p, "blocking", True) is False:
            started[step.id] = True
            continue
        if cls.type_name == "Join":
            for i, name in enumerate(p.sequences):  # type: ignore[attr-defined]
                ptr = f"{step.pointer}/sequences/{i}"
                if name in started:
                    continue
                if name in blocking_ids:
                    loader._add(f"'{name}' is a blocking step: it has finished before the Join is reached, so "
                                "there is nothing to wait for", step.source, ptr, element=f"state '{step.id}'",
                                hint="Join names non-blocking sequences (\"blocking\": false)")
                else:
                    close = difflib.get_close_matches(name, list(started), n=2)
                    loader._add(f"no non-blocking sequence '{name}' starts before this Join", step.source, ptr,
                                element=f"state '{step.id}'",
                                hint=("did you mean " + " or ".join(f"'{c}'" for c in close) + "?") if close else
                                "a Join waits for non-blocking sequences placed before it in this sequence or "
                                "an enclosing one")
        if cls.type_name == "ResetTimeout":
            target = _resolve(p.owner, path, seqs, st)  # type: ignore[attr-defined]
            if target is None:
                loader._add(f"'owner' names no sequence or step: '{p.owner}'", step.source,  # type: ignore[attr-defined]
                            step.pointer + "/owner", element=f"state '{step.id}'",
                            hint="the id of this sequence, an enclosing one or one of their steps")
            elif getattr(target.params, "timeout", None) is None:
                loader._add(f"'{target.id}' has no timeout to reset", step.source, step.pointer + "/owner",
                            element=f"state '{step.id}'", hint=f"give '{target.id}' a \"timeout\"")
        if not _can_finish(loader, step):
            loader._add(f"step '{step.id}' ({cls.type_name}) can never finish, so the sequence would stop there",
                        step.source, step.pointer, element=f"state '{step.id}'",
                        hint="give it an \"until\" condition or a \"timeout\", or use a type that finishes")


def _resolve(name: str, path: str, seqs: list[tuple[StateSpec, str]], here: StateSpec) -> StateSpec | None:
    """A ResetTimeout's owner: this sequence, an enclosing one, or a step of one of them, by id."""
    name = name.strip("/").split("/")[-1]  # an id, or a path ending in it
    for holder in [here] + [s for s, _ in reversed(seqs)]:
        if holder.id == name:
            return holder
        for step in holder.sequence.steps:
            if step.id == name:
                return step
    return None


def _can_finish(loader: Any, st: StateSpec) -> bool:
    if st.cls.is_final:
        return True
    outcomes = loader.outcomes(st)
    return outcomes is None or bool(outcomes)


# -- compiling conditions -------------------------------------------------------------------------------------
def compile_watch(loader: Any, st: StateSpec, kinds: dict[str, str], paths: set[str], scope: str) -> None:
    """Compile a state's precondition, until and monitor conditions (expressions or condition objects)."""
    p = st.params
    if all(getattr(p, key, None) is None for key in ("precondition", "until", "monitors", "timeout")):
        return
    watch = Watch()
    element = f"state '{st.id}'"
    ok = True

    def cond(raw: Any, ptr: str) -> Any:
        nonlocal ok
        from fsm import expr as E

        if isinstance(raw, str):
            c = loader._compile(raw, kinds, st.source, ptr, element, E.BOOL)
            if c is None:
                ok = False
                return None
            if c.constant and c.value is False and ptr.endswith("/until"):
                loader._add("the exit condition is always false, so the state can never finish", st.source, ptr,
                            element=element, hint="correct the condition")
                ok = False
                return None
            return E.on_context(c.fn), []
        cs = loader._parse_condition(raw, st.source, ptr, element, kinds, paths, scope, 0)
        if cs is None:
            ok = False
            return None
        return None, [cs]

    if p.precondition is not None:
        watch.precondition = cond(p.precondition, st.pointer + "/precondition")
    if p.until is not None:
        watch.until = cond(p.until, st.pointer + "/until")
    for i, m in enumerate(p.monitors or ()):
        ptr = f"{st.pointer}/monitors/{i}"
        c = cond(m.condition, ptr + "/condition")
        if c is not None:
            watch.monitors.append((c[0], c[1], m, ptr))
    if ok:
        st.watch = watch


def assignments(st: StateSpec) -> list[tuple[str, Any, str]]:
    """A SetVar's ``assign`` as (variable, value, pointer): compiled like a ``set.on_enter``."""
    if st.cls.type_name != "SetVar":
        return []
    items = st.params.assign  # type: ignore[attr-defined]
    return [(name, value, f"{st.pointer}/assign/{escape(name)}") for name, value in items.items()]


def condition_specs(st: StateSpec) -> list[Any]:
    """The condition objects of a state's step-common keys (for ``signal_names``)."""
    w = st.watch
    if w is None:
        return []
    out: list[Any] = []
    for c in (w.precondition, w.until):
        if c is not None:
            out.extend(c[1])
    for _holds, specs, _m, _p in w.monitors:
        out.extend(specs)
    return out


# -- building -------------------------------------------------------------------------------------------------
def build_state(obj: State, st: StateSpec, machine_regions: list[Any]) -> None:
    """Give a freshly built state its watcher and exit condition (before ``_prepare``)."""
    from .watch import Monitor, Watcher

    if st.sequence is not None:
        layout: SequenceLayout = st.sequence
        obj.adopt(list(obj.regions), layout.detached_after, layout.exception_ids)  # type: ignore[attr-defined]
    w = st.watch
    if w is None:
        return
    if w.until is not None:
        holds, conds = _built(w.until)
        obj._until = (holds, conds)
    monitors: list[Monitor] = []
    p = st.params
    if p.timeout is not None:
        m = Monitor(None, p.timeout_behavior, p.timeout_exception, f"timeout {p.timeout:g} s", kind="timeout")
        monitors.append(m)
    for holds, specs, mp, _ptr in w.monitors:
        fn, conds = _built((holds, specs))
        label = mp.description or (mp.condition if isinstance(mp.condition, str) else
                                   str(mp.condition.get("type", "condition")))
        monitors.append(Monitor(fn, mp.behavior, mp.exception, label, conditions=tuple(conds)))
    pre, pre_conds = _built(w.precondition) if w.precondition is not None else (None, [])
    if monitors or pre is not None:
        watcher = Watcher(obj, monitors, pre, tuple(pre_conds), p.timeout)
        for m in monitors:
            if m.kind == "timeout":
                m.holds = watcher.timed_out
        obj._watcher = watcher
        obj._watch = watcher.check


def _built(compiled: tuple[Any, list[Any]]) -> tuple[Any, list[Any]]:
    """``(holds(ctx), condition instances)`` from a compiled condition (an expression or a condition spec)."""
    holds, specs = compiled
    if holds is not None:
        return holds, []
    cond = specs[0].build()
    return cond.holds, [cond]


def bind(machine: Machine, specs: dict[str, StateSpec]) -> None:
    """After the whole machine is built: monitors find their exception sequences, caller behaviours get a
    watcher on the caller, Join and ResetTimeout their targets, pause buttons their edges, conditions their owner."""
    from .watch import Watcher

    by_path = machine.states_by_path
    for path, obj in by_path.items():
        st = specs.get(path)
        w = obj._watcher
        if w is not None:
            w.machine = machine
            for c in w.pre_conditions:
                c.bind(machine, obj)
            for m in w.monitors:
                for c in m.conditions:
                    c.bind(machine, obj)
                if m.exception_id is not None:
                    m.exception = _exception_region(obj, m.exception_id)
                if m.behavior in _CALLER:
                    caller = obj.region.owner if obj.region is not None else None
                    if caller is not None and caller._watcher is None:
                        caller._watcher = Watcher(caller, [])
                        caller._watcher.machine = machine
                        caller._watch = caller._watcher.check
                        caller._prepare()
        if obj._until is not None:
            for c in obj._until[1]:
                c.bind(machine, obj)
        type_name = obj.type_name
        if type_name == "Join":
            holders = []
            for name in obj.params.sequences:  # type: ignore[attr-defined]
                holder = _enclosing(obj)
                while holder is not None and name not in [r.initial.id for _, r in holder.detached]:
                    holder = _enclosing(holder)
                if holder is not None:
                    holders.append((holder, name))
            obj.holders = holders  # type: ignore[attr-defined]
        elif type_name == "ResetTimeout":
            name = obj.params.owner.strip("/").split("/")[-1]  # type: ignore[attr-defined]
            seq = _enclosing(obj)
            target = None
            while seq is not None and target is None:
                if seq.id == name:
                    target = seq
                else:
                    target = seq.chain.states.get(name) if seq.chain is not None else None  # type: ignore[attr-defined]
                    if target is None:
                        target = next((r.initial for _, r in seq.detached if r.initial.id == name), None)  # type: ignore[attr-defined]
                seq = _enclosing(seq)
            obj.target = target  # type: ignore[attr-defined]
        pause = getattr(obj.params, "pause_signal", None)
        if pause:
            machine._toggles.append((_rising(machine, pause, obj.params.pause_debounce), obj))  # type: ignore[attr-defined]
        del st


def _enclosing(state: State) -> Any:
    """The nearest Sequence that contains ``state``."""
    region = state.region
    while region is not None and region.owner is not None:
        owner = region.owner
        if getattr(owner, "compiles_steps", False):
            return owner
        region = owner.region
    return None


def _exception_region(state: State, name: str) -> Any:
    seq: Any = state if getattr(state, "compiles_steps", False) else _enclosing(state)
    while seq is not None:
        if name in seq.exceptions:
            return seq.exceptions[name]
        seq = _enclosing(seq)
    return None


def _rising(machine: Machine, name: str, debounce: float) -> Any:
    """A detector of the signal's rising edges (debounced), each counted once."""
    from fsm.debounce import Debounced

    ctx = machine.ctx
    history = ctx.watch_signal(name)
    filt = Debounced(history, debounce)
    last = [False]

    def edge(ctx: Any) -> bool:
        level = filt.advance(ctx._now)
        rose = level and not last[0]
        last[0] = level
        return rose
    return edge


__all__ = ["BEHAVIORS", "SequenceLayout", "Watch", "bind", "build_state", "check_tree", "compile_watch",
           "parse_sequence"]
