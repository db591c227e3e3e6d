"""Benchmark: the closed loop (physics 100 Hz, ultrasonic 20 Hz, machine 80 Hz), in x real time; without and with
camera.

Runs ``diagrams/hallway_lap.json`` in ``diagrams/worlds/hallway.json`` (three laps, about 200 s of
simulated time) a few times on one core and prints the best and median realtime factor, plus a
breakdown per simulated second (physics, sensors, machine). Then the camera loop: ``diagrams/gate_run.json``
in ``diagrams/worlds/gates.json`` with the camera at 640x480, 20 Hz, video off, OpenCV on one thread
(issue 9's target: at least 25x), with the render and detect cost per frame. Not a timed test: CI does not run it.

    .venv/bin/python benchmarks/bench_sim.py [--repeat 5] [--seed 0] [--camera-only] [--profile 25]

``--profile N`` prints, instead, where the lap without camera spends its work, deterministically: the Python
bytecode instructions each function runs per simulated second (inclusive of what it calls, and its own), the N
largest, counted with ``sys.settrace`` over the whole lap. Callgrind counts machine instructions but cannot see
Python functions on CPython 3.11; the two agree on the shares (about 50 machine instructions a bytecode here).
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent


def run_once(seed: int) -> tuple[float, float, dict]:
    import fsm
    from fsm.sim.car import SimCar
    from fsm.sim.loop import Simulation
    from fsm.sim.world import load_world

    world = load_world(ROOT / "diagrams" / "worlds" / "hallway.json")
    car = SimCar(world, seed=seed)
    machine = fsm.load(ROOT / "diagrams" / "hallway_lap.json", car=car)
    sim = Simulation(machine, car)
    cpu = time.thread_time()
    sim.run(duration=600)
    cpu = time.thread_time() - cpu
    m = sim.metrics()
    m["cpu_time"] = cpu  # the run's own processor time: what a busy machine's other jobs take is not in it
    return m["sim_time"], sim.wall_time, m


def breakdown(seed: int) -> dict[str, float]:
    """Microseconds per simulated second spent in physics steps, sensor samples and machine ticks."""
    import fsm
    from fsm.sim.car import SimCar
    from fsm.sim.world import load_world

    world = load_world(ROOT / "diagrams" / "worlds" / "hallway.json")
    car = SimCar(world, seed=seed)
    machine = fsm.load(ROOT / "diagrams" / "hallway_lap.json", car=car)
    n = 4000
    sense = car.sense
    t0 = time.perf_counter()
    for _ in range(n):
        sense()
    t_sense = (time.perf_counter() - t0) / n
    car.sense = lambda: None  # type: ignore[method-assign]
    t0 = time.perf_counter()
    for _ in range(n):
        car.step()
    t_step = (time.perf_counter() - t0) / n
    machine.start()
    t0 = time.perf_counter()
    for _ in range(n):
        machine.tick()
    t_tick = (time.perf_counter() - t0) / n
    rate = world.car.ultrasonic.rate
    return {
        "physics_ms_per_s": round(t_step * 100 * 1e3, 3),
        "sensors_ms_per_s": round(t_sense * rate * 1e3, 3),
        "machine_ms_per_s": round(t_tick * 80 * 1e3, 3),
    }


def run_camera(seed: int) -> dict[str, float]:
    """One gate_run lap with the camera; realtime factor and ms per rendered frame for render and detect."""
    import cv2

    import fsm
    from fsm.sim.car import SimCar
    from fsm.sim.loop import Simulation
    from fsm.sim.world import load_world

    cv2.setNumThreads(1)
    world = load_world(ROOT / "diagrams" / "worlds" / "gates.json")
    car = SimCar(world, seed=seed)
    cost = {"render": 0.0, "detect": 0.0}
    setup = car._camera_setup

    def timed_setup() -> tuple:
        renderer, detector = setup()
        render, detect = renderer.render, detector.detect

        def r(*a: object) -> object:
            t0 = time.perf_counter()
            out = render(*a)
            cost["render"] += time.perf_counter() - t0
            return out

        def d(*a: object) -> object:
            t0 = time.perf_counter()
            out = detect(*a)
            cost["detect"] += time.perf_counter() - t0
            return out

        renderer.render, detector.detect = r, d
        return renderer, detector

    car._camera_setup = timed_setup  # type: ignore[method-assign]
    sim = Simulation(fsm.load(ROOT / "diagrams" / "gate_run.json", car=car), car)
    sim.run(duration=300)
    m = sim.metrics()
    n = max(1, car.rendered_frames)
    return {"factor": m["sim_time"] / sim.wall_time, "sim_time": m["sim_time"], "outcome": sim.machine.outcome,
            "gates": f"{m['gates_passed']}/{m['gates_total']}", "collisions": m["collisions"],
            "frames": car.camera_frames, "rendered": car.rendered_frames,
            "render_ms": 1e3 * cost["render"] / n, "detect_ms": 1e3 * cost["detect"] / n,
            "camera_ms_per_s": 1e3 * (cost["render"] + cost["detect"]) / m["sim_time"],
            "odometry_error_m": m["odometry_error_m"]}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--camera-only", action="store_true", help="only the camera loop")
    parser.add_argument("--profile", type=int, metavar="N", help="the N functions that run the most bytecode")
    args = parser.parse_args(argv)
    if args.profile:
        profile(args.seed, args.profile)
        return 0
    if not args.camera_only:
        no_camera(args)
    runs = [run_camera(args.seed) for _ in range(args.repeat)]
    factors = [r["factor"] for r in runs]
    r = runs[0]
    print(f"closed loop with camera 640x480 @ 20 Hz, video off: gate_run.json in gates.json, {r['sim_time']:.1f} s "
          f"simulated, outcome {r['outcome']}, gates {r['gates']}, collisions {r['collisions']}, "
          f"odometry error {r['odometry_error_m']:.2f} m")
    print(f"realtime factor: best {max(factors):.1f}x, median {statistics.median(factors):.1f}x "
          f"(of {args.repeat} runs, one core, OpenCV 1 thread)")
    print(f"camera: {r['frames']} frames, {r['rendered']} rendered (markers possibly in view); per rendered frame "
          f"render {r['render_ms']:.2f} ms, detect {r['detect_ms']:.2f} ms; {r['camera_ms_per_s']:.1f} ms of "
          "camera per simulated second")
    return 0


def profile(seed: int, top: int) -> None:
    """Bytecode instructions per simulated second of each Python function of the lap (inclusive and own)."""
    from collections import Counter

    import fsm
    from fsm.sim.car import SimCar
    from fsm.sim.loop import Simulation
    from fsm.sim.world import load_world

    car = SimCar(load_world(ROOT / "diagrams" / "worlds" / "hallway.json"), seed=seed)
    sim = Simulation(fsm.load(ROOT / "diagrams" / "hallway_lap.json", car=car), car)
    own: Counter[str] = Counter()
    inclusive: Counter[str] = Counter()
    calls: Counter[str] = Counter()
    stack: list[list[Any]] = []  # per active frame: its name, its own count, its callees' count

    def name(code: Any) -> str:
        path = code.co_filename
        return f"{path.split('/fsm/')[-1] if '/fsm/' in path else Path(path).name}:{code.co_qualname}"

    def local(frame: Any, event: str, _arg: Any) -> Any:
        if event == "opcode":
            stack[-1][1] += 1
        elif event == "return":
            key, mine, below = stack.pop()
            own[key] += mine
            if all(entry[0] != key for entry in stack):  # a recursive call is counted once
                inclusive[key] += mine + below
            if stack:
                stack[-1][2] += mine + below
        return local

    def enter(frame: Any, event: str, _arg: Any) -> Any:
        frame.f_trace_opcodes, frame.f_trace_lines = True, False
        key = name(frame.f_code)
        calls[key] += 1
        stack.append([key, 0, 0])
        return local

    sys.settrace(enter)
    try:
        sim.run(duration=600)
    finally:
        sys.settrace(None)
    seconds = sim.machine.ctx.now
    total = sum(own.values())
    print(f"bytecode instructions per simulated second: {total / seconds:,.0f} (hallway lap, seed {seed}, "
          f"{seconds:.1f} s)")
    print("| function | inclusive | share | own | calls per s |")
    print("|---|---:|---:|---:|---:|")
    for key, count in inclusive.most_common(top):
        print(f"| `{key}` | {count / seconds:,.0f} | {count / total:.1%} | {own[key] / total:.1%} | "
              f"{calls[key] / seconds:,.0f} |")


def no_camera(args: argparse.Namespace) -> None:
    factors, cpu = [], []
    for _ in range(args.repeat):
        sim_time, wall, metrics = run_once(args.seed)
        factors.append(sim_time / wall)
        cpu.append(sim_time / metrics["cpu_time"])
    print(f"closed loop, no camera: hallway_lap.json, {metrics['sim_time']:.1f} s simulated, "
          f"{metrics['distance_m']:.1f} m, outcome collisions={metrics['collisions']}")
    print(f"realtime factor: best {max(factors):.0f}x, median {statistics.median(factors):.0f}x "
          f"(of {args.repeat} runs, one core); by the run's own processor time best {max(cpu):.0f}x, "
          f"median {statistics.median(cpu):.0f}x (load average {os.getloadavg()[0]:.1f})")
    print("breakdown per simulated second:", breakdown(args.seed))


if __name__ == "__main__":
    sys.exit(main())
