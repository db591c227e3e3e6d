"""The JUnit XML report of a scenario run (``fsmctl test --junit``), as CI systems read it: one ``testsuite``
with one ``testcase`` per scenario (per case of a matrix); a failed expectation is a ``failure``, an invalid scenario an
``error``, a skipped case and one that failed as its ``xfail`` expected are ``skipped``."""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass

from fsm.model.errors import Problem, escape_char

from .model import scenario_stem
from .runner import ScenarioResult


@dataclass
class Invalid:
    """A scenario file that could not be run: its name, file and problems."""

    name: str
    file: str
    problems: list[Problem]


def junit_xml(results: list[ScenarioResult | Invalid], suite: str = "fsmctl test") -> str:
    """The report as text (UTF-8 XML declaration included)."""
    runs = [r for r in results if isinstance(r, ScenarioResult)]
    counts = {"tests": str(len(results)), "failures": str(sum(not r.passed for r in runs)),
              "errors": str(len(results) - len(runs))}
    skipped = sum(r.status in ("skipped", "xfailed") for r in runs)
    total_time = f"{sum(r.wall_time for r in runs):.3f}"
    root = ET.Element("testsuites", {**counts, "time": total_time})
    ts = ET.SubElement(root, "testsuite", {"name": suite, **counts, "skipped": str(skipped), "time": total_time})
    for r in results:
        case = ET.SubElement(ts, "testcase", name=r.name, classname=_classname(r.file), file=r.file,
                             time="0" if isinstance(r, Invalid) else f"{r.wall_time:.3f}")
        if isinstance(r, Invalid):
            _invalid(case, r)
        else:
            _outcome(case, r)
    ET.indent(root)
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + xml_safe(ET.tostring(root, encoding="unicode")) + "\n"


def _invalid(case: ET.Element, r: Invalid) -> None:
    err = ET.SubElement(case, "error", type="invalid scenario",
                        message=f"{len([p for p in r.problems if p.severity == 'error'])} problem(s)")
    err.text = "\n".join(p.text for p in r.problems)


def _outcome(case: ET.Element, r: ScenarioResult) -> None:
    """A run's outcome in its test case: skipped (an expected failure too, as pytest's JUnit report has it), its
    failures, or its summary as its output."""
    if r.status in ("skipped", "xfailed"):
        skip = ET.SubElement(case, "skipped", type="pytest.skip" if r.status == "skipped" else "pytest.xfail",
                             message=r.skipped if r.skipped is not None else f"xfail: {r.xfail}")
        skip.text = r.summary_line()
    elif not r.passed:
        fail = ET.SubElement(case, "failure", type=r.failures[0].kind, message=r.summary_line())
        fail.text = "\n".join(line for f in r.failures for line in f.lines())
    else:
        out = ET.SubElement(case, "system-out")
        out.text = r.summary_line()


#: Characters XML 1.0 does not allow anywhere, not even as character references (ElementTree writes them raw).
_NOT_XML = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\ud800-\udfff\ufffe\uffff]")


def xml_safe(text: str) -> str:
    """``text`` with every character XML 1.0 forbids shown as ``\\x1b`` (``\\ud800``), so a state id or message
    holding one still makes a report that parses; every other character stays as it was."""
    return _NOT_XML.sub(lambda m: escape_char(m.group()), text)


def _classname(file: str) -> str:
    """``diagrams/examples/mission.scenario.json`` -> ``diagrams.examples.mission``."""
    return scenario_stem(file.replace("\\", "/")).strip("./").replace("/", ".") or "scenario"
