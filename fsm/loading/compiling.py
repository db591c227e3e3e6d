"""Compiling, the fourth load stage: a checked document and its analysis become a :class:`~fsm.model.plan.MachinePlan`.

Nothing here reports a problem: checking has found them all, and a document with errors is never compiled. What
this stage decides is how each part will run: the order in which a state's transitions are checked, each
transition's guard kind, each state's hooks and supervision, the initial blackboard, and what a runner asks
before building (does it need a car, which files and signals does it use).
"""

from __future__ import annotations

import weakref
from collections.abc import Iterable
from typing import Any

from fsm.loading.checking import Analysis, conditions_of, signal_names
from fsm.model import expr as E
from fsm.model.document import ConditionSpec, MachineSpec, Source, StateSpec, TransitionSpec
from fsm.model.jsonpos import escape
from fsm.model.plan import (
    NOTHING,
    Action,
    ConditionPlan,
    GuardPlan,
    MachinePlan,
    MonitorPlan,
    Predicate,
    RegionPlan,
    StatePlan,
    SupervisionPlan,
    TransitionPlan,
)


def compile_machine(spec: MachineSpec, analysis: Analysis) -> MachinePlan:
    """The plan of a checked document without errors."""
    compiler = _Compiler(analysis)
    root = compiler.region(spec, spec.name or "", "")
    return MachinePlan(
        name=spec.name or "",
        root=root,
        variables=compiler.variables,
        spec=spec,
        car_users=tuple(compiler.car_users),
        files=_files(spec) if compiler.nested else (spec.source.name,) if spec.source.name else (),
        signals=frozenset(signal_names(spec)) if compiler.mixed else frozenset(),
    )


