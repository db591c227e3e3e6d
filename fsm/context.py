"""Context: what states and transitions see: time, the plant (``car``), blackboard variables, input signals."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from .machine import Machine
    from .state import State


class Context:
    """Passed to every hook. ``now``/``dt``/``tick`` come from the machine's clock, never the wall clock.

    ``vars`` is the blackboard shared by all states (and parallel regions); ``car`` is the plant
    interface (``None`` for machines that need no car). Signals are boolean inputs (buttons, switches).
    Their level changes at once; an edge is seen for exactly one tick: when the level at the start of
    tick ``k+1`` differs from the level at the start of tick ``k`` (a change made between the two ticks
    or during tick ``k``). A signal set and reset between two ticks makes no edge.
    """

    __slots__ = ("now", "dt", "tick", "vars", "car", "machine", "_signals", "_changed", "_pending")

    def __init__(self, *, car: Any = None, variables: dict[str, Any] | None = None) -> None:
        self.now = 0.0
        self.dt = 0.0
        self.tick = 0
        self.vars: dict[str, Any] = dict(variables or {})
        self.car = car
        self.machine: Machine | None = None
        self._signals: dict[str, bool] = {}
        self._changed: dict[str, int] = {}
        #: Signals changed since the last tick started, with their level then.
        self._pending: dict[str, bool] = {}

    # -- signals --------------------------------------------------------------------------------
    def set_signal(self, name: str, value: bool = True) -> None:
        """Set input signal ``name``; a change of level is an edge during the next tick."""
        value = bool(value)
        old = self._signals.get(name, False)
        if old != value and name not in self._pending:
            self._pending[name] = old
        self._signals[name] = value

    def _tick_boundary(self) -> None:
        """At the start of a tick: the signals whose level differs from the last boundary have an edge now."""
        for name, old in self._pending.items():
            if self._signals.get(name, False) != old:
                self._changed[name] = self.tick
        self._pending.clear()

    def signal(self, name: str) -> bool:
        """The level of signal ``name`` (``False`` if never set)."""
        return self._signals.get(name, False)

    def rising(self, name: str) -> bool:
        """True during the one tick after the signal went from low to high."""
        return self._signals.get(name, False) and self._changed.get(name) == self.tick

    def falling(self, name: str) -> bool:
        """True during the one tick after the signal went from high to low."""
        return (not self._signals.get(name, False)) and self._changed.get(name) == self.tick

    @property
    def signals(self) -> dict[str, bool]:
        """A copy of all signal levels."""
        return dict(self._signals)

    # -- lookup ---------------------------------------------------------------------------------
    def state(self, path: str) -> State:
        """The state at ``path`` (``"drive/turn/slow"``), like EEROS ``getSequenceByName``."""
        assert self.machine is not None
        return self.machine.state(path)

    def time_in_state(self, state: State | str) -> float:
        """Seconds since ``state`` (an object or a path) was entered, paused time excluded."""
        if isinstance(state, str):
            state = self.state(state)
        return state.time_in_state(self)
