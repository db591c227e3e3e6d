#!/usr/bin/env python
"""This checkout against an earlier commit, in one run on one machine: the speed budgets of issue 21.

The earlier commit (default 2a4832e, before the load path and the run loop grew slower) is checked out into a
temporary git worktree and imported from there; each workload runs in a fresh process, the two sides
alternating round by round, so both see the same machine load. Figures are medians over the rounds.

Workloads (each the same code on both sides):

  load        load + validate + build of the 1000-state ring from disk, ms (median of 7 per process);
              transitions' ``Machine`` (which validates nothing) in the same processes, for the ratio
  first       ``import fsm`` and its loader, then the first load of that ring, fresh process, ms (what a command pays)
  warm        this checkout's plan cache (the other workloads run with FSM_NO_CACHE=1): the ring's document to its
              checked plan from the cache, in a fresh process (what ``fsmctl validate`` pays on the second run) and
              again in the same process; building the Machine from the plan apart; a miss that writes the cache.
              "document -> plan" is ``fsm.loading.loader.compile``: the plan is made, building the Machine is not
              counted (it is shown apart); the spec's states and transitions, made when first read, are not made
  validate    ``fsmctl validate`` of the ring in a fresh process, wall time of the whole process as a user waits for
              it: this checkout from a filled plan cache, the base without one (it has none)
  flat        the flat ring of 100 states (Always), transitions/s (best of 5 x 0.5 s)
  nested      10 x 10 x 10 nested composites, transitions/s
  guard       the flat ring with a guard ``n >= 0`` on every transition; ``guard+set`` adds ``n = n + 1``
  lap         the hallway lap without camera (three laps, 200 s simulated), x real time

    python benchmarks/bench_baseline.py [--base 2a4832e] [--rounds 3] [--only load,flat] [--instructions]

``--instructions`` adds what a fresh process pays, counted by callgrind on both sides (needs valgrind): ``import fsm``
and its loader, then the first load of the ring, then a second (the cold load), so a busy machine gives the same
figures as a quiet one. Both trees are compiled to ``__pycache__`` first, as an installation is.

Budgets (issue 21): load at least 2x faster than transitions' Machine and at most 10 ms; flat and nested at
least as fast as the base; guard / guard+set at most 30 % / 50 % below the plain ring (this checkout); the lap
(issue 36) at least the base's real-time factor, by wall clock, and also shown by the run's own processor time
(``time.thread_time``), which the other jobs of a busy machine disturb less.
"""

from __future__ import annotations

import argparse
import compileall
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
BENCH = Path(__file__).resolve().parent
WORKLOADS = ("load", "first", "warm", "validate", "flat", "nested", "guard", "guard+set", "lap")

