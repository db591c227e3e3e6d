"""tral-fsm: the workloads as machine documents, ticked with ``machine.tick()``; one adapter for both."""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import Any

import fsm

from .adapter import Adapter, Loader
from .workloads import FAN, FLAT_N, LOAD_N, expect


def ring_doc(n: int) -> dict[str, Any]:
    return {
        "name": f"ring{n}",
        "initial": "s0",
        "states": [{"id": f"s{i}", "type": "Idle"} for i in range(n)],
        "transitions": [{"type": "Always", "from": f"s{i}", "to": f"s{(i + 1) % n}"} for i in range(n)],
    }


def nested_doc() -> dict[str, Any]:
    def chain(prefix: str, n: int, child: Callable[[int], dict[str, Any]] | None, tr_type: str) -> dict[str, Any]:
        if child is None:
            states = [{"id": f"{prefix}{i}", "type": "Idle"} for i in range(n)]
        else:
            states = [{"id": f"{prefix}{i}", "type": "FSMState", "machine": child(i)} for i in range(n)]
        states.append({"id": "end", "type": "Final"})
        trans = [{"type": tr_type, "from": f"{prefix}{i}", "to": f"{prefix}{i + 1}" if i < n - 1 else "end"}
                 for i in range(n)]
        return {"initial": f"{prefix}0", "states": states, "transitions": trans}

    def leaves(_: int) -> dict[str, Any]:
        return chain("l", FAN, None, "Always")

    def middle(_: int) -> dict[str, Any]:
        return chain("m", FAN, leaves, "Finished")

    return {
        "name": "nested",
        "initial": "c0",
        "states": [{"id": f"c{k}", "type": "FSMState", "machine": middle(k)} for k in range(FAN)],
        "transitions": [{"type": "Finished", "from": f"c{k}", "to": f"c{(k + 1) % FAN}"} for k in range(FAN)],
    }


DOCUMENTS: dict[str, Callable[[], dict[str, Any]]] = {"flat": lambda: ring_doc(FLAT_N), "nested": nested_doc}


class TralFsm(Adapter):
    """``fsm.load`` of the workload's document; ``machine.tick()`` per step; transitions counted by the
    machine itself (``transition_count``) and checked against the workload's count."""

    library = key = dist = "tral-fsm"
    module = "fsm"
    notes = {"flat": "", "nested": ""}

    def build(self) -> Callable[[], Any]:
        self.m = fsm.load(DOCUMENTS[self.workload.name]())
        self.counted = 0
        return self.m.tick

    def advance(self, n: int) -> int:
        total = self.m.transition_count
        fired, self.counted = total - self.counted, total
        expect(fired, self.workload.fired(self.steps, n), f"tral-fsm {self.workload.name}: transitions fired")
        self.steps += n
        return fired

    def position(self) -> str:
        return self.m.active_path if self.m.started else self.workload.position(0)


class TralFsmLoad(Loader):
    library, key, module, dist = "tral-fsm fsm.load", "tral-fsm", "fsm", "tral-fsm"
    note = "JSON file; shape + semantic validation; build"

    def prepare(self) -> None:
        self.path = self.dir / "ring1000.json"
        self.path.write_text(json.dumps(ring_doc(LOAD_N), indent=1))

    def once(self) -> Any:
        return fsm.load(self.path)

    def verify(self, m: Any) -> None:
        m.tick()
        m.tick()
        expect(m.active_path, "s2", "tral-fsm load: active state after 2 ticks")
        expect(len(m.states_by_path), LOAD_N, "tral-fsm load: states built")
