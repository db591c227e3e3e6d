"""The live debugger's core (issue 24): inputs recorded in the trace and replayed from it, the faults a debugger
injects (fsm.session.inputs), breakpoints (fsm.debug.breakpoints) and the controller that applies commands between
ticks only
(fsm.debug.control): pause, steps, speed, rewind."""

from __future__ import annotations

import io
import json
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from fsm.debug.breakpoints import BreakpointError, make_breakpoint
from fsm.debug.control import CHUNK, Controller
from fsm.session.inputs import (
    FinishState,
    FireMonitor,
    ForceSensor,
    InputError,
    check_input,
    input_from_json,
    input_to_json,
    recorded_inputs,
)
from fsm.session.session import PauseState, Session, SetSignal, SetVars
from fsm.trace.recorder import Recorder
from fsm.trace.replay import parse_trace

REPO = Path(__file__).resolve().parents[1]
SORTER = REPO / "diagrams" / "examples" / "sorter.json"
LAP = REPO / "diagrams" / "hallway_lap.json"


def sorter_run() -> tuple[Session, io.StringIO]:
    session = Session.open(str(SORTER))
    out = io.StringIO()
    session.record(Recorder(out))
    return session, out


def lap_run() -> tuple[Session, io.StringIO]:
    from fsm.sim import simulate

    session = simulate(str(LAP), world=REPO / "diagrams" / "worlds" / "hallway.json")
    out = io.StringIO()
    session.record(Recorder(out))
    return session, out


def lines(text: str, kind: str | None = None) -> list[dict[str, Any]]:
    found = [json.loads(line) for line in text.splitlines()]
    return [line for line in found if kind is None or line["type"] == kind]


# -- inputs in the trace ---------------------------------------------------------------------------------------------
def test_every_input_is_a_line_of_the_trace_and_the_run_replays_from_it() -> None:
    session, out = sorter_run()
    session.schedule(0.0, SetVars({"parts": 5}))
    session.schedule(0.6, SetSignal("gripped"))
    session.schedule(1.3, SetVars({"jams": 2}))
    session.run(stop_rules=None)
    session.finish()
    first = out.getvalue()
    inputs = lines(first, "input")
    assert [(i["tick"], i["input"]["kind"]) for i in inputs] == [(0, "set"), (48, "signal"), (104, "set")]
    assert inputs[1]["text"] == "signal gripped high"
    trace = parse_trace(first.encode())
    assert [i["tick"] for i in trace.inputs] == [0, 48, 104]
    assert trace.at(104)[1]["jams"] == 2 and trace.at(103)[1]["jams"] == 0
    again, out2 = sorter_run()
    replayed, warnings = recorded_inputs(trace.inputs)
    assert not warnings
    for tick, item in replayed:
        again.schedule_tick(tick, item)
    again.run()
    again.finish()
    assert out2.getvalue() == first


def test_inputs_go_to_json_and_back_and_bad_ones_say_what_is_wrong() -> None:
    for item in (SetVars({"n": 1, "s": "x", "seen": ["a", "b"], "at": {"x": 1.5}}), SetSignal("go", False),
                 PauseState("a/b"), ForceSensor("front", 0.2, 40),
                 FireMonitor("cycle", "jam"), FinishState("grip", "failed")):
        assert input_from_json(json.loads(json.dumps(input_to_json(item)))) == item
    for bad, words in [(None, "JSON object"), ({"kind": "explode"}, "unknown input kind"),
                       ({"kind": "set", "values": {"1x": 1}}, "not a name"),
                       ({"kind": "set", "values": {"n": [[1]]}}, "a value is"),
                       ({"kind": "force", "sensor": "roof", "value": 1, "ticks": 1}, "'sensor' must be"),
                       ({"kind": "force", "sensor": "left", "value": float("nan"), "ticks": 1}, "finite"),
                       ({"kind": "force", "sensor": "left", "value": 1, "ticks": 0}, "'ticks'"),
                       ({"kind": "signal", "name": ""}, "'name'"), ({"kind": "pause", "path": 3}, "'path'")]:
        with pytest.raises(InputError, match=words):
            input_from_json(bad)


