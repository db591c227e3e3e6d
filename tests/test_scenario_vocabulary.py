"""The scenario vocabulary of issue 23 (docs/scenarios.md): windows, counts of entered and skipped runs, exits,
inner outcomes, tolerances, invariants, paused and suspended flags, pause and resume inputs. Each expectation
passes on a machine that does what it says and fails, with its trace, on one deliberately broken; bad input is
one located message each."""

from __future__ import annotations

import copy
import json
from pathlib import Path
from typing import Any

import pytest

from fsm.model.errors import DiagramError
from fsm.tools.cli import main
from fsm.tools.scenario import load_scenario, run_scenario

#: a (0.5 s), b (skipped: go is false), c (counts), d (1 s); the top-level sequence then ends the machine.
MACHINE: dict[str, Any] = {
    "initial": "main", "vars": {"n": 0, "go": False, "level": 0.0}, "inputs": ["estop", "jam"],
    "states": [{"id": "main", "type": "Sequence",
                "monitors": [{"condition": {"type": "SignalHigh", "signal": "jam"}, "exception": "clear",
                              "behavior": "restartOwner"}],
                "steps": [
                    {"id": "a", "type": "Wait", "seconds": 0.5},
                    {"id": "b", "type": "Wait", "seconds": 0.5, "precondition": "go"},
                    {"id": "c", "type": "SetVar", "assign": {"n": "n + 1", "level": "level + 0.1"}},
                    {"id": "d", "type": "Wait", "seconds": 1.0}],
                "exceptions": [{"id": "clear", "type": "Sequence", "steps": [
                    {"id": "wait_clear", "type": "Step", "until": {"type": "SignalLow", "signal": "jam"}}]}]}],
}


def broken(**changes: Any) -> dict[str, Any]:
    """The machine with step ``id`` changed by ``changes[id]`` (a dict of keys)."""
    doc = copy.deepcopy(MACHINE)
    for step in doc["states"][0]["steps"]:
        step.update(changes.get(step["id"], {}))
    return doc


def check(tmp_path: Path, expect: list[dict[str, Any]], machine: dict[str, Any] | None = None,
          inputs: list[dict[str, Any]] | None = None, duration: float = 3) -> list[str]:
    """Run a scenario; the failures' lines (empty when it passed)."""
    (tmp_path / "m.json").write_text(json.dumps(machine or MACHINE), encoding="utf-8")
    sc = tmp_path / "t.scenario.json"
    sc.write_text(json.dumps({"machine": "m.json", "duration": duration, "inputs": inputs or [],
                              "expect": expect}, indent=1), encoding="utf-8")
    result = run_scenario(load_scenario(sc))
    return [line for f in result.failures for line in f.lines()]


def problems(tmp_path: Path, expect: list[dict[str, Any]], inputs: list[dict[str, Any]] | None = None) -> list[str]:
    (tmp_path / "m.json").write_text(json.dumps(MACHINE), encoding="utf-8")
    sc = tmp_path / "t.scenario.json"
    sc.write_text(json.dumps({"machine": "m.json", "duration": 3, "inputs": inputs or [], "expect": expect},
                             indent=1), encoding="utf-8")
    with pytest.raises(DiagramError) as info:
        load_scenario(sc)
    return [str(p) for p in info.value.problems if p.severity == "error"]


def test_the_machine_passes_every_expectation(tmp_path: Path) -> None:
    assert check(tmp_path, [
        {"outcome": "succeeded", "within": [1.5, 1.55]},
        {"visits": ["a", "b", "c", "d"]},
        {"entered": "b", "count": 0}, {"skipped": "b", "count": 1, "within": [0.5, 0.5]},
        {"entered": "a", "count": 1, "within": [0, 0]}, {"exited": "a", "within": [0.5, 0.5]},
        {"outcome": "precondition_failed", "state": "b"}, {"outcome": "succeeded", "state": "a", "within": [0.5, 0.5]},
        {"at": 1.0, "vars": {"level": {"value": 0.1, "tolerance": 1e-9}, "n": 1}},
        {"invariant": "n <= 1 and level < 0.2"},
    ]) == []


