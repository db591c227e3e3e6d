"""``fsm.run``: the one way to run a machine from Python, from each kind of source, on a world or a car, and every
hint of an error message that names a call, run as written."""

from __future__ import annotations

import io
import json
import math
import re
import shlex
from pathlib import Path
from typing import Any

import pytest

import fsm
from fsm.loading.loader import compile as compile_plan
from fsm.tools.cli import main
from fsm.trace.recorder import Recorder

DOC: dict[str, Any] = {"initial": "a", "states": [{"id": "a", "type": "Idle"}, {"id": "b", "type": "Final"}],
                       "transitions": [{"type": "Timeout", "from": "a", "to": "b", "seconds": 0.5}]}
#: A machine that drives the car for half a second, then finishes.
DRIVES: dict[str, Any] = {"initial": "go", "states": [{"id": "go", "type": "FollowWall"},
                                                      {"id": "done", "type": "Final"}],
                          "transitions": [{"type": "Timeout", "from": "go", "to": "done", "seconds": 0.5}]}


WORLD = Path(__file__).resolve().parents[1] / "diagrams" / "worlds" / "hallway.json"


def write(tmp_path: Path, doc: dict[str, Any], name: str = "m.json") -> Path:
    path = tmp_path / name
    path.write_text(json.dumps(doc), encoding="utf-8")
    return path


def test_each_kind_of_source_runs_to_the_same_end(tmp_path: Path) -> None:
    path = write(tmp_path, DOC)
    spec, problems = fsm.check(DOC)
    assert spec is not None and problems == []
    sources: list[fsm.RunSource] = [path, str(path), json.dumps(DOC), DOC, spec, compile_plan(DOC), fsm.load(DOC)]
    results = [fsm.run(source) for source in sources]
    assert {(r.outcome, r.stopped) for r in results} == {("succeeded", "finished")}


def test_stop_rules_until_and_outputs() -> None:
    assert fsm.run(DOC, max_ticks=3).outcome is None
    assert fsm.run(DOC, stop=fsm.StopRules(duration=0.1)).stopped == "limit"
    seen: list[int] = []
    assert fsm.run(DOC, until=lambda s: seen.append(s.ticks) or s.ticks >= 5).stopped == "until"
    assert seen[-1] == 5
    out = io.StringIO()
    fsm.run(DOC, outputs=[Recorder(out)])
    lines = [json.loads(line) for line in out.getvalue().splitlines()]
    assert lines[0]["type"] == "header" and lines[-1] == {**lines[-1], "type": "end", "outcome": "succeeded"}


@pytest.mark.parametrize(("kwargs", "error", "words"), [
    ({"stop": 3}, TypeError, "stop must be"),
    ({"max_ticks": -1}, ValueError, "max_ticks"),
    ({"duration": "1"}, TypeError, "duration"),
    ({"stop": fsm.StopRules(duration=1.0), "duration": 1.0}, TypeError, "either stop"),
    ({"until": 3}, TypeError, "until must be"),
])
def test_wrong_arguments_name_themselves(kwargs: dict[str, Any], error: type[Exception], words: str) -> None:
    with pytest.raises(error, match=words):
        fsm.run(DOC, **kwargs)


def test_a_source_of_another_kind_is_refused() -> None:
    with pytest.raises(TypeError, match="source must be a path, JSON text"):
        fsm.run(42)  # type: ignore[arg-type]  # the wrong type is what this test is about
    with pytest.raises(TypeError, match="a machine already built"):
        fsm.run(fsm.load(DOC), dt=0.1)


def test_a_document_with_errors_raises_with_every_problem() -> None:
    with pytest.raises(fsm.DiagramError) as caught:
        fsm.run('{"initial": "a",\n "states": [{"id": "a", "type": "Nope"}]}')
    assert "unknown state type 'Nope'" in str(caught.value)
    problem = caught.value.problems[0]
    assert (problem.file, problem.line, problem.column) == ("<text>.json", 2, 25)  # located in the text


def test_a_machine_that_drives_runs_on_the_simulated_car(tmp_path: Path) -> None:
    path = write(tmp_path, DRIVES)
    result = fsm.run(path)
    assert (result.outcome, result.stopped) == ("succeeded", "finished")
    assert fsm.run(path, world=WORLD).outcome == "succeeded"


def test_a_machine_that_drives_runs_on_a_car_of_your_own() -> None:
    from fsm.sim.fake import FakeCar

    car = FakeCar()
    result = fsm.run(DRIVES, car=car)
    assert (result.outcome, result.stopped) == ("succeeded", "finished")
    assert car.speed_command > 0  # the wall follower drove it