def test_a_forced_reading_holds_for_its_ticks_and_then_the_car_is_the_car_again() -> None:
    session, _ = lap_run()
    session.step(10)
    car = session.car
    session.submit(ForceSensor("front", 0.123, 3))
    seen = []
    for _ in range(5):
        session.step(1)
        seen.append(session.machine.ctx.car.front)
    assert seen[:3] == [0.123] * 3 and seen[3] != 0.123
    assert session.machine.ctx.car is car  # the stand-in took itself out
    assert check_input(ForceSensor("front", 1, 1), Session.open(str(SORTER)).machine) is not None


def test_a_forced_front_reading_makes_the_lap_turn_early() -> None:
    plain, _ = lap_run()
    plain.run(until=lambda s: s.active_path != "lap1/bottom")
    forced, _ = lap_run()
    forced.step(100)
    forced.submit(ForceSensor("front", 0.5, 20))
    forced.run(until=lambda s: s.active_path != "lap1/bottom")
    assert forced.ticks < plain.ticks and forced.active_path == plain.active_path == "lap1/bottom_slow"


def test_a_fired_monitor_runs_its_exception_sequence_and_finish_ends_a_state() -> None:
    session, out = sorter_run()
    session.step(10)
    assert check_input(FireMonitor("cycle", "nope"), session.machine) is not None
    assert check_input(FireMonitor("cycle", "jam"), session.machine) is None
    session.submit(FireMonitor("cycle", "jam"))
    session.step(1)
    assert any("clear_jam" in p for p in session.machine.active_paths)
    session.step(200)
    grip = next(p for p in session.machine.states_by_path if p.endswith("grip"))
    session.run(until=lambda s: grip in s.machine.active_paths)
    assert check_input(FinishState(grip, "explode"), session.machine) is not None
    session.submit(FinishState(grip))
    session.step(2)
    assert grip not in session.machine.active_paths
    assert [i["input"]["kind"] for i in lines(out.getvalue(), "input")] == ["monitor", "finish"]


# -- breakpoints ------------------------------------------------------------------------------------------------------
def test_breakpoints_are_checked_against_the_machine_and_expressions_say_where_they_are_wrong() -> None:
    machine = Session.open(str(SORTER)).machine
    assert make_breakpoint(1, {"kind": "enter", "state": "cycle/*"}, machine).text == "entering cycle/*"
    for spec, words, column in [({"kind": "enter", "state": "cycel"}, "matches no state", None),
                                ({"kind": "teleport"}, "unknown breakpoint kind", None),
                                ({"kind": "expr", "expr": "parts >"}, "expected a value", 8),
                                ({"kind": "expr", "expr": "prats > 1"}, "did you mean parts", 1),
                                ({"kind": "expr", "expr": "parts + 1"}, "true/false is needed", 7),
                                ({"kind": "monitor", "owner": "cycle", "monitor": "fire"}, "matches no monitor", None)]:
        with pytest.raises(BreakpointError, match=words) as info:
            make_breakpoint(1, spec, machine, ["gripped"])
        assert info.value.column == column


# -- the controller ---------------------------------------------------------------------------------------------------
@pytest.fixture
def lap() -> Iterator[tuple[Controller, list[io.StringIO]]]:
    outs: list[io.StringIO] = []

    def factory() -> Session:
        session, out = lap_run()
        session.machine.ctx.vars["probe"] = 0  # a variable to inject (the lap has none)
        outs.append(out)
        return session

    controller = Controller(factory(), factory=factory, speed=None, paused=True)
    thread = threading.Thread(target=controller.loop, daemon=True)
    thread.start()
    yield controller, outs
    controller.send("stop")
    thread.join(10)
    assert not thread.is_alive()


def wait(controller: Controller, pred: Callable[[dict[str, Any]], bool], seconds: float = 20) -> dict[str, Any]:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        snap = controller.snapshot
        if snap and pred(snap):
            return snap
        time.sleep(0.002)
    raise AssertionError(f"not reached: {controller.snapshot}")