# -- entered vs skipped: a skipped step counts as entered for visits and never, not for `entered` --------------
def test_a_skipped_step_is_entered_for_visits_but_not_for_entered(tmp_path: Path) -> None:
    assert check(tmp_path, [{"visits": ["b"]}, {"entered": "b", "count": 0}, {"skipped": "b"}]) == []
    lines = check(tmp_path, [{"never": ["b"]}])
    assert "'b' was entered (main/b)" in lines[0]


def test_entered_and_skipped_fail_on_a_machine_that_runs_the_step(tmp_path: Path) -> None:
    lines = check(tmp_path, [{"entered": "b", "count": 0}, {"skipped": "b", "count": 1}],
                  broken(b={"precondition": "true"}))
    text = "\n".join(lines)
    assert "expect[0] entered: expected 'b' to be entered (and run) exactly 0 times, it happened once" in text
    assert "expect[1] skipped: expected 'b' to be skipped by its precondition exactly once, it happened 0 times" \
        in text
    assert "> tick     40 t=0.5       enter main/b (Finished from main/a)" in text


# -- windows ---------------------------------------------------------------------------------------------------
def test_windows_of_entries_exits_and_outcomes_fail_on_a_slower_machine(tmp_path: Path) -> None:
    expect = [{"entered": "c", "within": [0.45, 0.55]}, {"exited": "a", "within": [0.45, 0.55]},
              {"outcome": "succeeded", "within": [1.5, 1.55]}, {"outcome": "succeeded", "state": "a",
                                                             "within": [0.45, 0.55]}]
    assert check(tmp_path, expect) == []
    lines = check(tmp_path, expect, broken(a={"seconds": 0.8}))
    text = "\n".join(lines)
    assert "expected 'c' to be entered (and run) at least once between 0.45 s and 0.55 s, it happened 0 times; " \
           "outside the window at 0.8125 s" in text
    assert "expected 'a' to be left at least once between 0.45 s and 0.55 s" in text
    assert "expected outcome 'succeeded' between 1.5 s and 1.55 s, the machine finished with it at tick 146" in text
    assert "expected 'a' to finish with 'succeeded' between 0.45 s and 0.55 s: main/a finished with 'succeeded' " \
           "at tick 64" in text


def test_monitor_firings_in_a_window(tmp_path: Path) -> None:
    inputs = [{"at": 0.2, "signal": "jam", "value": True}, {"at": 0.3, "signal": "jam", "value": False}]
    assert check(tmp_path, [{"monitors": {"owner": "main", "within": [0.15, 0.25], "count": 1}}], inputs=inputs) == []
    lines = check(tmp_path, [{"monitors": {"owner": "main", "within": [0.0, 0.1], "count": 1}}], inputs=inputs)
    assert "expected a monitor of 'main' between 0 s and 0.1 s to fire exactly once, it fired 0 times" in lines[0]


def test_counts_of_entries(tmp_path: Path) -> None:
    restart = [{"at": 0.2, "signal": "jam", "value": True}, {"at": 0.3, "signal": "jam", "value": False}]
    assert check(tmp_path, [{"entered": "a", "count": 2}, {"exited": "a", "min": 2, "max": 2}], inputs=restart) == []
    lines = check(tmp_path, [{"entered": "a", "max": 1}], inputs=restart)
    assert "expected 'a' to be entered (and run) at most once, it happened 2 times (at 0, 0.3 s)" in lines[0]


# -- inner outcomes, tolerances, invariants ---------------------------------------------------------------------
def test_the_outcome_of_an_inner_state(tmp_path: Path) -> None:
    assert check(tmp_path, [{"outcome": "precondition_failed", "state": "b"}]) == []
    lines = check(tmp_path, [{"outcome": "precondition_failed", "state": "b"}], broken(b={"precondition": "true"}))
    assert "expected 'b' to finish with 'precondition_failed': main/b finished with 'succeeded' at tick 80" in lines[0]


def test_a_number_with_a_tolerance(tmp_path: Path) -> None:
    assert check(tmp_path, [{"at": 1, "vars": {"level": {"value": 0.12, "tolerance": 0.05}}}]) == []
    lines = check(tmp_path, [{"at": 1, "vars": {"level": {"value": 0.12, "tolerance": 0.05}}}],
                  broken(c={"assign": {"n": "n + 1", "level": "level + 0.2"}}))
    assert "expected level = 0.12 ± 0.05, got 0.2 (since tick 41" in lines[0]
    assert check(tmp_path, [{"at": 1, "vars": {"level": {"value": 0.12, "tolerance": 0.01}}}]) != []