class HandMadeCar:
    """A car written here, not ours: its values as plain attributes, its commands as methods (fsm.sim.io.CarIO)."""

    def __init__(self) -> None:
        self.left = self.right = self.front = 1.0
        self.sample = self.hall = 0
        self.distance = self.speed = self.steering = self.speed_command = 0.0
        self.wheelbase, self.max_steering_angle = 0.26, 0.4
        self.pose = (0.0, 0.0, 0.0)
        self.camera = None

    def set_steering(self, value: float) -> None:
        self.steering = value

    def set_speed(self, value: float) -> None:
        self.speed_command = value

    def emergency_stop(self) -> None:
        self.speed_command = 0.0


def test_a_car_of_your_own_is_checked_against_the_car_interface() -> None:
    car = HandMadeCar()
    assert fsm.run(DRIVES, car=car).outcome == "succeeded" and car.speed_command > 0
    with pytest.raises(TypeError, match=r"^car must have the car interface \(fsm\.sim\.io\.CarIO\): .*\(object\) "
                                        r"lacks camera, distance, emergency_stop, front, .*, wheelbase$"):
        fsm.run(DRIVES, car=object())
    del car.camera
    with pytest.raises(TypeError, match=r"\(HandMadeCar\) lacks camera$"):
        fsm.run(DRIVES, car=car)


@pytest.mark.parametrize(("variables", "error", "words"), [
    ([1, 2], TypeError, r"^variables must be a mapping of names to JSON values \(a dict\) or None, got \[1, 2\]"),
    ({1: 2}, TypeError, r"^variables: each name must be a string, got 1 \(int\)"),
    ({"a": object()}, TypeError, r"^variables\['a'\] must be a JSON value"),
    ({"a": {"b": [1, math.nan]}}, ValueError, r"^variables\['a'\]\['b'\]\[1\] must be a finite number"),
    ({"a": {2: 1}}, TypeError, r"^variables\['a'\]: each key must be a string"),
])
def test_variables_must_be_names_to_json_values(variables: Any, error: type[Exception], words: str) -> None:
    with pytest.raises(error, match=words):
        fsm.run(DOC, variables=variables)
    assert fsm.run(DOC, variables={"a": [1, {"b": None}], "c": 0.5}).variables == {"a": [1, {"b": None}], "c": 0.5}


def test_a_plugin_that_cannot_be_found_is_named_as_the_python_argument(tmp_path: Path,
                                                                       capsys: pytest.CaptureFixture[str]) -> None:
    missing = str(tmp_path / "none.py")
    for plugin, words in [("no_such_plugin_xyz", "plugins=['no_such_plugin_xyz']: no module named"),
                          ("a-b", "plugins=['a-b']: not a module name or a .py file"),
                          (missing, f"plugins=[{missing!r}]: no such file")]:
        for call in (fsm.run, fsm.load, fsm.check):
            with pytest.raises(ValueError, match=re.escape(words)):
                call(DOC, plugins=(plugin,))
    assert main(["--plugin", "a-b", "validate", str(write(tmp_path, DOC))]) == 2  # the command line keeps its words
    assert "--plugin 'a-b': not a module name" in capsys.readouterr().err


