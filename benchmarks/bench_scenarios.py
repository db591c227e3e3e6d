"""Scenario testing speed (issue 23): the eight EEROS thesis scenarios plus the sorter in one process (target
< 1 s), what an invariant checked at every tick costs on a 1,000-step sequence (target <= 20 % of its tick rate)
and what coverage adds (target <= 10 %); what the temporal expectations of the eight thesis scenarios cost against
the same runs without them (issue 34, target <= 10 %).

Everything runs in this process through the scenario runner (``load_scenario`` + ``run_scenario``), as
``fsmctl test`` and the pytest plugin do. The sequence is the one of ``bench_sequencer.py``: 1,000 ``Step``\\ s
that each finish at their first tick, repeated, under three sequences whose monitors stay false, so every tick
checks three monitors, ticks one step and fires one link; its scenario runs 40,000 ticks. Rates are the best of
``--repeat`` runs in processor time (``time.process_time``: a shared machine's load moves it less than the wall
clock), the variants round-robin so outside load spreads over all of them.

Coverage adds its work after the run (``Coverage.add``: every state, transition and monitor of the machine looked up
once); what it needs during the run (the transitions fired, the states entered) the scenario runner records for its
expectations anyway. So the "coverage" row differs from "none" by that work plus noise, and the row "coverage's own
work" gives it alone: the plain run's time plus ``Coverage.add``'s, timed on its own.

Run: ``.venv/bin/python benchmarks/bench_scenarios.py`` (``--quick`` for fewer repeats).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
THESIS = sorted((REPO / "diagrams" / "eeros").glob("case*.scenario.json"))
SORTER = REPO / "diagrams" / "examples" / "sorter.scenario.json"
TICKS = 40_000
DT = 0.0125


def sequence_doc(steps: int) -> dict[str, Any]:
    chain = [{"id": f"s{i}", "type": "Step"} for i in range(steps)]
    inner = {"id": "c", "type": "Sequence", "steps": chain,
             "monitors": [{"condition": "stop > 2", "behavior": "abortOwner"}]}
    middle = {"id": "b", "type": "Sequence", "steps": [inner],
              "monitors": [{"condition": "stop > 1", "behavior": "abortOwner"}]}
    outer = {"id": "a", "type": "Sequence", "steps": [middle], "repeat": 0,
             "monitors": [{"condition": "stop > 0", "behavior": "abortOwner"}]}
    return {"name": "bench", "initial": "a", "vars": {"stop": 0, "n": 0}, "inputs": ["halt"], "states": [outer]}


def suite_time(repeat: int) -> tuple[float, int]:
    """Seconds to load and run the nine scenarios in this process (best of ``repeat``), and their ticks."""
    from fsm.tools.scenario import load_scenario, run_scenario

    best, ticks = float("inf"), 0
    for _ in range(repeat):
        t0 = time.perf_counter()
        results = [run_scenario(load_scenario(p)) for p in [*THESIS, SORTER]]
        best = min(best, time.perf_counter() - t0)
        assert all(r.passed for r in results), [r.summary_line() for r in results if not r.passed]
        ticks = sum(r.ticks for r in results)
    return best, ticks


def is_temporal(exp: Any) -> bool:
    """An expectation of the temporal language (issue 34): always, eventually, never with a formula, at ... holds."""
    return exp.__class__.__name__ == "TemporalExpect" or getattr(exp, "holds", None) is not None


def temporal_cost(repeat: int) -> list[tuple[str, int, int, float, float]]:
    """Per thesis case: (name, temporal expectations, ticks, seconds without them, seconds with them), each the best
    of ``repeat`` in processor time, the two variants round-robin."""
    import dataclasses

    from fsm.tools.scenario import load_scenario, run_scenario

    rows = []
    for path in THESIS:
        full = load_scenario(path)
        kept = [e for e in full.scenario.expect if not is_temporal(e)]
        bare = dataclasses.replace(full, scenario=full.scenario.model_copy(update={"expect": kept}))
        best = {"bare": float("inf"), "full": float("inf")}
        ticks = 0
        for _ in range(repeat):
            for name, ld in (("bare", bare), ("full", full)):
                t0 = time.process_time()
                result = run_scenario(ld)
                best[name] = min(best[name], time.process_time() - t0)
                assert result.passed, result.summary_line()
                ticks = result.ticks
        rows.append((path.name.removesuffix(".scenario.json"), len(full.scenario.expect) - len(kept), ticks,
                     best["bare"], best["full"]))
    return rows


def sequence_rates(folder: Path, repeat: int) -> dict[str, float]:
    """Ticks per second of the 1,000-step sequence's scenario: plain, with an invariant over a variable, with one
    over a variable and a signal, with coverage."""
    from fsm.tools.scenario import load_scenario, run_scenario
    from fsm.tools.scenario.coverage import Coverage

    (folder / "seq.json").write_text(json.dumps(sequence_doc(1000)), encoding="utf-8")
    base = {"machine": "seq.json", "dt": DT, "max_ticks": TICKS, "expect": [{"finished": False}]}
    variants = {
        "none": base,
        "invariant (variable)": {**base, "expect": [{"finished": False}, {"invariant": "stop == 0"}]},
        "invariant (variable, signal)": {**base, "expect": [{"finished": False},
                                                             {"invariant": "stop == 0 and not signal_halt"}]},
        "coverage": base,
    }
    loaded = {}
    for name, doc in variants.items():
        path = folder / f"{name.split()[0]}{len(loaded)}.scenario.json"
        path.write_text(json.dumps(doc), encoding="utf-8")
        loaded[name] = load_scenario(path)
    best = dict.fromkeys(variants, float("inf"))
    adding = float("inf")

    class Timed(Coverage):  # the coverage's own work: what it adds after the run (its entries are always recorded)
        def add(self, *args: Any, **kwargs: Any) -> None:
            nonlocal adding
            t0 = time.process_time()
            super().add(*args, **kwargs)
            adding = min(adding, time.process_time() - t0)

    for _ in range(repeat):
        for name, ld in loaded.items():
            cov = Timed() if name == "coverage" else None
            t0 = time.process_time()
            result = run_scenario(ld, cov)
            best[name] = min(best[name], time.process_time() - t0)
            assert result.passed and result.ticks == TICKS, result.summary_line()
    rates = {name: TICKS / t for name, t in best.items()}
    rates["coverage's own work"] = TICKS / (best["none"] + adding)
    return rates


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="fewer repeats")
    ap.add_argument("--repeat", type=int, default=None, help="timed repeats (default 5, 2 with --quick)")
    args = ap.parse_args(argv)
    repeat = args.repeat or (2 if args.quick else 5)
    seconds, ticks = suite_time(repeat)
    with tempfile.TemporaryDirectory() as tmp:
        rates = sequence_rates(Path(tmp), repeat)
    temporal = temporal_cost(repeat)
    ok = True
    print("| workload | result | target |")
    print("|---|---|---|")
    verdict = seconds < 1.0
    ok &= verdict
    print(f"| 8 thesis scenarios + sorter, load and run ({ticks:,} ticks) | {seconds:.3f} s | < 1 s "
          f"{'ok' if verdict else 'MISSED'} |")
    plain = rates["none"]
    print(f"| 1,000-step sequence, no invariant | {plain:,.0f} ticks/s | |")
    for name in ("invariant (variable)", "invariant (variable, signal)", "coverage", "coverage's own work"):
        loss = 1 - rates[name] / plain
        limit = 0.10 if name.startswith("coverage") else 0.20
        verdict = loss <= limit
        ok &= verdict if name != "invariant (variable, signal)" else True
        target = f"<= {limit:.0%} loss {'ok' if verdict else 'MISSED'}" if name != "invariant (variable, signal)" \
            else "(reported)"
        print(f"| 1,000-step sequence, {name} | {rates[name]:,.0f} ticks/s ({loss:+.1%} loss) | {target} |")
    print()
    print("| thesis case | temporal expectations | ticks | run without them | with them | cost |")
    print("|---|---:|---:|---:|---:|---:|")
    for name, n, ticks, bare, full in temporal:
        print(f"| {name} | {n} | {ticks:,} | {bare * 1e3:.1f} ms | {full * 1e3:.1f} ms | {full / bare - 1:+.1%} |")
    bare_all = sum(r[3] for r in temporal)
    full_all = sum(r[4] for r in temporal)
    verdict = full_all / bare_all - 1 <= 0.10
    ok &= verdict
    print(f"| all eight | {sum(r[1] for r in temporal)} | {sum(r[2] for r in temporal):,} | {bare_all * 1e3:.1f} ms "
          f"| {full_all * 1e3:.1f} ms | {full_all / bare_all - 1:+.1%} (target <= 10 % "
          f"{'ok' if verdict else 'MISSED'}) |")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
