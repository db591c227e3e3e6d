"""A load leaves no cyclic garbage: everything it makes and drops is freed at once by reference counting, so the
collector's pass after the load (the first of several that walk every object still young) sees only what the machine
keeps. A closure that calls itself (a reference cycle through its own cell) held the checks' 2,000 (spec, path) pairs
of the 1000-state ring, with the specs themselves, until a later pass."""

from __future__ import annotations

import gc
from collections import Counter
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest

import fsm

REPO = Path(__file__).resolve().parents[1]
RING = {"name": "ring", "initial": "s0", "states": [{"id": f"s{i}", "type": "Idle"} for i in range(50)],
        "transitions": [{"type": "Always", "from": f"s{i}", "to": f"s{(i + 1) % 50}"} for i in range(50)]}


def _nested(depth: int) -> dict[str, Any]:
    states: list[dict[str, Any]] = [{"id": "a", "type": "Idle"}, {"id": "end", "type": "Final"}]
    if depth:
        states[0] = {"id": "a", "type": "FSMState", "machine": _nested(depth - 1)}
    return {"initial": "a", "states": states, "transitions": [{"type": "Finished" if depth else "Always",
                                                                "from": "a", "to": "end"}]}


@contextmanager
def garbage_saved() -> Iterator[list[Any]]:
    """The collector off, and what its passes find unreachable kept in ``gc.garbage`` to be looked at."""
    gc.disable()
    gc.set_debug(gc.DEBUG_SAVEALL)
    try:
        yield gc.garbage
    finally:
        gc.set_debug(0)
        gc.garbage.clear()
        gc.enable()


@pytest.mark.parametrize("doc", [RING, {"name": "nested", **_nested(4)}, REPO / "diagrams" / "examples" / "sorter.json",
                                 REPO / "diagrams" / "examples" / "mission.json"],
                         ids=["ring", "nested", "sorter (sequences)", "mission"])
def test_a_load_leaves_no_cyclic_garbage(doc: dict[str, Any] | Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("FSM_NO_CACHE", "1")
    fsm.load(doc)  # what a first load imports and builds once (modules, validators) is not the load's garbage
    gc.collect()  # the machine just dropped: cyclic by design (its regions and states know each other)
    with garbage_saved() as garbage:
        machine = fsm.load(doc)
        gc.collect()
        assert not garbage, Counter(type(o).__name__ for o in garbage).most_common(8)
    assert machine.root is not None