def test_an_invariant_is_checked_at_every_tick(tmp_path: Path) -> None:
    assert check(tmp_path, [{"invariant": "n <= 1"}]) == []
    lines = check(tmp_path, [{"invariant": "n <= 1"}], broken(c={"assign": {"n": "n + 2"}}))
    assert "expect[0] invariant: 'n <= 1' is false at tick 41 (t=0.5125 s) (n = 2)" in lines[0]
    assert any(line.startswith("    >") and "invariant n <= 1 false" in line for line in lines)


def test_an_invariant_over_a_signal_in_a_window(tmp_path: Path) -> None:
    inputs = [{"at": 1.0, "signal": "estop"}]
    assert check(tmp_path, [{"invariant": "not signal_estop", "within": [0, 0.9]}], inputs=inputs) == []
    lines = check(tmp_path, [{"invariant": "not signal_estop"}], inputs=inputs)
    assert "'not signal_estop' is false at tick 80 (t=1 s) (signal_estop = true)" in lines[0]


# -- pause and resume inputs, paused and suspended flags ----------------------------------------------------------
def test_pause_and_resume_a_subtree_by_path(tmp_path: Path) -> None:
    inputs = [{"at": 0.2, "pause": "main"}, {"at": 0.7, "resume": "main"}]
    expect = [{"at": 0.5, "paused": {"main": True, "a": True}, "suspended": {"a": False}},
              {"at": 0.8, "paused": {"main": False}}, {"exited": "a", "within": [1.0, 1.0]}]
    assert check(tmp_path, expect, inputs=inputs) == []
    lines = check(tmp_path, [{"at": 0.5, "paused": {"a": True}}])
    assert "expected 'a' paused, it was not (paused: none)" in lines[0]


def test_suspended_while_an_exception_sequence_runs(tmp_path: Path) -> None:
    inputs = [{"at": 0.2, "signal": "jam", "value": True}, {"at": 0.4, "signal": "jam", "value": False}]
    assert check(tmp_path, [{"at": 0.3, "suspended": {"main/a": True}, "paused": {"a": False}},
                            {"at": 0.1, "suspended": {"a": False}}], inputs=inputs) == []
    no_monitor = copy.deepcopy(MACHINE)
    no_monitor["states"][0]["monitors"][0]["condition"] = {"type": "SignalHigh", "signal": "estop"}
    lines = check(tmp_path, [{"at": 0.3, "suspended": {"a": True}}], no_monitor, inputs=inputs)
    assert "expected 'a' suspended, it was not (suspended: none)" in lines[0]


# -- bad input -------------------------------------------------------------------------------------------------
def test_bad_vocabulary_is_one_located_message_each(tmp_path: Path) -> None:
    got = problems(tmp_path, [
        {"entered": "a", "within": [2, 1]},
        {"entered": "a", "when": 1},
        {"enter": "a"},
        {"invariant": "n >= "},
        {"skipped": "a", "count": 1, "min": 1},
    ])
    text = "\n".join(got)
    assert "/expect/0/within" in got[0] and "the window ends (1 s) before it starts (2 s)" in text
    assert "at /expect/1/when" in text and "unknown key 'when'" in text
    assert "at /expect/2: error: expectation 2: an expectation is an object with one of" in text
    assert "at /expect/3/invariant" in text and "the invariant does not parse" in text
    assert "at /expect/4: error: expectation 4: 'count' is exact" in text
    # names are checked against the machine once the shape is right
    got = problems(tmp_path, [{"invariant": "m >= 0"}, {"outcome": "x", "state": "zz"}],
                   inputs=[{"at": 0.1, "pause": "a"}])
    text = "\n".join(got)
    assert len(got) == 3
    assert "at /expect/0/invariant" in text and "unknown variable 'm'" in text
    assert "(names: go, level, n, signal_estop, signal_jam)" in text
    assert "at /expect/1/state" in text and "the machine has no state 'zz'" in text
    assert "at /inputs/0/pause" in text and "a path from the top: 'main/a'" in text