def step_one(controller: Controller, tick: int) -> None:
    """One step of one tick, to ``tick``, as a person clicks Step 1."""
    controller.send("step", {"n": 1})
    wait(controller, lambda s: s["tick"] == tick and s["state"] == "paused")


def replies(controller: Controller) -> list[dict[str, Any]]:
    return [m for m in list(controller.messages) if m["kind"] == "reply"]


def test_steps_pause_exactly_and_a_breakpoint_stops_at_the_tick_the_trace_says(lap: Any) -> None:
    controller, outs = lap
    controller.send("step", {"n": 3})
    snap = wait(controller, lambda s: s["tick"] == 3 and s["state"] == "paused")
    assert snap["active"] == ["lap1/bottom"]
    controller.send("break", {"spec": {"kind": "enter", "state": "lap1/bottom_turn/settle"}}, 7)
    controller.send("break", {"spec": {"kind": "expr", "expr": "car_front <"}}, 8)
    controller.send("resume")
    snap = wait(controller, lambda s: s["hit"] is not None)
    assert snap["state"] == "paused" and snap["active"] == ["lap1/bottom_turn/settle"]
    entered = [e["tick"] for e in lines(outs[0].getvalue(), "event")
               if any(t["to"] == "lap1/bottom_turn/settle" for t in e["transitions"])]
    assert snap["hit"]["tick"] == snap["tick"] == entered[0]
    assert snap["hit"]["why"] == "entered lap1/bottom_turn/settle"
    bad = next(r for r in replies(controller) if r["id"] == 8)
    assert not bad["ok"] and bad["column"] == 12
    controller.send("step_transition")
    snap = wait(controller, lambda s: s["hit"] is not None and s["hit"]["breakpoint"] is None)
    assert "lap1/bottom_turn/settle -> lap1/bottom_turn/done" in snap["hit"]["why"]


def test_a_paused_run_tells_its_watchers_only_what_changed(lap: Any) -> None:
    """A paused run looks for commands every IDLE seconds; it publishes (and wakes the pages, which redraw) only when
    its status changed: an idle page costs the browser nothing."""
    import fsm.debug.control

    controller, _ = lap
    woken: list[int] = []
    controller.notify = lambda: woken.append(controller.snapshot["seq"])
    controller.send("step", {"n": 2})
    snap = wait(controller, lambda s: s["tick"] == 2 and s["state"] == "paused")
    time.sleep(5 * fsm.debug.control.IDLE)  # five looks of the paused loop
    assert controller.snapshot["seq"] == snap["seq"] and woken[-1] == snap["seq"]
    controller.send("speed", {"x": 2.0})
    snap = wait(controller, lambda s: s["speed"] == 2.0)
    assert snap["seq"] > woken[0] and woken[-1] == snap["seq"] and snap["tick"] == 2


def test_an_injected_variable_is_applied_before_the_next_tick_and_rewind_forks(lap: Any) -> None:
    controller, outs = lap
    controller.send("step", {"n": 50})
    wait(controller, lambda s: s["tick"] == 50 and s["state"] == "paused")
    controller.send("input", {"input": {"kind": "set", "values": {"probe": 7}}}, 1)
    controller.send("step", {"n": 10})
    snap = wait(controller, lambda s: s["tick"] == 60 and s["state"] == "paused")
    assert snap["inputs"] == [[51, "set probe = 7"]]
    assert next(r for r in replies(controller) if r["id"] == 1)["tick"] == 51
    trace = parse_trace(outs[0].getvalue().encode())
    assert trace.at(50)[1] == {"probe": 0} and trace.at(51)[1] == {"probe": 7}
    controller.send("rewind", {"tick": 40}, 2)
    snap = wait(controller, lambda s: s["tick"] == 40)
    assert snap["inputs"] == [] and len(outs) == 2
    assert next(r for r in replies(controller) if r["id"] == 2)["dropped"] == 1
    first, second = lines(outs[0].getvalue()), lines(outs[1].getvalue())
    upto = [line for line in first if line["type"] in ("event", "keyframe") and line["tick"] <= 40]
    assert [line for line in second if line["type"] in ("event", "keyframe")] == upto
    controller.send("rewind", {"tick": 41}, 3)  # only back: the future is not known yet
    wait(controller, lambda s: any(r["id"] == 3 for r in replies(controller)))
    assert "from 0 to the current 40" in next(r for r in replies(controller) if r["id"] == 3)["error"]


