"""Hot reload of a live run (issue 24, item 6): the machine swapped between two ticks for the edited document's,
keeping the variables, the active states by path and their clocks (fsm.debug.reload); an active state the new document
lacks pauses the run and says so; the reload is a line of the trace, read back by fsm.trace.replay and done again by a
rewind; an edited file with errors gives located errors (tools.live.reload) and changes nothing."""

from __future__ import annotations

import asyncio
import copy
import io
import json
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from fsm.debug.control import Controller
from fsm.loading.loader import check
from fsm.loading.loader import compile as compile_plan
from fsm.session.session import Session
from fsm.tools.live.reload import Watcher, loader
from fsm.trace.recorder import Recorder
from fsm.trace.replay import parse_trace

#: n counts up every 0.1 s (8 ticks); 'done' when n reaches 20.
COUNTER: dict[str, Any] = {
    "name": "counter", "initial": "count", "vars": {"n": 0},
    "states": [{"id": "count", "type": "Idle"}, {"id": "done", "type": "Final", "outcome": "done"}],
    "transitions": [{"type": "Always", "from": "count", "to": "done", "guard": "n >= 20"},
                    {"type": "Timeout", "from": "count", "to": "count", "seconds": 0.1, "set": {"n": "n + 1"}}]}


def edited(limit: int, **more: Any) -> dict[str, Any]:
    doc = copy.deepcopy(COUNTER)
    doc["transitions"][0]["guard"] = f"n >= {limit}"
    doc["vars"].update(more)
    return doc


@pytest.fixture
def counter() -> Iterator[tuple[Controller, list[io.StringIO]]]:
    from test_control import wait  # noqa: F401  (the same polling helper)

    outs: list[io.StringIO] = []

    def factory() -> Session:
        session = Session.open(copy.deepcopy(COUNTER))
        outs.append(io.StringIO())
        session.record(Recorder(outs[-1]))
        return session

    controller = Controller(factory(), factory=factory, speed=None, paused=True)
    thread = threading.Thread(target=controller.loop, daemon=True)
    thread.start()
    yield controller, outs
    controller.send("stop")
    thread.join(10)
    assert not thread.is_alive()


def test_a_reload_keeps_variables_active_states_and_their_clocks(counter: Any) -> None:
    from test_control import wait

    controller, outs = counter
    controller.send("step", {"n": 40})
    wait(controller, lambda s: s["tick"] == 40 and s["state"] == "paused")
    controller.send("reload", {"plan": compile_plan(edited(7, m=3)), "info": {"file": "counter.json"},
                               "signals": ["go"]})
    controller.send("resume")
    snap = wait(controller, lambda s: s["state"] == "ended")
    session = controller.session
    assert snap["outcome"] == "done" and session.machine.ctx.vars == {"n": 7, "m": 3}
    fresh = Session.open(edited(7, m=3))
    fresh.run()
    assert session.ticks == fresh.ticks  # the count state's timeout went on from its entry, as if never swapped
    trace = parse_trace(outs[0].getvalue().encode())
    assert not trace.warnings or all("no end line" in w for w in trace.warnings)
    [line] = trace.reloads
    assert (line["tick"], line["file"], line["kept"], line["missing"]) == (41, "counter.json", ["count"], [])
    assert trace.at(40)[1]["n"] == 5 and trace.at(41)[1] == {"n": 5, "m": 3}
    # a rewind past the reload does it again (a new trace, with its line); before it, the old machine comes back
    controller.send("rewind", {"tick": 45})
    wait(controller, lambda s: s["tick"] == 45)
    assert len(parse_trace(outs[1].getvalue().encode()).reloads) == 1
    assert controller.session.machine.ctx.vars["m"] == 3 and controller.signals == ("go",)
    controller.send("rewind", {"tick": 30}, "back")
    wait(controller, lambda s: s["tick"] == 30)
    told = next(m for m in list(controller.messages) if m.get("kind") == "rewound" and m["tick"] == 30)
    assert (told["dropped"], told["reloads_dropped"]) == (0, 1)  # the reload was undone, no input dropped
    answer = next(m for m in list(controller.messages) if m.get("id") == "back")
    assert (answer["dropped"], answer["reloads_dropped"]) == (0, 1)
    assert not parse_trace(outs[2].getvalue().encode()).reloads and "m" not in controller.session.machine.ctx.vars
    assert controller.signals == ()  # the signal names breakpoint expressions read are the old machine's again


def test_an_active_state_the_new_document_lacks_pauses_the_run_and_says_so(counter: Any) -> None:
    from test_control import wait

    controller, outs = counter
    controller.send("step", {"n": 30})
    wait(controller, lambda s: s["tick"] == 30 and s["state"] == "paused")
    doc = json.loads(json.dumps(COUNTER).replace('"count"', '"tally"'))
    controller.send("reload", {"plan": compile_plan(doc), "info": {"file": "counter.json"}})
    snap = wait(controller, lambda s: s["hit"] is not None)
    assert snap["state"] == "paused" and snap["active"] == ["tally"]
    assert snap["hit"]["text"] == "hot reload" and snap["hit"]["why"] == "count no longer exists, entered tally"
    assert parse_trace(outs[0].getvalue().encode()).reloads[0]["missing"] == [{"path": "count", "entered": "tally"}]
    assert snap["tick"] == 30 and controller.session.machine.ctx.vars["n"] == 3  # not started again


