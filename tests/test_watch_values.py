"""Watch values per tick, computed on request by re-simulation (fsm/debug/resim.py, Controller.watch_values): the
values a page is given for a range are, tick by tick, those of a plain run of the same document read directly after
every tick, whichever way they were computed (from a snapshot, from the start, at the current tick), and asking
leaves the run exactly as it was."""

from __future__ import annotations

import time
from typing import Any

import pytest

from fsm.session.session import Session, StopRules
from test_live_rewind import (
    LAP,
    ask,
    compare_tick_by_tick,
    eeros_plan,
    eeros_session,
    lap_session,
    running,
    state_of,
    step_to,
    trace_lines,
)

EXPRS = ["car_front", "car_left + car_right", "car_distance * 2", "car_speed < 0.5", "car_steering"]
INJECTED = {"kind": "force", "sensor": "front", "value": 2.9, "ticks": 40}


def _read(session: Session) -> tuple[Any, ...]:
    """What the watches say, read straight from the car and the variables (not through the watch code)."""
    car = session.machine.ctx.car
    return (car.front, car.left + car.right, car.distance * 2, car.speed < 0.5, car.steering)


@pytest.fixture(scope="module")
def plain() -> dict[int, tuple[Any, ...]]:
    """The hallway lap run tick by tick, the force injected before tick 701, read after every tick."""
    from fsm.session.inputs import input_from_json

    session = lap_session()
    session.schedule_tick(701, input_from_json(INJECTED))
    session.start()
    out = {0: _read(session)}
    for _ in range(2400):
        session.run(stop_rules=StopRules(max_ticks=1))
        out[session.ticks] = _read(session)
    return out


def _values(reply: dict[str, Any]) -> dict[int, tuple[Any, ...]]:
    assert not reply["reduced"] and reply["stopped"] is None
    return {t: tuple(vals) for t, *vals in zip(reply["ticks"], *reply["series"], strict=True)}


def _expect(plain: dict[int, tuple[Any, ...]], first: int, last: int) -> dict[int, tuple[Any, ...]]:
    return {t: plain[t] for t in range(first, last + 1)}


def test_a_range_s_values_are_a_plain_run_s_tick_by_tick_and_the_run_is_untouched(
        plain: dict[int, tuple[Any, ...]], monkeypatch: pytest.MonkeyPatch) -> None:
    with running(lap_session, snapshot_period=3.0, snapshot_share=1.0) as subject, \
            running(lap_session, snapshot_period=3.0, snapshot_share=1.0) as reference:
        for controller in (subject, reference):
            step_to(controller, 700)
            ask(controller, "input", {"input": INJECTED})
        for text in EXPRS:
            ask(subject, "watch", {"expr": text})
        step_to(subject, 2400)
        nearest = max(s.tick for s in subject.snapshots if s.tick <= 1000)
        from_snapshot = ask(subject, "watch_values", {"from": 1000, "to": 2300})
        assert from_snapshot["source"] == f"snapshot at tick {nearest}" and from_snapshot["watches"] == [1, 2, 3, 4, 5]
        assert _values(from_snapshot) == _expect(plain, 1000, 2300)
        from_start = ask(subject, "watch_values", {"from": 0, "to": 2400})
        assert from_start["source"] == "start" and _values(from_start) == _expect(plain, 0, 2400)
        here = ask(subject, "watch_values", {})
        assert here["source"] == "live" and _values(here) == _expect(plain, 2400, 2400)
        one = ask(subject, "watch_values", {"from": 1234, "to": 1234})
        assert _values(one) == _expect(plain, 1234, 1234)
        # the car touches a wall now (it cannot be snapshotted exactly): from the start, the same values
        monkeypatch.setattr("fsm.debug.control.exact_now", lambda session: False)
        touching = ask(subject, "watch_values", {"from": 1500, "to": 1600})
        assert touching["source"] == "start" and _values(touching) == _expect(plain, 1500, 1600)
        monkeypatch.undo()
        # more ticks than twice the plot's columns: each column's least and greatest of the exact values
        reduced = ask(subject, "watch_values", {"from": 0, "to": 2400, "width": 100})
        assert reduced["reduced"] and reduced["computed"] == 2401 and len(reduced["ticks"]) == 200
        fronts = [plain[t][0] for t in range(0, 2401)]
        assert min(x for x in reduced["series"][0]) == min(fronts) and max(reduced["series"][0]) == max(fronts)
        assert set(reduced["series"][3]) <= {0.0, 1.0}
        # asked or not, the run goes on the same, writes the same trace and keeps the same track; and a rewind to a
        # snapshot between the one the values came from and the current tick finds it whole (its track too)
        step_to(subject, 2450)
        step_to(reference, 2450)
        assert state_of(subject.session) == state_of(reference.session)
        assert trace_lines(subject.session) == trace_lines(reference.session)
        compare_tick_by_tick(subject, reference, 3)
        for controller in (subject, reference):
            ask(controller, "rewind", {"tick": 2300})
        compare_tick_by_tick(subject, reference, 3)


