"""sismic: statecharts built with its Python API; ``queue("next")`` then ``execute_once()`` (flat) or
``execute()`` (nested, so that the internal ``done`` events are processed too) per step."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from .adapter import Adapter, Loader
from .workloads import FAN, FLAT_N, LOAD_N, expect, nested_transitions


def ring(n: int) -> Any:
    from sismic.model import BasicState, CompoundState, Statechart, Transition

    sc = Statechart(f"ring{n}")
    sc.add_state(CompoundState("ring", initial="s0"), None)
    for i in range(n):
        sc.add_state(BasicState(f"s{i}"), "ring")
    for i in range(n):
        sc.add_transition(Transition(f"s{i}", f"s{(i + 1) % n}", event="next"))
    return sc


def nested() -> Any:
    from sismic.model import BasicState, CompoundState, FinalState, Statechart, Transition

    # sismic has no completion events: a final state raises an internal 'done' on entry, and each
    # composite leaves on 'done' (inner-first priority makes the innermost composite take it).
    sc = Statechart("nested")
    sc.add_state(CompoundState("ring", initial="c0"), None)
    trans = []
    for k in range(FAN):
        c = f"c{k}"
        sc.add_state(CompoundState(c, initial=f"{c}_m0"), "ring")
        trans.append(Transition(c, f"c{(k + 1) % FAN}", event="done"))
        for j in range(FAN):
            m = f"{c}_m{j}"
            sc.add_state(CompoundState(m, initial=f"{m}_l0"), c)
            trans.append(Transition(m, f"{c}_m{j + 1}" if j < FAN - 1 else f"{c}_end", event="done"))
            for i in range(FAN):
                sc.add_state(BasicState(f"{m}_l{i}"), m)
                trans.append(Transition(f"{m}_l{i}", f"{m}_l{i + 1}" if i < FAN - 1 else f"{m}_end", event="next"))
            sc.add_state(FinalState(f"{m}_end", on_entry="send('done')"), m)
        sc.add_state(FinalState(f"{c}_end", on_entry="send('done')"), c)
    for t in trans:
        sc.add_transition(t)
    return sc


class Sismic(Adapter):
    library = key = module = dist = "sismic"
    notes = {"flat": "Python API; queue('next') + execute_once() per step",
             "nested": "Python API; final states send('done'); queue('next') + execute() per step"}

    def build(self) -> Callable[[], Any]:
        from sismic.interpreter import Interpreter

        flat = self.workload.name == "flat"
        self.it = Interpreter(ring(FLAT_N) if flat else nested())
        self.it.execute_once()  # enter the initial configuration
        queue, execute = self.it.queue, (self.it.execute_once if flat else self.it.execute)

        def step() -> None:
            queue("next")
            execute()
        return step

    def position(self) -> str:
        return self.it.configuration[-1].replace("_", "/")

    def precheck(self) -> None:
        if self.workload.name == "nested":
            # Count the transitions sismic reports, not only the position, for the first 1,000 steps.
            self.check("at start")
            fired = 0
            for _ in range(FAN ** 3):
                self.it.queue("next")
                fired += sum(len(ms.transitions) for ms in self.it.execute())
                self.steps += 1
            expect(fired, nested_transitions(self.steps), "sismic nested: transitions reported by sismic")
            self.check("before timing")
        super().precheck()


class SismicLoad(Loader):
    library, key, module, dist = "sismic import_from_yaml", "sismic", "sismic", "sismic"
    note = "YAML file, schema-checked, + Interpreter"

    def prepare(self) -> None:
        from sismic.io import export_to_yaml

        self.path = self.dir / "ring1000.yaml"
        export_to_yaml(ring(LOAD_N), filepath=str(self.path))

    def once(self) -> Any:
        from sismic.interpreter import Interpreter
        from sismic.io import import_from_yaml

        return Interpreter(import_from_yaml(filepath=str(self.path)))

    def verify(self, it: Any) -> None:
        it.execute_once()
        for _ in range(2):
            it.queue("next")
            it.execute_once()
        expect(it.configuration, ["ring", "s2"], "sismic load: configuration after 2 events")
        expect(len(it.statechart.states), LOAD_N + 1, "sismic load: states built")
