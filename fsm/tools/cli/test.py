"""``fsmctl test``: run scenario files (``*.scenario.json``) and report like a test runner.

One line per scenario (``PASS name (ticks, time)`` or ``FAIL name: ...`` followed by the failing expectations
with the trace around their first diverging tick), then ``N passed, M failed``. Exit 0 when every scenario
passed, 1 when any failed or is invalid (its problems printed as located error lines), 2 for usage errors.
``--junit OUT.xml`` is written through :mod:`fsm.tools.files`, checked before any scenario runs against every
file the scenarios name (their machines and includes, worlds, plugin files). Printed lines go through
:func:`fsm.model.errors.printable`: ids from a file cannot drive the terminal.
"""

from __future__ import annotations

import argparse
import os
import sys
from typing import TYPE_CHECKING, Any, NamedTuple, TextIO

from fsm.model.errors import Problem, UsageError, printable

from .. import did_you_mean
from ..runs.args import checked
from .common import EXIT_FAIL, EXIT_OK, Subcommands, registry_from

if TYPE_CHECKING:
    from ..files import Output, Outputs
    from ..scenario.coverage import Coverage
    from ..scenario.junit import Invalid
    from ..scenario.model import LoadedScenario
    from ..scenario.runner import ScenarioResult


def register(sub: Subcommands) -> None:
    p = sub.add_parser("test", help="run scenario tests (*.scenario.json) and report like a test runner",
                       description="Run each scenario: its machine on a timeline of inputs (signal pulses, button "
                                   "presses with bounce, variable changes, pausing and resuming a subtree), then "
                                   "check its expectations (states visited in order or never, entered, skipped "
                                   "and left how often and in which time windows, active, paused and suspended "
                                   "states and variables (with tolerances) at given times, monitor firings, "
                                   "invariants at every tick, the outcome of the machine or an inner state). "
                                   "Exit 1 if any scenario failed or is invalid.")
    p.add_argument("scenarios", nargs="*", metavar="SCENARIO", help="scenario files (*.scenario.json)")
    p.add_argument("-q", "--quiet", action="store_true",
                   help="print only failures (with their trace) and the summary line")
    p.add_argument("--junit", metavar="OUT.xml", help="write a JUnit XML report ('-' for standard output)")
    p.add_argument("--coverage", action="store_true",
                   help="report state, transition and monitor coverage over all scenarios run")
    p.add_argument("--coverage-json", metavar="OUT.json",
                   help="write the coverage as JSON ('-' for standard output); implies --coverage")
    p.add_argument("--fail-under", metavar="PERCENT", type=_percent,
                   help="exit 1 when the coverage is under PERCENT (0-100); implies --coverage")
    p.add_argument("--max-runs", metavar="N", type=_positive,
                   help="allow a scenario's matrix to expand to up to N cases (default: at most 10,000)")
    g = p.add_argument_group("generated paths (--explore)")
    g.add_argument("--explore", metavar="MACHINE",
                   help="search the machine's inputs for paths that reach every state, transition and monitor (a "
                        "machine file, or a scenario file for its machine, plants and plugins); needs --duration "
                        "and --step")
    g.add_argument("--duration", metavar="S", type=float, help="--explore: simulated seconds each path runs")
    g.add_argument("--step", metavar="S", type=float, help="--explore: every S seconds one input may change")
    g.add_argument("--var", metavar="NAME=V1,V2", action="append", default=[],
                   help="--explore: a variable and the values to try (JSON values: 1,2 or true,false)")
    g.add_argument("--invariant", metavar="EXPR", action="append", default=[],
                   help="--explore: an expression that must hold on every path; a violation is written as a "
                        "minimal scenario")
    g.add_argument("-o", "--out", metavar="DIR", help="--explore: a new folder for the generated scenario files")
    p.set_defaults(func=cmd_test)


class _Load(NamedTuple):
    """One scenario file after loading: ready to run (``loaded``) or its ``problems``; the files it names."""

    file: str
    loaded: LoadedScenario | None
    problems: list[Problem]
    files: list[str]


