#!/usr/bin/env python
"""Instructions per checked tick of the scenario runner's temporal language (``always``, ``never``, ``eventually``,
``after`` ... ``ticks``, ``prev``, ``rose``, ``changed``, ``start``, ``entered``, ``active``, an invariant), counted
with callgrind as in ``bench_instructions.py``, on this checkout and on an earlier commit.

A machine repeats a four-step sequence (two counters change every 0.2 s, a signal toggles every second) under ten
temporal expectations ("checked"), and again under one plain ``at`` expectation ("bare": the run and its
recording alone). Each is run for 2 and for 42 simulated seconds in a fresh interpreter; the difference divided
by the 3,200 ticks between them is the cost of one tick, start-up and loading cancelled out. "checked - bare" is
what the temporal expectations cost per tick.

    python benchmarks/bench_temporal.py [--base 78f6f91] [--no-base]
"""

from __future__ import annotations

import argparse
import shutil
import sys
from pathlib import Path

from bench_baseline import REPO
from bench_instructions import base_checkout, callgrind, on_tree

#: the two runs' simulated seconds, and the tick period
SHORT, LONG, DT = 2, 42, 0.0125

PROBE = r'''
import json, sys, tempfile
from pathlib import Path
from fsm.tools.scenario import load_scenario, run_scenario

MACHINE = {
    "initial": "main", "vars": {"n": 0, "level": 0.0}, "inputs": ["jam"],
    "states": [{"id": "main", "type": "Sequence", "repeat": 100000, "steps": [
        {"id": "a", "type": "Wait", "seconds": 0.05},
        {"id": "b", "type": "Wait", "seconds": 0.05, "precondition": "n < 0"},
        {"id": "c", "type": "SetVar", "assign": {"n": "n + 1", "level": "level + 0.1"}},
        {"id": "d", "type": "Wait", "seconds": 0.1}]}],
}
EXPECT = [
    {"always": "n - prev(n) <= 1"}, {"never": "level < 0"}, {"eventually": "rose(n > 0)", "min": 1},
    {"eventually": "entered('main/*')", "min": 1}, {"always": "active(main) or n < 0"},
    {"eventually": "changed(level)", "min": 1}, {"never": "signal_jam and n > 100000000"},
    {"eventually": "n >= 1", "after": "entered(main/a)", "ticks": 40},
    {"always": "level - start(level) >= 0", "within": [0.5, 1e6]}, {"invariant": "n >= 0"},
]
duration, bare = float(sys.argv[1]), sys.argv[2] == "bare"
inputs = [{"at": 0.3 + k, "signal": "jam", "value": k % 2 == 0} for k in range(int(duration))]
folder = Path(tempfile.mkdtemp())
(folder / "m.json").write_text(json.dumps(MACHINE))
(folder / "t.scenario.json").write_text(json.dumps({
    "machine": "m.json", "duration": duration, "inputs": inputs,
    "expect": [{"at": 0.01, "active": "main/a"}] if bare else EXPECT}))
failures = run_scenario(load_scenario(folder / "t.scenario.json")).failures
assert not failures, [f.message for f in failures]
'''


def count(seconds: int, variant: str, tree: Path | None) -> int:
    """The instructions of one probe run (on ``tree``, or on this checkout)."""
    env, code = on_tree(PROBE, tree)
    return callgrind(["-c", code, str(seconds), variant], env, tree or REPO,
                     f"{variant} on {'base' if tree else 'this checkout'}")


def per_tick(variant: str, tree: Path | None) -> float:
    return (count(LONG, variant, tree) - count(SHORT, variant, tree)) / round((LONG - SHORT) / DT)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--base", default="78f6f91", help="the commit to compare with (default 78f6f91)")
    ap.add_argument("--no-base", action="store_true", help="count this checkout only")
    args = ap.parse_args(argv)
    if shutil.which("valgrind") is None:
        print("valgrind is not installed (apt install valgrind)", file=sys.stderr)
        return 2
    rows: dict[str, dict[str, float]] = {}
    with base_checkout(None if args.no_base else args.base) as tree:
        for variant in ("checked", "bare"):
            rows[variant] = {"main": per_tick(variant, None)}
            if tree is not None:
                rows[variant]["base"] = per_tick(variant, tree)
    rows["checked - bare"] = {k: rows["checked"][k] - rows["bare"][k] for k in rows["checked"]}
    print(f"| instructions per tick | {args.base} | this checkout | ratio |")
    print("|---|---:|---:|---:|")
    for name, row in rows.items():
        base = row.get("base")
        ratio = f"{row['main'] / base:.3f}" if base else ""
        print(f"| {name} | {f'{base:,.0f}' if base else ''} | {row['main']:,.0f} | {ratio} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