def test_a_machine_given_to_test_and_a_scenario_given_to_run(tmp_path: Path,
                                                               capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "m.json").write_text(json.dumps(MACHINE), encoding="utf-8")
    sc = tmp_path / "t.scenario.json"
    sc.write_text(json.dumps({"machine": "m.json", "expect": [{"outcome": "succeeded"}]}), encoding="utf-8")
    assert main(["test", str(tmp_path / "m.json")]) == 1
    out, err = capsys.readouterr()
    assert err.count("error:") == 1 and "this is a machine document" in err and "Traceback" not in err + out
    assert main(["run", str(sc)]) == 1
    out, err = capsys.readouterr()
    assert err.count("error:") == 1 and "this is a scenario test" in err and "fsmctl test" in err
    assert "Traceback" not in err + out


# -- decided: plants are first stepped after tick 1 -----------------------------------------------------------
def test_plants_are_stepped_after_every_tick_from_tick_1_on() -> None:
    from fsm.runtime.plant import Plant, PlantParams
    from fsm.session.session import Session

    class Counter(Plant):
        def reset(self, ctx: Any) -> None:
            self.ticks: list[int] = []
            ctx.vars["seen_by_tick_1"] = "reset"

        def step(self, ctx: Any, dt: float) -> None:
            self.ticks.append(ctx.tick)

    session = Session.open({"initial": "a", "states": [{"id": "a", "type": "Idle"}]}, dt=0.0125, record=False)
    plant = Counter(PlantParams(type="Counter", name="c"))
    plant.attach(session.machine)
    session.start()
    assert plant.ticks == []  # starting (tick 0) is no tick of the machine: reset set what tick 1 sees
    session.step(3)
    assert plant.ticks == [1, 2, 3]


# -- coverage --------------------------------------------------------------------------------------------------
def test_coverage_lists_what_was_never_entered_or_fired(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "m.json").write_text(json.dumps(MACHINE), encoding="utf-8")
    sc = tmp_path / "t.scenario.json"
    sc.write_text(json.dumps({"machine": "m.json", "duration": 3, "expect": [{"outcome": "succeeded"}]}),
                  encoding="utf-8")
    out_json = tmp_path / "cov.json"
    assert main(["test", "--coverage", "--coverage-json", str(out_json), str(sc)]) == 0
    out = capsys.readouterr().out
    assert "states 4/7, transitions 3/3, monitors 0/1" in out
    assert "never entered: main/clear, main/clear/wait_clear" in out and "only skipped: main/b" in out
    assert "monitors never fired: main: monitor" in out
    data = json.loads(out_json.read_text(encoding="utf-8"))
    assert data["totals"]["states"] == {"covered": 4, "total": 7}
    assert {"path": "main/b", "status": "skipped"} in data["machines"][0]["states"]
    assert main(["test", "--fail-under", "70", str(sc)]) == 1
    assert "FAIL coverage 63.6% is under --fail-under 70%" in capsys.readouterr().out
    # a second scenario that jams adds to the same machine's coverage
    sc2 = tmp_path / "jam.scenario.json"
    sc2.write_text(json.dumps({"machine": "m.json", "duration": 3, "inputs": [
        {"at": 0.2, "signal": "jam", "value": True}, {"at": 0.3, "signal": "jam", "value": False}],
        "expect": [{"outcome": "succeeded"}]}), encoding="utf-8")
    assert main(["test", "--fail-under", "75", str(sc), str(sc2)]) == 0
    assert "(2 run(s)): states 6/7, transitions 3/3, monitors 1/1" in capsys.readouterr().out