def cmd_test(args: argparse.Namespace) -> int:
    if args.explore is not None:
        return cmd_explore(args)
    if not args.scenarios:
        raise UsageError("give scenario files (*.scenario.json), or --explore MACHINE")
    from ..files import Outputs

    outputs = Outputs()
    junit = outputs.add(args.junit, "--junit")
    cov_out = outputs.add(args.coverage_json, "--coverage-json")
    if args.junit == "-" and args.coverage_json == "-":
        raise UsageError("--junit and --coverage-json cannot both write to standard output")
    coverage = _coverage(args)
    outputs.check(args.scenarios)  # a directory, a missing folder, a scenario: said before any plugin is imported
    registry_from(args)  # a --plugin that fails is a usage error, said once and not of a scenario
    loads = [_load(file, tuple(args.plugin), args.max_runs) for file in args.scenarios]
    # every file the inputs name (machines, includes, worlds, plugins): refused as --junit before any run
    outputs.open([*args.scenarios, *args.plugin, *(f for ld in loads for f in ld.files)])
    report = sys.stderr if outputs.to_stdout else sys.stdout
    try:
        results = [result for ld in loads for result in _run_load(ld, coverage, args.quiet, report)]
        ok = _tell_results(results, report)
        ok = _tell_coverage(coverage, args.fail_under, report) and ok
        _write_test_outputs(results, coverage, junit, cov_out, outputs)
    finally:
        outputs.discard()
    return EXIT_OK if ok else EXIT_FAIL


def _coverage(args: argparse.Namespace) -> Coverage | None:
    """The coverage to gather, when --coverage, --coverage-json or --fail-under asks for it."""
    if not (args.coverage or args.coverage_json is not None or args.fail_under is not None):
        return None
    from ..scenario.coverage import Coverage

    return Coverage()


def _run_load(ld: _Load, coverage: Any, quiet: bool, report: TextIO) -> list[ScenarioResult | Invalid]:
    """Run the cases of one scenario file, saying how each went (an invalid file: its problems)."""
    from ..scenario.junit import Invalid
    from ..scenario.model import cases

    if ld.loaded is None:
        for problem in ld.problems:
            print(problem, file=sys.stderr)
        name = _name(ld.file)
        errors = sum(1 for p in ld.problems if p.severity == "error")
        _say(f"ERROR {name}: invalid scenario ({errors or len(ld.problems)} problem(s) above)", report)
        return [Invalid(name, ld.file, ld.problems)]
    for warning in ld.loaded.warnings:
        print(warning, file=sys.stderr)
    results: list[ScenarioResult | Invalid] = []
    for case in cases(ld.loaded):
        result = _run(case, coverage)
        results.append(result)
        if not result.passed or not quiet:
            _say(result.summary_line(), report)
        if result.status == "failed":
            for failure in result.failures:
                for line in failure.lines():
                    _say(f"    {line}", report)
    return results


def _tell_results(results: list[ScenarioResult | Invalid], report: TextIO) -> bool:
    """The counts line (passed, failed, ...); whether none failed and none was invalid."""
    from ..scenario.junit import Invalid
    from ..scenario.runner import ScenarioResult

    statuses = [r.status for r in results if isinstance(r, ScenarioResult)]
    passed = statuses.count("passed")
    failed = statuses.count("failed")
    invalid = sum(1 for r in results if isinstance(r, Invalid))
    more = "".join(f", {statuses.count(k)} {k}" for k in ("skipped", "xfailed", "xpassed") if k in statuses)
    print(f"{passed} passed, {failed} failed{more}" + (f", {invalid} invalid" if invalid else ""), file=report)
    return not failed and not invalid


def _tell_coverage(coverage: Any, fail_under: float | None, report: TextIO) -> bool:
    """The coverage lines (with --coverage); whether coverage is at least ``--fail-under``."""
    if coverage is None:
        return True
    for line in coverage.text():
        _say(line, report)
    if fail_under is not None and coverage.percent() < fail_under:
        _say(f"FAIL coverage {coverage.percent():.1f}% is under --fail-under {fail_under:g}%", report)
        return False
    return True


def _write_test_outputs(results: list[ScenarioResult | Invalid], coverage: Any, junit: Output | None,
                        cov_out: Output | None, outputs: Outputs) -> None:
    """``--junit`` and ``--coverage-json``, written together."""
    from ..scenario.junit import junit_xml

    if junit is not None:
        junit.write(junit_xml(results))
    if cov_out is not None and coverage is not None:
        import json

        cov_out.write(json.dumps(coverage.to_json(), indent=2) + "\n")
    if junit is not None or cov_out is not None:
        outputs.commit()


