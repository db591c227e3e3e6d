"""Rewind from snapshots (issue 33 item 8): a rewind restores the nearest snapshot of the session at or before the
target (fsm.session.snapshot) and re-simulates from there; the run it gives is the one a full re-simulation gives,
tick by tick (active states, variables, the car's pose and readings) and line by line in the trace, across an
injected input, a breakpoint and a hot reload, on the hallway lap (the simulated car) and on an EEROS case
(a sequence paused by a bouncing button, with timeouts, on a plant)."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any, cast

import pytest

from fsm.debug.control import CHUNK, Controller
from fsm.session.session import Session, SetSignal, StopRules
from fsm.tools.live.stream import TraceFile
from fsm.trace.recorder import Recorder
from fsm.trace.replay import parse_trace

REPO = Path(__file__).resolve().parents[1]
LAP = REPO / "diagrams" / "hallway_lap.json"
HALLWAY = REPO / "diagrams" / "worlds" / "hallway.json"
PAUSE_CASE = REPO / "diagrams" / "eeros" / "case4_pause.scenario.json"


def lap_session() -> Session:
    from fsm.sim import simulate
    from fsm.tools.recording import run_recorder

    session = simulate(str(LAP), world=HALLWAY)
    session.record(run_recorder(TraceFile(), str(LAP), session.car, world_file=HALLWAY))
    return session


def gate_session() -> Session:
    """The gate run: the car's camera renders and detects markers (its noise and tracking are part of the run)."""
    from fsm.sim import simulate
    from fsm.tools.recording import run_recorder

    world = REPO / "diagrams" / "worlds" / "gates.json"
    session = simulate(str(REPO / "diagrams" / "gate_run.json"), world=world)
    session.record(run_recorder(TraceFile(), str(REPO / "diagrams" / "gate_run.json"), session.car, world_file=world))
    return session


def eeros_session() -> Session:
    """The EEROS pause case as its scenario runs it: the axis plant attached, the bouncing button's edges scheduled."""
    from fsm.loading.loader import compile as compile_spec
    from fsm.tools.scenario.model import load_scenario
    from fsm.tools.scenario.timeline import expand

    loaded = load_scenario(PAUSE_CASE)
    session = Session.open(compile_spec(loaded.spec), dt=loaded.dt)
    for cls, params in loaded.plants:
        cls(params).attach(session.machine)
    signals, _sets = expand(loaded.scenario, loaded.dt)
    for change in signals:
        session.schedule(change.time, SetSignal(change.name, change.level))
    session.record(Recorder(cast(Any, TraceFile())))
    return session


def eeros_plan() -> Any:
    from fsm.loading.loader import compile as compile_spec
    from fsm.tools.scenario.model import load_scenario

    return compile_spec(load_scenario(PAUSE_CASE).spec)


@contextmanager
def running(factory: Callable[[], Session], **options: Any) -> Iterator[Controller]:
    controller = Controller(factory(), factory=factory, speed=None, paused=True, **options)
    thread = threading.Thread(target=controller.loop, daemon=True)
    thread.start()
    try:
        yield controller
    finally:
        controller.send("stop")
        thread.join(20)
    assert not thread.is_alive()


def until(controller: Controller, pred: Callable[[dict[str, Any]], bool], seconds: float = 60) -> dict[str, Any]:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        snap = controller.snapshot
        if snap and pred(snap):
            return snap
        time.sleep(0.001)
    raise AssertionError(f"not reached: {controller.snapshot}")


def ask(controller: Controller, name: str, args: dict[str, Any] | None = None) -> dict[str, Any]:
    """Send a command and wait for its reply."""
    ask.n += 1  # type: ignore[attr-defined]
    number = ask.n  # type: ignore[attr-defined]
    controller.send(name, args, number)
    end = time.monotonic() + 60
    while time.monotonic() < end:
        for message in list(controller.messages):
            if message.get("kind") == "reply" and message.get("id") == number:
                assert message["ok"], message
                return message
        time.sleep(0.001)
    raise AssertionError(f"no reply to {name}")


ask.n = 0  # type: ignore[attr-defined]


def step_to(controller: Controller, tick: int) -> None:
    now = until(controller, lambda s: s.get("state") in ("paused", "ended"))["tick"]
    if tick > now:
        ask(controller, "step", {"n": tick - now})
    until(controller, lambda s: s["tick"] == tick and s["state"] == "paused")


def state_of(session: Session) -> tuple[Any, ...]:
    """What a tick left: the active states, the variables, and the car's pose and readings (if it has one)."""
    machine = session.machine
    car = machine.ctx.car
    seen: tuple[Any, ...] = (machine.ticks, machine.active_paths, dict(machine.ctx.vars), machine.finished)
    if car is not None:
        seen += (car.true_pose(), car.pose(), car.left, car.right, car.front, car.distance, car.steering)
    return seen


