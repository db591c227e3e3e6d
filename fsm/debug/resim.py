"""Watch values for a range of ticks, computed on request by re-simulating the run: nothing of it runs while the run
goes.

A live run keeps a watch's value only at the ticks a page is sent (:mod:`fsm.debug.control`: every status, at most a
chunk of ticks apart, and wherever the run pauses). The exact value at any other tick, and a watch's values at every
tick of a range, are computed when a page or ``fsmctl watch`` asks: a session standing at or before the range's
first tick (a snapshot restored, the run built afresh, a trace's run rebuilt) is run to its last tick, and the
watches' row (:func:`fsm.debug.watch.row_function`) is taken after each tick of the range. The run is deterministic,
so these are the values the run had.

:class:`Rows` holds what one request computed, and says where it stopped short (the run ended or raised before the
range's end, a hot reload that cannot be done again); :meth:`Rows.to_json` gives the values per tick, or, for more
ticks than a plot has pixel columns, each column's least and greatest value (taken from the exact values of every
tick in it).

:func:`aside` lets the controller re-simulate from a snapshot in the run's own objects (a snapshot is restored in
place) and give the run back as it was: the run's state now is snapshotted first and restored after, the recorder
and the controller's listener detached meanwhile (no trace line is written twice; the session's observers are called
as in a rewind's re-simulation: a live run has no video). What a snapshot shares with the run rather than copies
(the track's array of points, which a restore cuts in place) is copied for the re-simulation, so neither the run
nor its other snapshots lose what they hold.
"""

from __future__ import annotations

from array import array
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from fsm.debug.breakpoints import Watch
from fsm.debug.reload import ReloadRefused, swap_machine
from fsm.model.errors import DiagramError, StateRuntimeError
from fsm.session.snapshot import Snapshot, restore, take

if TYPE_CHECKING:
    from fsm.session.session import Session

#: The most ticks one request re-simulates values for (about ten minutes of the hallway lap at 80 Hz); a longer
#: range is cut to its last this many ticks, and the answer says so.
MAX_RANGE = 50_000
#: The most columns a reduced answer has (a plot wider than this many pixels gets this many).
MAX_COLUMNS = 4_000
Row = tuple[Any, ...]


@dataclass
class Rows:
    """The watches' rows for ticks ``first`` .. ``last`` (``ticks[k]`` after which ``rows[k]`` was taken), and why
    the values stop before ``last`` if they do (``stopped``)."""

    first: int
    last: int
    ticks: list[int] = field(default_factory=list)
    rows: list[Row] = field(default_factory=list)
    stopped: str | None = None
    #: how the values were computed (``live``: the run stands at that tick; ``snapshot N``; ``start``; ``trace``)
    source: str = ""

    def add(self, tick: int, row: Row) -> None:
        self.ticks.append(tick)
        self.rows.append(row)

    def to_json(self, width: int | None = None) -> dict[str, Any]:
        """For a page: ``ticks`` and one list of values per watch (``series``), every tick when they are no more
        than twice ``width``; else ``reduced``: per pixel column its first and last tick, with the column's least
        and greatest number in the order they came (a boolean counts as 0 or 1, text as no number)."""
        out: dict[str, Any] = {"from": self.first, "to": self.last, "computed": len(self.ticks),
                               "stopped": self.stopped, "source": self.source}
        count = len(self.rows[0]) if self.rows else 0
        if width is None or len(self.ticks) <= 2 * width:
            out.update(reduced=False, ticks=self.ticks, series=[[row[k] for row in self.rows] for k in range(count)])
            return out
        xs, series = reduce_rows(self.ticks, self.rows, count, width)
        out.update(reduced=True, ticks=xs, series=series)
        return out


def _numbers(rows: list[Row], k: int) -> list[float | None]:
    """Watch ``k``'s values as numbers: a boolean as 0 or 1, text, a list or NaN as ``None``."""
    out: list[float | None] = []
    for row in rows:
        v = row[k]
        t = type(v)
        out.append(float(v) if (t is float or t is int or t is bool) and v == v else None)
    return out