def test_commands_that_make_no_sense_are_answered_not_obeyed(lap: Any) -> None:
    controller, _ = lap
    commands: list[tuple[str, dict[str, Any]]] = [
        ("step", {"n": 0}), ("speed", {"x": -1}), ("rewind", {"tick": 5}), ("unbreak", {"breakpoint": 9}), ("fly", {}),
        ("input", {"input": {"kind": "finish", "path": "lap2"}})]
    for number, (name, args) in enumerate(commands):
        controller.send(name, args, number)
    wait(controller, lambda s: len(replies(controller)) >= 6)
    answers = {r["id"]: r for r in replies(controller)}
    assert all(not answers[n]["ok"] for n in range(6)), answers
    assert "not active" in answers[5]["error"]
    assert controller.snapshot["tick"] == 0


def test_the_pace_follows_real_time() -> None:
    session, _ = sorter_run()
    controller = Controller(session, speed=4.0)
    thread = threading.Thread(target=controller.loop, daemon=True)
    t0 = time.monotonic()
    thread.start()
    wait(controller, lambda s: s["tick"] >= 80)
    elapsed = time.monotonic() - t0
    controller.send("stop")
    thread.join(5)
    assert 0.2 <= elapsed < 1.0  # 1 s of machine time at 4x real time


def test_a_breakpoint_removed_by_its_number_fires_no_more(lap: Any) -> None:
    """The page sends ``{"cmd": "unbreak", "id": REQUEST, "breakpoint": N}``: the breakpoint's number never takes
    the request's place (issue 33: Remove never removed)."""
    controller, _ = lap
    controller.send("break", {"spec": {"kind": "enter", "state": "lap1/*"}}, 1)
    snap = wait(controller, lambda s: len(s["breakpoints"]) == 1)
    number = snap["breakpoints"][0]["id"]
    controller.send("unbreak", {"breakpoint": number}, 2)
    snap = wait(controller, lambda s: s["breakpoints"] == [])
    assert next(r for r in replies(controller) if r["id"] == 2)["ok"]
    controller.send("step", {"n": 900})
    snap = wait(controller, lambda s: s["tick"] == 900 and s["state"] == "paused")
    assert snap["hit"] is None


def test_the_controller_is_called_per_tick_only_while_something_looks(lap: Any) -> None:
    """Issue 33 (the live loop's cost per tick): with no breakpoint and no step to a transition, a chunk of ticks
    runs as a plain run (no per-tick hook, no listener of transitions); a breakpoint attaches both from the states
    active when it was added, and its removal detaches them again."""
    from fsm.debug.breakpoints import Watch

    controller, _ = lap
    looked: list[int] = []
    looker = controller._looker

    def counted() -> Any:
        looked.append(controller.session.ticks)
        return looker()

    controller._looker = counted  # type: ignore[method-assign]

    def watching() -> bool:
        return any(isinstance(listener, Watch) for listener in controller.session.machine.listeners)

    controller.send("step", {"n": 700})
    wait(controller, lambda s: s["tick"] == 700 and s["state"] == "paused")
    assert looked == [] and not watching()
    controller.send("break", {"spec": {"kind": "enter", "state": "lap2"}}, 1)
    controller.send("resume")
    snap = wait(controller, lambda s: s["hit"] is not None)
    assert looked and looked[0] == 700 and watching()
    assert snap["hit"]["why"] == "entered lap2"
    controller.send("unbreak", {"breakpoint": snap["hit"]["breakpoint"]}, 2)
    controller.send("step", {"n": 10})
    wait(controller, lambda s: s["tick"] == snap["tick"] + 10 and s["state"] == "paused")
    assert not watching() and looked[-1] < snap["tick"]


