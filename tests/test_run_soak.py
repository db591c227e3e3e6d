"""A car that runs all day (issue 37): every figure of a run is a running one, the laps and the trajectory are bounded,
memory stays flat, and the laps agree with the trace (issue 35)."""

from __future__ import annotations

import gc
import json
import math
import tracemalloc
from pathlib import Path
from typing import Any

import pytest

from fsm.session.session import StopRules
from fsm.sim import simulate
from fsm.sim.loop import LAP_HALF_WIDTH, LapLog, SteeringStats, Track, WallError
from fsm.sim.world import parse_world
from fsm.trace.replay import read_trace
from helpers import cli

REPO = Path(__file__).resolve().parents[1]
HALLWAY = REPO / "diagrams" / "worlds" / "hallway.json"
#: The machine of issue 37: follows the right-hand wall of the hallway, lap after lap, and never finishes.
FOREVER = {"name": "forever", "initial": "follow", "states": [
    {"id": "follow", "type": "FollowWall", "side": "right", "distance": 0.4, "speed": 1.0}]}


# -- running figures against the stored lists they replace ---------------------------------------------------------
def old_figures(errors: list[float], steering: list[tuple[int, float]], period: float) -> dict[str, Any]:
    """The summary's figures as they were computed before issue 37: from the whole lists, after the run."""
    out: dict[str, Any] = {
        "wall_error_rms_m": round(math.sqrt(sum(e * e for e in errors) / len(errors)), 5) if errors else None,
        "wall_error_max_m": round(max(abs(e) for e in errors), 5) if errors else None,
        "wall_error_samples": len(errors)}
    if len(steering) < 2:
        return out | {"steering_std": None, "steering_sign_changes_per_s": None, "straight_time_s": 0.0}
    values = [v for _n, v in steering]
    mean = sum(values) / len(values)
    std = math.sqrt(sum((v - mean) ** 2 for v in values) / len(values))
    changes = intervals = 0
    last_n, last_sign = steering[0][0], 0.0
    for n, v in steering:
        if n != last_n + 1:
            last_sign = 0.0
        else:
            intervals += 1
        sign = 1.0 if v > 0 else -1.0 if v < 0 else 0.0
        if sign:
            if last_sign and sign != last_sign:
                changes += 1
            last_sign = sign
        last_n = n
    seconds = intervals * period
    return out | {"steering_std": round(std, 5),
                  "steering_sign_changes_per_s": round(changes / seconds, 3) if seconds > 0 else None,
                  "straight_time_s": round(seconds, 3)}


def run_with_lists(monkeypatch: pytest.MonkeyPatch, source: Any, duration: float | None) -> tuple[dict[str, Any],
                                                                                                    dict[str, Any]]:
    """The run's summary, and the figures computed the old way from every sample the running figures were given."""
    errors: list[float] = []
    steering: list[tuple[int, float]] = []
    add_error, add_steering = WallError.add, SteeringStats.add

    def keep_error(self: WallError, error: float) -> None:
        errors.append(error)
        add_error(self, error)

    def keep_steering(self: SteeringStats, n: int, value: float) -> None:
        steering.append((n, value))
        add_steering(self, n, value)

    monkeypatch.setattr(WallError, "add", keep_error)
    monkeypatch.setattr(SteeringStats, "add", keep_steering)
    session = simulate(source, world=HALLWAY, stop=StopRules(duration))
    session.run()
    summary = session.summary()
    return summary, old_figures(errors, steering, session.driver.steering.period)


FIGURES = ["wall_error_rms_m", "wall_error_max_m", "wall_error_samples", "steering_std",
           "steering_sign_changes_per_s", "straight_time_s"]


def test_the_hallway_lap_reports_the_figures_the_stored_lists_gave(monkeypatch: pytest.MonkeyPatch) -> None:
    summary, old = run_with_lists(monkeypatch, REPO / "diagrams" / "hallway_lap.uxf", None)
    assert summary["outcome"] == "succeeded" and summary["wall_error_samples"] > 1500
    assert {k: summary[k] for k in FIGURES} == old


def test_a_long_run_reports_the_figures_the_stored_lists_gave(monkeypatch: pytest.MonkeyPatch) -> None:
    # 20 minutes of following the wall: 96,000 ticks, about 23,000 samples on straights and 17 laps
    summary, old = run_with_lists(monkeypatch, FOREVER, 1200.0)
    assert summary["ticks"] == 96_000 and summary["wall_error_samples"] > 15_000
    assert {k: summary[k] for k in FIGURES} == old
    assert summary["lap_totals"]["laps"] == len(summary["laps"]) > 10