def _positive(text: str) -> int:
    """``--max-runs``: a whole number >= 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 1, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 1, got {text!r}")
    return value


def _percent(text: str) -> float:
    """``--fail-under``: a number from 0 to 100."""
    import math

    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a percentage from 0 to 100, got {text!r}") from None
    if not math.isfinite(value) or not 0 <= value <= 100:
        raise argparse.ArgumentTypeError(f"expected a percentage from 0 to 100, got {text!r}")
    return value


def _load(file: str, plugins: tuple[str, ...], max_runs: int | None = None) -> _Load:
    """Read and check one scenario (and its machine); an invalid one keeps its problems, not a run."""
    from fsm.model.errors import DiagramError

    from ..scenario.model import load_scenario, named_files

    try:
        loaded = load_scenario(file, plugins, max_runs)
    except DiagramError as exc:
        return _Load(file, None, exc.problems, named_files(file))
    return _Load(file, loaded, [], loaded.inputs_files)


def _run(loaded: LoadedScenario, coverage: Any = None) -> ScenarioResult:
    """Run one scenario; a plugin that calls ``sys.exit`` during the run fails that scenario instead of ending
    ``fsmctl test`` with its status as if every scenario had passed."""
    from ..scenario.runner import Failure, ScenarioResult, run_scenario

    try:
        return run_scenario(loaded, coverage)
    except SystemExit as exc:
        return ScenarioResult(loaded.name, loaded.file, failures=[Failure(
            -1, loaded.file, "error", f"a plugin ended the process during the run (SystemExit: {exc.code!r}); "
                                      "the scenario did not finish")])


def _say(line: str, stream: TextIO) -> None:
    """Print one report line; ids and messages from files cannot drive the terminal (see ``printable``)."""
    print(printable(line), file=stream)


def _name(file: str) -> str:
    from pathlib import Path

    base = Path(file).name
    for suffix in (".scenario.json", ".json"):
        if base.endswith(suffix) and len(base) > len(suffix):
            return base[: -len(suffix)]
    return base or file


def cmd_explore(args: argparse.Namespace) -> int:
    """``fsmctl test --explore MACHINE``: see :mod:`fsm.tools.scenario.explore`."""
    from fsm.loading.loader import compile as compile_spec
    from fsm.model.errors import DiagramError

    from ..files import NewFolder
    from ..scenario.explore import Explorer, Space

    _check_explore_usage(args)
    values = _explore_values(args.var)
    try:
        target = _explore_target(args)
    except DiagramError as exc:
        for problem in exc.problems:
            print(problem, file=sys.stderr)
        return EXIT_FAIL
    signals, invariants = _explore_inputs(args, target, values)
    space = Space(signals, values, args.step, args.duration, target.dt)
    folder = None
    if args.out is not None:
        folder = NewFolder(args.out, "-o")
        folder.check()
    explorer = Explorer(compile_spec(target.spec), target.plants, space, invariants)
    result = explorer.search(args.max_runs or 2000)
    _tell_exploration(args, result, space, signals + list(values), target.dt)
    if folder is not None:
        from ..scenario.explore import write_scenarios

        folder.open()
        try:
            names = write_scenarios(explorer, result, folder, target.machine_file, target.base, args.out)
            folder.commit()
        finally:
            folder.discard()
        print(f"wrote {len(names)} scenario file(s) to {args.out}")
    return EXIT_FAIL if result.violation is not None else EXIT_OK


def _check_explore_usage(args: argparse.Namespace) -> None:
    """``--explore`` needs positive bounds, a step within the duration, and no scenario files."""
    import math

    missing = [(opt, why) for opt, value, why in (
        ("--duration", args.duration, "how long each explored path runs, in simulated seconds"),
        ("--step", args.step, "how often an input may change, in seconds")) if value is None]
    if missing:
        raise UsageError("--explore needs bounds: " + "; ".join(f"{o} ({w})" for o, w in missing)
                         + ", e.g. --duration 10 --step 0.5")
    for opt, value in (("--duration", args.duration), ("--step", args.step)):
        if not math.isfinite(value) or value <= 0:
            raise UsageError(f"{opt}: expected a number of seconds > 0, got {value:g}")
    if args.step > args.duration:
        raise UsageError(f"--step {args.step:g} is longer than --duration {args.duration:g}: no input could change")
    if args.scenarios:
        raise UsageError("--explore takes one machine; run the scenario files in another command")


def _explore_values(items: list[str]) -> dict[str, list[object]]:
    """``--var NAME=V1,V2``: the values to try for each variable (JSON)."""
    import json

    values: dict[str, list[object]] = {}
    for item in items:
        name, sep, text = item.partition("=")
        if not sep or not name or not text:
            raise UsageError(f"--var {item}: give the variable and the values to try, NAME=V1,V2 (unbounded "
                             "otherwise)")
        try:
            values[name] = [json.loads(v) for v in text.split(",")]
        except ValueError:
            raise UsageError(f"--var {item}: the values are JSON (1,2.5 or true,false or \"a\",\"b\")") from None
    return values


class _Target(NamedTuple):
    """What ``--explore`` explores: the checked machine, its plants, the scenario fields the generated files keep
    (``base``), the machine's file and the tick."""

    spec: Any
    plants: list[tuple[type, object]]
    base: dict[str, object]
    machine_file: str
    dt: float