def trace_lines(session: Session) -> dict[str, list[dict[str, Any]]]:
    recorder = session.recorder
    assert recorder is not None and isinstance(recorder.out, TraceFile)
    recorder.flush_samples(session.machine)
    trace = parse_trace(recorder.out.text().encode("utf-8"))
    return {"events": trace.events, "keyframes": trace.keyframes, "samples": trace.samples,
            "inputs": trace.inputs, "reloads": [{k: v for k, v in r.items() if k != "time"} for r in trace.reloads]}


def compare_tick_by_tick(subject: Controller, reference: Controller, ticks: int) -> None:
    """Step both one tick at a time, comparing what each tick left; then their traces, line by line."""
    for _ in range(ticks):
        step_to(subject, subject.session.ticks + 1)
        step_to(reference, reference.session.ticks + 1)
        assert state_of(subject.session) == state_of(reference.session)
    assert trace_lines(subject.session) == trace_lines(reference.session)
    drivers = subject.session.driver, reference.session.driver
    if drivers[0] is not None:  # the trajectory of the plot, and the summary's figures
        tracks = [list(cast(Any, driver).track) for driver in drivers]
        assert tracks[0] == tracks[1]
        summaries = [{k: v for k, v in s.summary().items() if "wall_time" not in k and "realtime" not in k}
                     for s in (subject.session, reference.session)]
        assert summaries[0] == summaries[1]


def test_a_rewind_from_a_snapshot_is_the_run_a_re_simulation_gives_on_the_hallway_lap() -> None:
    injected = {"kind": "force", "sensor": "front", "value": 2.9, "ticks": 40}
    with running(lap_session, snapshot_period=3.0, snapshot_share=1.0) as subject:
        step_to(subject, 700)
        ask(subject, "input", {"input": injected})  # applies before tick 701
        ask(subject, "break", {"spec": {"kind": "enter", "state": "lap1/right_slow"}})
        ask(subject, "resume")
        hit = until(subject, lambda s: s["hit"] is not None and s["state"] == "paused")
        assert hit["hit"]["breakpoint"] == 1
        ask(subject, "unbreak", {"breakpoint": 1})
        step_to(subject, 2600)
        assert len(subject.snapshots) >= 5
        target = 1700
        reply = ask(subject, "rewind", {"tick": target})
        assert reply["dropped"] == 0
        rewound = next(m for m in list(subject.messages) if m.get("kind") == "rewound")
        assert rewound["snapshot"] is not None and 700 < rewound["snapshot"] <= target  # after the injection
        with running(lap_session, snapshot_period=None) as reference:
            step_to(reference, 700)
            ask(reference, "input", {"input": injected})
            step_to(reference, target)
            assert state_of(subject.session) == state_of(reference.session)
            compare_tick_by_tick(subject, reference, 60)
            # and a second rewind, to before the injection: the snapshot it restores has not applied it
            ask(subject, "rewind", {"tick": 650})
            assert [t for t, _item in subject.log] == []
            step_to(subject, 900)
            with running(lap_session, snapshot_period=None) as plain:
                step_to(plain, 900)
                assert state_of(subject.session) == state_of(plain.session)


def test_a_rewind_from_a_snapshot_is_exact_with_the_camera_on_the_gate_run() -> None:
    with running(gate_session, snapshot_period=2.0, snapshot_share=1.0) as subject, \
            running(gate_session, snapshot_period=None) as reference:
        step_to(subject, 1800)
        ask(subject, "rewind", {"tick": 1300})
        rewound = next(m for m in list(subject.messages) if m.get("kind") == "rewound")
        assert rewound["snapshot"] is not None and rewound["snapshot"] > 800
        step_to(reference, 1300)
        assert subject.session.car.rendered_frames > 0
        compare_tick_by_tick(subject, reference, 30)