@pytest.mark.parametrize(("values", "field", "words"), [
    ({"prob": 1}, "name", "has no variable 'prob' (did you mean 'probe'?)"),
    ({"probe": "text"}, "value", "'probe' holds a whole number (0); 'text' is a text"),
    ({"probe": 2.5}, "value", "2.5 is a number"),
    ({"probe": True}, "value", "True is a true/false"),
    ({"gates": 1e308}, "value", "'gates' holds a list ([]); 1e+308 is a number"),
])
def test_an_injected_value_is_checked_like_a_document(lap: Any, values: dict[str, Any], field: str,
                                                       words: str) -> None:
    """A variable the machine lacks, or a value of another kind than the variable holds, is refused with the field
    it is about; nothing is submitted, so the run goes on as it was (issue 33: a list set to 1e308 ended the run)."""
    controller, _ = lap
    controller.session.machine.ctx.vars["gates"] = []
    controller.send("input", {"input": {"kind": "set", "values": values}}, 1)
    wait(controller, lambda s: bool(replies(controller)))
    answer = replies(controller)[0]
    assert not answer["ok"] and answer["field"] == field and words in answer["error"], answer
    controller.send("input", {"input": {"kind": "set", "values": {"probe": 3.0}}}, 2)  # whole: taken as 3
    controller.send("step", {"n": 5})
    snap = wait(controller, lambda s: s["tick"] == 5 and s["state"] == "paused")
    assert snap["inputs"] == [[1, "set probe = 3"]] and snap["ended"] is None


@pytest.mark.parametrize(("force", "field", "words"), [
    ({"sensor": "front", "value": 1e308, "ticks": 5}, "value", "force front: 1e+308 m is not a reading a car gives"),
    ({"sensor": "speed", "value": -50, "ticks": 5}, "value", "from -20 to 20 m/s"),
    ({"sensor": "front", "value": 0.3, "ticks": 10**9}, "ticks", "force front: 'ticks' must be a whole number"),
    ({"sensor": "front", "value": 0.3, "ticks": 2.5}, "ticks", "got 2.5"),
    ({"sensor": "front", "value": None, "ticks": 5}, "value", "'value' must be a finite number, got None"),
    ({"sensor": "roof", "value": 1, "ticks": 5}, "sensor", "'sensor' must be one of"),
])
def test_a_forced_reading_no_car_gives_is_refused_at_its_field(lap: Any, force: dict[str, Any], field: str,
                                                               words: str) -> None:
    """A page's "1e9" ticks once became 1 tick, and a front reading of 1e308 m was taken (issue 33's tryout): each
    is refused, naming the field, and nothing is submitted."""
    controller, _ = lap
    controller.send("input", {"input": {"kind": "force", **force}}, 1)
    wait(controller, lambda s: bool(replies(controller)))
    answer = replies(controller)[0]
    assert not answer["ok"] and answer["field"] == field and words in answer["error"], answer
    controller.send("step", {"n": 3})
    snap = wait(controller, lambda s: s["tick"] == 3 and s["state"] == "paused")
    assert snap["inputs"] == [] and snap["ended"] is None