def test_an_edited_file_with_errors_gives_located_errors_and_a_good_one_a_plan(tmp_path: Path) -> None:
    machine = tmp_path / "counter.json"
    machine.write_text(json.dumps(COUNTER, indent=1))
    load = loader(str(machine), lambda: check(str(machine)), compile_plan, lambda spec: {"files": [str(machine)]})
    watcher = Watcher([str(machine)], load)
    assert not watcher.changed()
    machine.write_text(json.dumps(COUNTER, indent=1).replace('"Idle"', '"Idel"'))
    assert watcher.changed()
    bad = load()
    assert bad.plan is None and len(bad.errors) == 1
    assert bad.errors[0].startswith(f"{machine}:10:4 at /states/0/type") and "Idel" in bad.errors[0], bad.errors
    machine.write_text("{ not json")
    assert load().errors[0].startswith(f"{machine}:1:3")
    machine.write_text(json.dumps(edited(3)))
    good = load()
    assert not good.errors and good.plan is not None and good.info["files"] == [str(machine)]


def test_the_watcher_tells_the_pages_of_errors_and_queues_a_good_edit(tmp_path: Path) -> None:
    machine = tmp_path / "counter.json"
    machine.write_text(json.dumps(COUNTER))
    load = loader(str(machine), lambda: check(str(machine)), compile_plan, lambda spec: {"files": [str(machine)]})
    watcher = Watcher([str(machine)], load)

    class Seen:
        def __init__(self) -> None:
            self.messages: list[dict[str, Any]] = []
            self.sent: list[tuple[str, dict[str, Any]]] = []
            self.notify = None

        def send(self, name: str, args: dict[str, Any]) -> None:
            self.sent.append((name, args))

    seen = Seen()
    redrawn: list[Any] = []

    async def main() -> None:
        task = asyncio.create_task(watcher.run(seen, redrawn.append))
        await asyncio.sleep(0.1)
        machine.write_text(json.dumps(COUNTER).replace('"Idle"', '"Idel"'))
        while not seen.messages:
            await asyncio.sleep(0.05)
        machine.write_text(json.dumps(edited(3)))
        while not seen.sent:
            await asyncio.sleep(0.05)
        task.cancel()

    asyncio.run(asyncio.wait_for(main(), 20))
    assert seen.messages[0]["ok"] is False and "Idel" in seen.messages[0]["errors"][0]
    assert [name for name, _ in seen.sent] == ["reload"] and len(redrawn) == 1


def test_an_edit_that_cannot_run_here_is_answered_and_the_run_goes_on(counter: Any) -> None:
    from test_control import replies, wait

    controller, outs = counter
    controller.send("step", {"n": 10})
    wait(controller, lambda s: s["tick"] == 10 and s["state"] == "paused")
    doc = copy.deepcopy(COUNTER)
    doc["states"].append({"id": "halt", "type": "Stop"})  # drives a car: this run has none
    doc["transitions"].append({"type": "Always", "from": "done", "to": "halt"})
    doc["states"][1] = {"id": "done", "type": "Idle"}
    controller.send("reload", {"plan": compile_plan(doc), "info": {"file": "counter.json"}}, 5)
    controller.send("step", {"n": 5})
    snap = wait(controller, lambda s: s["tick"] == 15 and s["state"] == "paused")
    [answer] = [r for r in replies(controller) if r["id"] == 5]
    assert not answer["ok"] and "cannot run here" in answer["error"] and "drives a car" in answer["error"]
    assert snap["active"] == ["count"] and not parse_trace(outs[0].getvalue().encode()).reloads
    assert controller.session.machine.ctx.machine is controller.session.machine


def test_a_reload_on_the_car_takes_new_parameters_and_keeps_one_of_each_listener() -> None:
    """The lap on the simulated car: the active FollowWall's speed edited; after the swap the car is commanded the
    new speed, the driver and the recorder listen once each, and the trace says when."""
    from fsm.sim import simulate
    from test_control import wait

    repo = Path(__file__).resolve().parents[1]
    lap = repo / "diagrams" / "lap.json"
    session = simulate(str(lap), world=repo / "diagrams" / "worlds" / "hallway.json")
    out = io.StringIO()
    session.record(Recorder(out))
    controller = Controller(session, speed=None, paused=True)
    thread = threading.Thread(target=controller.loop, daemon=True)
    thread.start()
    try:
        controller.send("step", {"n": 200})
        snap = wait(controller, lambda s: s["tick"] == 200 and s["state"] == "paused")
        assert snap["active"] == ["bottom"] and session.car.speed_command != 0.3
        doc = json.loads(lap.read_text())
        for state in doc["states"]:
            if state["id"] == "bottom":
                state["speed"] = 0.3
        controller.send("reload", {"plan": compile_plan(doc, base_dir=lap.parent), "info": {"file": str(lap)}})
        controller.send("step", {"n": 20})
        snap = wait(controller, lambda s: s["tick"] == 220 and s["state"] == "paused")
    finally:
        controller.send("stop")
        thread.join(10)
    assert snap["active"] == ["bottom"] and session.car.speed_command == 0.3
    listeners = session.machine.listeners
    assert len(listeners) == len({id(x) for x in listeners}) and session.driver.machine is session.machine
    assert [r["tick"] for r in parse_trace(out.getvalue().encode()).reloads] == [201]