class _Compiler:
    def __init__(self, analysis: Analysis) -> None:
        self.analysis = analysis
        self.variables: dict[str, Any] = {}
        self.car_users: list[str] = []
        #: whether any state has sub-machines (else the document's one level is its only file)
        self.nested = False
        #: whether a state or transition class is plain (``_plain_class``; a transition class: no car, no signal
        #: parameters), by class
        self.plain: dict[type[Any], bool] = {}
        #: whether any element took the long way: only then can the machine read a signal
        self.mixed = False

    def region(self, spec: MachineSpec, name: str, prefix: str) -> RegionPlan:
        for key, value in spec.vars.items():
            self.variables.setdefault(key, value)
        # The 1000-state ring is 2,000 elements of one kind each: a plain transition (no guard, set, conditions or
        # car or signal) and a plain state (see ``_plain_class``) are made here, in the level's loop, as tuples (a
        # NamedTuple's ``__new__`` is a Python call per element); anything else by ``transition`` and ``state``.
        regular: dict[str, tuple[TransitionPlan, ...]] = {}
        preempt: dict[str, tuple[TransitionPlan, ...]] = {}
        ordered = False
        plain = self.plain
        for index, tr in enumerate(spec.transitions):
            p = tr.params
            # the parameters' fields read from their dict: a pydantic model's attribute read is not specialised by
            # the interpreter (the model class defines __getattr__), a dict's item is
            f = p.__dict__
            cls = tr.cls
            is_plain = plain.get(cls)
            if is_plain is None:
                is_plain = plain[cls] = not (cls.needs_car or cls.signal_refs)
            if is_plain and f["guard"] is None and f["set"] is None and not tr.conditions:
                plan = _tuple(TransitionPlan, (cls, p, f["from_"], f["to"], index, _NO_GUARD, None, None, NOTHING))
            else:
                plan = self.transition(tr, index, prefix)
                self.mixed = True
            out = preempt if f["preempt"] else regular
            before = out.get(f["from_"])
            out[f["from_"]] = (plan,) if before is None else before + (plan,)
            if f["priority"] != 0:
                ordered = True
        if ordered:  # by priority, higher first; stable: declaration order within a priority
            regular = {key: tuple(sorted(plans, key=_priority)) for key, plans in regular.items()}
            preempt = {key: tuple(sorted(plans, key=_priority)) for key, plans in preempt.items()}
        states = []
        for st in spec.states:
            sid, cls, params = st.id, st.cls, st.params
            is_plain = plain.get(cls)
            if is_plain is None:
                is_plain = plain[cls] = _plain_class(cls)
            f = params.__dict__  # as for transitions
            if is_plain and not st.conditions and not st.subs and f["set"] is None and f["timeout"] is None \
                    and f["precondition"] is None and f["until"] is None and f["monitors"] is None:
                states.append(_tuple(StatePlan, (cls, params, sid, f"{prefix}/{sid}" if prefix else sid, None, None,
                                                 None, (), st.sequence, preempt.get(sid, ()), regular.get(sid, ()),
                                                 None, NOTHING)))
            else:
                states.append(self.state(st, prefix, regular.get(sid, ()), preempt.get(sid, ())))
                self.mixed = True
        return RegionPlan(name, prefix, tuple(states), spec.initial)

    def state(self, st: StateSpec, prefix: str, regular: tuple[TransitionPlan, ...],
              preempt: tuple[TransitionPlan, ...]) -> StatePlan:
        path = f"{prefix}/{st.id}" if prefix else st.id
        cls, params = st.cls, st.params
        if cls.needs_car:
            self.car_users.append(f"'{path}' ({st.type})")
        if st.conditions:
            self._car_conditions(conditions_of(st.conditions), f"'{path}'")
        regions = tuple([self.region(sub.machine, sub.name or st.id, f"{path}/{sub.name}" if sub.name else path)
                         for sub in st.subs if sub.machine is not None]) if st.subs else ()
        if regions:
            self.nested = True
        on_enter = on_exit = on_complete = None
        if params.set is not None or cls.assignment_fields:
            on_enter = self.assigner(st.source, self.entry_assignments(st))
            on_exit = self.assigner(st.source, self.set_assignments(st, "on_exit"))
            on_complete = self.assigner(st.source, self.set_assignments(st, "on_complete"))
        checks = {key: self.predicate(st, key, getattr(params, key)) for key in cls.condition_fields
                  if getattr(params, key, None) is not None} if cls.condition_fields else NOTHING
        supervision = None
        if params.precondition is not None or params.until is not None or params.monitors is not None \
                or params.timeout is not None:
            supervision = self.supervision(st)
        return StatePlan(cls, params, st.id, path, on_enter, on_exit, supervision, regions, st.sequence,
                         preempt, regular, on_complete, checks)

    def set_assignments(self, st: StateSpec, hook: str) -> list[tuple[str, str]]:
        """``(variable, pointer)`` of the state's ``set.<hook>``."""
        sets = st.params.set
        items = (getattr(sets, hook) or {}) if sets is not None else {}
        return [(name, f"{st.pointer}/set/{hook}/{escape(name)}") for name in items]

    def entry_assignments(self, st: StateSpec) -> list[tuple[str, str]]:
        """``(variable, pointer)`` of what runs on entry: ``set.on_enter``, then the type's assignment parameters."""
        sets = st.params.set
        out = [(name, f"{st.pointer}/set/on_enter/{escape(name)}") for name in ((sets.on_enter or {}) if sets else {})]
        for key in st.cls.assignment_fields:
            out += [(name, f"{st.pointer}/{key}/{escape(name)}") for name in getattr(st.params, key)]
        return out

    def assigner(self, source: Source, targets: list[tuple[str, str]]) -> Action | None:
        if not targets:
            return None
        pairs = [(name, self.analysis.expression(source, ptr)) for name, ptr in targets]
        action = E.assigner(pairs)
        ACTIONS[action] = tuple(pairs)
        return action

    def transition(self, tr: TransitionSpec, index: int, prefix: str) -> TransitionPlan:
        p = tr.params
        if tr.cls.needs_car:
            self.car_users.append(f"{_join(prefix, p.from_)} -> {_join(prefix, p.to)} ({tr.type})")
        if tr.conditions:
            self._car_conditions(conditions_of(tr.conditions), f"{_join(prefix, p.from_)} -> {_join(prefix, p.to)}")
        guard = _NO_GUARD
        if p.guard is not None:
            if isinstance(p.guard, str):
                guard = GuardPlan(expression=self.analysis.expression(tr.source, tr.pointer + "/guard"))
            elif "guard" in tr.conditions:
                guard = GuardPlan(condition=self.condition(tr.conditions["guard"], tr.source))
        if p.set is None and not tr.conditions:
            return TransitionPlan(tr.cls, p, p.from_, p.to, index, guard)
        targets = [(name, f"{tr.pointer}/set/{escape(name)}") for name in (p.set or {})]
        counter = None
        if len(targets) == 1:
            form = self.analysis.expression(tr.source, targets[0][1]).counter()
            counter = None if form is None else (targets[0][0], form)
        return TransitionPlan(
            cls=tr.cls, params=p, source=p.from_, target=p.to, position=index, guard=guard,
            assign=self.assigner(tr.source, targets), counter=counter,
            conditions={key: self.condition(cs, tr.source) for key, cs in tr.conditions.items() if key != "guard"},
        )

    def condition(self, cs: ConditionSpec, source: Source) -> ConditionPlan:
        return ConditionPlan(
            cls=cs.cls, params=cs.params, children=tuple(self.condition(c, source) for c in cs.children),
            exprs={key: self.analysis.expression(source, f"{cs.pointer}/{key}") for key in cs.cls.expr_fields})

    def predicate(self, st: StateSpec, key: str, raw: Any) -> Predicate:
        """A step condition: an expression, or a condition object."""
        if isinstance(raw, str):
            return self.analysis.expression(st.source, f"{st.pointer}/{key}")
        return self.condition(st.conditions[key], st.source)

    def supervision(self, st: StateSpec) -> SupervisionPlan | None:
        """The step-common keys: precondition, exit condition, monitors (the timeout first)."""
        p = st.params
        if p.precondition is None and p.until is None and p.monitors is None and p.timeout is None:
            return None
        monitors: list[MonitorPlan] = []
        timeout: float | E.Compiled | None = None
        if isinstance(p.timeout, str):
            timeout = self.analysis.expression(st.source, st.pointer + "/timeout")
            label = f"timeout {p.timeout} s"
        elif p.timeout is not None:
            timeout = p.timeout
            label = f"timeout {p.timeout:g} s"
        if timeout is not None:
            monitors.append(MonitorPlan(None, p.timeout_behavior, p.timeout_exception, label, kind="timeout"))
        for i, m in enumerate(p.monitors or ()):
            label = m.description or (m.condition if isinstance(m.condition, str) else
                                      str(m.condition.get("type", "condition")))
            monitors.append(MonitorPlan(self.predicate(st, f"monitors/{i}/condition", m.condition), m.behavior,
                                        m.exception, label))
        return SupervisionPlan(
            precondition=None if p.precondition is None else self.predicate(st, "precondition", p.precondition),
            until=None if p.until is None else self.predicate(st, "until", p.until),
            monitors=tuple(monitors),
            timeout=timeout,
        )

    def _car_conditions(self, conditions: Iterable[ConditionSpec], where: str) -> None:
        for cs in conditions:
            if getattr(cs.cls, "needs_car", False):
                self.car_users.append(f"{where} (condition {cs.type})")


#: Each compiled action of a plan with the ``(variable, expression)`` pairs it runs: how the plan cache stores an
#: action as data (``E.assigner`` of the pairs makes it again), never as code.
ACTIONS: weakref.WeakKeyDictionary[Action, tuple[tuple[str, E.Compiled], ...]] = weakref.WeakKeyDictionary()
_NO_GUARD = GuardPlan()
#: A plan record made from its fields in order, without the NamedTuple's ``__new__`` (a Python call).
_tuple = tuple.__new__


def _files(spec: MachineSpec) -> tuple[str, ...]:
    """Every file the machine was read from, each once: its own and its includes."""
    return tuple(dict.fromkeys(level.source.name for level in spec.levels() if level.source.name))


def _plain_class(cls: type[Any]) -> bool:
    """Whether a state of class ``cls`` without subs, conditions, ``set`` or step keys compiles to a plain plan: no
    car, no signal, assignment or condition parameters."""
    return not (cls.needs_car or cls.signal_refs or cls.assignment_fields or cls.condition_fields)


def _priority(t: TransitionPlan) -> int:
    return -t.params.priority


def _join(prefix: str, sid: str) -> str:
    return f"{prefix}/{sid}" if prefix else sid


__all__ = ["ACTIONS", "compile_machine"]
