"""Random rectangular hallway loops with ArUco gates, and diagrams/gate_run.uxf driven through each.

The worlds follow the gate run's specification (docs/car.md): a rectangular loop with corridors 1.8-2.6 m wide,
driven counter-clockwise from a start pose on a straight; gates with ids 0-49, on the straights at least 3 m after
a corner (and 1 m before the next), at least 3 m apart along a straight and 1.5 m from the start, their heading
within 25 degrees of the corridor's, 0.6-1.0 m wide with markers of 0.10-0.20 m, the posts clear of the walls.

    python benchmarks/bench_gate_worlds.py                  # 30 loops, seed 0 each
    python benchmarks/bench_gate_worlds.py -n 50 --seeds 0 1 --first 100 -j 8
    python benchmarks/bench_gate_worlds.py --keep /tmp/worlds   # keep the world files (w<N>.json)

Each world is checked with ``fsmctl validate``, then run with ``fsmctl run MACHINE --world W --seed S --summary``;
the table gives gates passed/total, collisions and the outcome, then the pass rate (every gate passed, 0
collisions, outcome succeeded). Exit status 1 when a run failed.
"""

from __future__ import annotations

import argparse
import json
import math
import random
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
MACHINE = ROOT / "diagrams" / "gate_run.uxf"

CORRIDOR = (1.8, 2.6)
GATE_WIDTH = (0.6, 1.0)
MARKER_SIZE = (0.10, 0.20)
MAX_TILT = 25.0  # degrees off the corridor
AFTER_CORNER = 3.0  # m from the inner corner at the straight's start
BEFORE_CORNER = 1.0  # m from the inner corner at its end
GATE_SPACING = 3.0  # m between two gates on one straight
START_CLEAR = 1.5  # m between the start and a gate
POST_CLEAR = 0.15  # m between a marker post and a wall
START_LANE = 0.495  # the start pose's distance from the outer wall, m


def generate(seed: int, anywhere: bool = False) -> dict[str, Any]:
    """A random loop: outer rectangle W x H, corridors of width c, gates on the four straights; with ``anywhere``
    the same loop with the start moved across the corridor (0.35 m from either wall at most)."""
    r = random.Random(seed)
    c = r.uniform(*CORRIDOR)
    width, height = r.uniform(14, 24), r.uniform(8, 14)
    ids = r.sample(range(50), 50)
    # the straights, driven counter-clockwise: origin on the outer wall, direction (degrees), length
    straights = [((0.0, 0.0), 0.0, width), ((width, 0.0), 90.0, height), ((width, height), 180.0, width),
                 ((0.0, height), 270.0, height)]
    side = r.randrange(4)  # the straight of the start
    (sox, soy), sdir, slen = straights[side]
    s_start = r.uniform(c + 1.0, slen - c - 1.0)
    gates: list[dict[str, Any]] = []
    for k, ((ox, oy), direction, length) in enumerate(straights):
        lo, hi = c + AFTER_CORNER, length - c - BEFORE_CORNER
        used: list[float] = []
        count = r.choice([0, 1, 1, 2, 2, 3])
        for _ in range(count if lo < hi else 0):  # a short straight may have no room for a gate
            for _try in range(100):
                s = r.uniform(lo, hi)
                if all(abs(s - u) >= GATE_SPACING for u in used) and (k != side or abs(s - s_start) >= START_CLEAR):
                    break
            else:
                continue
            used.append(s)
            gate_width = r.uniform(*GATE_WIDTH)
            tilt = r.uniform(-MAX_TILT, MAX_TILT)
            half = gate_width / 2 * abs(math.cos(math.radians(tilt)))  # half its extent across the corridor
            lateral = r.uniform(POST_CLEAR + half + 0.05, c - POST_CLEAR - half - 0.05)  # from the outer wall
            ux, uy = math.cos(math.radians(direction)), math.sin(math.radians(direction))
            nx, ny = -uy, ux  # to the left of the driving direction: into the corridor from the outer wall
            gates.append({"markers": [ids.pop(), ids.pop()],
                          "center": [round(ox + ux * s + nx * lateral, 3), round(oy + uy * s + ny * lateral, 3)],
                          "heading": round(direction + tilt, 1), "width": round(gate_width, 2),
                          "marker_size": round(r.uniform(*MARKER_SIZE), 3), "height": 0.2})
    ux, uy = math.cos(math.radians(sdir)), math.sin(math.radians(sdir))
    start = {"x": round(sox + ux * s_start - uy * START_LANE, 3), "y": round(soy + uy * s_start + ux * START_LANE, 3),
             "heading": sdir}
    lane = ""
    if anywhere:
        shift = random.Random(1000 + seed).uniform(0.35, c - 0.35) - START_LANE
        start["x"], start["y"] = round(start["x"] - uy * shift, 3), round(start["y"] + ux * shift, 3)
        lane = f", start lane {START_LANE + shift:.2f} m"
    return {"description": f"random loop {seed}: {width:.1f} x {height:.1f} m, corridors {c:.2f} m, "
                           f"{len(gates)} gates, start on straight {side}{lane}",
            "walls": [{"points": [[0, 0], [width, 0], [width, height], [0, height]], "closed": True},
                      {"points": [[c, c], [width - c, c], [width - c, height - c], [c, height - c]],
                       "closed": True}],
            "gates": gates, "start": start}


