"""Benchmark: the closed loop without camera (physics 100 Hz, ultrasonic 20 Hz, machine 80 Hz), in x real time.

Runs ``diagrams/hallway_lap.json`` in ``diagrams/worlds/hallway.json`` (three laps, about 200 s of
simulated time) a few times on one core and prints the best and median realtime factor, plus a
breakdown per simulated second (physics, sensors, machine). Not a timed test: CI does not run it.

    .venv/bin/python benchmarks/bench_sim.py [--repeat 5] [--seed 0]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

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
    sim.run(duration=600)
    m = sim.metrics()
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


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    factors = []
    for _ in range(args.repeat):
        sim_time, wall, metrics = run_once(args.seed)
        factors.append(sim_time / wall)
    print(f"closed loop, no camera: hallway_lap.json, {metrics['sim_time']:.1f} s simulated, "
          f"{metrics['distance_m']:.1f} m, outcome collisions={metrics['collisions']}")
    print(f"realtime factor: best {max(factors):.0f}x, median {statistics.median(factors):.0f}x "
          f"(of {args.repeat} runs, one core)")
    print("breakdown per simulated second:", breakdown(args.seed))
    return 0


if __name__ == "__main__":
    sys.exit(main())
