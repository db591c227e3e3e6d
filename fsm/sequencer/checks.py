"""The sequencer's checks over the whole tree, run by the check stage: what needs the enclosing sequences
(exception sequences named by monitors and timeouts, caller behaviours at the top level, Join and ResetTimeout
references, blocking steps that can never finish). Each finding is a located problem; nothing is changed."""

from __future__ import annotations

import difflib
import itertools
import operator
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from itertools import repeat
from typing import cast

from fsm.model.document import MachineSpec, SequenceLayout, StateSpec
from fsm.model.problems import Problems
from fsm.sequencer.layout import is_detached
from fsm.sequencer.steps import Call, Join, JoinParams, ResetTimeout, ResetTimeoutParams

#: Behaviours that act on the owner's caller (the state that contains it).
CALLER_BEHAVIORS = ("abortCallerOfOwner", "restartCallerOfOwner")


@dataclass(frozen=True)
class Enclosing:
    """A sequence around the state being checked, with its path."""

    spec: StateSpec
    path: str

    @property
    def layout(self) -> SequenceLayout:
        layout = self.spec.sequence
        assert layout is not None
        return layout


def check_sequences(root: MachineSpec, problems: Problems, can_finish: Callable[[StateSpec], bool]) -> None:
    """Check every state against the sequences that enclose it; ``can_finish`` tells whether a parsed state can
    ever finish (the check stage's, :func:`fsm.loading.outcomes.can_finish`)."""
    _walk(root, "", None, (), (), problems, can_finish)


def _walk(level: MachineSpec, prefix: str, caller: StateSpec | None, seqs: tuple[Enclosing, ...],
          using: tuple[str, ...], problems: Problems, can_finish: Callable[[StateSpec], bool]) -> None:
    """The states of ``level`` and the levels below it, checked against the sequences that enclose them. (A module
    function: a closure that calls itself is a reference cycle, left to the collector after every load.)"""
    for st in _to_walk(level.states):
        if issubclass(st.cls, Call):
            problems.add("a Call is a step of a Sequence: it runs a sequence declared in 'sequences'", st.source,
                         st.pointer, element=st.label, hint="put it in the steps of a Sequence")
        p = st.params
        if p.monitors is not None or p.timeout is not None or p.timeout_exception is not None \
                or "timeout_behavior" in p.model_fields_set:
            _check_state(problems, st, caller, seqs, using)
        if not st.subs:
            continue
        path = f"{prefix}/{st.id}" if prefix else st.id
        inner = seqs + (Enclosing(st, path),) if st.sequence is not None else seqs
        if st.sequence is not None:
            _check_steps(problems, st, seqs, can_finish)
        for i, sub in enumerate(st.subs):
            if sub.machine is None:
                continue
            now_using = using
            layout: SequenceLayout | None = st.sequence
            if layout is not None and i > len(layout.detached_after):
                now_using = using + (layout.exception_ids[i - 1 - len(layout.detached_after)],)
            _walk(sub.machine, path, st, inner, now_using, problems, can_finish)


_CLS = operator.attrgetter("cls")
_SUBS = operator.attrgetter("subs")
_PARAMS = operator.attrgetter("params")
_TIMED = operator.attrgetter("monitors", "timeout", "timeout_exception")
_FIELDS_SET = operator.attrgetter("__pydantic_fields_set__")


def _to_walk(states: list[StateSpec]) -> Iterable[StateSpec]:
    """The states of a level the walk must look at: all of them where one is a Call or has a monitor or a timeout
    key, else only those with regions (a plain level's states are passed over in C-speed steps)."""
    params = list(map(_PARAMS, states))
    if any(issubclass(cls, Call) for cls in set(map(_CLS, states))) or \
            list(map(_TIMED, params)).count((None, None, None)) != len(params) or \
            any(map(operator.contains, map(_FIELDS_SET, params), repeat("timeout_behavior"))):
        return states
    return itertools.compress(states, map(_SUBS, states))


def _check_state(problems: Problems, st: StateSpec, caller: StateSpec | None, seqs: tuple[Enclosing, ...],
                 using: tuple[str, ...]) -> None:
    """Exception sequences named by the state's monitors and timeout, and caller behaviours at the top level."""
    p = st.params
    own = (Enclosing(st, ""),) if st.sequence is not None else ()
    known = [eid for s in seqs + own for eid in s.layout.exception_ids]
    broken = {eid for s in seqs + own for eid in s.layout.broken_exception_ids}
    refs: list[tuple[str | None, str, str, bool]] = []  # (exception id, behavior, pointer, is the timeout)
    for i, m in enumerate(p.monitors or ()):
        refs.append((m.exception, m.behavior, f"{st.pointer}/monitors/{i}", False))
    if p.timeout is not None:
        refs.append((p.timeout_exception, p.timeout_behavior, st.pointer, True))
    else:
        for key in ("timeout_exception", "timeout_behavior"):
            if key in p.model_fields_set:
                problems.add(f"{key} without a timeout", st.source, f"{st.pointer}/{key}", element=st.label,
                             hint=f"add \"timeout\": SECONDS or remove {key}")
    for exc, behavior, ptr, is_timeout in refs:
        if exc is not None:
            key = "/timeout_exception" if is_timeout else "/exception"
            if exc in broken and exc not in known:
                continue  # declared, but it did not load: its own problems say why
            if exc not in known:
                close = difflib.get_close_matches(exc, known, n=2)
                hint = ("did you mean " + " or ".join(f"'{c}'" for c in close) + "?" if close else
                        "declare it in \"exceptions\" of this sequence or an enclosing one" if not known else
                        "exception sequences here: " + ", ".join(sorted(set(known))))
                problems.add(f"no exception sequence '{exc}'", st.source, ptr + key, element=st.label, hint=hint)
            elif exc in using:
                problems.add(f"exception sequence '{exc}' would start itself: it is used inside itself", st.source,
                             ptr + key, element=st.label,
                             hint="an exception sequence cannot be the exception of its own steps")
        if behavior in CALLER_BEHAVIORS and caller is None:
            key = "/timeout_behavior" if is_timeout else "/behavior"
            problems.add(f"'{behavior}' acts on the state that contains '{st.id}', but '{st.id}' is at the top "
                         "level: it has no caller", st.source, ptr + key, element=st.label,
                         hint="use abortOwner / restartOwner, or put it inside a sequence")