def test_every_hint_that_names_a_call_works_as_written(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The "no car was given" error of a machine that drives, loaded without a car: each call its hint names
    (in Python and on the command line) runs the machine, with FILE and WORLD as the user would fill them in."""
    path = write(tmp_path, DRIVES)
    with pytest.raises(fsm.DiagramError) as caught:
        fsm.load(path)
    hint = caught.value.problems[0].hint or ""
    python_calls = re.findall(r"fsm\.\w+\([^)]*\)", hint)
    commands = re.findall(r"`(fsmctl [^`]+)`", hint)
    assert python_calls and commands, hint
    for call in python_calls:
        result = eval(call.replace("FILE", repr(str(path))), {"fsm": fsm})  # the hint, run as written
        assert result.outcome == "succeeded", call
    for command in commands:
        argv = [str(path) if a == "FILE" else str(WORLD) if a == "WORLD" else a for a in shlex.split(command)]
        assert main(argv[1:]) == 0, command
    assert "succeeded" in capsys.readouterr().out


@pytest.mark.parametrize("extra", [[], ["--set", "a.seconds=0.2"]])
def test_fsmctl_run_checks_the_document_once(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                             capsys: pytest.CaptureFixture[str], extra: list[str]) -> None:
    """Read, parsed and checked once; compiled from that check (a ``--set`` override makes a new document, which is
    checked once more)."""
    import fsm.loading.loader as loader

    calls: list[object] = []
    real = loader.check_spec

    def counting(spec: Any, problems: Any) -> Any:
        calls.append(spec)
        return real(spec, problems)

    monkeypatch.setattr(loader, "check_spec", counting)
    path = write(tmp_path, {"initial": "a", "states": [{"id": "a", "type": "Wait", "seconds": 0.5},
                                                      {"id": "b", "type": "Final"}],
                            "transitions": [{"type": "Finished", "from": "a", "to": "b"}]})
    assert main(["run", str(path), "--duration", "1", *extra]) == 0
    assert "succeeded" in capsys.readouterr().out
    assert len(calls) == (2 if extra else 1)


def test_the_hint_of_a_registry_without_the_chain_link_works_as_written() -> None:
    """A sequence of several steps in a registry without ``Finished``: the hint's call makes a registry that loads
    it."""
    builtins = fsm.Registry.with_builtins()
    registry = fsm.Registry()
    for name in ("Sequence", "Wait"):
        registry.add_state(builtins.states[name], name)
    doc = {"initial": "s", "states": [{"id": "s", "type": "Sequence", "steps": [
        {"id": "a", "type": "Wait", "seconds": 0.1}, {"id": "b", "type": "Wait", "seconds": 0.1}]}]}
    with pytest.raises(fsm.DiagramError) as caught:
        fsm.load(doc, registry=registry)
    hint = caught.value.problems[0].hint or ""
    calls = re.findall(r"fsm\.[\w.]+\([^)]*\)", hint)
    assert calls == ["fsm.Registry.with_builtins()"], hint
    made = eval(calls[0], {"fsm": fsm})  # the hint, run as written
    assert fsm.run(doc, registry=made).outcome == "succeeded"


def test_the_result_says_where_the_run_stood() -> None:
    doc = {**DOC, "vars": {"laps": 2}}
    done = fsm.run(doc)
    assert (done.outcome, done.stopped, done.active) == ("succeeded", "finished", ("b",))
    assert (done.ticks, done.time) == (40, pytest.approx(0.5))
    assert done.variables == {"laps": 2}
    cut = fsm.run(doc, max_ticks=3, variables={"laps": 5})
    assert (cut.outcome, cut.stopped, cut.ticks, cut.active, cut.variables) == (None, "limit", 3, ("a",), {"laps": 5})


class Fails(fsm.State):
    """A state whose entry raises: the run stops with the error."""

    def on_enter(self, ctx: fsm.Context) -> None:
        raise RuntimeError("broken sensor")


def test_a_state_that_fails_still_ends_the_trace_with_its_error() -> None:
    registry = fsm.Registry.with_builtins()
    registry.add_state(Fails, "Fails")
    doc = {"initial": "a", "states": [{"id": "a", "type": "Idle"}, {"id": "b", "type": "Fails"}],
           "transitions": [{"type": "Timeout", "from": "a", "to": "b", "seconds": 0.1}]}
    out = io.StringIO()
    with pytest.raises(fsm.StateRuntimeError, match="broken sensor"):
        fsm.run(doc, registry=registry, outputs=[Recorder(out)])
    lines = [json.loads(line) for line in out.getvalue().splitlines()]
    assert any(line["type"] == "event" for line in lines)  # the transition into b
    end = lines[-1]
    assert end["type"] == "end" and end["error"]["state"] == "b" and "broken sensor" in end["error"]["message"]


def test_session_open_and_simulation_run_are_the_same_rule(tmp_path: Path) -> None:
    """``Session.open`` checks its arguments as fsm.run does and takes its sources; ``Simulation.run`` answers a
    RunResult as fsm.run does, with its stop arguments checked alike."""
    from fsm.session.run import open_session
    from fsm.sim.loop import Simulation

    assert fsm.Session.open(json.dumps(DOC)).run().outcome == "succeeded"
    assert fsm.Session.open(compile_plan(DOC)).run().outcome == "succeeded"
    for kwargs, error, words in [({"variables": [1]}, TypeError, "^variables must be a mapping"),
                                 ({"car": object()}, TypeError, "^car must have the car interface")]:
        with pytest.raises(error, match=words):
            fsm.Session.open(DOC, **kwargs)
    with pytest.raises(TypeError, match="^source must be a path, JSON text"):
        fsm.Session.open(42)  # type: ignore[arg-type]  # the wrong type is what this test is about
    simulation = open_session(DRIVES).driver
    assert isinstance(simulation, Simulation)
    with pytest.raises(ValueError, match="duration"):
        simulation.run(duration=-1.0)
    result = simulation.run(duration=0.2)
    assert isinstance(result, fsm.RunResult) and (result.stopped, result.ticks) == ("limit", 16)
    assert simulation.run(until=lambda s: s.ticks >= 20).stopped == "until"
    assert simulation.run().outcome == "succeeded"


def test_a_wrong_argument_nested_deeper_than_repr_goes_is_still_named() -> None:
    """The one rule errors show a value by (``shown_value``) bounds its depth: ``repr`` of a list nested 100,000
    deep raises RecursionError, and that must not replace the TypeError naming the argument."""
    deep: Any = []
    for _ in range(100_000):
        deep = [deep]
    with pytest.raises(TypeError, match=r"^stop must be an fsm\.StopRules or None, got \[\[\[.*\(list\)$"):
        fsm.run('{"initial": "a", "states": [{"id": "a", "type": "Idle"}]}', stop=deep)
