"""The pytest plugin of tral-fsm (entry point ``pytest11``: ``fsm``; switch it off with ``-p no:fsm``).

- ``*.scenario.json`` files among the paths pytest collects are test items (``pytest diagrams/`` runs them all);
  a failure is shown as ``fsmctl test`` shows it, the trace around the first diverging tick included;
- the ``fsm_machine`` fixture makes :class:`fsm.testing.MachineTest` objects (a machine file is relative to the
  test's file): start in a state with variables, feed inputs tick by tick, check with the scenario vocabulary;
- ``--fsm-coverage`` reports state, transition and monitor coverage over the scenarios and machines tested,
  ``--fsm-coverage-json FILE`` writes it, ``--fsm-fail-under N`` fails the run under N percent.

Importing this module imports nothing of the runtime: a test run that collects no scenario pays nothing.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

COVERAGE_KEY = pytest.StashKey[Any]()
NOTES_KEY = pytest.StashKey[list[str]]()


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("fsm", "tral-fsm machines and scenarios")
    group.addoption("--fsm-coverage", action="store_true",
                    help="report state, transition and monitor coverage of the machines tested")
    group.addoption("--fsm-coverage-json", metavar="FILE", help="write the coverage as JSON (implies --fsm-coverage)")
    group.addoption("--fsm-fail-under", metavar="PERCENT", type=float,
                    help="fail the run when the coverage is under PERCENT (implies --fsm-coverage)")
    group.addoption("--fsm-max-runs", metavar="N", type=int,
                    help="allow a scenario's matrix to expand to up to N cases (default: at most 10,000)")


def pytest_configure(config: pytest.Config) -> None:
    opt = config.option
    if getattr(opt, "fsm_coverage", False) or getattr(opt, "fsm_coverage_json", None) or \
            getattr(opt, "fsm_fail_under", None) is not None:
        under = getattr(opt, "fsm_fail_under", None)
        if under is not None and not 0 <= under <= 100:
            raise pytest.UsageError(f"--fsm-fail-under: expected a percentage from 0 to 100, got {under:g}")
        from fsm.tools.scenario.coverage import Coverage

        config.stash[COVERAGE_KEY] = Coverage()


def pytest_collect_file(file_path: Path, parent: pytest.Collector) -> pytest.Collector | None:
    if file_path.name.endswith(".scenario.json"):
        return ScenarioFile.from_parent(parent, path=file_path)
    return None


class ScenarioFile(pytest.File):
    """A scenario file: one test item, or one per case of its ``matrix`` (``name[case]``), marked ``skip`` or
    ``xfail`` as the scenario says. Collecting reads only the scenario's own file; the machine is loaded (and every
    problem reported) when an item runs."""

    def collect(self) -> Iterator[pytest.Item]:
        from fsm.tools.scenario.model import base_name

        plan = _case_plan(self.path, self.config.getoption("fsm_max_runs", None))
        if plan is None:  # unreadable or invalid: the item reports it when it runs
            yield ScenarioItem.from_parent(self, name=base_name(self.path))
            return
        name, cases = plan
        for case, skip, xfail in cases:
            item = ScenarioItem.from_parent(self, name=name if case is None else f"{name}[{case}]")
            item.case = case
            if skip is not None:
                item.add_marker(pytest.mark.skip(reason=skip))
            if xfail is not None:
                item.add_marker(pytest.mark.xfail(reason=xfail, raises=AssertionError, strict=False))
            yield item


def _case_plan(path: Path, max_runs: int | None) -> tuple[str, list[tuple[str | None, str | None, str | None]]] | None:
    """The scenario's name and its cases (name, skip, xfail), or None when its file does not read as a scenario."""
    from pydantic import ValidationError

    from fsm.model.errors import FsmError
    from fsm.tools.scenario.model import MAX_RUNS, Scenario, base_name, case_count, case_plan

    try:
        from fsm.loading.reading import parse_json_bytes, read_file_bytes

        data, _source = parse_json_bytes(read_file_bytes(path, "scenario"), str(path), path.parent)
        scenario = Scenario.model_validate(data)
    except (FsmError, ValidationError, ValueError):
        return None
    if case_count(scenario.matrix) > (MAX_RUNS if max_runs is None else max_runs):
        return None  # one item, that says so when it runs
    return base_name(path, scenario.name), [(c[0], c[3], c[4]) for c in case_plan(scenario)]