def test_steering_stats_agree_with_the_two_pass_std_on_large_offsets() -> None:
    # Welford's update keeps its precision where the textbook sum-of-squares formula would lose it
    stats = SteeringStats(0.05)
    values = [1e6 + 0.001 * ((i * 7919) % 13 - 6) for i in range(10_000)]
    for i, v in enumerate(values):
        stats.add(i, v)
    mean = sum(values) / len(values)
    std = math.sqrt(sum((v - mean) ** 2 for v in values) / len(values))
    assert stats.metrics()["steering_std"] == round(std, 5)


# -- bounded records ---------------------------------------------------------------------------------------------
def square_world() -> Any:
    return parse_world({"walls": [{"points": [[0, 0], [10, 0], [10, 10], [0, 10]], "closed": True}],
                        "start": {"x": 5.0, "y": 1.0, "heading": 0}})


def test_laps_past_the_limit_are_counted_in_the_totals_and_the_summary_says_so() -> None:
    log = LapLog(square_world(), limit=3)
    t = 0.0
    log.state(0.0, "a")
    log.update(0.0, 5.0, 1.0)
    for lap in range(1, 6):  # five laps of 10 + lap seconds, half of each in "a", half in "b"
        seconds = 10.0 + lap
        log.update(t + 1.0, 6.0, 1.0)
        log.state(t + seconds / 2, "b")
        log.update(t + seconds - 1.0, 4.9, 1.0)
        log.update(t + seconds, 5.1, 1.0)  # over the line: the lap ends
        log.state(t + seconds, "a")
        t += seconds
    m = log.metrics(t + 2.0)
    assert [lap["lap"] for lap in m["laps"]] == [3, 4, 5]
    assert [lap["time_s"] for lap in m["laps"]] == [13.0, 14.0, 15.0]
    totals = m["lap_totals"]
    assert totals["laps"] == 5 and totals["listed"] == 3 and totals["dropped"] == 2
    assert totals["time_s"] == 65.0 and totals["mean_s"] == 13.0
    assert totals["fastest"] == {"lap": 1, "time_s": 11.0} and totals["slowest"] == {"lap": 5, "time_s": 15.0}
    assert totals["states"] == {"a": 32.5, "b": 32.5}
    assert m["laps_note"] == "only the last 3 of 5 laps are listed (the limit is 3); lap_totals covers all of them"
    assert m["lap_unfinished"] == {"lap": 6, "start_s": 65.0, "time_s": 2.0, "complete": False, "states": {"a": 2.0}}
    assert "laps_note" not in LapLog(square_world()).metrics(1.0)


def test_the_trajectory_thins_itself_and_keeps_the_whole_run() -> None:
    track = Track(0.1, limit=8)
    for i in range(100):
        if i % track.every == 0:  # as the loop offers them: every track_every * every ticks
            track.add(float(i), 0.5, i % 3)
    points = list(track)
    assert 4 <= len(track) <= 8 and track.every == 16 and track.period == pytest.approx(1.6)
    assert points == [(pytest.approx(i * 0.1), float(i), 0.5, i % 3) for i in range(0, 100, 16)]
    assert track[::2] == points[::2]
    for limit in (1, 7):
        with pytest.raises(ValueError):
            Track(0.1, limit=limit)


def test_the_loop_keeps_the_trajectory_evenly_spaced_past_the_limit() -> None:
    session = simulate(FOREVER, world=HALLWAY, stop=StopRules())
    session.step(40_000)  # 10,000 points offered at one per 4 ticks: thinned twice, to one per 16 ticks
    sim = session.driver
    ticks = [round(t / session.dt) for t, *_ in sim.track]
    assert sim.track.every == 4 and ticks == list(range(0, 40_001, 16))
    x, y, _ = sim.car.true_pose()
    assert list(sim.track)[-1][1:] == (pytest.approx(x, abs=1e-5), pytest.approx(y, abs=1e-5), 0)  # the car now


def test_memory_retained_by_twenty_thousand_more_ticks_is_under_100_kb() -> None:
    session = simulate(FOREVER, world=HALLWAY, stop=StopRules())
    gc.collect()
    tracemalloc.start()
    try:
        session.step(8_000)  # more than a lap: the car's caches of the hallway are filled
        gc.collect()
        before = tracemalloc.get_traced_memory()[0]
        session.step(20_000)
        gc.collect()
        retained = tracemalloc.get_traced_memory()[0] - before
    finally:
        tracemalloc.stop()
    assert session.ticks == 28_000
    assert retained < 100_000, f"{retained:,} bytes retained by 20,000 ticks"