def _check_steps(problems: Problems, st: StateSpec, seqs: tuple[Enclosing, ...],
                 can_finish: Callable[[StateSpec], bool]) -> None:
    """Join and ResetTimeout references; blocking steps that can never finish."""
    layout = st.sequence
    assert layout is not None  # called for sequences only
    started: dict[str, bool] = {}  # non-blocking sequence ids placed before the current step, here and outside
    for holder in seqs:
        for step in holder.layout.steps:
            if is_detached(step):
                started.setdefault(step.id, True)
    blocking_ids = {s.id for holder in seqs for s in holder.layout.steps if not is_detached(s)}
    blocking_ids |= {s.id for s in layout.steps if not is_detached(s)}
    later = {s.id for s in layout.steps if is_detached(s)}
    for step in layout.steps:
        if is_detached(step):
            started[step.id] = True
            continue
        if issubclass(step.cls, Join):
            _check_join(problems, step, started, blocking_ids, later)
        if issubclass(step.cls, ResetTimeout):
            owner = cast(ResetTimeoutParams, step.params).owner  # a ResetTimeout's parameters are its Params
            target = _reset_target(owner, seqs, st)
            if target is None:
                problems.add(f"'owner' names no sequence or step: '{owner}'", step.source, step.pointer + "/owner",
                             element=step.label, hint="the id of this sequence, an enclosing one or one of their steps")
            elif target.params.timeout is None:
                problems.add(f"'{target.id}' has no timeout to reset", step.source, step.pointer + "/owner",
                             element=step.label, hint=f"give '{target.id}' a \"timeout\"")
        if not can_finish(step) and not step.params.endless and not _ended_from_outside(step, st, seqs):
            problems.add(f"step '{step.id}' ({step.type}) can never finish, so the sequence would stop there",
                         step.source, step.pointer, element=step.label,
                         hint="give it an \"until\" condition or a \"timeout\", a monitor that aborts or restarts "
                              "it, or say \"endless\": true when something outside ends it; or use a type that "
                              "finishes")


#: Behaviours by which a supervisor ends (or starts over) a state that would not finish by itself.
_ENDING = ("abortOwner", "restartOwner", "abortCallerOfOwner", "restartCallerOfOwner")


def _ended_from_outside(step: StateSpec, here: StateSpec, seqs: tuple[Enclosing, ...]) -> bool:
    """Whether a monitor or timeout with an ending behaviour watches the step, its sequence or an enclosing one
    (an Idle step watched by monitors, as in the thesis's delta-mouse and menu cases)."""
    for owner in (step, here, *(s.spec for s in seqs)):
        p = owner.params
        if p.timeout is not None and p.timeout_behavior in _ENDING:
            return True
        if any(m.behavior in _ENDING for m in p.monitors or ()):
            return True
    return False


def _check_join(problems: Problems, step: StateSpec, started: dict[str, bool], blocking_ids: set[str],
                later: set[str]) -> None:
    for i, name in enumerate(cast(JoinParams, step.params).sequences):  # a Join's parameters are its Params
        ptr = f"{step.pointer}/sequences/{i}"
        if name in started:
            continue
        if name in later:
            problems.add(f"the non-blocking sequence '{name}' starts after this Join, so the Join would wait for a "
                         "sequence that has not started", step.source, ptr, element=step.label,
                         hint=f"place the Join after '{name}' in the steps")
        elif name in blocking_ids:
            problems.add(f"'{name}' is a blocking step: it has finished before the Join is reached, so there is "
                         "nothing to wait for", step.source, ptr, element=step.label,
                         hint="Join names non-blocking sequences (\"blocking\": false)")
        else:
            close = difflib.get_close_matches(name, list(started), n=2)
            problems.add(f"no non-blocking sequence '{name}' starts before this Join", step.source, ptr,
                         element=step.label,
                         hint=("did you mean " + " or ".join(f"'{c}'" for c in close) + "?") if close else
                         "a Join waits for non-blocking sequences placed before it in this sequence or an "
                         "enclosing one")


def _reset_target(name: str, seqs: tuple[Enclosing, ...], here: StateSpec) -> StateSpec | None:
    """A ResetTimeout's owner: this sequence, an enclosing one, or a step of one of them, by id."""
    name = name.strip("/").split("/")[-1]  # an id, or a path ending in it
    for holder in [here] + [s.spec for s in reversed(seqs)]:
        if holder.id == name:
            return holder
        layout = holder.sequence
        assert layout is not None  # this sequence and the enclosing ones
        for step in layout.steps:
            if step.id == name:
                return step
    return None


__all__ = ["CALLER_BEHAVIORS", "check_sequences"]