def test_values_across_a_hot_reload_are_those_of_the_reloaded_run() -> None:
    """The EEROS pause case reloaded at tick 651: a range across it, from a snapshot before it, is done again with
    the reload; the reference is a plain run reloaded at the same tick, its variables read after every tick."""
    from fsm.debug.reload import swap_machine

    with running(eeros_session, snapshot_period=1.0, snapshot_share=1.0) as subject:
        ask(subject, "watch", {"expr": "cycles * 10"})
        ask(subject, "watch", {"expr": "axis_x"})
        step_to(subject, 650)
        ask(subject, "reload", {"plan": eeros_plan(), "info": {"file": "case4_pause.json"}})
        step_to(subject, 900)
        reply = ask(subject, "watch_values", {"from": 560, "to": 900})
        assert reply["source"].startswith("snapshot at tick") and int(reply["source"].split()[-1]) < 650
    session = eeros_session()
    session.start()
    want: dict[int, tuple[Any, ...]] = {}
    while session.ticks < 900:
        if session.ticks == 650:
            session.replace_machine(swap_machine(session.machine, eeros_plan()).machine)
        session.run(stop_rules=StopRules(max_ticks=1))
        ctx = session.machine.ctx
        want[session.ticks] = (ctx.vars["cycles"] * 10, ctx.vars["axis_x"])
    assert _values(reply) == {t: want[t] for t in range(560, 901)}


BAD = [({"from": 10, "to": 5}, "from (10) is after to (5)"),
       ({"to": 99_999}, "to is a tick from 0 to the current 300"),
       ({"from": -1}, "from is a tick from 0"),
       ({"from": 0, "width": 0}, "a width is 1 to 4000"),
       ({"from": True}, "from is a tick")]


def test_a_bad_request_is_refused_with_what_is_wrong() -> None:
    with running(lap_session, snapshot_period=None) as controller:
        step_to(controller, 300)
        controller.send("watch_values", {}, "none")
        controller.send("watch", {"expr": "car_front"})
        for k, (args, _error) in enumerate(BAD):
            controller.send("watch_values", args, k)
        end = time.monotonic() + 20
        while not {"none", *range(len(BAD))} <= {m.get("id") for m in list(controller.messages)}:
            assert time.monotonic() < end
            time.sleep(0.002)
        replies = {m.get("id"): m for m in list(controller.messages) if m.get("kind") == "reply"}
        assert not replies["none"]["ok"] and "no watch expression" in replies["none"]["error"]
        for k, (_args, error) in enumerate(BAD):
            assert not replies[k]["ok"] and error in replies[k]["error"], replies[k]


@pytest.fixture(scope="module")
def lap_trace(tmp_path_factory: pytest.TempPathFactory) -> Any:
    from fsm.tools.cli import main

    path = tmp_path_factory.mktemp("watch") / "lap.jsonl"
    assert main(["run", str(LAP), "--duration", "6", "--trace", str(path), "-q"]) == 0
    return path


def test_fsmctl_watch_prints_every_tick_s_values_as_a_plain_run_has_them(
        lap_trace: Any, plain: dict[int, tuple[Any, ...]], capsys: pytest.CaptureFixture[str]) -> None:
    import csv

    from helpers import cli

    code, out, err = cli(capsys, "watch", str(lap_trace), *EXPRS, "--from", "150", "--to", "480", "--csv")
    assert code == 0, err
    rows = list(csv.reader(out.splitlines()))
    assert rows[0] == ["tick", "time", *EXPRS]
    got = {int(r[0]): (float(r[2]), float(r[3]), float(r[4]), r[5] == "true", float(r[6])) for r in rows[1:]}
    assert got == _expect(plain, 150, 480)  # every digit (the trace's run is the fixture's before its injection)
    code, out, err = cli(capsys, "watch", str(lap_trace), "car_front", "--from", "478")
    assert code == 0 and out.splitlines() == ["tick    time  car_front", " 478  5.9750          3",
                                              " 479  5.9875          3", " 480  6.0000          3"], out


