"""Watch expressions compiled into one generated function per set (fsm/debug/watch.py): the same values as the
compiled expressions one by one, tick by tick, and the same error texts where they fail."""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import pytest

from fsm.debug.breakpoints import BreakpointError
from fsm.debug.watch import Slow, compile_watch, row_function

EXPRS = ["car_front", "car_front < 0.9", "car_left + car_right", "car_distance * 2", "n", "n / 4", "n % 3",
         "-n + 1", "abs(car_left - 2)", "min(n, car_front)", "max(n, 1, car_right)", "name + '!'",
         "flag and n > 2", "not flag or signal_go", "signal_go", "n == 3", "name != 'a'", "1 + 2", "n >= 2.5"]


def _machine(**vars: Any) -> Any:
    car = SimpleNamespace(left=1.0, right=2.0, front=3.0, distance=0.5, speed=0.2, steering=0.0, speed_command=0.3)
    ctx = SimpleNamespace(vars=dict(vars), signals={"go": False}, car=car)
    return SimpleNamespace(ctx=ctx)


def _both(texts: list[str], machine: Any) -> tuple[Any, Any]:
    watches = [compile_watch(t, machine) for t in texts]
    return row_function(watches), Slow(watches).row


def test_the_generated_row_equals_the_expressions_one_by_one_over_many_ticks() -> None:
    machine = _machine(n=1, name="x", flag=True)
    fast, slow = _both(EXPRS, machine)
    ctx = machine.ctx
    for tick in range(200):
        ctx.car.front = 3.0 - tick * 0.02
        ctx.car.left = 1.0 + (tick % 7) * 0.3
        ctx.vars["n"] = tick % 11 if tick % 5 else tick * 0.5
        ctx.vars["flag"] = tick % 3 == 0
        ctx.vars["name"] = "ab"[tick % 2]
        ctx.signals["go"] = tick % 4 == 1
        got, want = fast(ctx), slow(ctx)
        assert got == want, tick
        assert [type(v) for v in got] == [type(v) for v in want]


def test_a_tick_where_nothing_read_moved_keeps_the_row_object() -> None:
    machine = _machine(n=1)
    fast, _ = _both(["car_front", "n * 2"], machine)
    first = fast(machine.ctx)
    assert fast(machine.ctx) is first
    machine.ctx.car.front = 1.5
    second = fast(machine.ctx)
    assert second == (1.5, 2) and second is not first


def test_what_fails_gives_the_error_text_of_the_language() -> None:
    machine = _machine(n=1, name="x")
    fast, slow = _both(["car_front", "10 / n", "n"], machine)
    machine.ctx.vars["n"] = 0
    assert fast(machine.ctx) == slow(machine.ctx) == (3.0, "error: division by zero", 0)
    machine.ctx.vars["n"] = "text"  # a reload gave the variable another kind
    row = fast(machine.ctx)
    assert row[0] == 3.0 and row[1].startswith("error: variable 'n' holds 'text'") and row == slow(machine.ctx)
    del machine.ctx.vars["n"]
    assert fast(machine.ctx)[2].startswith("error: variable 'n' has no value")
    machine.ctx.vars["n"] = 2
    assert fast(machine.ctx) == (3.0, 5.0, 2)  # and back on the generated path
    machine.ctx.car = None  # a run without a car
    assert fast(machine.ctx)[0].startswith("error:")


def test_a_watched_list_is_never_kept_from_an_earlier_tick() -> None:
    machine = _machine(gates=[])
    fast, _ = _both(["gates"], machine)
    first = fast(machine.ctx)
    machine.ctx.vars["gates"].append(1)
    assert fast(machine.ctx) is not first


def test_a_bad_watch_is_refused_with_its_column() -> None:
    machine = _machine(n=1)
    with pytest.raises(BreakpointError) as err:
        compile_watch("n +", machine)
    assert err.value.column == 4
    with pytest.raises(BreakpointError):
        compile_watch("nope * 2", machine)
    with pytest.raises(BreakpointError):
        compile_watch("  ", machine)