def test_a_rewind_from_a_snapshot_across_a_hot_reload_on_an_eeros_case() -> None:
    with running(eeros_session, snapshot_period=1.0, snapshot_share=1.0) as subject, \
            running(eeros_session, snapshot_period=None) as reference:
        for controller in (subject, reference):
            step_to(controller, 300)
            ask(controller, "input", {"input": {"kind": "set", "values": {"cycles": 5}}})
        step_to(subject, 700)
        ask(subject, "reload", {"plan": eeros_plan(), "info": {"file": "case4_pause.json"}})
        step_to(subject, 1400)
        drawn: list[Any] = []
        subject.machine_changed = drawn.append
        ask(subject, "rewind", {"tick": 1000})  # a snapshot after the reload
        assert drawn == []
        ask(subject, "rewind", {"tick": 650})  # a snapshot before it: the reload is dropped
        rewound = [m for m in list(subject.messages) if m.get("kind") == "rewound"]
        assert rewound[-1]["reloads_dropped"] == 1 and rewound[-1]["snapshot"] is not None
        # the page is told to draw the machine the run started with again, as after a reload
        assert drawn == [None]
        told = [m for m in list(subject.messages) if m.get("kind") == "reload" and m.get("rewound")]
        assert told and told[-1]["ok"] and "undid 1 later hot reload" in told[-1]["text"]
        ask(subject, "reload", {"plan": eeros_plan(), "info": {"file": "case4_pause.json"}})  # done again at 651
        step_to(subject, 1200)
        ask(subject, "rewind", {"tick": 900})  # a snapshot before the reload: it is done again on the way
        step_to(reference, 650)
        ask(reference, "reload", {"plan": eeros_plan(), "info": {"file": "case4_pause.json"}})
        step_to(reference, 900)
        assert state_of(subject.session) == state_of(reference.session)
        assert subject.session.machine.ctx.vars["cycles"] >= 5
        compare_tick_by_tick(subject, reference, 40)


def test_a_rewind_beyond_the_horizon_says_how_far_back_it_can_go() -> None:
    # snapshots not paced by their cost (a busy machine would space them out): one at each chunk the car allows
    with running(lap_session, snapshot_period=2.0, snapshot_share=1e9, horizon=10.0) as controller:
        step_to(controller, 100)
        ask(controller, "input", {"input": {"kind": "force", "sensor": "front", "value": 2.5, "ticks": 5}})
        step_to(controller, 3000)  # 37.5 s: the first 27.5 s are beyond a 10 s horizon
        earliest = controller.earliest
        assert 2000 - 160 <= earliest <= 3000 - 800 and controller.snapshots[0].tick == earliest
        assert controller.log == [] and controller.session.applied == []
        controller.send("rewind", {"tick": 100}, "far")
        end = time.monotonic() + 20
        while not any(m.get("id") == "far" for m in list(controller.messages)):
            assert time.monotonic() < end
            time.sleep(0.002)
        refused = next(m for m in list(controller.messages) if m.get("id") == "far")
        assert not refused["ok"] and f"rewound to tick {earliest} " in refused["error"]
        assert "--rewind-horizon" in refused["error"] and controller.snapshot["rewind_from"] == earliest
        ask(controller, "rewind", {"tick": earliest + 10})
        assert controller.session.ticks == earliest + 10


def test_the_horizon_holds_however_dear_a_snapshot_is() -> None:
    """Snapshots are paced by their processor time; a share this small would hold off every snapshot after the
    first (a slow first one on a loaded machine does the same). The horizon is a promise all the same: a snapshot
    at least every third of it, so the start and every input since are let go once they are beyond it."""
    with running(lap_session, snapshot_share=1e-12, horizon=10.0) as controller:
        step_to(controller, 4000)  # 50 s: the first 40 s are beyond a 10 s horizon
        earliest = controller.earliest
        assert 4000 - 800 - 2 * CHUNK <= earliest <= 4000 - 800
        assert controller.snapshot["rewind_from"] == earliest == controller.snapshots[0].tick


@pytest.mark.parametrize("horizon", [0.0])
def test_no_horizon_keeps_no_history(horizon: float) -> None:
    with running(lap_session, horizon=horizon) as controller:
        step_to(controller, 2000)
        assert controller.snapshots == [] and controller.snapshot["can_rewind"] is False
        controller.send("rewind", {"tick": 10}, "no")
        end = time.monotonic() + 20
        while not any(m.get("id") == "no" for m in list(controller.messages)):
            assert time.monotonic() < end
            time.sleep(0.002)
        assert "--rewind-horizon 0" in next(m for m in list(controller.messages) if m.get("id") == "no")["error"]


def _fill_bounded_caches(session: Session) -> None:
    """What a run keeps that is bounded by design, filled to its bound before memory is measured, so that what the
    test sees growing is what the horizon must bound: the beam index's (cell, sector) entries, at most one for each
    in the world's box, all filled here; and the track kept for the plot, at most its limit of points (a small limit
    here, so that it is full within the warm-up)."""
    import math

    from fsm.sim.car import BEAM_CELL, BEAM_SECTORS
    from fsm.sim.loop import Simulation, Track

    sim = session.driver
    assert isinstance(sim, Simulation)
    sim.track = Track(sim.track.period, limit=256)
    index = sim.car._beam_index
    assert index is not None
    x0, x1 = min(seg[4] for seg in index.segments), max(seg[5] for seg in index.segments)
    y0, y1 = min(seg[6] for seg in index.segments), max(seg[7] for seg in index.segments)
    for i in range(math.floor(x0 / BEAM_CELL), math.floor(x1 / BEAM_CELL) + 1):
        for j in range(math.floor(y0 / BEAM_CELL), math.floor(y1 / BEAM_CELL) + 1):
            for k in range(BEAM_SECTORS):
                a = (k + 0.5) * index.width
                index.near((i + 0.5) * BEAM_CELL, (j + 0.5) * BEAM_CELL, math.cos(a), math.sin(a))


