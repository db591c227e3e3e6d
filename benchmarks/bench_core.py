#!/usr/bin/env python
"""Core benchmark of tral-fsm against its peers (issue 2, "Performance").

Workloads, all measured in one run on the same machine:

  flat    (a) a ring of 100 states, each leaving by ``Always`` to the next: transitions per second.
  nested  (b) three levels of nesting, 10 x 10 x 10: a root ring of 10 composites, each a chain of 10
              composites, each a chain of 10 leaves (``Always``) ending in a ``Final``; composites
              leave by ``Finished``. Transitions per second, every fired transition at any level
              counted (1,110 transitions per 1,000 ticks).
  load    (c) load + validate + build of a 1000-state ring from a file on disk: median wall time (ms).

Peers run equivalent workloads (see benchmarks/README.md): transitions (Machine, HierarchicalMachine),
python-statemachine, sismic and py_trees, one module each in ``peers/``, behind one interface
(``peers/adapter.py``); timing is in ``measure.py``, the tables in ``report.py``. A peer that is not
installed is reported, not fatal.
Every workload is checked before and after timing (the active state after a known number of steps
must be the expected one), so a broken equivalent cannot produce a number.

    python benchmarks/bench_core.py             # full run (about 1-2 minutes)
    python benchmarks/bench_core.py --quick     # smoke test (< 30 s)
    python benchmarks/bench_core.py --only flat --only sismic --json out.json
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path
from typing import Any

# The repository has top-level folders named ``transitions/`` and ``states/`` (installed as
# ``fsm.transitions`` / ``fsm.states``). When the repository root is on sys.path (``python -m ...`` or
# ``python -c`` from the root) ``import transitions`` would find that folder instead of the PyPI
# package. Drop the root from sys.path: ``fsm`` itself is found through the installed package.
REPO = Path(__file__).resolve().parents[1]
sys.path[:] = [p for p in sys.path if Path(p or os.getcwd()).resolve() != REPO]

from measure import measure_loads, measure_rates  # noqa: E402
from peers import LIBRARIES, LOADERS  # noqa: E402
from report import add_ratios, print_table, targets  # noqa: E402


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--quick", action="store_true", help="short smoke run (a few seconds)")
    p.add_argument("--json", metavar="FILE", help="write the results as JSON")
    p.add_argument("--only", action="append", default=[], metavar="NAME",
                   help="run only these workloads (flat, nested, load) and/or libraries (tral-fsm, transitions, "
                        "transitions-hsm, python-statemachine, sismic, py_trees); repeatable or comma-separated. "
                        "tral-fsm always runs, for the ratios.")
    p.add_argument("--repeat", type=int, help="timed repeats per rate workload (default 5, quick 2)")
    p.add_argument("--seconds", type=float, help="target seconds per repeat (default 1.0, quick 0.05)")
    p.add_argument("--n", type=int, help="fixed steps per repeat instead of calibrating")
    p.add_argument("--load-repeat", type=int, help="timed loads for (c) (default 7, quick 3)")
    p.add_argument("--no-gc", action="store_true", help="disable the garbage collector while timing")
    args = p.parse_args(argv)
    args.repeat = args.repeat or (2 if args.quick else 5)
    args.seconds = args.seconds or (0.05 if args.quick else 1.0)
    args.load_repeat = args.load_repeat or (3 if args.quick else 7)
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    workloads = {"flat", "nested", "load"}
    libraries = set(LIBRARIES)
    names = [n.strip() for item in args.only for n in item.split(",") if n.strip()]
    want_w = {n for n in names if n in workloads}
    want_l = {n for n in names if n in libraries}
    unknown = [n for n in names if n not in workloads and n not in libraries]
    if unknown:
        print(f"unknown --only name(s): {', '.join(unknown)}; choose from "
              f"{', '.join(sorted(workloads))}, {', '.join(sorted(libraries))}", file=sys.stderr)
        return 2

    def chosen(workload: str, key: str) -> bool:
        return (not want_w or workload in want_w) and (not want_l or key in want_l or key == "tral-fsm")

    env = {"python": platform.python_version(), "implementation": platform.python_implementation(),
           "machine": platform.machine(), "platform": platform.platform(), "cpus": os.cpu_count(),
           "loadavg_start": " ".join(f"{x:.2f}" for x in os.getloadavg()),
           "quick": args.quick, "repeat": args.repeat, "seconds_per_repeat": args.seconds,
           "load_repeat": args.load_repeat,
           "gc": "off while timing" if args.no_gc else "on, collected before each repeat"}
    results: list[dict[str, Any]] = []
    t0 = time.perf_counter()
    measure_rates(args, chosen, results)
    if chosen("load", "tral-fsm"):
        measure_loads(args, [c for c in LOADERS if chosen("load", c.key)], results)
    env["loadavg_end"] = " ".join(f"{x:.2f}" for x in os.getloadavg())
    env["wall_s"] = round(time.perf_counter() - t0, 1)
    add_ratios(results)
    goals = targets(results)
    print_table(results, goals, env)
    print(f"\n({env['wall_s']} s wall)")
    if args.json:
        Path(args.json).write_text(json.dumps({"environment": env, "results": results, "targets": goals},
                                              indent=2) + "\n")
    broken = [r for r in results if str(r.get("status", "")).startswith(("BROKEN", "ERROR"))]
    return 1 if broken else 0


if __name__ == "__main__":
    sys.exit(main())
