"""py_trees: memory Sequences of leaves that return RUNNING once, then SUCCESS; ``root.tick_once()`` per step.

A leaf's SUCCESS is a transition, and so is an inner Sequence's SUCCESS (the ``Finished`` equivalent);
both are counted where they happen, and the step count is derived from them.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from .adapter import Adapter
from .workloads import FAN, FLAT_N, expect, nested_transitions


class PyTrees(Adapter):
    library, key, module, dist = "py_trees tick_once", "py_trees", "py_trees", "py_trees"
    notes = {"flat": "memory Sequence of leaves RUNNING once then SUCCESS; root.tick_once() per step",
             "nested": "nested memory Sequences (completion counted as a transition); root.tick_once() per step"}

    def build(self) -> Callable[[], Any]:
        import py_trees
        from py_trees.common import Status

        self.count = [0]
        count = self.count
        running, success = Status.RUNNING, Status.SUCCESS

        class Step(py_trees.behaviour.Behaviour):
            """RUNNING on its first tick, SUCCESS on the second: one tick = one state change."""

            def __init__(self, name: str) -> None:
                super().__init__(name)
                self.first = True

            def initialise(self) -> None:
                self.first = True

            def update(self) -> Status:
                if self.first:
                    self.first = False
                    return running
                count[0] += 1
                return success

        class Composite(py_trees.composites.Sequence):
            """A memory Sequence whose completion counts as a transition (the ``Finished`` equivalent)."""

            def terminate(self, new_status: Status) -> None:
                if new_status == success:
                    count[0] += 1

        Sequence = py_trees.composites.Sequence
        if self.workload.name == "flat":
            self.root = Sequence("ring", memory=True, children=[Step(f"s{i}") for i in range(FLAT_N)])
        else:
            self.root = Sequence("ring", memory=True, children=[
                Composite(f"c{k}", memory=True, children=[
                    Composite(f"m{j}", memory=True, children=[Step(f"l{i}") for i in range(FAN)])
                    for j in range(FAN)])
                for k in range(FAN)])
        self.Composite = py_trees.composites.Composite
        self.root.tick_once()  # the first tick enters the first leaf (RUNNING); no transition
        self.running = running
        self.counted = 0
        return self.root.tick_once

    def advance(self, n: int) -> int:
        fired, self.counted = self.count[0] - self.counted, self.count[0]
        # The position rule counts leaf changes: a leaf succeeds every tick but the one where the
        # whole ring completes (the root Sequence restarts on the next tick).
        self.steps = self._leaf_successes()
        return fired

    def _leaf_successes(self) -> int:
        c = self.count[0]
        if self.workload.name == "flat":
            return c
        # count = leaves + middle completions + top completions: invert nested_transitions (increasing)
        lo, hi = 0, c
        while lo < hi:
            mid = (lo + hi) // 2
            if nested_transitions(mid) < c:
                lo = mid + 1
            else:
                hi = mid
        expect(nested_transitions(lo), c, "py_trees nested: transitions counted (leaves + completions)")
        return lo

    def position(self) -> str:
        node = self.root
        names = []
        while isinstance(node, self.Composite):
            node = node.current_child
            names.append(node.name)
        return "/".join(names)

    def check(self, when: str) -> None:
        if self.root.status != self.running:
            # The tick where the whole ring completed: every leaf has run, the next tick restarts.
            expect(self.steps % self.workload.cycle, 0,
                   f"py_trees {self.workload.name}, {when}: ring completed off-cycle")
            return
        super().check(when)

    def precheck(self) -> None:
        start = self.steps
        super().precheck()
        if self.workload.name == "flat":
            expect(self.steps - start, FLAT_N, f"{self.library}: leaf changes in {FLAT_N + 1} ticks")
