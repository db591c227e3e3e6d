"""State: the base class of every state type, its lifecycle hooks and finishing with an outcome."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, ClassVar

from .params import StateParams

if TYPE_CHECKING:
    from .context import Context
    from .region import Region
    from .transition import Transition


class State:
    """A state of a machine. Subclass it, declare ``Params``, override the hooks you need, and register it.

    The runtime calls ``on_enter`` when the state becomes active (take resources), ``tick`` once per
    machine tick while it is active (compute outputs), and ``on_exit`` when it is left (release them).
    A state that can finish (``can_finish = True``) calls ``finish(outcome)``; ``Finished``
    transitions then route on that outcome.
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
        "_tick",
        "_enter",
        "_exit",
        "_source_hooks",
        "_set_enter",
        "_set_exit",
        "_watch",
        "_watcher",
        "_until",
    )

    Params: ClassVar[type[StateParams]] = StateParams
    #: Registered type name; set by the registry.
    type_name: ClassVar[str] = ""
    #: Whether instances can finish; the loader refuses a ``Finished`` transition out of a type that cannot.
    can_finish: ClassVar[bool] = False
    #: The outcomes instances can finish with (checked against ``Finished`` transitions that name one).
    #: ``None`` means any string.
    outcomes: ClassVar[tuple[str, ...] | None] = ("succeeded",)
    #: A final state ends its machine level.
    is_final: ClassVar[bool] = False
    #: Composite states own sub-machines (see :class:`fsm.composite.Composite`).
    is_composite: ClassVar[bool] = False
    #: States that drive the plant (``ctx.car``); a machine with one cannot be built without a car.
    needs_car: ClassVar[bool] = False

    def __init__(self, id: str, params: StateParams | None = None) -> None:
        self.id = id
        self.params = params if params is not None else self.Params(id=id, type=self.type_name or type(self).__name__)
        self.path = id
        self.region: Region | None = None
        self.regions: tuple[Region, ...] = ()
        self.finished = False
        self.outcome: str | None = None
        self.entered_at = 0.0
        self.paused = False
        #: Machine time since which this state's clock stands still (it or an ancestor is paused), else None.
        self.frozen_since: float | None = None
        self.preempt: tuple[Transition, ...] = ()
        self.regular: tuple[Transition, ...] = ()
        self.transitions: list[Transition] = []
        self._tick: Any = None
        self._enter: Any = None
        self._exit: Any = None
        self._source_hooks: tuple[Any, ...] = ()
        #: The document's ``set`` of this state, compiled: ``fn(ctx)`` or None.
        self._set_enter: Any = None
        self._set_exit: Any = None
        #: Monitors, timeout and precondition (``fsm.sequencer.watch.Watcher``) or None; ``_watch`` is its
        #: ``check``, which ``Region.step`` calls before anything else of this state.
        self._watcher: Any = None
        self._watch: Any = None
        #: The exit condition (``until``): ``(holds(ctx), condition objects to reset on entry)`` or None.
        self._until: Any = None

    @classmethod
    def possible_outcomes(cls, params: StateParams) -> set[str] | None:
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

    # -- API for subclasses ---------------------------------------------------------------------
    def finish(self, outcome: str = "succeeded") -> None:
        """Mark the state finished with ``outcome``; ``Finished`` transitions out of it can now fire."""
        self.finished = True
        self.outcome = outcome

    def time_in_state(self, ctx: Context) -> float:
        """Seconds on the machine's clock since the state was entered, paused time excluded."""
        since = self.frozen_since
        return (ctx.now if since is None else since) - self.entered_at

    @property
    def active(self) -> bool:
        """True while this state and all its ancestors are active."""
        state: State | None = self
        while state is not None:
            region = state.region
            if region is None:
                return True
            if region.active is not state or not region.started:
                return False
            state = region.owner
        return True

    # -- runtime internals ----------------------------------------------------------------------
    def _prepare(self) -> None:
        """Precompute the hot-path hooks: ``None`` where the class keeps the base no-op."""
        cls = type(self)
        self._tick = self.tick if cls.tick is not State.tick else None
        if self._until is not None:
            self._tick = self._until_tick(self._tick, self._until[0])
        has_enter = cls.on_enter is not State.on_enter
        has_exit = cls.on_exit is not State.on_exit
        self._source_hooks = tuple(
            t._source_hook for t in self.transitions if t._source_hook is not None
        )
        plain_enter = not (has_enter or self.regions or self._source_hooks or self.can_finish
                           or self._set_enter is not None or self._watcher is not None or self._until is not None)
        self._enter = None if plain_enter else self._enter_full
        frozen = self.paused or self.frozen_since is not None
        self._exit = self._exit_full if (has_exit or self.regions or frozen or self._set_exit is not None) else None

    def _enter_full(self, ctx: Context) -> None:
        """Enter: reset finishing, arm the outgoing transitions, ``on_enter``, then the sub-machines."""
        self.finished = False
        self.outcome = None
        phase = "set on_enter"
        try:
            if self._until is not None:
                phase = "until"
                for condition in self._until[1]:
                    condition.reset(ctx)
            if self._watcher is not None:
                phase = "precondition"
                if not self._watcher.arm(ctx):
                    self.finished = True
                    self.outcome = "precondition_failed"
                    return
                phase = "set on_enter"
            if self._set_enter is not None:
                self._set_enter(ctx)
            phase = "on_source_enter"
            for hook in self._source_hooks:
                hook(ctx)
            phase = "on_enter"
            self.on_enter(ctx)
        except Exception as exc:
            raise ctx.machine._runtime_error(self, phase, exc) from exc
        for region in self.regions:
            region.start(ctx)

    def _until_tick(self, tick: Any, until: Any) -> Any:
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

    def _exit_full(self, ctx: Context) -> None:
        """Exit: sub-machines first (innermost first; parallel regions in reverse order), then ``on_exit``."""
        for region in reversed(self.regions):
            region.stop(ctx)
        w = self._watcher
        if w is not None and w.halted and self.outcome == "precondition_failed":
            return  # skipped by its precondition: it was never entered, so it is not exited either
        phase = "on_exit"
        try:
            self.on_exit(ctx)
            if self._set_exit is not None:
                phase = "set on_exit"
                self._set_exit(ctx)
        except Exception as exc:
            raise ctx.machine._runtime_error(self, phase, exc) from exc
        if self.paused or self.frozen_since is not None:
            # Left by an outer transition while paused: no longer paused or frozen; restore the plain hooks.
            self.paused = False
            self.frozen_since = None
            self._prepare()

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.path!r}>"