def test_a_list_variable_takes_a_list_of_its_kind(lap: Any) -> None:
    """A list variable was refused whatever the page sent, and told to "inject a list", which the page could not
    write. A list of the kind it holds is taken (whole numbers given as 2.0 made 2); one of another kind is not."""
    controller, _ = lap
    controller.session.machine.ctx.vars["gates"] = [1]
    controller.send("input", {"input": {"kind": "set", "values": {"gates": [1, "x"]}}}, 1)
    controller.send("input", {"input": {"kind": "set", "values": {"gates": 3}}}, 2)
    controller.send("input", {"input": {"kind": "set", "values": {"gates": [2.0, 3]}}}, 3)
    wait(controller, lambda s: len(replies(controller)) == 3)
    answers = {r["id"]: r for r in replies(controller)}
    assert not answers[1]["ok"] and answers[1]["field"] == "value"
    assert "written as JSON, such as [1]" in answers[2]["error"]
    assert answers[3]["ok"], answers[3]
    controller.send("step", {"n": 2})
    snap = wait(controller, lambda s: s["tick"] == 2 and s["state"] == "paused")
    assert snap["inputs"] == [[1, "set gates = [2, 3]"]] and snap["ended"] is None
    assert controller.session.machine.ctx.vars["gates"] == [2, 3]


def test_a_signal_no_condition_reads_is_refused_and_one_it_reads_is_taken() -> None:
    session, _ = sorter_run()
    controller = Controller(session, paused=True, signals=["gripped"])
    thread = threading.Thread(target=controller.loop, daemon=True)
    thread.start()
    try:
        controller.send("input", {"input": {"kind": "signal", "name": "griped"}}, 1)
        controller.send("input", {"input": {"kind": "signal", "name": "gripped"}}, 2)
        wait(controller, lambda s: len(replies(controller)) == 2)
        answers = {r["id"]: r for r in replies(controller)}
        assert not answers[1]["ok"] and answers[1]["field"] == "name"
        assert "no condition of the machine reads it (did you mean 'gripped'?)" in answers[1]["error"]
        assert answers[2]["ok"]
    finally:
        controller.send("stop")
        thread.join(10)


def test_watch_expressions_are_kept_at_the_ticks_a_page_sees_and_cost_nothing_without(lap: Any) -> None:
    controller, _ = lap
    controller.send("step", {"n": 10})
    wait(controller, lambda s: s["tick"] == 10 and s["state"] == "paused")
    assert not controller.watch_log  # none asked: nothing evaluated
    controller.send("watch", {"expr": "car_right"}, 1)
    controller.send("watch", {"expr": "probe + 1"}, 2)
    controller.send("watch", {"expr": "car_front <"}, 3)
    controller.send("step", {"n": 30})
    snap = wait(controller, lambda s: s["tick"] == 40 and s["state"] == "paused")
    answers = {r["id"]: r for r in replies(controller)}
    assert answers[1]["ok"] and answers[2]["ok"] and not answers[3]["ok"] and answers[3]["column"] == 12
    assert [w["text"] for w in snap["watches"]] == ["car_right", "probe + 1"]
    rows = list(controller.watch_log)
    assert [t for t, _ in rows] == [10, 40]  # when added, and where the step paused: not the ticks between
    assert all(row[1] == 1 for _t, row in rows)
    sent = [r for m in controller.messages if m["kind"] == "watched" for r in m["rows"]]
    assert [t for t, _ in sent] == [t for t, _ in rows]
    assert rows[-1][1][0] == controller.session.car.right  # the reading the machine sees now
    controller.send("step", {"n": 600})  # chunks of CHUNK ticks: a row at the end of each (what a page can show)
    wait(controller, lambda s: s["tick"] == 640 and s["state"] == "paused")
    assert [t for t, _ in controller.watch_log] == [10, 40, 40 + CHUNK, 40 + 2 * CHUNK, 640]
    controller.send("rewind", {"tick": 20}, 4)
    wait(controller, lambda s: s["tick"] == 20)
    assert [t for t, _ in controller.watch_log] == [10, 20]  # the later ones belong to the run rewound
    controller.send("unwatch", {"watch": 1}, 5)
    snap = wait(controller, lambda s: [w["text"] for w in s["watches"]] == ["probe + 1"])


