"""The plan: what the compile stage makes of a checked document, and all the build stage needs. Immutable and
typed: per state its type, parameters, compiled hooks, supervision (monitors, timeout, precondition, exit
condition) and regions; per transition its guard, of an explicit kind, and its actions.

A plan holds no runtime objects, so one plan builds any number of independent machines (a sweep's runs, a
debugger's rewinds).
"""

from __future__ import annotations

import enum
from collections.abc import Callable, Mapping
from types import MappingProxyType
from typing import TYPE_CHECKING, Any, NamedTuple, Union

from fsm.model.expr import Compiled, VarOp

if TYPE_CHECKING:
    from fsm.model.document import MachineSpec, SequenceLayout
    from fsm.model.params import ConditionParams, StateParams, TransitionParams

#: A compiled action: what runs, given the context.
Action = Callable[[Any], None]


class GuardKind(enum.Enum):
    """How the runtime decides whether a transition fires, cheapest first."""

    #: fires whenever it is checked (``Always`` without a guard)
    ALWAYS = "always"
    #: ``variable OP constant`` on the blackboard and nothing else, run inline by the region
    COMPARE = "compare"
    #: a call: the type's ``check``, a guard, or both
    CALL = "call"


class ActionKind(enum.Enum):
    """What firing a transition runs between the source's exit and the target's entry."""

    NONE = "none"
    #: ``target = variable OP constant`` and nothing else, run inline by the region
    COUNTER = "counter"
    #: a call: the type's ``action``, the ``set``, or both
    CALL = "call"


#: An empty mapping, shared (plans are never changed).
NOTHING: Mapping[str, Any] = MappingProxyType({})


class ConditionPlan(NamedTuple):
    """A condition object ready to build: its class, parameters, children and compiled expressions."""

    cls: type[Any]  #: a registered Condition class (the model names no runtime class)
    params: ConditionParams
    children: tuple[ConditionPlan, ...] = ()
    exprs: Mapping[str, Compiled] = NOTHING

    def build(self) -> Any:
        """A fresh instance (each user gets its own: conditions keep state)."""
        return self.cls(self.params, [c.build() for c in self.children], dict(self.exprs))


#: A compiled condition of a state (precondition, exit condition, monitor): an expression or a condition object.
Predicate = Union[Compiled, ConditionPlan]


class GuardPlan(NamedTuple):
    """A transition's document guard on top of its type's check: none, an expression, or a condition object."""

    expression: Compiled | None = None
    condition: ConditionPlan | None = None


class TransitionPlan(NamedTuple):
    """One transition: its type and parameters, its endpoints (ids in its level), its document guard and ``set``,
    and the condition objects of its type's condition parameters."""

    cls: type[Any]  #: a registered Transition class
    params: TransitionParams
    source: str
    target: str
    #: declaration order in its level
    position: int
    guard: GuardPlan = GuardPlan(None, None)
    #: the ``set``, compiled: one action, or None
    assign: Action | None = None
    #: ``target = variable OP constant`` when that is the whole ``set`` (the region runs it inline)
    counter: tuple[str, VarOp] | None = None
    conditions: Mapping[str, ConditionPlan] = NOTHING

    @property
    def kind(self) -> GuardKind:
        """The guard's kind: what the runtime runs to decide whether the transition fires."""
        if not self.cls.unconditional or self.guard.condition is not None or self.conditions:
            return GuardKind.CALL
        expression = self.guard.expression
        if expression is None:
            return GuardKind.ALWAYS
        return GuardKind.COMPARE if expression.comparison() is not None else GuardKind.CALL


class MonitorPlan(NamedTuple):
    """A monitor of a state, or its timeout (``condition`` None: the supervisor's clock decides)."""

    condition: Predicate | None
    behavior: str
    exception: str | None
    label: str
    kind: str = "monitor"


class SupervisionPlan(NamedTuple):
    """A state's step-common keys, compiled: precondition, exit condition, monitors (the timeout first)."""

    precondition: Predicate | None = None
    until: Predicate | None = None
    monitors: tuple[MonitorPlan, ...] = ()
    #: seconds, or an expression read each time the state is entered
    timeout: float | Compiled | None = None

    @property
    def watches(self) -> bool:
        """Whether the state needs a supervisor at run time (the exit condition alone does not)."""
        return bool(self.monitors) or self.precondition is not None


class StatePlan(NamedTuple):
    """One state: its type, parameters, path, hooks, supervision, regions and outgoing transitions (ordered:
    preemptive first as the region checks them, then the regular ones, by priority and declaration)."""

    cls: type[Any]  #: a registered State class
    params: StateParams
    id: str
    path: str
    #: the document's ``set.on_enter`` (and a type's assignment parameters) and ``set.on_exit``, compiled
    on_enter: Action | None = None
    on_exit: Action | None = None
    supervision: SupervisionPlan | None = None
    regions: tuple[RegionPlan, ...] = ()
    sequence: SequenceLayout | None = None
    preempt: tuple[TransitionPlan, ...] = ()
    regular: tuple[TransitionPlan, ...] = ()
    #: ``set.on_complete``, compiled: run when the state is left after it finished by itself
    on_complete: Action | None = None
    #: the type's condition parameters (``Sequence.repeat_while``), compiled
    checks: Mapping[str, Predicate] = NOTHING


class RegionPlan(NamedTuple):
    """One machine level: its states in document order and its initial state's id."""

    name: str
    path: str
    states: tuple[StatePlan, ...]
    initial: str


class MachinePlan(NamedTuple):
    """A whole machine: its levels, the initial blackboard, and what runners ask before they build it."""

    name: str
    root: RegionPlan
    #: the initial blackboard variables (every level's ``vars``, the outer level first)
    variables: Mapping[str, Any]
    #: the checked document it was compiled from (overrides, graphs and traces read it)
    spec: MachineSpec
    #: what needs a car: "'path' (Type)" for states, "from -> to (Type)" for transitions
    car_users: tuple[str, ...] = ()
    #: every file the machine was read from: its own and its includes
    files: tuple[str, ...] = ()
    #: every input signal the machine reads
    signals: frozenset[str] = frozenset()

    @property
    def needs_car(self) -> bool:
        return bool(self.car_users)

    def states(self) -> list[StatePlan]:
        """Every state of the machine, each level's states before those of the levels below it."""
        out: list[StatePlan] = []
        todo = [self.root]
        while todo:
            region = todo.pop(0)
            out.extend(region.states)
            todo.extend(r for st in region.states for r in st.regions)
        return out


__all__ = ["Action", "ActionKind", "Predicate", "ConditionPlan", "GuardKind", "GuardPlan", "MachinePlan",
           "MonitorPlan", "RegionPlan", "StatePlan", "SupervisionPlan", "TransitionPlan"]
