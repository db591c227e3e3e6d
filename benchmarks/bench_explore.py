"""Generated paths (issue 34): `fsmctl test --explore` over the eight EEROS thesis machines (each with its scenario's
plants and plugins), every 1 s one input may change, 12 s per path; target: all eight in under 60 s on one core.

Prints, per machine, the runs, the time, what was reached of its states, transitions and monitors, and what stayed
unreached (the thesis machines' 6 s and 4 s move timeouts cannot fire: the plant always reaches the switch first,
and nothing an input does slows it). Wall clock on a shared machine: noisy, the total is what the target is about.

Run: ``.venv/bin/python benchmarks/bench_explore.py`` (``--duration`` and ``--step`` change the bounds).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
THESIS = sorted((REPO / "diagrams" / "eeros").glob("case*.scenario.json"))


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--duration", type=float, default=12.0)
    ap.add_argument("--step", type=float, default=1.0)
    args = ap.parse_args(argv)
    from fsm.loading.loader import compile as compile_spec
    from fsm.loading.loader import signal_names
    from fsm.tools.scenario.explore import Explorer, Space
    from fsm.tools.scenario.model import load_scenario

    print("| thesis machine | runs | time | reached | unreached |")
    print("|---|---:|---:|---:|---|")
    t0 = time.perf_counter()
    for path in THESIS:
        loaded = load_scenario(path)
        spec = loaded.spec
        signals = sorted(set(getattr(spec, "inputs", None) or ()) | set(signal_names(spec)))
        for cls, params in loaded.plants:
            signals = [s for s in signals if s not in cls(params).signals()]
        space = Space(signals, {}, args.step, args.duration, loaded.dt)
        result = Explorer(compile_spec(spec), loaded.plants, space, []).search(max_runs=2000)
        total = len(result.targets)
        print(f"| {path.name.removesuffix('.scenario.json')} | {result.runs} | {result.seconds:.2f} s | "
              f"{total - len(result.unreached)}/{total} | {', '.join(result.unreached) or 'none'} |")
    took = time.perf_counter() - t0
    ok = took < 60
    print(f"| all eight | | {took:.1f} s | | target < 60 s {'ok' if ok else 'MISSED'} |")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
