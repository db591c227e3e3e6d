"""The car mission (issue 10, item 7): diagrams/mission.uxf in the obstacle hallway. The obstacle monitor fires
at the box (from the front sensor, not ground truth), the pause button stops the car and freezes the timers, and
the .uxf converts to the .json the scenario runs (diagrams/mission.scenario.json runs in test_scenarios.py)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, NamedTuple

import pytest

import fsm
from helpers import cli, plain_document

REPO = Path(__file__).resolve().parents[1]
MISSION = REPO / "diagrams" / "mission.json"
OBSTACLE = REPO / "diagrams" / "worlds" / "obstacle.json"


class Firing(NamedTuple):
    """A monitor that fired: when, whose, and what the front sensor read then."""

    time: float
    owner: str
    front: float


class MonitorLog(fsm.Listener):
    """The monitor firings of a run."""

    def __init__(self, car: Any) -> None:
        self.car = car
        self.firings: list[Firing] = []

    def on_monitor(self, ctx: Any, owner: Any, monitor: Any) -> None:
        self.firings.append(Firing(ctx.now, owner.path, self.car.front))


class Run(NamedTuple):
    machine: fsm.Machine
    car: Any
    log: MonitorLog
    samples: list[tuple[float, float, float]]  # (time, speed, distance)


def _run(pause: tuple[float, float] | None) -> Run:
    from fsm.sim.car import SimCar
    from fsm.sim.loop import Simulation
    from fsm.sim.world import load_world

    car = SimCar(load_world(OBSTACLE), seed=0)
    m = fsm.load(MISSION, car=car)
    if pause is not None:
        for at in pause:
            m.schedule_signal("pause", at)
            m.schedule_signal("pause", at + 0.1, False)
    log = m.add_listener(MonitorLog(car))
    samples: list[tuple[float, float, float]] = []

    def sample(*_: Any) -> bool:
        samples.append((m.now, car.speed, car.distance))
        return False

    Simulation(m, car).run(max_ticks=6000, stop=sample)
    return Run(m, car, log, samples)


def test_the_monitor_fires_at_the_obstacle_and_the_mission_succeeds() -> None:
    m, car, log, _ = _run(None)
    assert m.outcome == "succeeded"
    drive = [f for f in log.firings if f.owner == "mission/drive"]
    assert len(drive) == 1 and drive[0].front < 0.25  # what the front sensor read when it fired
    assert [f.owner for f in log.firings] == ["mission/drive", "mission/inspect"]  # the inspection's timeout
    assert m.state("mission/inspect").outcome == "timeout" and m.ctx.vars["evasions"] == 1


def test_the_pause_button_stops_the_car_and_freezes_the_timers() -> None:
    plain = _run(None)
    paused = _run((5.0, 8.0))
    m, _car, log, samples = paused
    assert m.outcome == "succeeded"
    still = [(t, v, d) for t, v, d in samples if 5.6 <= t <= 8.0]
    assert still and all(abs(v) < 1e-6 for _, v, _ in still)  # stopped within 0.6 s of the press
    assert still[-1][2] - still[0][2] < 1e-9  # and did not move
    shift = [a.time - b.time for a, b in zip(log.firings, plain.log.firings, strict=True)]
    assert len(shift) == 2 and all(s == pytest.approx(3.0, abs=0.3) for s in shift)  # every later event ~3 s later


def test_the_umlet_mission_converts_to_the_json(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "m.json"
    code, _out, err = cli(capsys, "convert", str(REPO / "diagrams" / "mission.uxf"), "-o", str(out))
    assert code == 0, err

    assert plain_document(json.loads(out.read_text())) == plain_document(json.loads(MISSION.read_text()))
