"""Sweep speed (issue 12): 16 runs of the 200 s hallway lap with -j 2 at least 1.8x faster than with -j 1 on a
2-core machine, and a dispatch overhead under 50 ms per run.

The overhead is measured on runs that do almost nothing (a machine without a car, 0.1 s of simulated time): the
workers' wall time per run minus the time the run itself took (measured inside the worker), with the sweep's
fixed start (process start, imports, planning) taken out by a sweep of 2 runs. Each sweep starts from an empty output
folder (no run is skipped). The wall time includes the sweep's start (Python, imports, planning, the workers'
spawn), which does not shrink with -j: with laps of about 0.25 s it weighs about a sixth of 16 runs, so the same
ratio is also measured on 64 laps. Run: ``.venv/bin/python benchmarks/bench_sweep.py`` (``--runs N`` to change 16).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
FSMCTL = str(Path(sys.executable).parent / "fsmctl")


#: The sweeps run as under a default Python, which caches compiled modules (``__pycache__``): with
#: PYTHONDONTWRITEBYTECODE set (as on some CI machines), every process, each worker too, compiles this project's
#: modules again, about 0.1 s per process that a user's sweep does not pay.
ENV = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}


def sweep(args: list[str]) -> tuple[float, float]:
    """Wall time of a sweep and the summed time its runs took inside the workers."""
    import json

    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        subprocess.run([FSMCTL, "sweep", *args, "-o", tmp, "--no-progress", "-q"], check=True, env=ENV)
        wall = time.perf_counter() - t0
        inside = sum(json.loads(line)["seconds"] for line in Path(tmp, "sweep.jsonl").read_text().splitlines())
        return wall, inside


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=16, help="lap runs (default 16)")
    ap.add_argument("--long", type=int, default=64, metavar="N",
                    help="also N laps with -j 1 and -j 2, where the fixed start weighs less (default 64; 0: skip)")
    args = ap.parse_args()
    lap = ["--machine", str(REPO / "diagrams" / "hallway_lap.uxf"), "--seeds", f"0:{args.runs}"]
    print(f"load: {os.getloadavg()[0]:.2f} (1 min) on {os.cpu_count()} CPUs")
    sweep(["--machine", str(REPO / "diagrams" / "hallway_lap.uxf"), "--seeds", "0:2", "-j", "2"])  # caches modules
    one, inside_one = sweep(lap + ["-j", "1"])
    two, _ = sweep(lap + ["-j", "2"])
    blinker = ["--machine", str(REPO / "diagrams" / "examples" / "blinker.uxf"), "--duration", "0.1", "-j", "2"]
    start, _ = sweep(blinker + ["--seeds", "0:2"])
    many, inside = sweep(blinker + ["--seeds", "0:130"])
    overhead = ((many - start) * 2 - inside) / 128  # per run: worker time not spent running it, fixed start excluded
    long_one = long_two = None
    if args.long:
        many_laps = ["--machine", str(REPO / "diagrams" / "hallway_lap.uxf"), "--seeds", f"0:{args.long}"]
        long_one, _ = sweep(many_laps + ["-j", "1"])
        long_two, _ = sweep(many_laps + ["-j", "2"])
    print("| workload | measured | target |")
    print("|---|---:|---|")
    print(f"| {args.runs} hallway laps (200 s each), -j 1 | {one:.1f} s (runs {inside_one:.1f} s, fixed start "
          f"{one - inside_one:.1f} s) | |")
    print(f"| {args.runs} hallway laps, -j 2 | {two:.1f} s ({one / two:.2f}x) | >= 1.8x "
          f"{'(pass)' if one / two >= 1.8 else '(MISS)'} |")
    if long_one is not None and long_two is not None:
        print(f"| {args.long} hallway laps, -j 1 / -j 2 | {long_one:.1f} s / {long_two:.1f} s "
              f"({long_one / long_two:.2f}x) | |")
    print(f"| dispatch overhead per run (128 runs of 0.1 s, -j 2; sweep start {start:.2f} s) | "
          f"{overhead * 1000:.1f} ms | < 50 ms {'(pass)' if overhead < 0.05 else '(MISS)'} |")


if __name__ == "__main__":
    main()
