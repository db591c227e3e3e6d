#!/usr/bin/env python
"""Instructions, not seconds: the cost per tick and per load of this checkout and of an earlier commit, counted
with valgrind (callgrind), so that a shared, busy machine gives the same figures as an idle one.

Each workload runs in a fresh interpreter under ``valgrind --tool=callgrind`` twice, once with 0 repetitions and
once with N; the difference divided by N is the cost of one repetition, with start-up, imports and warm-up
cancelled out (with ``PYTHONHASHSEED=0``: string hashes move the counts by about 1 % between processes
otherwise). The earlier commit is checked out into a temporary git worktree (as in ``bench_baseline.py``).

  flat        one tick of the flat ring of 100 states (Always)
  nested      one tick of the 10 x 10 x 10 nested composites
  plain       one tick of the sequencer benchmark's ring without guards (the reference of the next two)
  guard       the same ring with a guard ``n >= 0`` on every transition; ``guard+set`` adds ``n = n + 1``
  load        one load + validate + build of the 1000-state ring from disk
  stages      the load's stages apart, each repeated on inputs prepared by the stages before it (the collector
              off, as during a load): parse (read + parse of the ring's file), check, compile, build; ``nested``
              after a stage's name (``parse/nested``, or ``nested-stages`` for all four) takes the 10 x 10 x 10
              nested document instead of the ring
  lap         one simulated second of the hallway lap without camera (car, sensors, machine, loop; seed 0)

Rate losses follow from the counts: a guard costing ``g`` instructions per tick against ``p`` plain loses
``1 - p / g`` of the rate. Needs valgrind (``apt install valgrind``); slow (about 50x): a few minutes in all.

    python benchmarks/bench_instructions.py [--base 2a4832e] [--only flat,load] [--no-base]
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from bench_baseline import REPO, base_tree

BENCH = Path(__file__).resolve().parent
STAGES = ("parse", "check", "compile", "build")
WORKLOADS = ("flat", "nested", "plain", "guard", "guard+set", "load", "lap", *STAGES, *(f"{s}/nested" for s in STAGES))
#: names standing for several workloads
GROUPS = {"stages": STAGES, "nested-stages": tuple(f"{s}/nested" for s in STAGES)}
#: repetitions of the measured run (the other runs 0); for the lap, simulated seconds. Six loads, not three: a load
#: leaves a 1000-state machine of cyclic garbage, freed by the collector's full passes, and whether one of those
#: (about 50M instructions) falls inside three loads or not moved the count per load by up to 17M (163M or 180M for
#: the same tree); four and six loads agree within 0.2 %.
REPEAT = {"load": 6, "lap": 60, **{w: 6 for group in GROUPS.values() for w in group}}
TICKS = 10000
#: workloads only this checkout runs (the guard budget is against this checkout's plain ring)
MAIN_ONLY = ("plain", "guard", "guard+set")

PROBE = r'''
import json, sys, tempfile
from pathlib import Path
if BASE:  # this checkout (an editable install is a plain path entry to it) must not shadow the base's fsm
    sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != Path(BENCH).resolve().parent]
sys.path.insert(0, BENCH)
import fsm
from peers.tral_fsm import ring_doc, nested_doc
workload, n = sys.argv[1], int(sys.argv[2])
if workload == "lap":
    from fsm.sim.car import SimCar
    from fsm.sim.loop import Simulation
    from fsm.sim.world import load_world
    root = Path(BENCH).parent
    car = SimCar(load_world(root / "diagrams" / "worlds" / "hallway.json"), seed=0)
    sim = Simulation(fsm.load(root / "diagrams" / "hallway_lap.json", car=car), car)
    if n:
        sim.run(duration=n)
elif workload.split("/")[0] in ("parse", "check", "compile", "build"):  # one stage, on what the stages before made
    import gc
    from fsm.loading.building import build
    from fsm.loading.checking import check
    from fsm.loading.compiling import compile_machine
    from fsm.loading.loader import registry_of
    from fsm.loading.parsing import parse
    from fsm.model.problems import Problems
    stage, _, which = workload.partition("/")
    path = Path(tempfile.mkdtemp()) / "doc.json"
    path.write_text(json.dumps(nested_doc() if which == "nested" else ring_doc(1000), indent=1))
    registry = registry_of(())
    fsm.load(path)  # the first load builds what is built on first use (models, validators)
    gc.collect()
    gc.disable()  # as during a load (fsm.loading.loader.collection_paused)
    spec = parse(path, registry, Problems())
    analysis = check(spec, Problems())
    plan = compile_machine(spec, analysis)
    build(plan)
    run = {"parse": lambda: parse(path, registry, Problems()), "check": lambda: check(spec, Problems()),
           "compile": lambda: compile_machine(spec, analysis), "build": lambda: build(plan)}[stage]
    for _ in range(n):
        run()
elif workload == "load":
    path = Path(tempfile.mkdtemp()) / "ring1000.json"
    path.write_text(json.dumps(ring_doc(1000), indent=1))
    fsm.load(path)
    for _ in range(n):
        fsm.load(path)
else:
    if workload in ("plain", "guard", "guard+set"):
        from bench_sequencer import ring_doc as guard_ring
        doc = guard_ring(workload)
    else:
        doc = nested_doc() if workload == "nested" else ring_doc(100)
    m = fsm.load(doc)
    m.start()
    for _ in range(n):
        m.tick()
'''


def on_tree(code: str, tree: Path | None) -> tuple[dict[str, str], str]:
    """The environment (string hashes fixed, the plan cache off) and the code of a probe of ``tree``'s fsm (``None``:
    this checkout's): on a base tree its fsm must win over this checkout's editable install."""
    env = dict(os.environ, PYTHONHASHSEED="0", FSM_NO_CACHE="1")
    if tree is None:
        env.pop("PYTHONPATH", None)
        return env, code
    env["PYTHONPATH"] = str(tree)
    return env, ("import sys\nsys.meta_path[:] = [f for f in sys.meta_path if 'editable' not in "
                 "type(f).__module__.lower()]\n" + code)


def instructions(workload: str, n: int, tree: Path | None) -> int:
    # string hashes decide dict probing: the same on every run; the plan cache off: the cold load, as on the base
    env, code = on_tree(f"BENCH = {str(BENCH)!r}\nBASE = {tree is not None}\n" + PROBE, tree)
    return callgrind(["-c", code, workload, str(n)], env, tree or REPO,
                     f"{workload} on {'base' if tree else 'this checkout'}")


def callgrind(args: list[str], env: dict[str, str], cwd: Path, what: str) -> int:
    """The instructions of ``python ARGS`` (run in ``cwd`` with ``env``) counted by callgrind; RuntimeError naming
    ``what`` when it fails."""
    # --trace-children: this machine's interpreter re-executes itself at start, and only the new image runs the code
    done = subprocess.run(["valgrind", "--tool=callgrind", "--trace-children=yes", "--callgrind-out-file=/dev/null",
                           sys.executable, *args],
                          env=env, capture_output=True, text=True, cwd=str(cwd), timeout=3600)
    found = re.search(r"Collected\s*:\s*(\d+)", done.stderr)
    if done.returncode != 0 or found is None:
        raise RuntimeError(f"{what} failed:\n{done.stderr[-2000:]}")
    return int(found.group(1))


def per_repetition(workload: str, tree: Path | None) -> float:
    n = REPEAT.get(workload, TICKS)
    return (instructions(workload, n, tree) - instructions(workload, 0, tree)) / n


@contextmanager
def base_checkout(base: str | None) -> Iterator[Path | None]:
    """A worktree of commit ``base`` for the block (``None``: no base, this checkout only), removed after it."""
    if base is None:
        yield None
        return
    where = Path(tempfile.mkdtemp(prefix="tral-base-"))
    try:
        yield base_tree(base, where)
    finally:
        subprocess.run(["git", "-C", str(REPO), "worktree", "remove", "--force", str(where / "base")],
                       capture_output=True)
        shutil.rmtree(where, ignore_errors=True)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--base", default="2a4832e", help="the commit to compare with (default 2a4832e)")
    ap.add_argument("--no-base", action="store_true", help="count this checkout only")
    ap.add_argument("--only", default=",".join(WORKLOADS), help="comma-separated workloads: " + ", ".join(WORKLOADS)
                    + "; " + ", ".join(GROUPS) + " for the stages")
    ap.add_argument("--json", metavar="FILE", help="also write the counts as JSON")
    args = ap.parse_args(argv)
    chosen = [x for w in args.only.split(",") if w for x in GROUPS.get(w, (w,))]
    unknown = [w for w in chosen if w not in WORKLOADS]
    if unknown:
        print(f"unknown workload(s): {', '.join(unknown)}", file=sys.stderr)
        return 2
    if shutil.which("valgrind") is None:
        print("valgrind is not installed (apt install valgrind)", file=sys.stderr)
        return 2
    counts: dict[str, dict[str, float]] = {}
    with base_checkout(None if args.no_base else args.base) as tree:
        for workload in chosen:
            row = counts.setdefault(workload, {})
            row["main"] = per_repetition(workload, None)
            if tree is not None and workload not in MAIN_ONLY:
                row["base"] = per_repetition(workload, tree)
            print(f"{workload}: {json.dumps(row)}", file=sys.stderr, flush=True)
    unit = {"load": "per load", "lap": "per simulated second", **{w: "per stage" for g in GROUPS.values() for w in g}}
    print(f"| workload | {args.base} | this checkout | ratio |")
    print("|---|---:|---:|---:|")
    for workload, row in counts.items():
        base = row.get("base")
        ratio = f"{row['main'] / base:.2f}" if base else ""
        if workload in ("guard", "guard+set") and "plain" in counts:
            ratio = f"rate {1 - counts['plain']['main'] / row['main']:.0%} below plain"
        print(f"| {workload} ({unit.get(workload, 'per tick')}) | {f'{base:,.0f}' if base else ''} | "
              f"{row['main']:,.0f} | {ratio} |")
    if args.json:
        Path(args.json).write_text(json.dumps(counts, indent=1) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