# -- the laps against the trace (issue 35) -----------------------------------------------------------------------
def test_the_hallway_laps_are_the_laps_the_trace_shows(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    trace_file, summary_file = tmp_path / "lap.jsonl", tmp_path / "lap.json"
    code, _, err = cli(capsys, "run", str(REPO / "diagrams" / "hallway_lap.uxf"), "--trace", str(trace_file),
                       "--sample-rate", "80", "--summary", str(summary_file), "-q")
    assert code == 0, err
    summary = json.loads(summary_file.read_text())
    trace = read_trace(trace_file)
    dt = trace.dt
    assert dt is not None
    start = trace.header["world"]["start"]
    x0, y0 = start["x"], start["y"]
    c, s = math.cos(math.radians(start["heading"])), math.sin(math.radians(start["heading"]))
    crossings = []  # when the car's centre crossed the start line forwards, from the pose of every tick
    before = None
    for sample in trace.samples:
        dx, dy = sample["car"]["x"] - x0, sample["car"]["y"] - y0
        ahead = dx * c + dy * s
        if before is not None and before < 0 <= ahead and abs(-dx * s + dy * c) <= LAP_HALF_WIDTH:
            crossings.append(sample["time"])
        before = ahead
    end = trace.end["time"] if trace.end else trace.last_tick * dt
    bounds = [0.0, *crossings, end]
    # the time in each leaf path between each two crossings, from the transitions
    changes = [(e["time"], ", ".join(e["active"])) for e in trace.events]
    expected: list[dict[str, float]] = []
    for lo, hi in zip(bounds, bounds[1:], strict=False):
        states: dict[str, float] = {}
        for (t, path), (t_next, _) in zip(changes, [*changes[1:], (end, "")], strict=True):
            overlap = min(hi, t_next) - max(lo, t)
            if overlap > 0:
                states[path] = states.get(path, 0.0) + overlap
        expected.append(states)

    laps = summary["laps"]
    assert len(crossings) == 3 and len(laps) == 3  # three laps, not four
    assert all(lap["complete"] for lap in laps)
    for lap, lo, hi, states in zip(laps, bounds, bounds[1:], expected, strict=False):
        assert lap["start_s"] == pytest.approx(lo, abs=dt) and lap["time_s"] == pytest.approx(hi - lo, abs=dt)
        assert set(lap["states"]) == set(states), lap["lap"]
        for path, seconds in states.items():
            assert lap["states"][path] == pytest.approx(seconds, abs=dt), (lap["lap"], path)
        assert sum(lap["states"].values()) == pytest.approx(lap["time_s"], abs=1e-3)
    # what the car drove after the last crossing (stopping at the start) is not a lap
    tail = summary["lap_unfinished"]
    assert tail["complete"] is False and tail["start_s"] == pytest.approx(crossings[-1], abs=dt)
    assert tail["states"] == {"stop": pytest.approx(end - crossings[-1], abs=dt)}
    assert summary["lap_totals"]["laps"] == 3 and summary["lap_totals"]["dropped"] == 0
    assert summary["lap_totals"]["time_s"] == pytest.approx(crossings[-1], abs=dt)


# -- long durations ----------------------------------------------------------------------------------------------
def test_a_simulated_run_of_years_is_refused_with_the_ticks_it_would_take(capsys: pytest.CaptureFixture[str],
                                                                           tmp_path: Path) -> None:
    machine = tmp_path / "forever.json"
    machine.write_text(json.dumps(FOREVER))
    before = sorted(p.name for p in tmp_path.iterdir())
    code, out, err = cli(capsys, "run", str(machine), "--duration", "1e9", "--summary", str(tmp_path / "s.json"))
    assert code == 2 and not out
    assert err.strip().splitlines()[-1].endswith(
        "--dt 0.0125 with a run of 1e+09 s makes 8e+10 ticks, more than 10,000,000; give --max-ticks N to allow a "
        "run that long, or a larger --dt / shorter --duration")
    assert sorted(p.name for p in tmp_path.iterdir()) == before


def test_runs_on_the_wall_clock_take_a_duration_of_years() -> None:
    import argparse

    from fsm.tools.cli.run import _tick_limit

    def args(**given: Any) -> argparse.Namespace:
        return argparse.Namespace(**({"duration": 1e9, "max_ticks": None, "ros": None, "live": False, "speed": 1.0}
                                     | given))

    assert _tick_limit(args(ros="car.json"), 0.0125) == (1e9, None)
    assert _tick_limit(args(live=True), 0.0125) == (1e9, None)
    from fsm.model.errors import UsageError

    with pytest.raises(UsageError, match="makes 8e[+]10 ticks"):
        _tick_limit(args(live=True, speed=None), 0.0125)  # --live --speed max: a simulated run as fast as it goes
