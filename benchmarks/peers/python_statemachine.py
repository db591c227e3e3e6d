"""python-statemachine: ``StateChart`` classes built with the Python API, ``sm.send("next")`` per step."""

from __future__ import annotations

import functools
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

from .adapter import Adapter, Loader
from .workloads import FAN, FLAT_N, LOAD_N, Unsupported, expect


def ring_doc(n: int) -> dict[str, Any]:
    """The ring in python-statemachine's own JSON format (for ``statemachine.io.load``)."""
    states: dict[str, Any] = {
        f"s{i}": {"transitions": [{"event": "next", "target": f"s{(i + 1) % n}"}]} for i in range(n)}
    states["s0"]["initial"] = True
    return {"name": f"ring{n}", "states": states}


def ring_class(n: int) -> Any:
    """The ring as a StateChart subclass built with the Python API (about 1.5x faster to run than a
    class from ``statemachine.io.load``, so the peer gets its better number)."""
    from statemachine import State, StateChart

    states = {f"s{i}": State(initial=i == 0) for i in range(n)}
    event = None
    for i in range(n):
        t = states[f"s{i}"].to(states[f"s{(i + 1) % n}"])
        event = t if event is None else event | t
    return type(f"Ring{n}", (StateChart,), {**states, "next": event, "__module__": __name__})


def nested_class() -> Any:
    """Compound states; a compound that reaches its final child raises done.state.<id> (SCXML semantics),
    taken in the same macrostep as the 'next' that caused it (``done_state_<id>`` declares that event).
    Ids are unique machine-wide and use '_' (a '.' would make done.state descriptors prefix-match)."""
    from statemachine import State, StateChart

    compound = type(State.Compound)

    def chain(prefix: str, name: str, child: Callable[[str], dict[str, Any]] | None) -> dict[str, Any]:
        ids = [f"{prefix}{name}{i}" for i in range(FAN)]
        ns: dict[str, Any] = {}
        for i, sid in enumerate(ids):
            if child is None:
                ns[sid] = State(initial=i == 0)
            else:
                ns[sid] = compound(sid, (State.Compound,), {**child(sid + "_"), "__module__": __name__},
                                   initial=i == 0)
        end = ns[f"{prefix}end"] = State(final=True)
        if child is None:
            event = None
            for i, sid in enumerate(ids):
                t = ns[sid].to(ns[ids[i + 1]] if i < FAN - 1 else end)
                event = t if event is None else event | t
            ns["next"] = event
        else:
            for i, sid in enumerate(ids):
                ns[f"done_state_{sid}"] = ns[sid].to(ns[ids[i + 1]] if i < FAN - 1 else end)
        return ns

    def leaves(prefix: str) -> dict[str, Any]:
        return chain(prefix, "l", None)

    def middle(prefix: str) -> dict[str, Any]:
        return chain(prefix, "m", leaves)

    ns: dict[str, Any] = {"__module__": __name__}
    for k in range(FAN):
        ns[f"c{k}"] = compound(f"c{k}", (State.Compound,), {**middle(f"c{k}_"), "__module__": __name__},
                               initial=k == 0)
    for k in range(FAN):
        ns[f"done_state_c{k}"] = ns[f"c{k}"].to(ns[f"c{(k + 1) % FAN}"])
    return type("Nested", (StateChart,), ns)


class Psm(Adapter):
    library, key, module, dist = "python-statemachine", "python-statemachine", "statemachine", "python-statemachine"
    notes = {"flat": "StateChart subclass built with the Python API; sm.send('next') per step",
             "nested": "compound states, done.state.<id> events for Finished; sm.send('next') per step"}

    def build(self) -> Callable[[], Any]:
        from statemachine import State

        if self.workload.name == "nested" and not hasattr(State, "Compound"):
            raise Unsupported("this version has no compound states")
        self.sm = (ring_class(FLAT_N) if self.workload.name == "flat" else nested_class())()
        return functools.partial(self.sm.send, "next")

    def position(self) -> str:
        ids = [s.id for s in self.sm.configuration]
        return max(ids, key=len).replace("_", "/")


class PsmLoad(Loader):
    library, key = "python-statemachine io.load(validate=True)", "python-statemachine"
    module, dist = "statemachine", "python-statemachine"
    note = "native JSON file, JSON-Schema validated, class + instance"
    validate = True

    def prepare(self) -> None:
        import statemachine.io as sio

        if not hasattr(sio, "load"):
            raise Unsupported("this version has no statemachine.io.load")
        self.path: Path = self.dir / "ring1000_psm.json"
        self.path.write_text(json.dumps(ring_doc(LOAD_N), indent=1))

    def once(self) -> Any:
        from statemachine.io import load

        return load(str(self.path), validate=self.validate)()

    def verify(self, sm: Any) -> None:
        sm.send("next")
        sm.send("next")
        expect([s.id for s in sm.configuration], ["s2"], "python-statemachine load: active state after 2 events")
        expect(len(sm.states), LOAD_N, "python-statemachine load: states built")


class PsmLoadNoValidate(PsmLoad):
    library = "python-statemachine io.load"
    note = "native JSON file, no schema validation, class + instance"
    validate = False