class ScenarioItem(pytest.Item):
    """One scenario (or one case of its matrix) run with ``fsmctl test``'s checks and output."""

    case: str | None = None

    def runtest(self) -> None:
        from . import ScenarioError, scenario_lines

        passed, lines = scenario_lines(self.path, self.config.stash.get(COVERAGE_KEY, None), case=self.case,
                                       max_runs=self.config.getoption("fsm_max_runs", None), marked=True)
        if not passed:
            raise ScenarioError(lines)

    def repr_failure(self, excinfo: pytest.ExceptionInfo[BaseException],
                     style: Any = None) -> str | Any:
        from . import ScenarioError

        if isinstance(excinfo.value, ScenarioError):
            return "\n".join(excinfo.value.lines)
        return super().repr_failure(excinfo)

    def reportinfo(self) -> tuple[Path, int | None, str]:
        return self.path, 0, f"scenario {self.name}"  # a line: pytest places skips by it


@pytest.fixture
def fsm_machine(request: pytest.FixtureRequest) -> Iterator[Callable[..., Any]]:
    """Make a :class:`fsm.testing.MachineTest`: ``fsm_machine("m.json", state="main/grip", vars={"n": 2})``; a
    relative file is found next to the test's file."""
    from . import MachineTest

    made: list[MachineTest] = []

    def near(name: Any) -> Any:
        if isinstance(name, (str, Path)) and not Path(name).is_absolute():
            here = Path(request.path).parent / name
            return here if here.exists() else name
        return name

    def make(source: Any, **keys: Any) -> MachineTest:
        source = near(source)
        if keys.get("world") is not None:
            keys["world"] = near(keys["world"])
        m = MachineTest(source, **keys)
        made.append(m)
        return m

    yield make
    coverage = request.config.stash.get(COVERAGE_KEY, None)
    if coverage is not None:
        for m in made:
            coverage.add(m.machine, m.record, key=m.file)


def pytest_sessionfinish(session: pytest.Session, exitstatus: int) -> None:
    """Write the coverage JSON and apply ``--fsm-fail-under`` (the terminal summary comes after this)."""
    config = session.config
    coverage = config.stash.get(COVERAGE_KEY, None)
    if coverage is None:
        return
    workeroutput = getattr(config, "workeroutput", None)
    if workeroutput is not None:  # a pytest-xdist worker: the controller adds the workers' up and reports
        workeroutput["fsm_coverage"] = coverage.to_json()
        return
    notes: list[str] = []
    path = config.option.fsm_coverage_json
    failed = False
    if path:
        import json

        from fsm.model.errors import FsmError
        from fsm.tools.files import write_output

        try:
            write_output(path, json.dumps(coverage.to_json(), indent=2) + "\n", "--fsm-coverage-json")
        except FsmError as exc:
            notes.append(f"ERROR {exc}")
            failed = True
        else:
            notes.append(f"coverage written to {path}")
    under = config.option.fsm_fail_under
    if under is not None and coverage.percent() < under:
        notes.append(f"FAIL coverage {coverage.percent():.1f}% is under --fsm-fail-under {under:g}%")
        failed = True
    config.stash[NOTES_KEY] = notes
    if failed and exitstatus == 0:
        session.exitstatus = pytest.ExitCode.TESTS_FAILED


@pytest.hookimpl(optionalhook=True)
def pytest_testnodedown(node: Any, error: Any) -> None:
    """pytest-xdist: a worker finished; add the coverage it collected to the controller's."""
    coverage = node.config.stash.get(COVERAGE_KEY, None)
    data = getattr(node, "workeroutput", {}).get("fsm_coverage")
    if coverage is not None and data:
        coverage.merge_json(data)


def pytest_terminal_summary(terminalreporter: Any, exitstatus: int, config: pytest.Config) -> None:
    coverage = config.stash.get(COVERAGE_KEY, None)
    if coverage is None:
        return
    terminalreporter.section("tral-fsm coverage")
    for line in coverage.text() + config.stash.get(NOTES_KEY, []):
        terminalreporter.write_line(line)