def reduce_rows(ticks: list[int], rows: list[Row], count: int, width: int) -> tuple[list[int], list[list[Any]]]:
    """``rows`` in ``width`` columns of consecutive ticks: each column two points (its first and last tick) carrying
    its least and greatest number of each watch, in the order they came (``None`` for a column with none)."""
    n = len(ticks)
    bounds = [(c * n // width, (c + 1) * n // width) for c in range(width)]
    bounds = [(lo, hi) for lo, hi in bounds if lo < hi]
    xs = [t for lo, hi in bounds for t in (ticks[lo], ticks[hi - 1])]
    series: list[list[Any]] = []
    for k in range(count):
        numbers = _numbers(rows, k)
        out: list[Any] = []
        for lo, hi in bounds:
            part = numbers[lo:hi]
            found = [v for v in part if v is not None]
            if not found:
                out += [None, None]
                continue
            least, most = min(found), max(found)
            out += [least, most] if part.index(least) <= part.index(most) else [most, least]
        series.append(out)
    return xs, series


def rows_between(session: Session, row: Callable[[Any], Row], first: int, last: int, out: Rows,
                 reloads: Iterable[tuple[int, Any]] = ()) -> Rows:
    """Run ``session`` (started, standing at a tick at or before ``first``) to tick ``last``, adding the row after
    each tick from ``first`` on to ``out``; ``reloads`` (the tick before which each applied, its plan) are done again
    on the way, up to the one before tick ``last + 1`` (the session then stands where that tick would start). Stops
    short (``out.stopped`` says why) where the run ends or raises."""
    from fsm.session.session import StopRules

    def keep(s: Session) -> bool:
        tick = s.machine.ctx.tick
        if tick >= first:
            out.add(tick, row(s.machine.ctx))
        return False

    if session.ticks >= first:
        out.add(session.ticks, row(session.machine.ctx))
    try:
        for at, plan in sorted(reloads, key=lambda r: r[0]):
            if at > last + 1:
                break
            if session.ticks < at - 1 and not _run(session, keep, at - 1 - session.ticks, out, StopRules):
                return out
            try:
                swap = swap_machine(session.machine, plan)
            except (ReloadRefused, DiagramError, StateRuntimeError) as exc:
                out.stopped = f"the hot reload before tick {at} could not be done again: {exc}"
                return out
            session.replace_machine(swap.machine)
        if session.ticks < last:
            _run(session, keep, last - session.ticks, out, StopRules)
    except StateRuntimeError as exc:
        out.stopped = f"the run raised in tick {session.machine.ctx.tick}: {exc}"
    return out


def _run(session: Session, keep: Callable[[Session], bool], ticks: int, out: Rows, rules: Any) -> bool:
    """``ticks`` more ticks; False (``out.stopped`` says why) when the run ended before them."""
    goal = session.ticks + ticks
    result = session.run(until=keep, stop_rules=rules(max_ticks=ticks))
    if session.ticks < goal:
        out.stopped = f"the run ended at tick {session.ticks} ({result.stopped})"
        return False
    return True


def exact_now(session: Session) -> bool:
    """Whether a snapshot of ``session`` taken now restores exactly (its world says so: not while the simulated car
    touches a wall)."""
    driver = session.driver
    if driver is None:
        return True
    ready = getattr(driver, "snapshot_ready", None)
    return ready is not None and bool(ready())


@contextmanager
def aside(session: Session) -> Iterator[Callable[[Snapshot], None]]:
    """Re-simulate in ``session``'s own objects and give it back as it is now (see the module docstring). The body
    calls the function it is given with the snapshot to start from (restored, the recorder and the controller's
    listener off until the end) and runs from there. Only between two ticks, on the loop's thread, when
    :func:`exact_now`."""
    recorder = session.recorder
    out: Any = recorder.out if recorder is not None else None
    here = take([session], session.ticks, shared=[x for x in (out, session.machine.listeners) if x is not None])
    lists: list[tuple[list[Any], list[Any]]] = []

    def start(snap: Snapshot) -> None:
        restore(_own(snap))
        listeners = session.machine.listeners
        lists.append((listeners, list(listeners)))
        listeners[:] = [x for x in listeners if x is not session.recorder and not isinstance(x, Watch)]
        session.recorder = None

    try:
        yield start
    finally:
        for listeners, saved in reversed(lists):
            listeners[:] = saved
        restore(here)


def _own(snap: Snapshot) -> Snapshot:
    """``snap`` with the arrays its hooks' states share with the run copied (the car's track keeps its points in
    one array that only grows, and a restore of an older snapshot cuts it in place: the re-simulation works on a
    copy, and the array the run and its other snapshots share stays whole)."""
    return Snapshot(snap.tick, snap.entries, [(obj, _copied(state)) for obj, state in snap.hooks], snap.generators,
                    snap.extra)


def _copied(state: Any) -> Any:
    if isinstance(state, array):
        return array(state.typecode, state)
    if type(state) is tuple:
        return tuple(_copied(x) for x in state)
    return state


__all__ = ["MAX_COLUMNS", "MAX_RANGE", "Rows", "aside", "exact_now", "reduce_rows", "rows_between"]