#: Run in a fresh interpreter on either side: prints one JSON object. ``sys.argv[1]`` is the workload.
PROBE = r'''
import gc, json, statistics, sys, tempfile, time
from pathlib import Path
if sys.argv[1] == "first":  # a fresh process: import fsm, then its first load of the ring (what `fsmctl validate` pays)
    ring = Path(sys.argv[2])
    t0 = time.perf_counter()
    import fsm
    load = fsm.load  # fsm's names are imported on first use: the loader's import counts as importing, on either tree
    t1 = time.perf_counter()
    load(ring)
    t2 = time.perf_counter()
    print(json.dumps({"import_ms": (t1 - t0) * 1000, "first_ms": (t2 - t1) * 1000}))
    sys.exit(0)
if sys.argv[1] == "warm":  # this checkout's plan cache, filled by an earlier process: document -> plan, then build
    ring = Path(sys.argv[2])
    t0 = time.perf_counter()
    from fsm.loading import loader
    from fsm.loading.building import build
    t1 = time.perf_counter()
    plan = loader.compile(ring)
    t2 = time.perf_counter()
    build(plan)
    t3 = time.perf_counter()
    from fsm.loading import cache as _cache
    hits, builds, misses = [], [], []
    for _ in range(7):  # read from the file each time: what the process keeps in memory cleared
        loader._LAST.clear(); _cache._KEPT.clear(); gc.collect()
        a = time.perf_counter(); plan = loader.compile(ring); b = time.perf_counter(); build(plan)
        hits.append(b - a); builds.append(time.perf_counter() - b)
    import os as _os
    for _ in range(3):  # a miss that writes the cache: the cache file gone, the document loaded and stored
        _cache.flush()  # the previous load's file is written on a thread of its own
        _os.unlink(_cache.file_of(str(ring)))
        loader._LAST.clear(); _cache._KEPT.clear(); gc.collect()
        a = time.perf_counter(); loader.compile(ring); misses.append(time.perf_counter() - a)
    print(json.dumps({"import_ms": (t1 - t0) * 1000, "first_plan_ms": (t2 - t1) * 1000,
                      "first_build_ms": (t3 - t2) * 1000, "plan_ms": statistics.median(hits) * 1000,
                      "build_ms": statistics.median(builds) * 1000, "miss_ms": statistics.median(misses) * 1000}))
    sys.exit(0)
if BASE:  # this checkout (an editable install is a plain path entry to it) must not shadow the base's fsm
    sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != Path(BENCH).resolve().parent]
sys.path.insert(0, BENCH)
import fsm
from peers.tral_fsm import ring_doc as load_ring, nested_doc
from peers.workloads import FLAT_N
from bench_sequencer import ring_doc as guard_ring
workload = sys.argv[1]

def rate(doc, count_transitions):
    best = 0.0
    for _ in range(5):
        m = fsm.load(doc)
        m.start()
        tick = m.tick
        n = 20000
        while True:
            gc.collect()
            before = m.transition_count
            t0 = time.perf_counter()
            for _ in range(n):
                tick()
            dt = time.perf_counter() - t0
            if dt > 0.5:
                break
            n *= 2
        fired = m.transition_count - before if count_transitions else n
        best = max(best, fired / dt)
    return best

if workload == "load":
    import json as _json
    d = tempfile.mkdtemp()
    path = Path(d) / "ring1000.json"
    path.write_text(_json.dumps(load_ring(1000), indent=1))
    fsm.load(path)
    times = []
    for _ in range(7):
        gc.collect()
        t0 = time.perf_counter(); fsm.load(path); times.append(time.perf_counter() - t0)
    out = {"ms": statistics.median(times) * 1000}
    try:
        from peers.pytransitions import TransitionsLoad
        loader = TransitionsLoad(Path(d)); loader.prepare(); loader.once()
        peer = []
        for _ in range(7):
            gc.collect()
            t0 = time.perf_counter(); loader.once(); peer.append(time.perf_counter() - t0)
        out["transitions_ms"] = statistics.median(peer) * 1000
    except Exception as exc:
        out["transitions_error"] = repr(exc)
    print(json.dumps(out))
elif workload in ("flat", "nested"):
    doc = load_ring(FLAT_N) if workload == "flat" else nested_doc()
    print(json.dumps({"rate": rate(doc, True)}))
elif workload in ("guard", "guard+set", "plain"):
    print(json.dumps({"rate": rate(guard_ring(workload), True)}))
elif workload == "lap":
    from bench_sim import run_once
    factors, cpu = [], []
    for _ in range(2):
        sim_time, wall, _m = run_once(0)
        factors.append(sim_time / wall)
        cpu.append(sim_time / _m["cpu_time"])
    print(json.dumps({"factor": max(factors), "cpu_factor": max(cpu)}))
'''


def base_tree(commit: str, where: Path) -> Path:
    """The base commit checked out into ``where`` (a git worktree), importable as ``fsm`` by PYTHONPATH."""
    tree = where / "base"
    subprocess.run(["git", "-C", str(REPO), "worktree", "add", "--detach", "--force", str(tree), commit],
                   check=True, capture_output=True)
    for name, target in (("states", "../states"), ("transitions", "../transitions"), ("tools", "../tools"),
                         ("worlds", "../diagrams/worlds")):
        link = tree / "fsm" / name
        if not link.exists():
            link.symlink_to(target)
    compiled(tree)
    return tree


def compiled(tree: Path) -> None:
    """The tree's modules compiled to ``__pycache__`` as an installation has them: a fresh worktree has none, and with
    ``PYTHONDONTWRITEBYTECODE`` set every process would compile its imports again (tens of ms on either side)."""
    for folder in ("fsm", "states", "transitions", "tools"):
        if (tree / folder).is_dir():
            compileall.compile_dir(str(tree / folder), quiet=2)


#: ``fsmctl validate RING`` as the console script runs it (``sys.argv[1]``: the ring).
VALIDATE = "import sys\nfrom fsm.tools.cli import main\nsys.exit(main(['validate', '-q', sys.argv[1]]))\n"


