"""State: the base class of every state type, its lifecycle hooks and finishing with an outcome."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any, ClassVar, Generic, NamedTuple, TypeVar, cast

from fsm.model.errors import StateRuntimeError
from fsm.model.params import StateParams, adopt_generic_params

if TYPE_CHECKING:
    from fsm.runtime.condition import Condition
    from fsm.runtime.context import Context, MachineView
    from fsm.runtime.region import Region
    from fsm.runtime.supervisor import Supervisor
    from fsm.runtime.transition import Transition

P = TypeVar("P", bound=StateParams)
#: The checks of a state whose type has no condition parameters (shared; the builder gives others their own).
_NO_CHECKS: dict[str, Any] = {}

#: A hook the runtime calls with the context (``None`` where there is nothing to do).
Hook = Callable[["Context"], None]


class Until(NamedTuple):
    """A state's exit condition, built: ``holds(ctx)`` and the condition objects to reset on each entry."""

    holds: Callable[[Context], bool]
    conditions: tuple[Condition[Any], ...]


class State(Generic[P]):
    """A state of a machine. Subclass it, declare ``Params``, override the hooks you need, and register it.

    The runtime calls ``on_enter`` when the state becomes active (take resources), ``tick`` once per
    machine tick while it is active (compute outputs), and ``on_exit`` when it is left (release them).
    A state that can finish (``can_finish = True``) calls ``finish(outcome)``; ``Finished``
    transitions then route on that outcome.

    ``State`` is generic over its parameters: ``class Wait(State[WaitParams])`` types ``self.params.seconds`` and
    makes ``WaitParams`` the type's ``Params`` (what the document is checked against); a ``Params`` declared as
    well must agree with it (be it or a subclass), else registering the class is a ``RegistrationError``.
    """

    __slots__ = (
        "id",
        "params",
        "path",
        "region",
        "regions",
        "finished",
        "outcome",
        "entered_at",
        "paused",
        "frozen_since",
        "preempt",
        "regular",
        "transitions",
        "supervisor",
        "until",
        "entry_action",
        "exit_action",
        "tick_hook",
        "enter_hook",
        "exit_hook",
        "arms",
        "watched",
        "checks",
        "resets",
        "complete_action",
        "completed",
        "completion_ran",
    )

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
    #: state finds each as ``self.checks[name](ctx)``.
    condition_fields: ClassVar[tuple[str, ...]] = ()
    # Which hooks a class overrides, found once per class (``__init_subclass__``) rather than per state built.
    _overrides_enter: ClassVar[bool] = False
    _overrides_exit: ClassVar[bool] = False
    _overrides_tick: ClassVar[bool] = False
    binds_references: ClassVar[bool] = False

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        adopt_generic_params(cls, StateParams)
        cls._overrides_enter = cls.on_enter is not State.on_enter
        cls._overrides_exit = cls.on_exit is not State.on_exit
        cls._overrides_tick = cls.tick is not State.tick
        cls.binds_references = cls.bind is not State.bind

    def __init__(self, id: str, params: P | None = None) -> None:
        self.id = id
        self.params: P = params if params is not None else cast(P, self.Params(id=id, type=type(self).__name__))
        self.path = id
        self.region: Region | None = None
        self.regions: tuple[Region, ...] = ()
        self.finished = False
        self.outcome: str | None = None
        self.entered_at = 0.0
        self.paused = False
        #: Machine time since which this state's clock stands still (it or an ancestor is paused, or it is
        #: suspended while a monitor's exception sequence runs), else None.
        self.frozen_since: float | None = None
        self.preempt: tuple[Transition[Any], ...] = ()
        self.regular: tuple[Transition[Any], ...] = ()
        self.transitions: list[Transition[Any]] = []
        #: Monitors, timeout and precondition (:class:`fsm.runtime.supervisor.Supervisor`), or None.
        self.supervisor: Supervisor | None = None
        #: The exit condition (``until``), or None.
        self.until: Until | None = None
        #: The document's ``set`` of this state, compiled, or None.
        self.entry_action: Hook | None = None
        self.exit_action: Hook | None = None
        # What the runtime calls, fixed when the machine is built (seal): None where the base does nothing.
        self.tick_hook: Hook | None = None
        self.enter_hook: Hook | None = None
        self.exit_hook: Hook | None = None
        #: The outgoing transitions' hooks run on each entry (their references, their conditions' resets).
        self.arms: tuple[Hook, ...] = ()
        #: Whether anything is checked before the tick: a supervisor or preemptive transitions (fixed by seal).
        self.watched = False
        #: The type's condition parameters, built: ``checks[name](ctx) -> bool``.
        self.checks: dict[str, Callable[[Context], bool]] = _NO_CHECKS
        #: Condition objects of ``checks`` to reset on each entry.
        self.resets: tuple[Condition[Any], ...] = ()
        #: The document's ``set.on_complete``, compiled, or None; run when the state is left after it finished
        #: by itself (``completed``: it called :meth:`finish`), not when aborted, timed out, skipped or restarted.
        self.complete_action: Hook | None = None
        self.completed = False
        self.completion_ran = False

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

    def bind(self, machine: MachineView) -> None:
        """Called once when the machine is built, to resolve references to other states (``Join``)."""

    # -- API for subclasses ---------------------------------------------------------------------
    def finish(self, outcome: str = "succeeded") -> None:
        """Mark the state finished with ``outcome``; ``Finished`` transitions out of it can now fire."""
        self.finished = True
        self.outcome = outcome
        self.completed = True

    def time_in_state(self, ctx: Context) -> float:
        """Seconds on the machine's clock since the state was entered, paused time excluded."""
        since = self.frozen_since
        return (ctx.now if since is None else since) - self.entered_at

    @property
    def active(self) -> bool:
        """True while this state and all its ancestors are active."""
        state: State[Any] | None = self
        while state is not None:
            region = state.region
            if region is None:
                return True
            if region.active is not state or not region.started:
                return False
            state = region.owner
        return True

    # -- the runtime ----------------------------------------------------------------------------
    def seal(self) -> None:
        """Fix the hooks the runtime calls, once the machine is built: ``None`` where there is nothing to do, so
        a plain state costs the tick loop one test per hook."""
        cls = type(self)
        if self.transitions:
            self.arms = tuple(arm for t in self.transitions if (arm := t.arm) is not None)
        supervised = self.supervisor is not None
        self.watched = supervised or bool(self.preempt)
        tick = self.tick_method() if cls._overrides_tick or self.regions else None
        self.tick_hook = tick if self.until is None else self._until_tick(tick, self.until.holds)
        if self.complete_action is not None:
            self.tick_hook = self._completing_tick(self.tick_hook, self.complete_action)
        plain_enter = not (cls._overrides_enter or self.regions or self.arms or self.can_finish or self.resets
                           or self.entry_action is not None or supervised or self.until is not None)
        self.enter_hook = None if plain_enter else self._enter
        self.exit_hook = self._exit if (cls._overrides_exit or self.regions or self.exit_action is not None) else None

    def tick_method(self) -> Hook | None:
        """What ticking this state calls, or None when its class keeps the base's empty tick."""
        return self.tick if type(self)._overrides_tick else None

    def leave(self, ctx: Context) -> None:
        """Exit as a transition or an outer level does, and drop a pause or suspension it was held in."""
        if self.exit_hook is not None:
            self.exit_hook(ctx)
        self.release()

    def release(self) -> None:
        """No longer paused or frozen (the state was left while held)."""
        self.paused = False
        self.frozen_since = None

    def take_over(self, ctx: Context, old: State[Any]) -> None:
        """Become active in place of ``old``, the state at the same path in the machine a hot reload replaces
        (:mod:`fsm.debug.reload`), between two ticks. Carried over: its clock (entry time, pause, freeze), whether it
        finished and with which outcome, its timeout's reset; armed afresh: its outgoing transitions and its
        conditions; run: the type's ``on_enter`` with the new parameters, unless it had finished. The document's
        ``set`` actions are not run (the variables stay as they are). Its sub-levels are the caller's."""
        self.entered_at = old.entered_at
        self.paused = old.paused
        self.frozen_since = old.frozen_since
        self.finished, self.outcome = old.finished, old.outcome
        self.completed, self.completion_ran = old.completed, old.completion_ran
        phase = "until"
        try:
            for condition in self.resets:
                condition.reset(ctx)
            if self.until is not None:
                for condition in self.until.conditions:
                    condition.reset(ctx)
            supervisor = self.supervisor
            if supervisor is not None:
                phase = "precondition"
                supervisor.arm(ctx)
                before = old.supervisor
                supervisor.halted = before.halted if before is not None else False
                supervisor.reset_at = before.reset_at if before is not None else 0.0
            phase = "on_source_enter"
            for arm in self.arms:
                arm(ctx)
            if not old.finished:
                phase = "on_enter"
                self.on_enter(ctx)
        except StateRuntimeError:
            raise
        except Exception as exc:
            raise StateRuntimeError.of(self, phase, ctx, exc) from exc

    def _enter(self, ctx: Context) -> None:
        """Enter: reset finishing, arm the outgoing transitions, ``on_enter``, then the sub-machines."""
        self.finished = False
        self.outcome = None
        self.completed = self.completion_ran = False
        phase = "set on_enter"
        try:
            for condition in self.resets:
                condition.reset(ctx)
            if self.until is not None:
                phase = "until"
                for condition in self.until.conditions:
                    condition.reset(ctx)
            if self.supervisor is not None:
                phase = "precondition"
                if not self.supervisor.arm(ctx):
                    self.finished = True
                    self.outcome = "precondition_failed"
                    machine = ctx.machine
                    if machine is not None and machine.listeners:
                        machine.notify_skipped(self)
                    return
                phase = "set on_enter"
            if self.entry_action is not None:
                self.entry_action(ctx)
            phase = "on_source_enter"
            for arm in self.arms:
                arm(ctx)
            phase = "on_enter"
            self.on_enter(ctx)
            if self.completed and self.complete_action is not None:  # finished on entry (a Final, a SetVar)
                phase = "set on_complete"
                self.completion_ran = True
                self.complete_action(ctx)
        except StateRuntimeError:
            raise
        except Exception as exc:
            raise StateRuntimeError.of(self, phase, ctx, exc) from exc
        for region in self.regions:
            region.start(ctx)

    def _until_tick(self, tick: Hook | None, until: Callable[[Context], bool]) -> Hook:
        """The tick with the exit condition checked after it: the state finishes when ``until`` holds."""
        if tick is None:
            def check(ctx: Context) -> None:
                if not self.finished and until(ctx):
                    self.finish("succeeded")
            return check

        def tick_then_check(ctx: Context) -> None:
            tick(ctx)
            if not self.finished and until(ctx):
                self.finish("succeeded")
        return tick_then_check

    def _completing_tick(self, tick: Hook | None, complete: Hook) -> Hook:
        """The tick followed by ``set.on_complete`` in the tick the state finishes by itself (once per entry)."""
        def tick_then_complete(ctx: Context) -> None:
            if tick is not None:
                tick(ctx)
            if self.completed and not self.completion_ran:
                self.completion_ran = True
                try:
                    complete(ctx)
                except StateRuntimeError:
                    raise
                except Exception as exc:
                    raise StateRuntimeError.of(self, "set on_complete", ctx, exc) from exc
        return tick_then_complete

    def _exit(self, ctx: Context) -> None:
        """Exit: sub-machines first (innermost first; parallel regions in reverse order), then ``on_exit``."""
        for region in reversed(self.regions):
            region.stop(ctx)
        supervisor = self.supervisor
        if supervisor is not None and supervisor.halted and self.outcome == "precondition_failed":
            return  # skipped by its precondition: it was never entered, so it is not exited either
        phase = "on_exit"
        try:
            self.on_exit(ctx)
            if self.exit_action is not None:
                phase = "set on_exit"
                self.exit_action(ctx)
        except StateRuntimeError:
            raise
        except Exception as exc:
            raise StateRuntimeError.of(self, phase, ctx, exc) from exc

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.path!r}>"
