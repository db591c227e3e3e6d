"""The testing kit for Python (``fsm.testing``) and its pytest plugin (``pytest11`` entry point): a machine started
in a given state with given variables, fed inputs tick by tick and checked with the scenario vocabulary;
``*.scenario.json`` files collected as test items with ``fsmctl test``'s failure output; coverage."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from importlib.metadata import entry_points
from pathlib import Path

import pytest

from fsm.testing import MachineTest, ScenarioError

REPO = Path(__file__).resolve().parents[1]
SORTER = REPO / "diagrams" / "examples" / "sorter.json"
MISSION = REPO / "diagrams" / "examples" / "mission.scenario.json"


def test_start_in_a_state_with_variables_and_check_with_the_vocabulary() -> None:
    m = MachineTest(SORTER, state="cycle/grip", vars={"parts": 2})
    assert m.active_paths == ["cycle/grip", "cycle/conveyor/run"]
    m.always("parts <= 3")
    m.run_for(2.5)
    m.expect({"monitors": {"owner": "grip", "kind": "timeout", "count": 1, "within": [2.0, 2.0]}},
             {"outcome": "timeout", "state": "grip"}, {"skipped": "place", "count": 1}, {"vars": {"parts": 2}})
    with pytest.raises(ScenarioError) as info:
        m.expect({"vars": {"parts": 3}}, {"entered": "place"})
    text = str(info.value)
    assert "expect[0] at 2.5 s: expected parts = 3, got 2" in text
    assert "expect[1] entered: expected 'place' to be entered (and run) at least once, it happened 0 times" in text
    assert "> tick    200 t=2.5" in text  # the trace around the diverging tick, as fsmctl test prints it


def test_inputs_tick_by_tick_and_an_invariant_that_fails_raises_at_its_tick() -> None:
    m = MachineTest(SORTER, vars={"parts": 0})
    m.always("parts <= 3")
    m.signal("jam").tick(2)
    m.expect({"monitors": {"owner": "cycle", "count": 1}}, {"active": "cycle/clear_jam"},
             {"suspended": {"cycle/approach": True}})
    m.signal("jam", False).tick(2).expect({"entered": "approach", "count": 2})
    m.pause("cycle").tick().expect({"paused": {"cycle/approach": True}})
    m.resume("cycle").tick().expect({"paused": {"cycle": False}})
    m.set(parts=7)
    with pytest.raises(ScenarioError) as info:
        m.tick()
    assert "invariant: 'parts <= 3' is false at tick 7 (t=0.0875 s) (parts = 7)" in str(info.value)


def test_a_machine_with_a_plant() -> None:
    cases = REPO / "diagrams" / "eeros"
    plugin = str(REPO / "examples" / "eeros" / "eeros_plant.py")
    m = MachineTest(cases / "case1_axis.json", plugins=(plugin,), state="right",
                    plants=[{"name": "axis", "type": "Axis", "length": 1.0, "speed": 0.25, "start": 0.5}])
    m.always("axis_crashes == 0")
    m.signal("right").run_for(2.5)
    m.expect({"monitors": {"owner": "right", "count": 1, "within": [2.0, 2.05]}}, {"active": "hold"},
             {"vars": {"axis_x": {"value": 1.0, "tolerance": 0.001}}})
    with pytest.raises(ValueError, match="unknown plant type 'Axle'"):
        MachineTest(cases / "case1_axis.json", plugins=(plugin,), plants=[{"name": "a", "type": "Axle"}])


def test_bad_arguments_are_clear_errors() -> None:
    with pytest.raises(ValueError, match="no state at the path 'grip'; did you mean 'cycle/grip'"):
        MachineTest(SORTER, state="grip")
    m = MachineTest(SORTER)
    with pytest.raises(ValueError, match="unknown key 'cuont' \\(did you mean 'count'\\?\\)"):
        m.expect({"entered": "grip", "cuont": 1})
    with pytest.raises(ValueError, match="the machine has no state 'gripp'"):
        m.expect({"entered": "gripp"})
    with pytest.raises(ValueError, match="after now"):
        m.expect({"at": 5, "vars": {"parts": 0}})
    with pytest.raises(ValueError, match="unknown variable 'part'"):
        m.always("part > 0")


def test_the_plugin_is_registered_and_imports_neither_the_tools_nor_the_car() -> None:
    assert "fsm.testing.plugin" in {ep.value for ep in entry_points(group="pytest11")}
    code = ("import sys, fsm.testing.plugin; print(sorted(m for m in sys.modules if m.startswith(('fsm.tools', "
            "'fsm.sim', 'cv2', 'pymunk'))))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=True)
    assert out.stdout.strip() == "[]"


def test_pytest_collects_scenarios_and_runs_the_fixture(tmp_path: Path) -> None:
    """One pytest run in a folder: a passing and a failing scenario, a test using the fixture, coverage JSON."""
    good = json.loads(MISSION.read_text(encoding="utf-8"))
    good["machine"] = str(REPO / "diagrams" / "examples" / good["machine"])
    (tmp_path / "good.scenario.json").write_text(json.dumps(good), encoding="utf-8")
    bad = dict(good, expect=[{"outcome": "aborted"}])
    (tmp_path / "bad.scenario.json").write_text(json.dumps(bad, indent=1), encoding="utf-8")
    (tmp_path / "test_by_hand.py").write_text(textwrap.dedent(f'''
        def test_sorter(fsm_machine):
            m = fsm_machine({str(SORTER)!r}, state="cycle/grip", vars={{"parts": 5}})
            m.signal("gripped").tick(2).expect({{"outcome": "succeeded", "state": "grip"}}, {{"active": "cycle/place"}},
                                               {{"vars": {{"parts": 5}}}})
    '''), encoding="utf-8")
    env = {k: v for k, v in os.environ.items() if k != "PYTEST_ADDOPTS"}
    proc = subprocess.run([sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "-p", "no:randomly",
                           "--fsm-coverage-json", "cov.json", "--fsm-fail-under", "10", str(tmp_path)],
                          capture_output=True, text=True, timeout=120, cwd=tmp_path, env=env)
    out = proc.stdout
    assert proc.returncode == 1, out + proc.stderr
    assert "3 items" in out or "collected 3 items" in out
    assert "1 failed, 2 passed" in out
    assert "FAIL bad: expect[0] outcome (tick 320, t=4 s): expected outcome 'aborted', got 'succeeded'" in out
    assert "bad.scenario.json:" in out and "> tick    320 t=4" in out
    assert "Traceback" not in out
    data = json.loads((tmp_path / "cov.json").read_text(encoding="utf-8"))
    machines = {Path(m["machine"]).name: m for m in data["machines"]}
    assert machines["mission.json"]["runs"] == 2 and machines["sorter.json"]["runs"] == 1
    assert "tral-fsm coverage" in out


def test_coverage_is_added_up_over_pytest_xdist_workers(tmp_path: Path) -> None:
    """With -n 2 the scenarios run in two worker processes: the controller reports the coverage of both, and
    --fsm-fail-under judges that (issue 34: it used to print 0/0 and pass)."""
    drive = REPO / "diagrams" / "examples" / "drive.scenario.json"  # covers 6 of 8 states
    base = json.loads(drive.read_text(encoding="utf-8"))
    base["machine"] = str(REPO / "diagrams" / "examples" / base["machine"])
    for k in range(4):  # four items, so that both workers get some
        (tmp_path / f"m{k}.scenario.json").write_text(json.dumps(base), encoding="utf-8")
    env = {k: v for k, v in os.environ.items() if k != "PYTEST_ADDOPTS"}

    def run(*extra: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run([sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "-p", "no:randomly",
                               "--fsm-coverage-json", "cov.json", *extra, str(tmp_path)],
                              capture_output=True, text=True, timeout=180, cwd=tmp_path, env=env)

    serial = run()
    assert serial.returncode == 0, serial.stdout + serial.stderr
    alone = json.loads((tmp_path / "cov.json").read_text(encoding="utf-8"))
    spread = run("-n", "2", "--fsm-fail-under", "99.9")
    assert "4 passed" in spread.stdout, spread.stdout + spread.stderr
    together = json.loads((tmp_path / "cov.json").read_text(encoding="utf-8"))
    assert together == alone and together["machines"][0]["runs"] == 4
    assert together["totals"]["states"]["total"] > 0
    summary = next(line for line in spread.stdout.splitlines() if line.startswith("coverage: "))
    assert summary == next(line for line in serial.stdout.splitlines() if line.startswith("coverage: "))
    assert alone["percent"] < 99.9
    assert spread.returncode == 1 and "is under --fsm-fail-under 99.9%" in spread.stdout


def test_fsm_machine_drives_the_car_in_a_world(tmp_path: Path) -> None:
    """A machine that drives the car is tested by hand in a world (issue 34): it follows the wall at 1 s, its
    invariant reads the car's readings; without a world it is refused with what to add."""
    (tmp_path / "test_car.py").write_text(textwrap.dedent(f'''
        import pytest

        def test_follow(fsm_machine):
            m = fsm_machine({str(REPO / "diagrams" / "corner_turn.json")!r},
                            world={str(REPO / "diagrams" / "worlds" / "hallway.json")!r}, seed=0)
            m.always("car_front > 0.05")
            m.run_for(1.0).expect({{"active": "follow"}})
            assert m.machine.ctx.car.speed > 0

        def test_no_world(fsm_machine):
            with pytest.raises(ValueError, match="drives the car: give the world"):
                fsm_machine({str(REPO / "diagrams" / "corner_turn.json")!r})
    '''), encoding="utf-8")
    env = {k: v for k, v in os.environ.items() if k != "PYTEST_ADDOPTS"}
    proc = subprocess.run([sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "-p", "no:randomly", "-q",
                           str(tmp_path)], capture_output=True, text=True, timeout=180, cwd=tmp_path, env=env)
    assert "2 passed" in proc.stdout, proc.stdout + proc.stderr


def test_machine_test_refuses_expectations_checked_over_a_run() -> None:
    m = MachineTest(SORTER)
    for exp in ({"always": "parts >= 0"}, {"invariant": "parts >= 0"}, {"at": 0, "holds": "parts >= 0"}):
        with pytest.raises(ValueError, match="checked while a run goes on: use m.always"):
            m.expect(exp)
