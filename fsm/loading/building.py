"""Building, the last load stage: a :class:`~fsm.model.plan.MachinePlan` becomes a running
:class:`~fsm.runtime.machine.Machine`.

Every state, region and transition is instantiated from the plan; references between them (exception
sequences, a Join's sequences, ``InState``'s state, conditions' owners) are bound once all exist; then each
state's hooks are sealed. Nothing here reports a document problem, except a machine that drives a car built
without one.
"""

from __future__ import annotations

from typing import Any

from fsm.model import expr as E
from fsm.model.errors import DiagramError, Problem
from fsm.model.plan import ConditionPlan, MachinePlan, Predicate, RegionPlan, StatePlan, TransitionPlan
from fsm.runtime.composite import Composite
from fsm.runtime.condition import Condition
from fsm.runtime.context import Context
from fsm.runtime.machine import Machine
from fsm.runtime.region import (
    Region,
    StateWiring,
    TransitionWiring,
    Until,
    new_state,
    new_transition,
    sealed_as_made,
    wiring,
)
from fsm.runtime.state import State, state_binds_references
from fsm.runtime.supervisor import Monitor, Supervisor, supervisor_of
from fsm.runtime.transition import transition_binds_references
from fsm.sequencer.checks import CALLER_BEHAVIORS


def build(plan: MachinePlan, *, clock: Any = None, car: Any = None, context: Context | None = None) -> Machine:
    """A fresh machine from ``plan`` (a plan builds any number of independent machines)."""
    ctx = context if context is not None else Context(car=car)
    for key, value in plan.variables.items():
        ctx.vars.setdefault(key, value)
    if ctx.car is None and plan.needs_car:
        users = plan.car_users
        names = ", ".join(users[:5]) + (" ..." if len(users) > 5 else "")
        raise DiagramError([Problem(f"this machine drives a car ({names}) but no car was given",
                                    plan.spec.source.name, hint="run it with `fsmctl run FILE --world WORLD`, "
                                    "or in Python with fsm.run(FILE) (it drives the simulated car "
                                    "in the default world)")])
    builder = _Builder()
    root = builder.region(plan.root, None)
    machine = Machine(root, name=plan.name, clock=clock, context=ctx, all_regions=builder.regions,
                      states_by_path=builder.states)
    builder.bind(machine)
    return machine


