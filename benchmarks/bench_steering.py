"""Benchmark: how smoothly wall following drives the steering servo on the hallway lap (issue 26).

Runs ``diagrams/hallway_lap.json`` in ``diagrams/worlds/hallway.json`` for a few seeds and prints, per seed, the
summary's steering figures on straights (the command's standard deviation in steering units, full range 2, and its
sign changes per second) and the wall error, then the median against the targets: at most 1 sign change per second,
a standard deviation under 0.05 (a fortieth of the full range) and a wall error under 3 cm RMS. Figures, not a timed
test (CI does not run it).

    .venv/bin/python benchmarks/bench_steering.py [--seeds 8]
"""

from __future__ import annotations

import argparse
import statistics
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def run(seed: int) -> dict[str, float]:
    from fsm.sim import simulate

    session = simulate(str(ROOT / "diagrams" / "hallway_lap.json"), world=ROOT / "diagrams" / "worlds" / "hallway.json",
                       seed=seed)
    session.run()
    m = session.summary()
    return {"std": m["steering_std"], "changes": m["steering_sign_changes_per_s"], "rms": m["wall_error_rms_m"],
            "collisions": m["collisions"], "outcome": m["outcome"]}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=8)
    args = parser.parse_args(argv)
    rows = [run(seed) for seed in range(args.seeds)]
    print("| seed | steering std | sign changes/s | wall error RMS | collisions | outcome |")
    print("|---|---|---|---|---|---|")
    for seed, r in enumerate(rows):
        print(f"| {seed} | {r['std']:.3f} | {r['changes']:.2f} | {r['rms'] * 100:.2f} cm | {r['collisions']} | "
              f"{r['outcome']} |")
    std = statistics.median(r["std"] for r in rows)
    changes = statistics.median(r["changes"] for r in rows)
    rms = statistics.median(r["rms"] for r in rows)
    ok = std < 0.05 and changes <= 1.0 and rms < 0.03
    print(f"median: std {std:.3f} (target < 0.05), {changes:.2f} sign changes/s (target <= 1), wall error "
          f"{rms * 100:.2f} cm RMS (target < 3 cm): {'met' if ok else 'NOT met'}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