# -- substitution ----------------------------------------------------------------------------------------------
def test_a_substituted_state_runs_its_replacement_and_keeps_its_step_keys(tmp_path: Path) -> None:
    sub = [{"state": "d", "with": {"type": "Wait", "seconds": 0.1}}]
    (tmp_path / "m.json").write_text(json.dumps(MACHINE), encoding="utf-8")
    sc = tmp_path / "t.scenario.json"
    sc.write_text(json.dumps({"machine": "m.json", "duration": 3, "substitute": sub,
                              "expect": [{"outcome": "succeeded", "within": [0.6, 0.65]}]}), encoding="utf-8")
    assert run_scenario(load_scenario(sc)).passed
    # by type, and a transition's type: the level's transition a -> b becomes a Timeout of 0.2 s
    doc = {"initial": "a", "states": [{"id": "a", "type": "Idle"}, {"id": "b", "type": "Final"}],
           "transitions": [{"type": "Signal", "from": "a", "to": "b", "signal": "go"}]}
    (tmp_path / "m.json").write_text(json.dumps(doc), encoding="utf-8")
    sc.write_text(json.dumps({"machine": "m.json", "duration": 1, "substitute": [
        {"transition": {"from": "a", "to": "b"}, "with": {"type": "Timeout", "seconds": 0.2}}],
        "expect": [{"outcome": "succeeded", "within": [0.2, 0.2]}]}), encoding="utf-8")
    assert run_scenario(load_scenario(sc)).passed
    sc.write_text(json.dumps({"machine": "m.json", "duration": 1, "substitute": [
        {"type": "Idle", "with": {"type": "Wait", "seconds": 0.3}}],
        "expect": [{"exited": "a", "within": [0.3, 0.3]}]}), encoding="utf-8")
    assert run_scenario(load_scenario(sc)).failures  # a Wait finishes, but no transition leaves on Finished
    sc.write_text(json.dumps({"machine": "m.json", "duration": 1, "substitute": [
        {"type": "Idle", "with": {"type": "Wait", "seconds": 0.3}},
        {"transition": {"from": "a", "to": "b"}, "with": {"type": "Finished"}}],
        "expect": [{"exited": "a", "within": [0.3, 0.3]}]}), encoding="utf-8")
    assert run_scenario(load_scenario(sc)).passed


def test_bad_substitutions_are_located_in_the_scenario(tmp_path: Path) -> None:
    (tmp_path / "m.json").write_text(json.dumps(MACHINE), encoding="utf-8")
    sc = tmp_path / "t.scenario.json"
    sc.write_text(json.dumps({"machine": "m.json", "duration": 3, "substitute": [
        {"state": "d", "with": {"type": "Wiat", "seconds": 1}},
        {"state": "zz", "with": {"type": "Wait", "seconds": 1}},
        {"state": "a", "type": "Wait", "with": {"type": "Wait", "seconds": 1}},
    ], "expect": [{"outcome": "succeeded"}]}, indent=1), encoding="utf-8")
    with pytest.raises(DiagramError) as info:
        load_scenario(sc)
    text = "\n".join(str(p) for p in info.value.problems)
    assert "at /substitute/0/with/type: error: unknown state type 'Wiat' (did you mean 'Wait'?)" in text
    assert "at /substitute/1: error: the machine has no state 'zz' to substitute" in text
    assert "at /substitute/2: error: a substitution names one of 'state', 'type' or 'transition'" in text
    sc.write_text(json.dumps({"machine": "m.json", "duration": 3, "substitute": [
        {"state": "d", "with": {"type": "Wait", "secs": 1}}], "expect": [{"outcome": "succeeded"}]}, indent=1),
        encoding="utf-8")
    with pytest.raises(DiagramError) as info:
        load_scenario(sc)
    text = "\n".join(str(p) for p in info.value.problems)
    assert "at /substitute/0/with/secs: error: with this substitution the machine is invalid: unknown parameter " \
           "'secs' (did you mean 'seconds'?)" in text


def test_an_invariant_over_the_cars_readings(tmp_path: Path) -> None:
    repo = Path(__file__).resolve().parents[1] / "diagrams"
    doc = json.loads((repo / "corner_turn.scenario.json").read_text(encoding="utf-8"))
    doc.pop("$schema", None)
    doc.update(machine=str(repo / doc["machine"]), world=str(repo / doc["world"]), duration=10.5,
               expect=[{"invariant": "car_front > 0.05"}, {"invariant": "car_front > 1.0"}])
    sc = tmp_path / "car.scenario.json"
    sc.write_text(json.dumps(doc), encoding="utf-8")
    result = run_scenario(load_scenario(sc))
    assert [f.index for f in result.failures] == [1]
    message = result.failures[0].message
    assert "'car_front > 1.0' is false at tick 812 (t=10.15 s) (car_front = 0.9" in message, message
    shown = float(message.rsplit("car_front = ", 1)[1].rstrip(")"))
    assert 0.9 < shown <= 1.0  # the first reading at or below 1 m, as the car approaches the corner