class _Builder:
    def __init__(self) -> None:
        self.states: dict[str, State[Any]] = {}
        self.regions: list[Region] = []
        #: each state's record, in build order (for binding)
        self.built: list[StateWiring] = []
        #: the states with a supervisor
        self.supervised: list[tuple[State[Any], StatePlan]] = []
        #: each condition object with the state it belongs to
        self.conditions: list[tuple[Condition[Any], State[Any]]] = []
        #: whether each state and transition class built overrides ``bind`` (noted on its first element: the bind
        #: pass runs only if one does)
        self.binds: dict[type[Any], bool] = {}
        #: whether each state class built is sealed as its record is made (``sealed_as_made``)
        self.sealed: dict[type[Any], bool] = {}
        #: the records to seal: all but those of plain states, made sealed (see ``sealed_as_made``)
        self.sealing: list[StateWiring] = []

    def region(self, plan: RegionPlan, owner: State[Any] | None) -> Region:
        # One loop per level, the plan records unpacked rather than read field by field (a NamedTuple's field is a
        # descriptor call): a plain state (no regions, hooks, checks or supervision) costs its two objects and no
        # further call; anything else is dressed by ``state``.
        states: dict[str, State[Any]] = {}
        by_path = self.states
        built = self.built
        binds = self.binds
        sealed = self.sealed
        sealing = self.sealing
        leaving = []  # (record, preemptive, regular, queued for sealing) of each state with transitions
        for sp in plan.states:
            cls, params, sid, path, on_enter, on_exit, sup, regions, _seq, preempt, regular, on_complete, checks = sp
            record = new_state(cls, sid, params, path)
            states[sid] = by_path[path] = record.state
            built.append(record)
            if cls not in binds:
                binds[cls] = state_binds_references(record.state)
                sealed[cls] = sealed_as_made(cls)
            queued = True  # for sealing
            if regions or checks or sup is not None or on_enter is not None or on_exit is not None \
                    or on_complete is not None:
                self.state(record, sp)
            elif sealed[cls] and not preempt and len(regular) <= 1:
                queued = False
            if queued:
                sealing.append(record)
            if preempt or regular:
                leaving.append((record, preempt, regular, queued))
        region = Region(plan.name, plan.path, states, states[plan.initial])
        region.owner = owner
        self.regions.append(region)
        transition = self.transition
        for source, preempt, regular, queued in leaving:
            if len(regular) == 1 and not preempt:
                # one transition out of a state is the usual case: built without a comprehension's frame
                only = transition(regular[0], states)
                source.regular = (only,)
                source.transitions = (only.transition,)
                if only.arm is not None and not queued:
                    sealing.append(source)
                continue
            source.regular = tuple([transition(tp, states) for tp in regular])
            source.preempt = tuple([transition(tp, states) for tp in preempt])
            source.transitions = tuple([t.transition for t in sorted(source.preempt + source.regular, key=_position)])
        return region

    def state(self, record: StateWiring, plan: StatePlan) -> None:
        """What a state has beyond its object and record: its regions, ``set`` actions, checks and supervision."""
        obj = record.state
        if plan.regions:
            regions = [self.region(rp, obj) for rp in plan.regions]
            assert isinstance(obj, Composite)  # only composites have regions
            obj.attach_regions(regions, plan)
        if plan.on_enter is not None or plan.on_exit is not None or plan.on_complete is not None:
            record.entry_action = plan.on_enter
            record.exit_action = plan.on_exit
            record.complete_action = plan.on_complete
        if plan.checks:
            resets: list[Condition[Any]] = []
            predicates = {}
            for key, check in plan.checks.items():
                holds, conditions = self.predicate(check, obj)
                predicates[key] = holds
                resets.extend(conditions)
            obj.predicates = predicates
            record.resets = tuple(resets)
        sup = plan.supervision
        if sup is not None:
            if sup.until is not None:
                holds, conditions = self.predicate(sup.until, obj)
                record.until = Until(holds, conditions)
            if sup.watches:
                self.supervise(obj, plan)
                self.supervised.append((obj, plan))

    def supervise(self, obj: State[Any], plan: StatePlan) -> None:
        sup = plan.supervision
        assert sup is not None
        monitors: list[Monitor] = []
        for mp in sup.monitors:
            holds, conditions = self.predicate(mp.condition, obj) if mp.condition is not None else (_never, ())
            monitors.append(Monitor(holds, mp.behavior, mp.exception, mp.label, kind=mp.kind, conditions=conditions))
        pre, pre_conditions = self.predicate(sup.precondition, obj) if sup.precondition is not None else (None, ())
        timeout = sup.timeout
        supervisor = Supervisor(obj, monitors, pre, pre_conditions,
                                E.on_context(timeout) if isinstance(timeout, E.Compiled) else timeout)
        for m in monitors:
            if m.kind == "timeout":
                m.holds = supervisor.timed_out
        wiring(obj).supervisor = supervisor

    def predicate(self, check: Predicate, owner: State[Any]) -> tuple[Any, tuple[Condition[Any], ...]]:
        """``(holds(ctx), condition objects)`` of a step condition: an expression, or a condition object."""
        if isinstance(check, ConditionPlan):
            condition = check.build()
            self.conditions.append((condition, owner))
            return condition.holds, (condition,)
        return E.on_context(check), ()

    def transition(self, plan: TransitionPlan, states: dict[str, State[Any]]) -> TransitionWiring:
        cls, params, source_id, target_id, position, guard, assign, counter, conditions = plan
        source = states[source_id]
        t = new_transition(cls, params, source, states[target_id], position)
        if cls not in self.binds:
            self.binds[cls] = transition_binds_references(t.transition)
        expression, condition = guard
        if not conditions and expression is None and condition is None and assign is None:
            return t
        built = {key: cp.build() for key, cp in conditions.items()}
        if condition is not None:
            built["guard"] = condition.build()
            t.apply_guard(built["guard"].holds)
        elif expression is not None:
            t.apply_guard(E.on_context(expression), expression.comparison())
        if built:
            t.apply_conditions(built)
            self.conditions.extend((c, source) for c in built.values())
        if assign is not None:
            t.apply_set(assign, counter)
        return t

    def bind(self, machine: Machine) -> None:
        """Once everything exists: references, supervisors (exception sequences, callers), conditions' owners;
        then every state's hooks are sealed."""
        for obj, _plan in self.supervised:
            supervisor = supervisor_of(wiring(obj))
            if supervisor is not None:
                supervisor.machine = machine
                for m in supervisor.monitors:
                    if m.exception_id is not None:
                        m.exception = _exception_region(obj, m.exception_id)
                    if m.behavior in CALLER_BEHAVIORS:
                        _supervise_caller(obj, machine)
        for condition, owner in self.conditions:
            condition.bind(machine, owner)
        sealing = self.sealing
        if any(self.binds.values()):
            for record in self.built:
                for t in record.transitions:
                    if transition_binds_references(t):
                        t.bind(machine)
                state = record.state
                if state_binds_references(state):
                    state.bind(machine)
            sealing = self.built  # what a binding element changed is not known: every record sealed
        for record in sealing:
            record.seal()


def _position(t: TransitionWiring) -> int:
    return t.index


def _never(ctx: Context) -> bool:
    return False


def _supervise_caller(state: State[Any], machine: Machine) -> None:
    """A ``...CallerOfOwner`` behaviour acts on the state that contains ``state``: it needs a supervisor too."""
    region = wiring(state).region
    caller = region.owner if region is not None else None
    if caller is not None and wiring(caller).supervisor is None:
        supervisor = wiring(caller).supervisor = Supervisor(caller, [])
        supervisor.machine = machine


def _exception_region(state: State[Any], name: str) -> Region | None:
    """The region of the exception sequence ``name``, declared by the nearest sequence (this state or an
    enclosing one) that declares it."""
    from fsm.sequencer.steps import Sequence, enclosing_sequence

    seq = state if isinstance(state, Sequence) else enclosing_sequence(state)
    while seq is not None:
        if name in seq.exceptions:
            return seq.exceptions[name]
        seq = enclosing_sequence(seq)
    return None


__all__ = ["build"]
