"""Context: what states and transitions see: time, the plant (``car``), blackboard variables, input signals."""

from __future__ import annotations

import numbers
import reprlib
from collections.abc import Sequence
from typing import Any, Protocol


class StateView(Protocol):
    """A state as the code of another one sees it (``ctx.state(path)``, a ``bind``'s ``machine.resolve``): where it
    is, whether it runs, how it finished. :class:`fsm.runtime.state.State` is one; the protocol lives here, below the
    states, so that the context names them without importing them (no import cycle)."""

    @property
    def path(self) -> str:
        """Its path in the machine (``"drive/turn"``)."""
        ...

    @property
    def active(self) -> bool:
        """True while it and all its ancestors are active."""
        ...

    @property
    def paused(self) -> bool:
        """True while paused (by ``pause``, a pause button)."""
        ...

    @property
    def finished(self) -> bool:
        """True once it finished (since its last entry)."""
        ...

    @property
    def outcome(self) -> str | None:
        """The outcome it finished with, or None."""
        ...

    def time_in_state(self, ctx: Context) -> float:
        """Seconds since it was entered, paused time excluded."""
        ...


class MachineView(Protocol):
    """The machine as the code it runs sees it: ``ctx.machine``, and the argument of every ``bind`` (a state's, a
    transition's, a condition's). :class:`fsm.runtime.machine.Machine` is one; the protocol lives here, below the
    states, so that they name what they use of their machine without importing it (no import cycle)."""

    @property
    def ctx(self) -> Context:
        """The machine's context (the blackboard, signals, the clock's time)."""
        ...

    @property
    def listeners(self) -> Sequence[object]:
        """The attached listeners (empty: nobody to tell)."""
        ...

    def state(self, path: str) -> StateView:
        """The state at the full ``path``."""
        ...

    def resolve(self, path: str, scope: str = "") -> StateView:
        """The state ``path`` names when written in the level at ``scope``."""
        ...

    def pause(self, path: str | None = None) -> None:
        """Pause the state at ``path`` (the whole machine without one)."""
        ...

    def resume(self, path: str | None = None) -> None:
        """Resume what :meth:`pause` paused."""
        ...

    def add_pause_button(self, state: StateView, signal: str, debounce: float = 0.0) -> None:
        """Each rising edge of ``signal`` pauses or resumes ``state``."""
        ...

    def notify_skipped(self, state: StateView) -> None:
        """Tell the listeners that ``state``, just entered, was skipped by its precondition."""
        ...


