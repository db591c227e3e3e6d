"""transitions (pytransitions): ``Machine`` and ``HierarchicalMachine``, one ``next`` trigger per step."""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import Any

from .adapter import Adapter, Loader
from .workloads import FAN, FLAT_N, LOAD_N, expect


def ring_spec(n: int) -> dict[str, Any]:
    return {
        "initial": "s0",
        "states": [f"s{i}" for i in range(n)],
        "transitions": [{"trigger": "next", "source": f"s{i}", "dest": f"s{(i + 1) % n}"} for i in range(n)],
    }


def machine(spec: dict[str, Any], hierarchical: bool) -> Any:
    if hierarchical:
        from transitions.extensions import HierarchicalMachine as cls
    else:
        from transitions import Machine as cls
    return cls(states=spec["states"], transitions=spec["transitions"], initial=spec["initial"],
               auto_transitions=False)


def nested_machine() -> Any:
    """Compounds with ``final=True`` end states; a compound's ``on_final`` triggers ``done`` (queued), which
    moves to the next sibling compound."""
    from transitions.extensions import HierarchicalMachine

    holder: dict[str, Any] = {}

    def completion(final_state: str) -> Callable[[], None]:
        # transitions calls on_final of every ancestor whose active subtree is all final, so the
        # root composite would also see its child's completion: only the real one triggers 'done'.
        def on_final() -> None:
            m = holder["m"]
            if m.state == final_state:
                m.done()
        return on_final

    states: list[Any] = []
    trans: list[dict[str, str]] = []
    for k in range(FAN):
        c = f"c{k}"
        mids: list[Any] = []
        for j in range(FAN):
            m = f"m{j}"
            leaves: list[Any] = [f"l{i}" for i in range(FAN)] + [{"name": "end", "final": True}]
            mids.append({"name": m, "children": leaves, "initial": "l0", "on_final": completion(f"{c}_{m}_end")})
            for i in range(FAN):
                trans.append({"trigger": "next", "source": f"{c}_{m}_l{i}",
                              "dest": f"{c}_{m}_l{i + 1}" if i < FAN - 1 else f"{c}_{m}_end"})
            trans.append({"trigger": "done", "source": f"{c}_{m}",
                          "dest": f"{c}_m{j + 1}" if j < FAN - 1 else f"{c}_end"})
        mids.append({"name": "end", "final": True})
        states.append({"name": c, "children": mids, "initial": "m0", "on_final": completion(f"{c}_end")})
        trans.append({"trigger": "done", "source": c, "dest": f"c{(k + 1) % FAN}"})
    holder["m"] = HierarchicalMachine(states=states, transitions=trans, initial="c0", auto_transitions=False,
                                      queued=True)
    return holder["m"]


class Transitions(Adapter):
    library, key, module, dist = "transitions Machine", "transitions", "transitions", "transitions"
    notes = {"flat": "auto_transitions=False; one 'next' trigger per step"}
    hierarchical = False

    def build(self) -> Callable[[], Any]:
        if self.workload.name == "nested":
            self.m = nested_machine()
        else:
            self.m = machine(ring_spec(FLAT_N), self.hierarchical)
        return self.m.next

    def position(self) -> str:
        return self.m.state.replace("_", "/")


class Hsm(Transitions):
    library, key = "transitions HierarchicalMachine", "transitions-hsm"
    notes = {"flat": Transitions.notes["flat"],
             "nested": "final=True leaves, compound on_final triggers 'done' (queued=True); "
                       "one 'next' trigger per step"}
    hierarchical = True


class TransitionsLoad(Loader):
    library, key, module, dist = "transitions Machine", "transitions", "transitions", "transitions"
    note = "JSON file (json.load) -> Machine(auto_transitions=False)"
    hierarchical = False

    def prepare(self) -> None:
        self.path = self.dir / "ring1000_transitions.json"
        self.path.write_text(json.dumps(ring_spec(LOAD_N), indent=1))

    def once(self) -> Any:
        with open(self.path, encoding="utf-8") as f:
            spec = json.load(f)
        return machine(spec, self.hierarchical)

    def verify(self, m: Any) -> None:
        m.next()
        m.next()
        expect(m.state, "s2", f"{self.library} load: state after 2 triggers")
        expect(len(m.states), LOAD_N, f"{self.library} load: states built")


class HsmLoad(TransitionsLoad):
    library, key = "transitions HierarchicalMachine", "transitions-hsm"
    note = "JSON file (json.load) -> HierarchicalMachine(auto_transitions=False)"
    hierarchical = True