def test_watch_values_are_those_of_their_tick_and_a_row_where_nothing_read_moved_is_reused(lap: Any) -> None:
    """Each row is what the expressions give for that tick's variables and readings (an injected variable shows
    from the tick it applied before); a row where none of the names read changed is the last row."""
    controller, _ = lap
    for n, text in enumerate(("probe", "car_right", "probe * 2 + car_right", "car_right < probe")):
        controller.send("watch", {"expr": text}, n)
    for tick in range(1, 21):
        step_one(controller, tick)
    controller.send("input", {"input": {"kind": "set", "values": {"probe": 5}}}, 9)
    for tick in range(21, 61):
        step_one(controller, tick)
    rows = list(controller.watch_log)
    assert [t for t, _ in rows] == list(range(61))  # a step of one tick at a time: each tick shown
    assert [row[0] for _t, row in rows] == [0] * 21 + [5] * 40  # the set applies before tick 21
    for _t, (probe, right, total, below) in rows:
        assert total == probe * 2 + right and below is (right < probe)
    rights = [row[1] for _t, row in rows]
    assert len(set(rights)) > 1  # the reading moved (the ultrasonic sensors sample at 20 Hz, the ticks at 80)
    reused = [k for k in range(1, len(rows)) if rows[k][1] is rows[k - 1][1]]
    assert reused and all(rights[k] == rights[k - 1] for k in reused)
    assert all(rows[k][1] is not rows[k - 1][1] for k in range(1, len(rows)) if rights[k] != rights[k - 1])
    controller.send("watch", {"expr": "car_left"}, 10)  # one more: every row has its column from now on
    controller.send("step", {"n": 2})
    wait(controller, lambda s: s["tick"] == 62 and s["state"] == "paused")
    assert [len(row) for _t, row in controller.watch_log] == [5, 5]  # 60 (when added), 62
    assert controller.watch_log[-1][1][4] == controller.session.car.left


def test_a_watched_list_is_read_afresh_at_every_row(lap: Any) -> None:
    """A list changes in place (equal to itself though changed): a watch reading one never keeps an old row."""
    controller, _ = lap
    controller.session.machine.ctx.vars["gates"] = []
    controller.send("watch", {"expr": "gates"}, 1)
    for tick in range(1, 6):
        step_one(controller, tick)
    rows = [row for _t, row in controller.watch_log]
    assert len(rows) == 6 and all(rows[k] is not rows[k - 1] for k in range(1, 6))


def test_a_run_that_raises_after_an_injection_has_it_undone_not_the_run_ended() -> None:
    """A value of the right kind can still make a state raise (here a guard dividing by it): the injection is undone
    (the run rewound to before it) and the run paused there, told why; it never ends because of an injection."""
    doc = {"name": "divide", "initial": "wait", "vars": {"n": 1},
           "states": [{"id": "wait", "type": "Idle"}, {"id": "done", "type": "Final"}],
           "transitions": [{"type": "Always", "from": "wait", "to": "done", "guard": "10 / n > 100"}]}
    outs: list[io.StringIO] = []

    def factory() -> Session:
        session = Session.open(doc)
        out = io.StringIO()
        session.record(Recorder(out))
        outs.append(out)
        return session

    controller = Controller(factory(), factory=factory, speed=None, paused=True)
    thread = threading.Thread(target=controller.loop, daemon=True)
    thread.start()
    try:
        controller.send("step", {"n": 10})
        wait(controller, lambda s: s["tick"] == 10 and s["state"] == "paused")
        controller.send("input", {"input": {"kind": "set", "values": {"n": 0}}}, 1)
        controller.send("step", {"n": 5})
        snap = wait(controller, lambda s: s["hit"] is not None)
        assert snap["state"] == "paused" and snap["ended"] is None and snap["inputs"] == []
        assert snap["tick"] == 10 and snap["hit"]["text"] == "injection undone"
        why = snap["hit"]["why"]
        assert why.startswith("the run raised in tick 11, after the injection 'set n = 0' (applied before tick 11)")
        assert "division by zero" in why
        assert controller.session.machine.ctx.vars["n"] == 1
        controller.send("step", {"n": 5})  # and it goes on as before the injection
        snap = wait(controller, lambda s: s["tick"] == 15 and s["state"] == "paused")
        assert snap["ended"] is None
    finally:
        controller.send("stop")
        thread.join(10)
