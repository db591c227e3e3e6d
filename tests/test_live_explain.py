"""Why (issue 33, deliverable 2): for a tick, every transition leaving each active state in the order checked,
what it read and its verdict, computed by re-simulation (``fsmctl explain TRACE --tick N``, the live page's Why
panel through the controller's ``why``), and checked against the trace; the run pays nothing when nobody asks."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from fsm.tools.cli.explain import explain_trace
from fsm.trace.replay import read_trace
from helpers import cli
from live_helpers import COUNTER, REPO

LAP = str(REPO / "diagrams" / "hallway_lap.json")


@pytest.fixture(scope="module")
def lap_trace(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("explain") / "lap.jsonl"
    from fsm.tools.cli import main

    assert main(["run", LAP, "--duration", "12", "--trace", str(path), "-q"]) == 0
    return path


def test_explain_names_what_fired_what_it_read_and_why_the_rest_did_not(lap_trace: Path,
                                                                        capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = cli(capsys, "explain", str(lap_trace), "--tick", "828")
    assert code == 0, err
    lines = out.splitlines()
    assert lines[0] == "tick 828 (10.3500 s), from lap1/bottom_slow:"
    fired = next(line for line in lines if line.strip().startswith("1. lap1/bottom_slow -> lap1/bottom_turn"))
    assert "(SensorLevel sensor=front below=0.9 samples=1): fired; read car_front = 0.88" in fired
    assert any("lap1/bottom_slow -> lap1/bottom (SensorLevel" in line and
               line.endswith("a higher-priority transition fired") for line in lines)
    assert "lap1 -> lap2 (Finished): condition false" in out
    assert lines[-1] == "  fired: lap1/bottom_slow -> lap1/bottom_turn"


def test_every_tick_with_a_transition_is_explained_as_the_trace_recorded_it(lap_trace: Path) -> None:
    trace = read_trace(lap_trace)
    for event in trace.events[1:4]:  # explain_trace raises when the re-simulation parts from the trace
        explanation = explain_trace(trace, event["tick"])
        verdicts = [c.verdict for _s, checks in explanation.states for c in checks]
        assert verdicts.count("fired") == len([t for t in event["transitions"] if t.get("from")])
    quiet = explain_trace(trace, 100)
    assert quiet.fired == [] and all(c.verdict in ("condition false", "guard false")
                                     for _s, checks in quiet.states for c in checks)


def test_a_guard_false_and_a_condition_false_are_told_apart(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    machine = tmp_path / "counter.json"
    machine.write_text(COUNTER)
    trace = tmp_path / "t.jsonl"
    assert cli(capsys, "run", str(machine), "--trace", str(trace), "-q")[0] == 0
    code, out, err = cli(capsys, "explain", str(trace), "--tick", "8", "--json")
    assert code == 0, err
    data = json.loads(out)
    checks = data["states"][0]["transitions"]
    assert [(c["to"], c["guard"], c["verdict"]) for c in checks] == [
        ("<img src=x onerror=alert(1)>", "n > 50", "guard false"), ("done", "n >= 20", "guard false"),
        ("count", None, "fired")]
    assert checks[0]["values"]["n"] == 0 and checks[0]["guard_value"] is False
    later = json.loads(cli(capsys, "explain", str(trace), "--tick", "9", "--json")[1])["states"][0]["transitions"]
    assert [c["verdict"] for c in later] == ["guard false", "guard false", "condition false"]
    assert later[0]["values"]["n"] == 1


@pytest.mark.parametrize(("args", "words"), [
    (["--tick", "0"], "--tick 0: the trace's ticks are 1 to"), (["--tick", "99999"], "choose one of them")])
def test_a_tick_the_trace_does_not_have_is_one_message(lap_trace: Path, args: list[str], words: str,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = cli(capsys, "explain", str(lap_trace), *args)
    assert code == 1 and words in err and "Traceback" not in err and out == ""


def test_a_trace_is_explained_from_its_header_world_from_any_folder(lap_trace: Path, tmp_path: Path,
                                                                   monkeypatch: pytest.MonkeyPatch,
                                                                   capsys: pytest.CaptureFixture[str]) -> None:
    """The header holds the world as the run loaded it: a trace whose world file is named relative to another
    folder, or was changed since, is re-simulated as it ran (issue 33's tryout: ``cd / && fsmctl explain`` said
    "world file not found")."""
    text = lap_trace.read_text().splitlines()
    header = json.loads(text[0])
    world = json.loads(Path(header["world_file"]).read_text())
    world["start"]["y"] = 0.7  # the file now says another start: not the run's
    world.pop("$schema", None)
    (tmp_path / "worlds").mkdir()
    (tmp_path / "worlds" / "hallway.json").write_text(json.dumps(world))
    header["world_file"] = "worlds/hallway.json"
    moved = tmp_path / "moved.jsonl"
    moved.write_text("\n".join([json.dumps(header), *text[1:]]) + "\n")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    code, out, err = cli(capsys, "explain", str(moved), "--tick", "828")
    assert code == 0, err
    assert out.splitlines()[-1] == "  fired: lap1/bottom_slow -> lap1/bottom_turn"


def test_a_trace_whose_world_is_not_the_runs_is_told_not_explained(lap_trace: Path, tmp_path: Path,
                                                                  capsys: pytest.CaptureFixture[str]) -> None:
    text = lap_trace.read_text().splitlines()
    header = json.loads(text[0])
    header["world"]["start"]["y"] = 0.7  # the car starts elsewhere: another run
    changed = tmp_path / "changed.jsonl"
    changed.write_text("\n".join([json.dumps(header), *text[1:]]) + "\n")
    code, _out, err = cli(capsys, "explain", str(changed), "--tick", "828")
    assert code == 1 and "not the run the trace recorded" in err and "Traceback" not in err