def _explore_target(args: argparse.Namespace) -> _Target:
    """The machine of ``--explore`` (a machine file, or a scenario with its plants); a car machine is refused."""
    target = args.explore
    if target.endswith(".scenario.json"):
        from pathlib import Path

        from ..scenario.model import load_scenario

        loaded = load_scenario(target, tuple(args.plugin))
        if loaded.world_path is not None:
            raise UsageError(f"--explore {target}: its machine drives the car; --explore runs machines without "
                             "a world")
        sc = loaded.scenario
        here = Path(os.path.relpath(Path(target).parent, args.out or "."))
        base: dict[str, object] = {k: v for k, v in (("plugins", [str(here / pl) for pl in sc.plugins]),
                                                     ("plants", sc.plants)) if v}
        return _Target(loaded.spec, loaded.plants, base, str(Path(target).parent / sc.machine), loaded.dt)
    from fsm.loading.loader import check, uses_car

    spec, problems = check(target, registry=registry_from(args))
    spec = checked(problems, spec)
    if uses_car(spec):
        raise UsageError(f"--explore {target}: the machine drives the car; --explore runs machines without a "
                         "world")
    return _Target(spec, [], {}, target, 0.0125)


def _explore_inputs(args: argparse.Namespace, target: _Target, values: dict[str, list[object]]
                    ) -> tuple[list[str], list[tuple[str, Any]]]:
    """The signals the search sets (those no plant drives) and the compiled ``--invariant`` expressions."""
    from fsm.loading.loader import signal_names
    from fsm.model.expr import BOOL, ExprError, compile_expr

    spec = target.spec
    declared = dict(getattr(spec, "vars", {}) or {})
    for name in values:
        if name not in declared:
            close = did_you_mean(name, sorted(declared))
            raise UsageError(f"--var {name}: the machine has no variable '{name}'" + (f" ({close})" if close else ""))
    signals = sorted(set(getattr(spec, "inputs", None) or ()) | set(signal_names(spec)))
    for _cls, params in target.plants:
        signals = [s for s in signals if s not in _cls(params).signals()]  # a plant drives them, not the search
    kinds = {k: "any" for k in declared} | {f"signal_{s}": BOOL for s in signals}
    invariants = []
    for text in args.invariant:
        try:
            invariants.append((text, compile_expr(text, kinds, want=BOOL).fn))
        except ExprError as exc:
            raise UsageError(f"--invariant {text!r}: {exc}") from None
    return signals, invariants


def _tell_exploration(args: argparse.Namespace, result: Any, space: Any, inputs: list[str], dt: float) -> None:
    """What the search ran, what it reached and did not (and why), and an invariant's violation."""
    total = len(result.targets)
    print(f"explored {args.explore}: {result.runs} runs in {result.seconds:.2f} s, {space.slots} input slots of "
          f"{space.step:g} s, inputs: {', '.join(inputs) or 'none'}")
    print(f"reached {total - len(result.unreached)}/{total} (states, transitions, monitors)")
    why = ("the run budget ran out (--max-runs " + str(args.max_runs or 2000) + ")" if result.exhausted else
           f"not reached by any input sequence within {space.slots} slots of {space.step:g} s (bounded depth; a "
           "guard no explored input can make true stays unreached)")
    for t in result.unreached:
        print(f"  unreached: {t}: {why}")
    if result.violation is not None:
        path, tick, text = result.violation
        print(f"VIOLATION '{text}' at tick {tick} (t={tick * dt:g} s) after {sum(1 for a in path if a[0] != 'wait')} "
              "input(s)")
