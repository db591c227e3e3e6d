"""The scenario's temporal language (issue 34, points 1-8; docs/scenarios.md "Over time"): always, never, eventually,
until, after ... ticks over state terms (active, paused, entered, skipped, outcome, any state below a path) and
terms over time (prev, rose, fell, changed, start). Each expectation passes on the run it describes and fails, with
the tick and the values it read, on a statement the run does not bear out; bad formulas are located errors with
suggestions, and nothing runs."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from fsm.model.errors import DiagramError
from fsm.tools.cli import main
from fsm.tools.scenario import load_scenario, run_scenario

#: a (0.5 s), b (skipped: go is false), c (counts), d (1 s); the top-level sequence then ends the machine.
MACHINE: dict[str, Any] = {
    "initial": "main", "vars": {"n": 0, "go": False, "level": 0.0}, "inputs": ["jam"],
    "states": [{"id": "main", "type": "Sequence", "steps": [
        {"id": "a", "type": "Wait", "seconds": 0.5},
        {"id": "b", "type": "Wait", "seconds": 0.5, "precondition": "go"},
        {"id": "c", "type": "SetVar", "assign": {"n": "n + 1", "level": "level + 0.1"}},
        {"id": "d", "type": "Wait", "seconds": 1.0}]}],
}
PAUSE = [{"at": 1.0, "pause": "main"}, {"at": 1.5, "resume": "main"}]


def scenario(tmp_path: Path, expect: list[dict[str, Any]], inputs: list[dict[str, Any]] | None = None) -> Path:
    (tmp_path / "m.json").write_text(json.dumps(MACHINE), encoding="utf-8")
    sc = tmp_path / "t.scenario.json"
    sc.write_text(json.dumps({"machine": "m.json", "duration": 3, "inputs": inputs or [], "expect": expect},
                             indent=1), encoding="utf-8")
    return sc


def failures(tmp_path: Path, *expect: dict[str, Any], inputs: list[dict[str, Any]] | None = None) -> list[str]:
    result = run_scenario(load_scenario(scenario(tmp_path, list(expect), inputs)))
    return [f"{f.kind}: {f.message}" for f in result.failures]


def problems(tmp_path: Path, *expect: dict[str, Any]) -> list[str]:
    with pytest.raises(DiagramError) as info:
        load_scenario(scenario(tmp_path, list(expect)))
    return [str(p) for p in info.value.problems if p.severity == "error"]


def test_point_1_a_state_not_active_over_a_window(tmp_path: Path) -> None:
    assert failures(tmp_path, {"never": "active(d)", "within": [0, 0.5]},
                    {"always": "not active(d)", "until": "entered(c)"}) == []
    assert failures(tmp_path, {"never": "active(d)", "within": [0, 1.0]}) == [
        "never: 'active(d)' holds at tick 42 (t=0.525 s) (active(d) = true)"]


def test_point_2_state_terms_in_invariants_and_outcomes(tmp_path: Path) -> None:
    assert failures(tmp_path, {"invariant": "n == 0 or active(c) or active(d) or outcome(main) == 'succeeded'"},
                    {"always": "level == 0 or n == 1"}) == []
    assert failures(tmp_path, {"invariant": "n == 0 or active(d)"}) == [
        "invariant: 'n == 0 or active(d)' is false at tick 41 (t=0.5125 s) (n = 1, active(d) = false)"]


def test_point_3_previous_values_edges_and_a_grace_of_n_ticks(tmp_path: Path) -> None:
    assert failures(tmp_path, {"always": "n - prev(n) <= 1"}, {"eventually": "rose(n > 0)", "count": 1},
                    {"eventually": "changed(level)", "count": 1}, {"never": "fell(n > 0)"},
                    {"eventually": "n == 1", "after": "skipped(b)", "ticks": 1}) == []
    assert failures(tmp_path, {"eventually": "n == 1", "after": "entered(a)", "ticks": 3}) == [
        "eventually: 'n == 1' did not hold within 3 tick(s) after 'entered(a)' held at tick 0 (t=0 s); at tick 3 "
        "(t=0.0375 s) (n = 0)"]


def test_point_4_pause_and_resume_counted_and_timed(tmp_path: Path) -> None:
    assert failures(tmp_path, {"eventually": "rose(paused(main))", "count": 1, "within": [0, 3]},
                    {"eventually": "fell(paused(d))", "at": [1.5]}, {"never": "paused(main)", "within": [0, 0.99]},
                    inputs=PAUSE) == []
    assert failures(tmp_path, {"eventually": "rose(paused(main))", "at": [1.25]}, inputs=PAUSE) == [
        "eventually: expected 'rose(paused(main))' to hold at 1.25 s, it held at 1 s"]


def test_point_5_entries_of_any_state_below_a_path(tmp_path: Path) -> None:
    assert failures(tmp_path, {"eventually": "entered('main/*')", "count": 3},
                    {"eventually": "skipped('main/*')", "count": 1}) == []
    assert failures(tmp_path, {"eventually": "entered('main/*')", "max": 2}) == [
        "eventually: expected 'entered('main/*')' to hold at at most 2 ticks, it held at 3 ticks "
        "(at 0, 0.5125, 0.525 s)"]


def test_point_6_the_last_outcome_of_a_state_at_a_time(tmp_path: Path) -> None:
    assert failures(tmp_path, {"at": 0.4, "holds": "outcome(a) == ''"},
                    {"at": 0.6, "holds": "outcome(a) == 'succeeded' and outcome(b) == 'precondition_failed'"}) == []
    assert failures(tmp_path, {"at": 0.6, "holds": "outcome(b) == 'succeeded'"}) == [
        "at 0.6 s: 'outcome(b) == 'succeeded'' is false at tick 48 (t=0.6 s) (outcome(b) = \"precondition_failed\")"]


def test_point_7_relative_timing_of_the_kth_entry(tmp_path: Path) -> None:
    assert failures(tmp_path, {"eventually": "entered(d)", "after": "entered(a)", "nth": 1, "ticks": 42}) == []
    assert failures(tmp_path, {"eventually": "entered(d)", "after": "entered(a)", "nth": 1, "seconds": 0.5})[0] \
        .startswith("eventually: 'entered(d)' did not hold within 40 tick(s) after 'entered(a)' held at tick 0")
    assert failures(tmp_path, {"eventually": "entered(d)", "after": "entered(a)", "nth": 2, "ticks": 42}) == [
        "eventually: 'entered(a)' never held 2 times (it held 1 times), so 'entered(d)' was never checked after it"]


def test_point_8_a_value_steady_relative_to_the_start_of_its_window(tmp_path: Path) -> None:
    assert failures(tmp_path, {"always": "abs(level - start(level)) < 0.01", "within": [0.6, 1.4]},
                    {"always": "level - start(level) <= 0.1", "after": "entered(a)"}) == []
    assert failures(tmp_path, {"always": "level == start(level)", "within": [0, 1]}) == [
        "always: 'level == start(level)' is false at tick 41 (t=0.5125 s) (level = 0.1, start(level) = 0.0)"]


def test_until_must_end(tmp_path: Path) -> None:
    assert failures(tmp_path, {"always": "level < 1", "until": "active(d) and n == 5"}) == [
        "always: 'active(d) and n == 5' never held (until it does, 'level < 1' must hold); the run ended at tick 122 "
        "(t=1.525 s)"]


def test_bad_formulas_are_located_with_suggestions_and_nothing_runs(tmp_path: Path) -> None:
    found = problems(tmp_path, {"always": "not active(dd)"}, {"never": "actve(d)"}, {"eventually": "rose(n)"},
                     {"always": "a"}, {"always": "n +"})
    assert len(found) == 5, found
    assert "t.scenario.json:7:" in found[0] and "the machine has no state 'dd'" in found[0] and "'d'" in found[0]
    assert "unknown function 'actve' (did you mean 'active'?" in found[1]
    assert "rose() takes a true/false value" in found[2] and "rose(x > 0)" in found[2]
    assert "unknown variable 'a'" in found[3] and "'a' is a state: write active(a)" in found[3]
    assert "/expect/4/always" in found[4] and "expected a value" in found[4]


def test_a_formula_error_points_at_its_character_as_in_a_machine_document(tmp_path: Path) -> None:
    """Scenario problems take the machine documents' located-problems path (fsm.model.problems.Problems): an
    error inside a formula is placed at its character in the JSON string, not at the key."""
    sc = tmp_path / "t.scenario.json"
    (tmp_path / "m.json").write_text(json.dumps(MACHINE), encoding="utf-8")
    sc.write_text('{"machine": "m.json",\n "expect": [{"always": "n >= 0 and actve(d)"}]}\n', encoding="utf-8")
    with pytest.raises(DiagramError) as info:
        load_scenario(sc)
    (problem,) = info.value.problems
    line = sc.read_text(encoding="utf-8").splitlines()[1]
    assert (problem.line, problem.column) == (2, line.index("actve") + 1), str(problem)


def test_keys_that_do_not_go_together_are_located(tmp_path: Path) -> None:
    found = problems(tmp_path, {"always": "n >= 0", "count": 2}, {"never": "n > 5", "until": "active(d)"},
                     {"always": "n >= 0", "never": "n > 5"}, {"eventually": "n > 0", "ticks": 3},
                     {"eventually": "n > 0", "at": [9]}, {"always": "n > 0", "cuont": 1})
    assert len(found) == 6, found
    assert "/expect/0/count" in found[0] and "'count' counts the ticks an 'eventually'" in found[0]
    assert "'until' goes with 'always'" in found[1]
    assert "give one of 'always', 'never' and 'eventually'" in found[2]
    assert "'ticks' counts from a trigger" in found[3]
    assert "/expect/4/at/0" in found[4] and "after the end of the run" in found[4]
    assert "unknown key 'cuont'" in found[5] and "did you mean 'count'" in found[5]


def test_fsmctl_test_shows_the_trace_of_a_temporal_failure(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    sc = scenario(tmp_path, [{"never": "active(d)", "within": [0, 1.0]}])
    assert main(["test", str(sc)]) == 1
    out = capsys.readouterr().out
    assert "FAIL t: expect[0] never (tick 42, t=0.525 s): 'active(d)' holds" in out
    assert "> tick     42 t=0.525     never active(d) failed" in out