def test_the_values_a_page_is_shown_are_the_trace_s_at_every_pause_and_sample() -> None:
    """Watches are evaluated on the ticks a page can show (each status: every chunk of ticks, every pause), not on
    every tick: what the page is sent at those ticks is what the trace says there (the car's readings in its
    samples and events, the variables), at breakpoints, after an injection, after steps and while running."""
    import json
    import threading
    import time
    from pathlib import Path

    from fsm.debug.control import Controller
    from fsm.sim import simulate
    from fsm.tools.live.stream import LineBuffer
    from fsm.tools.recording import run_recorder
    from fsm.trace.replay import parse_trace

    repo = Path(__file__).resolve().parents[1]
    lap, world = repo / "diagrams" / "hallway_lap.json", repo / "diagrams" / "worlds" / "hallway.json"
    session = simulate(str(lap), world=world)
    session.machine.ctx.vars["probe"] = 0
    buffer = LineBuffer()
    session.record(run_recorder(buffer, str(lap), session.car, world_file=world))
    controller = Controller(session, speed=None, paused=True)
    thread = threading.Thread(target=controller.loop, daemon=True)
    thread.start()

    def until(pred: Any) -> dict[str, Any]:
        end = time.monotonic() + 30
        while time.monotonic() < end:
            if controller.snapshot and pred(controller.snapshot):
                return controller.snapshot
            time.sleep(0.002)
        raise AssertionError(controller.snapshot)

    try:
        for text in ("car_front", "car_left + car_right", "car_distance", "probe * 2", "car_speed < 0.5"):
            controller.send("watch", {"expr": text})
        controller.send("break", {"spec": {"kind": "enter", "state": "lap1/*/settle"}})
        controller.send("break", {"spec": {"kind": "expr", "expr": "car_distance > 30"}})
        controller.send("resume")
        hit1 = until(lambda s: s["hit"] is not None)["tick"]
        controller.send("input", {"input": {"kind": "set", "values": {"probe": 3}}})
        controller.send("step", {"n": 7})
        until(lambda s: s["tick"] == hit1 + 7 and s["state"] == "paused")
        controller.send("resume")
        hit2 = until(lambda s: s["hit"] is not None and s["tick"] > hit1 + 7)["tick"]
        controller.send("step", {"n": 1000})
        until(lambda s: s["tick"] == hit2 + 1000 or (s["hit"] is not None and s["tick"] > hit2))
    finally:
        controller.send("stop")
        thread.join(10)
    session = controller.session
    session.finish()
    trace = parse_trace(buffer.text().encode("utf-8"))
    car = {line["tick"]: line["car"] for line in [*trace.samples, *trace.events] if "car" in line}
    sent = [tuple(r) for m in list(controller.messages) if m["kind"] == "watched" for r in m["rows"]]
    assert sent == list(controller.watch_log)
    ticks = [t for t, _row in sent]
    assert ticks == sorted(set(ticks)) and hit1 in ticks and hit2 in ticks and hit1 + 7 in ticks
    assert len(ticks) < session.ticks / 20  # not every tick
    compared = []
    for tick, (front, sides, distance, probe2, slow) in sent:
        assert probe2 == 2 * trace.at(tick)[1]["probe"]
        here = car.get(tick)
        if here is None:
            continue
        compared.append(tick)
        assert front == pytest.approx(here["front"], abs=2e-4)
        assert distance == pytest.approx(here["distance"], abs=2e-4)
        assert sides == pytest.approx(here["left"] + here["right"], abs=4e-4)
        assert slow is (here["speed"] < 0.5) or abs(here["speed"] - 0.5) < 2e-4
    assert hit1 in compared and hit2 in compared  # a breakpoint's tick has its event line, with the car
    assert len(compared) >= 8, json.dumps(ticks)  # the chunks' ends fall on sampled ticks while running