def probe(workload: str, tree: Path | None, ring: Path | None = None, cache: Path | None = None) -> dict[str, Any]:
    env = dict(os.environ)
    if workload in ("warm", "validate") and cache is not None:  # a cache folder of the benchmark's own
        env["FSM_CACHE_DIR"] = str(cache)
        env.pop("FSM_NO_CACHE", None)
    else:
        env["FSM_NO_CACHE"] = "1"  # the cold path on this checkout, as on the base (which has no cache)
    if tree is not None:
        env["PYTHONPATH"] = str(tree)
    else:
        env.pop("PYTHONPATH", None)
    code = f"BENCH = {str(BENCH)!r}\nBASE = {tree is not None}\n" + (VALIDATE if workload == "validate" else PROBE)
    if tree is not None:  # the base's fsm must win over this checkout's editable install
        code = ("import sys\nsys.meta_path[:] = [f for f in sys.meta_path if 'editable' not in "
                "type(f).__module__.lower()]\n" + code)
    args = [str(ring)] if workload == "validate" else [workload, *([str(ring)] if ring else [])]
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", code, *args], env=env, capture_output=True, text=True,
                          cwd=str(tree or REPO), timeout=900)
    if workload == "validate" and done.returncode == 0:
        return {"wall_ms": (time.perf_counter() - start) * 1000}
    if done.returncode != 0:
        raise RuntimeError(f"{workload} on {'base' if tree else 'this checkout'} failed:\n{done.stderr[-2000:]}")
    result: dict[str, Any] = json.loads(done.stdout.strip().splitlines()[-1])
    return result


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--base", default="2a4832e", help="the commit to compare with (default 2a4832e)")
    ap.add_argument("--rounds", type=int, default=3, help="rounds, each running every workload on both sides")
    ap.add_argument("--only", default=",".join(WORKLOADS), help="comma-separated workloads: " + ", ".join(WORKLOADS))
    ap.add_argument("--instructions", action="store_true",
                    help="also count with valgrind what a fresh process pays to import fsm and for its first load")
    args = ap.parse_args(argv)
    chosen = [w for w in args.only.split(",") if w]
    unknown = [w for w in chosen if w not in WORKLOADS]
    if unknown:
        print(f"unknown workload(s): {', '.join(unknown)}", file=sys.stderr)
        return 2
    where = Path(tempfile.mkdtemp(prefix="tral-base-"))
    try:
        tree = base_tree(args.base, where)
        compiled(REPO)
        ring = where / "ring1000.json"
        sys.path.insert(0, str(BENCH))
        from peers.tral_fsm import ring_doc

        ring.write_text(json.dumps(ring_doc(1000), indent=1))
        runs: dict[tuple[str, str], list[dict[str, Any]]] = {}
        needs_plain = any(w in chosen for w in ("guard", "guard+set"))
        for r in range(args.rounds):
            for workload in chosen + (["plain"] if needs_plain else []):
                for side, path in (("base", tree), ("main", None)):
                    if workload in ("guard", "guard+set", "plain", "warm") and side == "base":
                        continue  # the guard budget is against this checkout's plain ring; the base has no cache
                    if workload in ("warm", "validate") and r == 0 and side == "main":
                        probe(workload, path, ring, where / "cache")  # fills the cache
                    runs.setdefault((workload, side), []).append(probe(workload, path, ring, where / "cache"))
            print(f"round {r + 1} of {args.rounds} done", file=sys.stderr)
        report(runs, chosen, args.base)
        if args.instructions:
            first_instructions(tree, ring, args.base)
    finally:
        subprocess.run(["git", "-C", str(REPO), "worktree", "remove", "--force", str(where / "base")],
                       capture_output=True)
        shutil.rmtree(where, ignore_errors=True)
    return 0


#: A fresh process up to a stage: 0 the interpreter's start, 1 ``import fsm`` and its loader, 2 the first load of
#: the ring, 3 a second load (``sys.argv[1]``: the stage, ``sys.argv[2]``: the ring).
FIRST_STAGES = r'''
import sys
stage, ring = int(sys.argv[1]), sys.argv[2]
if BASE:
    from pathlib import Path
    sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != Path(BENCH).resolve().parent]
if stage >= 1:
    import fsm
    load = fsm.load
for _ in range(stage - 1):
    load(ring)
'''


def first_instructions(tree: Path, ring: Path, base: str) -> None:
    """Instructions (callgrind, ``PYTHONHASHSEED=0``, the cache off) of ``import fsm``, the first and a second load
    of the ring in a fresh process, on both sides: the stages' differences, so the interpreter's start cancels."""
    from bench_instructions import callgrind

    counts: dict[str, list[int]] = {}
    for side, path in (("base", tree), ("main", None)):
        env = dict(os.environ, PYTHONHASHSEED="0", FSM_NO_CACHE="1")
        code = f"BENCH = {str(BENCH)!r}\nBASE = {path is not None}\n" + FIRST_STAGES
        if path is not None:
            env["PYTHONPATH"] = str(path)
            code = ("import sys\nsys.meta_path[:] = [f for f in sys.meta_path if 'editable' not in "
                    "type(f).__module__.lower()]\n" + code)
        else:
            env.pop("PYTHONPATH", None)
        counts[side] = [callgrind(["-c", code, str(stage), str(ring)], env, path or REPO, f"stage {stage} on {side}")
                        for stage in range(4)]
    print(f"\n| fresh process, instructions (M) | {base} | this checkout | ratio |")
    print("|---|---:|---:|---:|")
    for stage, what in ((1, "`import fsm` and its loader"), (2, "then the first load of the ring"),
                        (3, "then a second load (the cold load)")):
        b, m = (counts[s][stage] - counts[s][stage - 1] for s in ("base", "main"))
        print(f"| {what} | {b / 1e6:,.1f} | {m / 1e6:,.1f} | {m / b:.2f} |")
    b, m = (counts[s][2] - counts[s][0] for s in ("base", "main"))
    print(f"| import and first load together | {b / 1e6:,.1f} | {m / 1e6:,.1f} | {m / b:.2f} |")