def test_a_live_run_past_its_horizon_retains_under_100_kb_in_20000_more_ticks() -> None:
    """Issue 37 item 4: the snapshots, inputs and trace of a live run stay within the horizon (10 simulated seconds
    here), so memory is flat after it (tracemalloc: deterministic, unlike RSS)."""
    import gc
    import tracemalloc

    from fsm.sim import simulate
    from fsm.tools.recording import run_recorder

    forever = {"name": "forever", "initial": "follow", "states": [
        {"id": "follow", "type": "FollowWall", "side": "right", "distance": 0.4, "speed": 1.0}]}
    session = simulate(forever, world=HALLWAY, stop=StopRules(max_ticks=10**7))
    session.record(run_recorder(TraceFile(), "forever.json", session.car, world_file=HALLWAY, document=forever))
    controller = Controller(session, speed=None, horizon=10.0, snapshot_period=2.5, snapshot_share=1e9)
    _fill_bounded_caches(session)

    def run_to(tick: int) -> None:  # an input every 5 s on the way: the inputs kept are bounded by the horizon too
        while session.ticks < tick:
            controller.send("input", {"input": {"kind": "set", "values": {"k": session.ticks}}})
            end = min(tick, session.ticks + 400)
            controller.loop(stop=lambda end=end: session.ticks >= end)  # type: ignore[misc]

    gc.collect()
    tracemalloc.start()
    try:
        run_to(4_000)  # past the horizon (800 ticks) and a lap: the car's caches of the hallway are filled
        gc.collect()
        before = tracemalloc.get_traced_memory()[0]
        run_to(24_000)
        gc.collect()
        retained = tracemalloc.get_traced_memory()[0] - before
    finally:
        tracemalloc.stop()
    assert 24_000 <= session.ticks < 24_000 + CHUNK  # stop() is looked at between chunks of ticks
    # none is taken while the car touches a wall (this machine scrapes the hallway's corners about half the time)
    assert 1 <= len(controller.snapshots) <= 5 and controller.earliest >= 24_000 - 800 - 2_000
    assert len(controller.log) <= 3 and len(session.applied) <= 3
    assert retained < 100_000, f"{retained:,} bytes retained by 20,000 ticks"


def test_the_fields_a_snapshot_reads_by_name_are_every_attribute_the_objects_have() -> None:
    """The classes whose snapshots read their attributes by name (not through ``__dict__``, which slows CPython
    3.11's attribute access of the object down for good) must name all of them, or a rewind would not be exact."""
    from fsm.session.snapshot import _KINDS, take

    for make in (lap_session, gate_session, eeros_session):
        session = make()
        session.run(stop_rules=StopRules(max_ticks=1200))
        snap = take([session], session.ticks, shared=[session.recorder.out if session.recorder else None,
                                                      session.machine.listeners])
        checked = 0
        for obj, _kept in snap.entries:
            cls = type(obj)
            if _KINDS.by_dict.get(cls) is False and hasattr(obj, "__dict__"):
                names, _getter, skip = _KINDS.layout(cls)
                missing = set(vars(obj)) - skip - set(names)
                assert not missing, f"{cls.__qualname__} does not name {missing}"
                checked += 1
        assert checked >= (2 if make is eeros_session else 7)


@pytest.mark.parametrize(("args", "said"), [
    (["--rewind-horizon", "10"], "--rewind-horizon is an option of the live debugger: add --live"),
    (["--live", "--rewind-horizon", "-3"], "a rewind horizon is 0 or more seconds (or 'inf'), got -3"),
    (["--live", "--rewind-horizon", "nan"], "a rewind horizon is 0 or more seconds (or 'inf'), got nan"),
    (["--live", "--rewind-horizon", "ten"], "expected seconds of simulated time or 'inf', got 'ten'"),
])
def test_a_rewind_horizon_that_is_no_horizon_is_a_usage_error(capsys: pytest.CaptureFixture[str], args: list[str],
                                                               said: str) -> None:
    from helpers import cli

    code, out, err = cli(capsys, "run", str(LAP), *args)
    assert code == 2 and said in err and out == ""