class Context:
    """Passed to every hook. ``now``/``dt``/``tick`` come from the machine's clock, never the wall clock.

    ``vars`` is the blackboard shared by all states (and parallel regions); ``car`` is the plant
    interface (``None`` for machines that need no car). Signals are boolean inputs (buttons, switches).
    Their level changes at once; an edge is seen for exactly one tick: when the level at the start of
    tick ``k+1`` differs from the level at the start of tick ``k`` (a change made between the two ticks
    or during tick ``k``). A signal set and reset between two ticks makes no edge.
    """

    __slots__ = ("_now", "_dt", "_tick", "vars", "car", "machine", "_signals", "_changed", "_pending", "_history",
                 "plants")

    def __init__(self, *, car: Any = None, variables: dict[str, Any] | None = None) -> None:
        # Only the machine advances these (through the underscored slots); states read the properties.
        self._now = 0.0
        self._dt = 0.0
        self._tick = 0
        self.vars: dict[str, Any] = dict(variables or {})
        self.car = car
        self.machine: MachineView | None = None
        #: simulated plants by name (:class:`fsm.runtime.plant.Plant`, a layer above: kept as objects here),
        #: attached by a scenario or a run
        self.plants: dict[str, object] = {}
        self._signals: dict[str, bool] = {}
        self._changed: dict[str, int] = {}
        #: Signals changed since the last tick started, with their level then.
        self._pending: dict[str, bool] = {}
        #: Level changes of the watched signals (debounced conditions): name -> [(time, level)].
        self._history: dict[str, list[tuple[float, bool]]] = {}

    # -- time (read-only: a state that could move the clock would break every other state's timing) -----
    @property
    def now(self) -> float:
        """Machine time of the current tick, in seconds (``tick * dt`` on the simulated clock)."""
        return self._now

    @now.setter
    def now(self, value: Any) -> None:
        _read_only("now")

    @property
    def dt(self) -> float:
        """Seconds since the previous tick (0 before the first)."""
        return self._dt

    @dt.setter
    def dt(self, value: Any) -> None:
        _read_only("dt")

    @property
    def tick(self) -> int:
        """Number of the current tick (0 while the initial states are entered)."""
        return self._tick

    @tick.setter
    def tick(self, value: Any) -> None:
        _read_only("tick")

    # -- signals --------------------------------------------------------------------------------
    def set_signal(self, name: str, value: bool = True) -> None:
        """Set input signal ``name`` (a non-empty string) to ``value`` (``True``/``False`` or ``1``/``0``);
        a change of level is an edge during the next tick."""
        check_signal_name(name)
        value = signal_level(value)
        old = self._signals.get(name, False)
        if old != value and name not in self._pending:
            self._pending[name] = old
        self._signals[name] = value

    def begin_tick(self) -> None:
        """At the start of a tick (the machine calls it when signals changed since the last one): the signals whose
        level differs from the last boundary have an edge now."""
        history = self._history
        for name, old in self._pending.items():
            level = self._signals.get(name, False)
            if level != old:
                self._changed[name] = self._tick
                if name in history:
                    history[name].append((self._now, level))
        self._pending.clear()

    def plant(self, name: str) -> Any:
        """The plant attached under ``name`` (``KeyError`` naming the attached ones when there is none)."""
        try:
            return self.plants[name]
        except KeyError:
            known = ", ".join(sorted(self.plants)) or "none"
            raise KeyError(f"no plant '{name}' is attached (attached: {known}); a scenario attaches plants with "
                           f"\"plants\": [{{\"name\": \"{name}\", \"type\": ...}}]") from None

    def signal_history(self, name: str) -> list[tuple[float, bool]]:
        """The change history of signal ``name``, kept from now on: ``[(time, level)]``, one entry per tick
        boundary at which its level differed from the previous boundary (conditions with ``debounce`` read it)."""
        history = self._history.get(name)
        if history is None:
            history = self._history[name] = []
            if self._signals.get(name, False):
                history.append((self._now, True))
        return history

    def signal(self, name: str) -> bool:
        """The level of signal ``name`` (``False`` if never set)."""
        return self._signals.get(name, False)

    def rising(self, name: str) -> bool:
        """True during the one tick after the signal went from low to high."""
        return self._signals.get(name, False) and self._changed.get(name) == self._tick

    def falling(self, name: str) -> bool:
        """True during the one tick after the signal went from high to low."""
        return (not self._signals.get(name, False)) and self._changed.get(name) == self._tick

    @property
    def signals(self) -> dict[str, bool]:
        """A copy of all signal levels."""
        return dict(self._signals)

    # -- lookup ---------------------------------------------------------------------------------
    def state(self, path: str) -> StateView:
        """The state at ``path`` (``"drive/turn/slow"``), like EEROS ``getSequenceByName``."""
        assert self.machine is not None
        return self.machine.state(path)

    def time_in_state(self, state: StateView | str) -> float:
        """Seconds since ``state`` (an object or a path) was entered, paused time excluded."""
        if isinstance(state, str):
            state = self.state(state)
        return state.time_in_state(self)


def _read_only(name: str) -> None:
    raise AttributeError(f"ctx.{name} is read-only: the machine's clock sets it each tick "
                         "(keep your own time reference in the state, e.g. self.started = ctx.now)")


# -- argument checks (Context.set_signal and Machine.schedule_signal) ---------------------------------
def shown_value(value: Any) -> str:
    """A value as error messages show it: its repr (cut at 60 characters) and its type."""
    try:
        text = repr(value)
    except RecursionError:  # nested deeper than repr goes (a list in a list 100,000 deep): shown to a bounded depth
        text = reprlib.repr(value)
    text = text if len(text) <= 60 else text[:57] + "..."
    return f"{text} ({type(value).__name__})"


def check_signal_name(name: Any) -> None:
    """A signal name is a non-empty string (``TypeError``/``ValueError`` otherwise)."""
    if not isinstance(name, str):
        raise TypeError(f"a signal name is a string, got {shown_value(name)}")
    if not name:
        raise ValueError("a signal name may not be empty")


def signal_level(value: Any) -> bool:
    """A signal's level from ``True``/``False`` or ``1``/``0``; anything else is refused."""
    if isinstance(value, bool):
        return value
    if isinstance(value, numbers.Integral) and not isinstance(value, bool):
        if value in (0, 1):
            return bool(value)
        raise ValueError(f"a signal's value is True/False or 1/0, got {value!r}")
    raise TypeError(f"a signal's value is True/False or 1/0, got {shown_value(value)}")
