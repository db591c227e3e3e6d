"""``fsmctl test``: run scenario files (``*.scenario.json``) and report like a test runner.

One line per scenario (``PASS name (ticks, time)`` or ``FAIL name: ...`` followed by the failing expectations
with the trace around their first diverging tick), then ``N passed, M failed``. Exit 0 when every scenario
passed, 1 when any failed or is invalid (its problems printed as located error lines), 2 for usage errors.
``--junit OUT.xml`` is written through :mod:`fsm.tools.files`, checked before anything runs.
"""

from __future__ import annotations

import argparse
import sys

from .common import EXIT_FAIL, EXIT_OK


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("test", help="run scenario tests (*.scenario.json) and report like a test runner",
                       description="Run each scenario: its machine on a timeline of inputs (signal pulses, button "
                                   "presses with bounce, variable changes), then check its expectations (states "
                                   "visited in order, never visited, active states and variables at given times, "
                                   "the outcome). Exit 1 if any scenario failed or is invalid.")
    p.add_argument("scenarios", nargs="+", metavar="SCENARIO", help="scenario files (*.scenario.json)")
    p.add_argument("-q", "--quiet", action="store_true",
                   help="print only failures (with their trace) and the summary line")
    p.add_argument("--junit", metavar="OUT.xml", help="write a JUnit XML report ('-' for standard output)")
    p.set_defaults(func=cmd_test)


def cmd_test(args: argparse.Namespace) -> int:
    from fsm.errors import DiagramError

    from ..files import Outputs
    from ..scenario.junit import Invalid, junit_xml
    from ..scenario.model import load_scenario
    from ..scenario.runner import ScenarioResult, run_scenario

    outputs = Outputs()
    junit = outputs.add(args.junit, "--junit")
    outputs.open(args.scenarios)  # a bad --junit path, or one naming a scenario, is refused before any run
    report = sys.stderr if outputs.to_stdout else sys.stdout
    results: list[ScenarioResult | Invalid] = []
    try:
        for file in args.scenarios:
            try:
                loaded = load_scenario(file, tuple(args.plugin))
            except DiagramError as exc:
                for problem in exc.problems:
                    print(problem, file=sys.stderr)
                name = _name(file)
                results.append(Invalid(name, file, exc.problems))
                print(f"ERROR {name}: invalid scenario ({len(exc.errors) or len(exc.problems)} problem(s) above)",
                      file=report)
                continue
            for warning in loaded.warnings:
                print(warning, file=sys.stderr)
            result = run_scenario(loaded)
            results.append(result)
            if result.passed:
                if not args.quiet:
                    print(result.summary_line(), file=report)
            else:
                print(result.summary_line(), file=report)
                for failure in result.failures:
                    for line in failure.lines():
                        print(f"    {line}", file=report)
        passed = sum(1 for r in results if isinstance(r, ScenarioResult) and r.passed)
        failed = sum(1 for r in results if isinstance(r, ScenarioResult) and not r.passed)
        invalid = sum(1 for r in results if isinstance(r, Invalid))
        print(f"{passed} passed, {failed} failed" + (f", {invalid} invalid" if invalid else ""), file=report)
        if junit is not None:
            junit.write(junit_xml(results))
            outputs.commit()
    finally:
        outputs.discard()
    return EXIT_OK if passed == len(results) else EXIT_FAIL


def _name(file: str) -> str:
    from pathlib import Path

    base = Path(file).name
    for suffix in (".scenario.json", ".json"):
        if base.endswith(suffix) and len(base) > len(suffix):
            return base[: -len(suffix)]
    return base or file