def fsmctl(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "fsm.tools.cli", *args], capture_output=True, text=True)


def run_one(world: Path, seed: int, machine: Path, out: Path) -> dict[str, Any]:
    summary = out / f"{world.stem}.seed{seed}.summary.json"
    proc = fsmctl("run", str(machine), "--world", str(world), "--seed", str(seed), "--summary", str(summary), "-q")
    row: dict[str, Any] = {"world": world.name, "seed": seed}
    if not summary.exists():
        row.update(passed=0, total=0, collisions=-1, outcome=f"error: {proc.stderr.strip()[-200:]}", ok=False)
        return row
    s = json.loads(summary.read_text())
    row.update(passed=s.get("gates_passed", 0), total=s.get("gates_total", 0), collisions=s.get("collisions", 0),
               outcome=s.get("outcome"), sim_time=s.get("sim_time"))
    row["ok"] = (row["outcome"] == "succeeded" and row["collisions"] == 0 and row["passed"] == row["total"])
    return row


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-n", type=int, default=30, help="number of random loops (default 30)")
    ap.add_argument("--first", type=int, default=0, help="seed of the first loop (default 0)")
    ap.add_argument("--seeds", type=int, nargs="+", default=[0], help="run seeds (sensor noise) per loop")
    ap.add_argument("--world", type=Path, nargs="*", default=[], help="also run these world files")
    ap.add_argument("--machine", type=Path, default=MACHINE)
    ap.add_argument("--keep", type=Path, help="write the worlds (and summaries) here instead of a temp dir")
    ap.add_argument("-j", "--jobs", type=int, default=4, help="runs in parallel (default 4)")
    ap.add_argument("--anywhere", action="store_true",
                    help="start anywhere across the corridor instead of 0.5 m from the outer wall")
    args = ap.parse_args(argv)

    with tempfile.TemporaryDirectory(prefix="gate_worlds_") as tmp:
        out = args.keep or Path(tmp)
        out.mkdir(parents=True, exist_ok=True)
        worlds = list(args.world)
        for k in range(args.first, args.first + args.n):
            path = out / f"w{k}.json"
            path.write_text(json.dumps(generate(k, args.anywhere), indent=1) + "\n")
            worlds.append(path)
        bad = fsmctl("validate", *map(str, worlds[len(args.world):])) if args.n else None
        if bad is not None and bad.returncode != 0:
            print(bad.stdout + bad.stderr, file=sys.stderr)
            return 2
        jobs = [(w, s) for w in worlds for s in args.seeds]
        with ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
            rows = list(pool.map(lambda ws: run_one(ws[0], ws[1], args.machine, out), jobs))
    print(f"{'world':<22} {'seed':>4} {'gates':>7} {'coll':>4}  outcome")
    for row in rows:
        mark = "" if row["ok"] else "  <- FAIL"
        print(f"{row['world']:<22} {row['seed']:>4} {row['passed']:>3}/{row['total']:<3} {row['collisions']:>4}  "
              f"{row['outcome']}{mark}")
    ok = sum(r["ok"] for r in rows)
    print(f"pass rate: {ok}/{len(rows)} = {100.0 * ok / max(1, len(rows)):.0f} % "
          f"(gates {sum(r['passed'] for r in rows)}/{sum(r['total'] for r in rows)}, "
          f"collisions {sum(max(0, r['collisions']) for r in rows)})")
    return 0 if ok == len(rows) else 1


if __name__ == "__main__":
    sys.exit(main())
