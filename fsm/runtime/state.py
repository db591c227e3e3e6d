"""State: the base class of every state type, its lifecycle hooks and finishing with an outcome.

What the runtime keeps of a state besides its identity and parameters (its level, sub-levels, transitions,
supervisor, the hooks it calls, its clock) is its *wiring record*, one slot (``_fsm``): a
:class:`fsm.runtime.region.StateWiring`, of which this module knows the base, :class:`Life` (see
:func:`use_record`). A plugin author's ``self.`` therefore holds
``id``, ``path``, ``params``, ``finished``, ``outcome`` and ``predicates`` of the base, and the author's own names
(``region``, ``transitions`` or ``supervisor`` among them, if they like). This module names none of the classes a
state is linked to: the record's type lives above it, with the region.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any, ClassVar, Generic, TypeVar, cast

from fsm.model.params import StateParams, adopt_generic_params
from fsm.runtime.deprecation import Renamed

if TYPE_CHECKING:
    from fsm.runtime.context import Context

P = TypeVar("P", bound=StateParams)
#: The predicates of a state whose type has no condition parameters (shared; the builder gives others their own).
_NO_PREDICATES: dict[str, Any] = {}
#: Where the deprecated links of a state are read now.
_WIRING = "fsm.runtime.region.wiring(state)"

#: A hook the runtime calls with the context (``None`` where there is nothing to do).
Hook = Callable[["Context"], None]


class Life:
    """The part of a state's wiring record this module knows: its clock and how it finished by itself. A state is
    made with the full record, a :class:`fsm.runtime.region.StateWiring` (a subclass, with the state's links), once
    the runtime's region module is imported (:func:`use_record`); before, with this, which that module's ``wiring``
    replaces when first asked."""

    __slots__ = ("state", "entered_at", "paused", "frozen_since", "completed", "completion_ran")

    def __init__(self, state: State[Any]) -> None:
        self.state = state
        self.entered_at = 0.0
        self.paused = False
        #: Machine time since which this state's clock stands still (it or an ancestor is paused, or it is
        #: suspended while a monitor's exception sequence runs), else None.
        self.frozen_since: float | None = None
        #: It called :meth:`State.finish` since its last entry (``set.on_complete`` runs then), and whether that ran.
        self.completed = False
        self.completion_ran = False

    def carry(self, before: Life) -> None:
        """Take over the clock of ``before``, the record this one replaces (a state made before the runtime's
        region module was imported, given its full record)."""
        self.entered_at, self.paused, self.frozen_since = before.entered_at, before.paused, before.frozen_since
        self.completed, self.completion_ran = before.completed, before.completion_ran

    @property
    def active(self) -> bool:
        """A state in no machine level is active."""
        return True


def _record_of(state: State[Any]) -> Life:
    return state._fsm


def tick_hook(state: State[Any]) -> Hook | None:
    """What ticking ``state`` calls (fixed when the machine is built; see ``State._tick_method``)."""
    return state._tick_method()


def state_binds_references(state: State[Any]) -> bool:
    """Whether the class of ``state`` overrides ``bind`` (the builder calls it only then)."""
    return type(state)._binds_references


#: The class of the record a state is made with (see :class:`Life`).
_record: type[Life] = Life


def use_record(record: type[Life]) -> None:
    """Make states with ``record`` from now on: the runtime's region module gives its full record when imported, so
    that a state built into a machine is made wired rather than wired afterwards (a record made once)."""
    global _record
    _record = record


class State(Generic[P]):
    """A state of a machine. Subclass it, declare ``Params``, override the hooks you need, and register it.

    The runtime calls ``on_enter`` when the state becomes active (take resources), ``tick`` once per
    machine tick while it is active (compute outputs), and ``on_exit`` when it is left (release them).
    A state that can finish (``can_finish = True``) calls ``finish(outcome)``; ``Finished``
    transitions then route on that outcome.

    ``State`` is generic over its parameters: ``class Wait(State[WaitParams])`` types ``self.params.seconds`` and
    makes ``WaitParams`` the type's ``Params`` (what the document is checked against); a ``Params`` declared as
    well must agree with it (be it or a subclass), else registering the class is a ``RegistrationError``.

    What an instance holds of the base: ``id``, ``path``, ``params``, ``finished``, ``outcome``, ``predicates``,
    and one slot of runtime wiring (``_fsm``, see :func:`fsm.runtime.region.wiring`). The names the base takes (its
    hooks, settings and own names) are listed in :data:`fsm.runtime.namespace.TAKEN`; a class that shadows one is
    refused when it is registered. Every other name is yours.
    """

    __slots__ = ("id", "params", "path", "finished", "outcome", "predicates", "_fsm")

    #: The parameters' model: the generic argument (``class Wait(State[WaitParams])``) unless declared.
    Params: ClassVar[type[StateParams]] = StateParams
    #: The generic argument the class (or its nearest base that names one) gives: ``Params`` must be it or a
    #: subclass of it, or registering the class fails (``self.params`` is typed by it).
    params_argument: ClassVar[type[StateParams] | None] = None
    #: Whether instances can finish; the loader refuses a ``Finished`` transition out of a type that cannot.
    can_finish: ClassVar[bool] = False
    #: The outcomes instances can finish with (checked against ``Finished`` transitions that name one).
    #: ``None`` means any string.
    outcomes: ClassVar[tuple[str, ...] | None] = ("succeeded",)
    #: A final state ends its machine level.
    is_final: ClassVar[bool] = False
    #: Composite states own sub-machines (see :class:`fsm.runtime.composite.Composite`).
    is_composite: ClassVar[bool] = False
    #: States that drive the plant (``ctx.car``); a machine with one cannot be built without a car.
    needs_car: ClassVar[bool] = False
    #: Names of parameters that hold input signal names (``pause_signal``).
    signal_refs: ClassVar[tuple[str, ...]] = ()
    #: Names of parameters that hold assignments (``{"var": "expression"}``) run on entry, like ``set.on_enter``.
    assignment_fields: ClassVar[tuple[str, ...]] = ()
    #: Names of parameters that hold conditions (an expression or a condition object, like ``until``); the built
    #: state finds each as ``self.predicates[name](ctx)``.
    condition_fields: ClassVar[tuple[str, ...]] = ()
    # Which hooks a class overrides, found once per class (``__init_subclass__``) rather than per state built.
    _overrides_enter: ClassVar[bool] = False
    _overrides_exit: ClassVar[bool] = False
    _overrides_tick: ClassVar[bool] = False
    #: Whether the class overrides ``bind`` (the builder calls it only then).
    _binds_references: ClassVar[bool] = False

    if not TYPE_CHECKING:  # hidden from type checkers: a plugin's own attribute of one of these names type-checks
        #: Deprecated names, read for one release with a ``DeprecationWarning``: ``checks`` is ``predicates``; the
        #: links are in the wiring record (:func:`fsm.runtime.region.wiring`).
        checks = Renamed("checks", "predicates", where="state")
        region = Renamed("region", "region", record=_record_of, where=_WIRING)
        regions = Renamed("regions", "regions", record=_record_of, default=(), where=_WIRING)
        transitions = Renamed("transitions", "transitions", record=_record_of, default=[], where=_WIRING)
        supervisor = Renamed("supervisor", "supervisor", record=_record_of, where=_WIRING)
        #: The runtime's, not the author's: behind one underscore now.
        tick_method = Renamed("tick_method", "_tick_method",
                              read="fsm.runtime.state.tick_hook(state) for tick_method()")
        binds_references = Renamed("binds_references", "_binds_references", on_class=True,
                                   read="fsm.runtime.state.state_binds_references(state)")

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        adopt_generic_params(cls, StateParams)
        cls._overrides_enter = cls.on_enter is not State.on_enter
        cls._overrides_exit = cls.on_exit is not State.on_exit
        cls._overrides_tick = cls.tick is not State.tick
        cls._binds_references = cls.bind is not State.bind

    def __init__(self, id: str, params: P | None = None) -> None:
        self.id = id
        self.params: P = params if params is not None else cast(P, self.Params(id=id, type=type(self).__name__))
        self.path = id
        self.finished = False
        self.outcome: str | None = None
        #: The type's condition parameters, built: ``predicates[name](ctx) -> bool``.
        self.predicates: dict[str, Callable[[Context], bool]] = _NO_PREDICATES
        #: The runtime's record of this state (its links and clock); see the module's docstring.
        self._fsm: Life = _record(self)

    @property
    def type_name(self) -> str:
        """The registered type name this state was built as (its document's ``type``)."""
        return self.params.type

    @classmethod
    def possible_outcomes(cls, params: P) -> set[str] | None:
        """The outcomes an element with ``params`` can finish with: empty if it never finishes, ``None`` if any."""
        if not cls.can_finish:
            return set()
        return None if cls.outcomes is None else set(cls.outcomes)

    # -- hooks for subclasses -------------------------------------------------------------------
    def on_enter(self, ctx: Context) -> None:
        """Called when the state becomes active, before any tick."""

    def tick(self, ctx: Context) -> None:
        """Called once per machine tick while the state is active (and not paused)."""

    def on_exit(self, ctx: Context) -> None:
        """Called when the state is left (innermost first)."""

    def on_pause(self, ctx: Context) -> None:
        """Called when the state stops being ticked by a pause (its own or an ancestor's) or while a monitor's
        exception sequence suspends it: stop what it drives (a motor, the car), as a paused machine stands still."""

    def on_resume(self, ctx: Context) -> None:
        """Called when a pause ends and the state is ticked again: restart what ``on_pause`` stopped."""

    def bind(self, machine: Any) -> None:
        """Called once when the machine is built, to resolve references to other states (``Join``). ``machine`` is
        the :class:`fsm.Machine` being built; an override annotates it ``Machine``, or ``MachineView``
        (:mod:`fsm.runtime.context`, what the runtime's own types use of it): both type-check."""

    def _tick_method(self) -> Hook | None:
        """What ticking this state calls (fixed when the machine is built), or None when its class keeps the base's
        empty tick; a composite ticks its regions."""
        return self.tick if type(self)._overrides_tick else None

    # -- API for subclasses ---------------------------------------------------------------------
    def finish(self, outcome: str = "succeeded") -> None:
        """Mark the state finished with ``outcome``; ``Finished`` transitions out of it can now fire."""
        self.finished = True
        self.outcome = outcome
        self._fsm.completed = True

    def time_in_state(self, ctx: Context) -> float:
        """Seconds on the machine's clock since the state was entered, paused time excluded."""
        life = self._fsm
        since = life.frozen_since
        return (ctx.now if since is None else since) - life.entered_at

    @property
    def active(self) -> bool:
        """True while this state and all its ancestors are active."""
        return self._fsm.active

    @property
    def paused(self) -> bool:
        """True while paused (by ``Machine.pause`` or a pause button)."""
        return self._fsm.paused

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.path!r}>"
