#!/usr/bin/env python
"""Issue 31 on tools/: what splitting the complex functions cost on the one hot path they touch, counted in
instructions (valgrind's callgrind, via ``bench_instructions.callgrind``), so that a busy machine gives the same
figures as an idle one.

The hot path is the scenario checker's per-tick work: ``TemporalRun.step`` (read what the formulas use) and
``Watch.step`` (one formula's state), both split into steps in issue 31. The workload is ``fsmctl test``'s
``load_scenario`` + ``run_scenario`` on a machine that switches between two states every 0.1 s, with four
expectations over time (``always``, ``eventually``, ``after``/``always`` and an ``invariant``). It runs in a
fresh interpreter twice, for 1 s and for 101 s of simulated time: the difference over the 8,000 ticks between is
the cost of one tick of machine and checker, with start-up, imports and loading cancelled out. The earlier commit
is exported with ``git archive`` into a temporary folder (no worktree) and imported by ``PYTHONPATH``.

    python benchmarks/bench_tools.py [--base b6eb550] [--no-base]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from bench_instructions import callgrind

REPO = Path(__file__).resolve().parent.parent
SHORT, LONG = 1, 101  # simulated seconds
DT = 0.0125

MACHINE = {"initial": "a", "vars": {"n": 0},
           "states": [{"id": "a", "type": "Idle"}, {"id": "b", "type": "Idle"}],
           "transitions": [{"type": "Timeout", "from": "a", "to": "b", "seconds": 0.1},
                           {"type": "Timeout", "from": "b", "to": "a", "seconds": 0.1}]}
EXPECT = [{"always": "active(a) or active(b)"}, {"eventually": "entered(b)"},
          {"after": "entered(a)", "always": "not active(b) or n >= 0", "ticks": 20}, {"invariant": "n >= 0"}]

PROBE = r'''
import sys
import fsm
assert fsm.__file__.startswith(sys.argv[2]), f"imported {fsm.__file__}, not the tree under {sys.argv[2]}"
from fsm.tools.scenario import load_scenario, run_scenario
result = run_scenario(load_scenario(sys.argv[1]))
assert result.passed, [f.message for f in result.failures]
'''


def write_scenario(folder: Path, seconds: int) -> Path:
    (folder / "m.json").write_text(json.dumps(MACHINE), encoding="utf-8")
    path = folder / f"s{seconds}.scenario.json"
    path.write_text(json.dumps({"machine": "m.json", "duration": seconds, "dt": DT, "expect": EXPECT}),
                    encoding="utf-8")
    return path


def instructions(scenario: Path, tree: Path | None) -> int:
    """The instructions of checking ``scenario`` in a fresh interpreter, with this checkout's ``fsm`` or, with
    ``tree``, the exported one (``PYTHONPATH`` comes before the editable install's plain path entry)."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env["PYTHONHASHSEED"] = "0"
    if tree is not None:
        env["PYTHONPATH"] = str(tree)
    root = tree or REPO
    return callgrind(["-c", PROBE, str(scenario), str(root)], env, root, f"{scenario.name} on {root}")


def per_tick(folder: Path, tree: Path | None) -> float:
    ticks = round((LONG - SHORT) / DT)
    long, short = write_scenario(folder, LONG), write_scenario(folder, SHORT)
    return (instructions(long, tree) - instructions(short, tree)) / ticks


def export(commit: str, where: Path) -> Path:
    """``commit``'s fsm/ exported into ``where`` (``git archive``: nothing is added to the repository)."""
    tree = where / "base"
    tree.mkdir()
    archive = subprocess.run(["git", "-C", str(REPO), "archive", commit, "fsm", "diagrams/worlds"], check=True,
                             capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(tree)], input=archive, check=True)
    return tree


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--base", default="b6eb550", help="the commit to compare with (default b6eb550, before issue 31)")
    ap.add_argument("--no-base", action="store_true", help="count this checkout only")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        rows = [("this checkout", per_tick(folder, None))]
        if not args.no_base:
            rows.append((f"base {args.base}", per_tick(folder, export(args.base, folder))))
    print(f"| scenario check, instructions per tick ({len(EXPECT)} expectations over time) | count |")
    print("|---|---:|")
    for name, count in rows:
        print(f"| {name} | {count:,.0f} |")
    if len(rows) == 2:
        print(f"| change | {rows[0][1] / rows[1][1] - 1:+.1%} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
