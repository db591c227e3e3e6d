#!/usr/bin/env python
"""The plan cache (fsm/loading/cache.py) on the 1000-state ring: what a load costs from the cache against the
cold load, in instructions (callgrind, the machine is shared: wall clocks move by 2x) and in wall-clock medians
taken alternately in the same run.

"Load" here is the document to its checked plan (``fsm.loading.loader.compile``: read, parse, validate, check,
compile, or the cache's read and key check); building the Machine from the plan is counted apart.

Rows:

  fresh process   importing the loader, then the registry (the types' modules and plugins the key names), then
                  its first load of the ring (what ``fsmctl validate`` pays), without the cache (FSM_NO_CACHE=1)
                  and from a filled cache; in instructions the import is subtracted (the registry is not)
  same process    one more load (per repetition, 5 repetitions less 0): no cache, from the cache (what the process
                  keeps in memory, and with that cleared: the file read again); building apart
  a miss          a load whose cache file is gone: checked and compiled (the time to the result), and the file
                  written beside it in a thread (the time it goes on after the result, and instructions with it)
  validate        ``fsm.loading.loader.check`` (what ``fsmctl validate`` asks: the problems; a hit makes neither the
                  plan nor the spec's contents), fresh process and again in the same process, read from the file

A hit reads the file's first part (problems, analysis) at once and makes the plan when it is first asked for, so
"load" (``compile``, which returns the plan) pays for the plan and "validate" does not; the spec's states and
transitions are made when first read, by neither.

    python benchmarks/bench_plan_cache.py [--rounds 5] [--no-instructions]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

BENCH = Path(__file__).resolve().parent
REPO = BENCH.parent
sys.path.insert(0, str(BENCH))

from bench_baseline import compiled  # noqa: E402
from bench_instructions import callgrind  # noqa: E402

#: ``sys.argv``: what to run, the ring's path, repetitions.
PROBE = r'''
import json, os, statistics, sys, time
t0 = time.perf_counter()
from fsm.loading import loader
from fsm.loading.building import build
t1 = time.perf_counter()
what, ring, n = sys.argv[1], sys.argv[2], int(sys.argv[3])
load = loader.check if what == "check" else loader.compile
out = {"import_ms": (t1 - t0) * 1000}
if what != "import":
    from fsm.loading.registry import default_registry
    default_registry()  # the types' modules imported, plugins' entry points read (what the key names)
    t2 = time.perf_counter()
    out["registry_ms"] = (t2 - t1) * 1000
    plan = load(ring)
    out["first_ms"] = (time.perf_counter() - t2) * 1000
    from fsm.loading import cache
    cache.flush()  # a first load that missed: its file written
    out["first_write_ms"] = (time.perf_counter() - t2) * 1000 - out["first_ms"]
    times, builds, writes = [], [], []
    for _ in range(n):
        if what in ("miss", "file", "check"):
            cache._KEPT.clear()  # what the process keeps in memory: gone, so the file is read (or written)
        if what == "miss":
            os.unlink(cache.file_of(ring))
        loader._LAST.clear()  # no plan kept from the load before: the next one reads the cache (or the document)
        a = time.perf_counter()
        plan = load(ring)
        b = time.perf_counter()
        if what == "build":
            build(plan)
        times.append(b - a)
        builds.append(time.perf_counter() - b)
        c = time.perf_counter()
        cache.flush()  # a miss: the file is written beside the caller; here the caller waits for it
        writes.append(time.perf_counter() - c)
    if n:
        out["ms"] = statistics.median(times) * 1000
        out["build_ms"] = statistics.median(builds) * 1000
        out["write_ms"] = statistics.median(writes) * 1000
print(json.dumps(out))
'''

CASES = {  # name: (what, FSM_NO_CACHE)
    "import": ("import", True),
    "cold": ("load", True),
    "hit": ("load", False),
    "file": ("file", False),
    "miss": ("miss", False),
    "build": ("build", False),
    "check": ("check", False),
}


def env_for(cache: Path, no_cache: bool) -> dict[str, str]:
    env = dict(os.environ, PYTHONHASHSEED="0", FSM_CACHE_DIR=str(cache))
    env.pop("PYTHONPATH", None)
    if no_cache:
        env["FSM_NO_CACHE"] = "1"
    else:
        env.pop("FSM_NO_CACHE", None)
    return env


def wall(case: str, ring: Path, cache: Path, n: int) -> dict[str, Any]:
    what, no_cache = CASES[case]
    done = subprocess.run([sys.executable, "-c", PROBE, what, str(ring), str(n)], env=env_for(cache, no_cache),
                          capture_output=True, text=True, cwd=str(REPO), timeout=600, check=True)
    result: dict[str, Any] = json.loads(done.stdout.strip().splitlines()[-1])
    return result


def count(case: str, ring: Path, cache: Path, n: int) -> int:
    what, no_cache = CASES[case]
    return callgrind(["-c", PROBE, what, str(ring), str(n)], env_for(cache, no_cache), REPO, case)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=5, help="wall-clock rounds, the cases alternating")
    ap.add_argument("--no-instructions", action="store_true", help="wall clocks only (no valgrind)")
    args = ap.parse_args(argv)
    where = Path(tempfile.mkdtemp(prefix="tral-plan-cache-"))
    compiled(REPO)  # as installed: with PYTHONDONTWRITEBYTECODE set, each fresh process would compile its imports
    try:
        from peers.tral_fsm import ring_doc

        ring = where / "ring1000.json"
        ring.write_text(json.dumps(ring_doc(1000), indent=1))
        cache = where / "cache"
        wall("hit", ring, cache, 0)  # fills the cache
        runs: dict[str, list[dict[str, Any]]] = {}
        for _ in range(args.rounds):
            for case in ("import", "cold", "hit", "file", "miss", "build", "check"):
                runs.setdefault(case, []).append(wall(case, ring, cache, 5))
            wall("hit", ring, cache, 0)  # the miss case left a fresh file; keep it filled
        counts: dict[str, float] = {}
        if not args.no_instructions and shutil.which("valgrind"):
            wall("hit", ring, cache, 0)
            base = count("import", ring, cache, 0)
            for case in ("cold", "hit", "file", "miss", "check"):
                if case not in ("file", "miss"):
                    counts[f"first {case}"] = count(case, ring, cache, 0) - base
                wall("hit", ring, cache, 0)
                counts[f"again {case}"] = (count(case, ring, cache, 5) - count(case, ring, cache, 0)) / 5
                wall("hit", ring, cache, 0)
        report(runs, counts)
    finally:
        shutil.rmtree(where, ignore_errors=True)
    return 0


def med(runs: list[dict[str, Any]], key: str) -> float:
    return statistics.median(r[key] for r in runs if key in r)


def report(runs: dict[str, list[dict[str, Any]]], counts: dict[str, float]) -> None:
    load = os.getloadavg()[0]
    print(f"load average {load:.1f} (wall clocks on a shared machine: read the ratios and the instructions)\n")
    print("| the 1000-state ring: document -> checked plan | no cache | from the cache | ratio |")
    print("|---|---:|---:|---:|")
    imp = med(runs["import"], "import_ms")
    print(f"| importing the loader, fresh process (ms, median) | {imp:.1f} | | |")
    c, h = med(runs["cold"], "registry_ms"), med(runs["hit"], "registry_ms")
    print(f"| then the registry: the types' modules, plugins (ms, median) | {c:.1f} | {h:.1f} | |")
    c, h = med(runs["cold"], "first_ms"), med(runs["hit"], "first_ms")
    print(f"| then the first load in a fresh process (ms, median) | {c:.1f} | {h:.2f} | {c / h:.1f}x |")
    c, h, f = med(runs["cold"], "ms"), med(runs["hit"], "ms"), med(runs["file"], "ms")
    print(f"| one more load in the same process, kept in memory (ms, median) | {c:.2f} | {h:.2f} | {c / h:.1f}x |")
    print(f"| one more load in the same process, read from the file (ms, median) | {c:.2f} | {f:.2f} | {c / f:.1f}x |")
    v, w = med(runs["check"], "first_ms"), med(runs["check"], "ms")
    print(f"| validate (the problems only), first in a fresh process (ms, median) | | {v:.2f} | |")
    print(f"| validate (the problems only), again in the same process, from the file (ms, median) | | {w:.2f} | |")
    m, w = med(runs["miss"], "ms"), med(runs["miss"], "write_ms")
    print(f"| a miss: checked and compiled, the file written beside it (ms, median) | {c:.2f} | {m:.2f} | "
          f"{m / c:.2f}x |")
    print(f"| a miss: the write, finished after the result (ms, median) | | {w:.2f} | |")
    print(f"| building the Machine from the plan, apart (ms, median) | | {med(runs['build'], 'build_ms'):.2f} | |")
    if counts:
        c, h = counts["first cold"], counts["first hit"]
        print(f"| the registry and the first load, fresh process (instructions, the import subtracted) | "
              f"{c / 1e6:.1f}M | {h / 1e6:.1f}M | {c / h:.1f}x |")
        c = counts["again cold"]
        for case, what in (("hit", "kept in memory"), ("file", "read from the file")):
            h = counts[f"again {case}"]
            print(f"| one more load in the same process, {what} (instructions) | {c / 1e6:.1f}M | {h / 1e6:.2f}M | "
                  f"{c / h:.0f}x |")
        print(f"| validate (the problems only), fresh process (instructions, the import subtracted) | | "
              f"{counts['first check'] / 1e6:.2f}M | |")
        print(f"| validate (the problems only), again in the same process, from the file (instructions) | | "
              f"{counts['again check'] / 1e6:.2f}M | |")
        m = counts["again miss"]
        print(f"| a miss, the write included (instructions, every thread) | {c / 1e6:.1f}M | {m / 1e6:.1f}M | "
              f"{m / c:.2f}x |")


if __name__ == "__main__":
    sys.exit(main())