@pytest.mark.parametrize(("args", "error"), [
    (["car_front", "nope * 2"], "expression 2 'nope * 2', column 1: unknown variable 'nope' (known: car_"),
    (["car_frnt"], "unknown variable 'car_frnt' (did you mean car_front"),
    (["car_front +"], "expression 1 'car_front +', column 12: "),
    (["car_front", "--to", "99999"], "--to 99999: the trace's ticks are 0 to 480"),
    (["car_front", "--from", "9", "--to", "3"], "--from 9 is after --to 3"),
])
def test_fsmctl_watch_refuses_a_bad_expression_or_range_with_where(
        lap_trace: Any, args: list[str], error: str, capsys: pytest.CaptureFixture[str]) -> None:
    from helpers import cli

    code, out, err = cli(capsys, "watch", str(lap_trace), *args)
    assert code == 1 and out == "" and error in err and "Traceback" not in err, err


def test_beyond_the_horizon_a_request_says_why_or_is_clipped(monkeypatch: pytest.MonkeyPatch) -> None:
    with running(lap_session, snapshot_period=2.0, snapshot_share=1.0, horizon=10.0) as controller:
        ask(controller, "watch", {"expr": "car_front"})
        step_to(controller, 2400)
        earliest = controller.earliest
        assert earliest > 0
        controller.send("watch_values", {"from": 5, "to": 10}, "far")
        end = time.monotonic() + 20
        while not any(m.get("id") == "far" for m in list(controller.messages)):
            assert time.monotonic() < end
            time.sleep(0.002)
        far = next(m for m in list(controller.messages) if m.get("id") == "far")
        assert not far["ok"] and "beyond the rewind horizon" in far["error"]
        part = ask(controller, "watch_values", {"from": 0, "to": earliest + 5})
        assert part["from"] == earliest and "beyond the rewind horizon" in part["clipped"]
        assert part["ticks"] == list(range(earliest, earliest + 6)) and part["stopped"] is None
        monkeypatch.setattr("fsm.debug.control.exact_now", lambda session: False)
        controller.send("watch_values", {"from": earliest + 10, "to": earliest + 20}, "wall")
        while not any(m.get("id") == "wall" for m in list(controller.messages)):
            assert time.monotonic() < end
            time.sleep(0.002)
        wall = next(m for m in list(controller.messages) if m.get("id") == "wall")
        assert not wall["ok"] and "the car touches a wall at the current tick" in wall["error"]


def test_why_re_simulates_the_same_way_from_a_snapshot_or_the_start_and_across_a_reload(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """The live Why goes through the same re-simulation as watch values: from a snapshot it says what fsmctl
    explain says of the run's trace, from the start too, and a tick after a hot reload is explained."""
    from fsm.tools.cli.explain import explain_trace
    from fsm.trace.replay import parse_trace

    with running(lap_session, snapshot_period=3.0, snapshot_share=1.0) as subject:
        step_to(subject, 2400)
        recorder = subject.session.recorder
        assert recorder is not None
        recorder.flush_samples(subject.session.machine)
        trace = parse_trace(recorder.out.text().encode("utf-8"))
        first = min(s.tick for s in subject.snapshots)
        tick = next(e["tick"] for e in trace.events if e["tick"] > first + 1 and e.get("transitions"))
        want = explain_trace(trace, tick).to_json()
        assert ask(subject, "why", {"tick": tick})["why"] == want
        monkeypatch.setattr("fsm.debug.control.exact_now", lambda session: False)
        assert ask(subject, "why", {"tick": tick})["why"] == want
        monkeypatch.undo()
    with running(eeros_session, snapshot_period=1.0, snapshot_share=1.0) as subject:
        step_to(subject, 650)
        ask(subject, "reload", {"plan": eeros_plan(), "info": {"file": "case4_pause.json"}})
        step_to(subject, 700)
        assert ask(subject, "why", {"tick": 651})["why"]["tick"] == 651
        assert ask(subject, "why", {"tick": 690})["why"]["tick"] == 690
