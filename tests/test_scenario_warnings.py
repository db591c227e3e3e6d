"""A scenario whose only problems are warnings loads and runs (issue 31): warnings are kept with the scenario and
printed, only errors stop it, wherever in the load they are found."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from fsm.model.errors import Problem
from fsm.tools.cli import main
from fsm.tools.scenario import load_scenario, model, run_scenario

MACHINE = {"initial": "wait", "inputs": ["go"],
           "states": [{"id": "wait", "type": "Wait", "seconds": 0.2}]}


def write(tmp_path: Path, inputs: list[dict[str, object]]) -> Path:
    (tmp_path / "m.json").write_text(json.dumps(MACHINE), encoding="utf-8")
    sc = tmp_path / "t.scenario.json"
    sc.write_text(json.dumps({"machine": "m.json", "duration": 1, "inputs": inputs,
                              "expect": [{"outcome": "succeeded"}]}, indent=1), encoding="utf-8")
    return sc


def test_a_warning_of_the_machine_check_does_not_stop_the_scenario(tmp_path: Path,
                                                                   capsys: pytest.CaptureFixture[str]) -> None:
    sc = write(tmp_path, [{"at": 0.1, "signal": "nobody_reads_me", "width": 0.1}])
    loaded = load_scenario(sc)
    assert [p.severity for p in loaded.warnings] == ["warning"]
    assert "nobody_reads_me" in loaded.warnings[0].message and loaded.warnings[0].line == 5
    assert run_scenario(loaded).passed
    assert main(["test", str(sc)]) == 0
    assert "5:3 at /inputs/0: warning: input 0: the machine reads no signal" in capsys.readouterr().err


def test_a_warning_found_before_the_machine_is_loaded_does_not_stop_it(tmp_path: Path,
                                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    """No check of the scenario's own text warns today; one that does must not keep the machine from loading
    (it used to end at ``assert loaded is not None``)."""
    checked = model.timeline_problems

    def with_a_warning(scenario: model.Scenario, name: str) -> list[Problem]:
        return checked(scenario, name) + [Problem("a warning about the timeline", name, "/inputs/0",
                                                  severity="warning")]

    monkeypatch.setattr(model, "timeline_problems", with_a_warning)
    loaded = load_scenario(write(tmp_path, [{"at": 0.1, "signal": "go", "width": 0.1}]))
    assert ("a warning about the timeline", 5) in [(p.message, p.line) for p in loaded.warnings]
    assert loaded.spec is not None and run_scenario(loaded).passed
