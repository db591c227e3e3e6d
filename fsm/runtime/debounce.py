"""Debouncing: the stable level of a bouncing input signal (a push button), decided from its change history."""

from __future__ import annotations

#: Half a nanosecond of slack for times computed from ticks (80 ticks of 0.0125 s are 1 s).
_EPS = 5e-10


class Debounced:
    """The debounced level of one signal: it takes the raw level once that level has been stable for
    ``seconds`` (a change that is undone sooner is a bounce and never counts). Computed from the signal's
    change history (``ctx.signal_history``), so it does not depend on how often it is asked."""

    __slots__ = ("history", "seconds", "index", "level", "edge_at")

    def __init__(self, history: list[tuple[float, bool]], seconds: float) -> None:
        self.history = history
        self.seconds = seconds
        self.index = 0  # next raw change not yet decided
        self.level = False
        #: time at which the debounced level last changed (None: never)
        self.edge_at: float | None = None

    def advance(self, now: float) -> bool:
        """Decide every raw change whose fate is known at ``now``; returns the debounced level."""
        h = self.history
        d = self.seconds
        i = self.index
        n = len(h)
        while i < n:
            at, level = h[i]
            until = h[i + 1][0] if i + 1 < n else None
            if until is not None and until - at < d - _EPS:
                i += 1  # undone before it was stable: a bounce
                continue
            if until is None and now - at < d - _EPS:
                break  # still settling
            if level != self.level:
                self.level = level
                self.edge_at = at + d
            i += 1
        self.index = i
        return self.level