def median(runs: list[dict[str, Any]], key: str) -> float:
    return statistics.median(r[key] for r in runs if key in r)


def report(runs: dict[tuple[str, str], list[dict[str, Any]]], chosen: list[str], base: str) -> None:
    print(f"| workload | {base} | this checkout | ratio | budget |")
    print("|---|---:|---:|---:|---|")
    if "load" in chosen:
        b, m = median(runs["load", "base"], "ms"), median(runs["load", "main"], "ms")
        peer = median(runs["load", "main"], "transitions_ms")
        verdict = "pass" if peer / m >= 2 and m <= 10 else "MISS"
        print(f"| load + validate + build, 1000 states (ms, median) | {b:.1f} | {m:.1f} | {b / m:.2f}x faster | "
              f"<= 10 ms and >= 2x transitions' Machine ({peer:.1f} ms: {peer / m:.2f}x): {verdict} |")
    if "first" in chosen:
        for key, what in (("import_ms", "`import fsm` in a fresh process (ms, median)"),
                          ("first_ms", "then the first load of the ring (ms, median)")):
            b, m = median(runs["first", "base"], key), median(runs["first", "main"], key)
            print(f"| {what} | {b:.1f} | {m:.1f} | {b / m:.2f}x faster | first load <= base: "
                  f"{'pass' if key == 'import_ms' or m <= b else 'MISS'} |")
    if "warm" in chosen:
        warm = runs["warm", "main"]
        for key, what, budget in (
                ("import_ms", "plan cache, fresh process: importing the loader (ms, median)", None),
                ("first_plan_ms", "plan cache, fresh process: the ring's document -> plan from the cache (ms)", 2.0),
                ("first_build_ms", "plan cache, fresh process: then building the Machine (ms)", None),
                ("plan_ms", "plan cache, same process: document -> plan from the cache file (ms)", 2.0),
                ("build_ms", "plan cache, same process: building the Machine (ms)", None),
                ("miss_ms", "plan cache, a miss: document -> plan, checked, compiled and written (ms)", None)):
            m = median(warm, key)
            verdict = "" if budget is None else f"<= {budget:g} ms: {'pass' if m <= budget else 'MISS'}"
            print(f"| {what} | | {m:.2f} | | {verdict} |")
    if "validate" in chosen:
        b, m = median(runs["validate", "base"], "wall_ms"), median(runs["validate", "main"], "wall_ms")
        print(f"| `fsmctl validate` of the ring, fresh process, wall time (ms, median; this checkout from its plan "
              f"cache) | {b:.1f} | {m:.1f} | {b / m:.2f}x faster | |")
    for workload in ("flat", "nested"):
        if workload in chosen:
            b, m = median(runs[workload, "base"], "rate"), median(runs[workload, "main"], "rate")
            print(f"| {workload} (transitions/s) | {b:,.0f} | {m:,.0f} | {m / b:.2f} | >= base: "
                  f"{'pass' if m >= b else 'MISS'} |")
    if ("plain", "main") in runs:
        plain = median(runs["plain", "main"], "rate")
        for workload, budget in (("guard", 0.30), ("guard+set", 0.50)):
            if workload in chosen:
                r = median(runs[workload, "main"], "rate")
                loss = 1 - r / plain
                print(f"| flat ring, {workload} on every transition (transitions/s) | | {r:,.0f} | {loss:.0%} below "
                      f"plain {plain:,.0f} | <= {budget:.0%}: {'pass' if loss <= budget else 'MISS'} |")
    if "lap" in chosen:
        b, m = median(runs["lap", "base"], "factor"), median(runs["lap", "main"], "factor")
        print(f"| hallway lap, no camera (x real time) | {b:.0f} | {m:.0f} | {m / b:.2f} | >= 1.00: "
              f"{'pass' if m >= b else 'MISS'} |")
        b, m = median(runs["lap", "base"], "cpu_factor"), median(runs["lap", "main"], "cpu_factor")
        print(f"| hallway lap, no camera (x the run's own processor time) | {b:.0f} | {m:.0f} | {m / b:.2f} | |")
    print(f"\nload average at the end: {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    sys.exit(main())
