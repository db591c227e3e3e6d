"""The interface every library implements: an ``Adapter`` per rate workload, a ``Loader`` for (c).

An adapter builds the workload and returns the call that performs one step; the timed loop, the step
bookkeeping and the position checks are here, once, so that every library is timed the same way.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, ClassVar

from .workloads import Workload, expect


class Adapter:
    """One library driving one rate workload. Subclasses set the class attributes and implement
    ``build`` and ``position``; ``notes`` maps the workloads the library can run to a table note."""

    library: ClassVar[str] = ""   # label in the table
    key: ClassVar[str] = ""       # name for --only
    module: ClassVar[str] = ""    # import name (to tell "not installed")
    dist: ClassVar[str] = ""      # distribution name (for the version)
    notes: ClassVar[dict[str, str]] = {}

    def __init__(self, workload: Workload) -> None:
        self.workload = workload
        self.steps = 0
        self._step: Callable[[], Any] | None = None

    @property
    def note(self) -> str:
        return self.notes[self.workload.name]

    # -- what a library implements ------------------------------------------------------------------
    def build(self) -> Callable[[], Any]:
        """Build the workload's machine; return the zero-argument call that performs one step."""
        raise NotImplementedError

    def position(self) -> str:
        """The active leaf, written like the workload's ``position`` ("s7", "c1/m2/l3")."""
        raise NotImplementedError

    def advance(self, n: int) -> int:
        """Book ``n`` steps just run; return the transitions they fired (by default the workload's count)."""
        fired = self.workload.fired(self.steps, n)
        self.steps += n
        return fired

    # -- the same for everyone ------------------------------------------------------------------------
    def setup(self) -> None:
        self._step = self.build()

    def run(self, n: int) -> tuple[float, int]:
        """Perform ``n`` steps; return (seconds, transitions fired)."""
        step = self._step
        assert step is not None, "setup() first"
        rng = range(n)
        t0 = time.perf_counter()
        for _ in rng:
            step()
        dt = time.perf_counter() - t0
        return dt, self.advance(n)

    def check(self, when: str) -> None:
        expect(self.position(), self.workload.position(self.steps),
               f"{self.library} {self.workload.name}, {when}, active state after {self.steps} steps")

    def precheck(self) -> None:
        """Step through known positions (crossing every level boundary) before anything is timed."""
        self.check("at start")
        done = 0
        for mark in self.workload.marks:
            self.run(mark - done)
            done = mark
            self.check("before timing")


class Loader:
    """One library's (c): load + validate + build the 1000-state ring from a file it wrote beforehand."""

    library: ClassVar[str] = ""
    key: ClassVar[str] = ""
    module: ClassVar[str] = ""
    dist: ClassVar[str] = ""
    note: ClassVar[str] = ""

    def __init__(self, directory: Path) -> None:
        self.dir = directory

    def prepare(self) -> None:
        """Write the file (not timed)."""

    def once(self) -> Any:
        """Load + validate + build; returns something ``verify`` can step."""
        raise NotImplementedError

    def verify(self, built: Any) -> None:
        raise NotImplementedError
