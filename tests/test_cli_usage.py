"""Command-line mistakes get what to type: the command's usage, the option meant, the side of the command an option
goes on, exit codes in --help; --set errors name the state's type at exit 2; --expect on an unfinished run; the
progress line against the run's real stop rule; user-code exceptions with file and line, whole tracebacks when
asked (--traceback, FSM_TRACEBACK=1), also in ``fsmctl test``."""

from __future__ import annotations

import io
import json
import subprocess
import sys
from pathlib import Path

import pytest

from fsm.tools.cli.app import main
from fsm.tools.cli.run import ProgressBar

REPO = Path(__file__).resolve().parents[1]
CORNER = str(REPO / "diagrams" / "corner_turn.json")

CRASH = '''\
from fsm import State, register_state


def helper(x):
    return x.missing


@register_state
class Crash(State):
    """Crashes on entry."""

    def on_enter(self, ctx):
        helper(ctx)
'''


def fsmctl(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def usage_error(capsys: pytest.CaptureFixture[str], *argv: str) -> str:
    with pytest.raises(SystemExit) as exc:
        main(list(argv))
    assert exc.value.code == 2
    return capsys.readouterr().err


def test_a_misspelt_option_of_a_command_gets_its_usage_and_the_option_meant(capsys: pytest.CaptureFixture[str]) -> None:
    err = usage_error(capsys, "run", CORNER, "--wrold", "x.json")
    assert err.startswith("usage: fsmctl run [-h]")
    assert err.rstrip().endswith("fsmctl run: error: unrecognized arguments: --wrold x.json; did you mean --world?")


def test_several_misspelt_options_each_get_a_suggestion(capsys: pytest.CaptureFixture[str]) -> None:
    err = usage_error(capsys, "validate", CORNER, "--strikt", "--quite")
    assert "--strikt: did you mean --strict?; --quite: did you mean --quiet?" in err


def test_fsmctls_own_option_after_the_command_is_named_as_such(capsys: pytest.CaptureFixture[str]) -> None:
    err = usage_error(capsys, "run", CORNER, "--plugin", "x.py")
    assert err.startswith("usage: fsmctl run ")
    assert ("--plugin is an option of fsmctl itself: put it before the command (fsmctl --plugin x.py run ...)"
            in err)


def test_fsmctls_own_option_before_the_file_keeps_its_own_value(capsys: pytest.CaptureFixture[str]) -> None:
    """``run --plugin P FILE``: argparse alone takes P for the file and FILE for the plugin; the hint moves P."""
    hint = ("--plugin is an option of fsmctl itself: put it before the command (fsmctl --plugin my_types.py "
            "run ...)")
    for argv, said in ((["run", "--plugin", "my_types.py", "missing.json"], "--plugin my_types.py"),
                       (["run", "--plugin=my_types.py", "missing.json"], "--plugin=my_types.py"),
                       (["run", "missing.json", "--plugin", "my_types.py"], "--plugin my_types.py")):
        err = usage_error(capsys, *argv)
        assert err.startswith("usage: fsmctl run "), argv
        assert f"fsmctl run: error: unrecognized arguments: {said}; {hint}" in err, (argv, err)
    err = usage_error(capsys, "run", "--traceback", "--plugin", "my_types.py", CORNER, "--wrold", "w.json")
    assert ("unrecognized arguments: --traceback --plugin my_types.py --wrold w.json; --traceback is an option of "
            "fsmctl itself: put it before the command (fsmctl --traceback run ...); " + hint
            + "; --wrold: did you mean --world?") in err
    err = usage_error(capsys, "run", CORNER, "--", "--plugin")  # after --, a file name: one too many
    assert "unrecognized arguments: --plugin" in err


def test_a_commands_option_before_the_command_is_named_as_such(capsys: pytest.CaptureFixture[str]) -> None:
    err = usage_error(capsys, "--summary", "s.json", "run", CORNER)
    assert err.startswith("usage: fsmctl run ")
    assert ("fsmctl run: error: --summary is an option of `fsmctl run`: put it after the command "
            "(fsmctl run ... --summary ...)") in err


def test_a_misspelt_top_level_option_and_command(capsys: pytest.CaptureFixture[str]) -> None:
    err = usage_error(capsys, "--plugn", "x.py", "run", CORNER)
    assert err.rstrip().endswith("fsmctl: error: unrecognized option --plugn; did you mean --plugin?")
    err = usage_error(capsys, "rn", CORNER)
    assert err.rstrip().endswith("did you mean 'run'?") and "invalid choice: 'rn'" in err
    err = usage_error(capsys, "validate", CORNER, "--format", "jsn")
    assert err.startswith("usage: fsmctl validate") and err.rstrip().endswith("did you mean 'json'?")


def test_help_lists_the_exit_statuses(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["--help"])
    out = capsys.readouterr().out
    assert "exit status:\n  0    success\n  1    a document is invalid or a run failed" in out
    assert "  2    command-line usage error\n  130  a run stopped by Ctrl-C or SIGTERM" in out
    assert "--traceback" in out and "FSM_TRACEBACK=1" in out


def test_a_misspelt_set_names_the_states_type_at_exit_2(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    code, _, err = fsmctl(capsys, "run", CORNER, "--set", "follow.sped=1")
    assert code == 2
    assert err == ("fsmctl: error: --set follow.sped=1: 'follow' (FollowWall) has no parameter 'sped'; "
                   "did you mean 'speed'?\n")
    code, _, err = fsmctl(capsys, "sweep", "--machine", CORNER, "--set", "follow.sped=1,2", "-o",
                          str(tmp_path / "out"))
    assert code == 2
    assert err == ("fsmctl sweep: error: --set follow.sped=1,2: 'follow' (FollowWall) has no parameter 'sped'; "
                   "did you mean 'speed'?\n")
    assert not (tmp_path / "out").exists()


def test_expect_on_an_unfinished_run_says_so(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    doc = tmp_path / "idle.json"
    doc.write_text(json.dumps({"initial": "a", "states": [{"id": "a", "type": "Idle"}]}))
    code, _, err = fsmctl(capsys, "run", str(doc), "--duration", "0.5", "--expect", "succeeded", "-q")
    assert code == 1
    assert err == ("fsmctl run: expected outcome 'succeeded', not finished after 0.5 s (--duration sets how long it "
                   "may run)\n")


class _Sim:
    now = 12.5
    active_path = "turn/arc"

    class car:  # noqa: N801 (a stand-in for the simulation's car)
        distance = 9.75


def test_progress_is_a_bar_against_a_set_limit_and_a_spinner_otherwise(monkeypatch: pytest.MonkeyPatch) -> None:
    err = io.StringIO()
    monkeypatch.setattr(sys, "stderr", err)
    ProgressBar(25.0, cap=25.0)(_Sim())
    assert err.getvalue().startswith("\r[###############---------------]    12.5 s      9.8 m  turn/arc")
    err.truncate(0)
    err.seek(0)
    ProgressBar(None, cap=600.0)(_Sim())
    line = err.getvalue()
    assert line[1] in "|/-\\" and "12.5 s" in line and line.endswith("(until the machine ends, at most 600 s)")


# -- tracebacks ------------------------------------------------------------------------------------------------------
@pytest.fixture
def crash(tmp_path: Path) -> Path:
    (tmp_path / "crash.py").write_text(CRASH)
    (tmp_path / "m.json").write_text(json.dumps({"initial": "go", "states": [{"id": "go", "type": "Crash"}]}))
    (tmp_path / "m.scenario.json").write_text(json.dumps({"machine": "m.json", "plugins": ["crash.py"],
                                                          "duration": 1, "expect": [{"visits": ["go"]}]}))
    return tmp_path


def _cli(folder: Path, *argv: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    import os

    return subprocess.run([sys.executable, "-m", "fsm.tools.cli", *argv], cwd=folder, capture_output=True, text=True,
                          timeout=120, env={**{k: v for k, v in os.environ.items() if k != "FSM_TRACEBACK"},
                                            **(env or {})})


def test_user_code_exceptions_name_file_and_line(crash: Path) -> None:
    proc = _cli(crash, "--plugin", "crash.py", "run", "m.json")
    assert proc.returncode == 1
    assert proc.stderr == ("fsmctl run: m.json: state 'go' raised AttributeError in on_enter at tick 0 (t=0.0000 s): "
                           f"'Context' object has no attribute 'missing' (at {crash / 'crash.py'}:5)\n")


@pytest.mark.parametrize("how", ["flag", "env"])
def test_the_whole_traceback_when_asked(crash: Path, how: str) -> None:
    argv = ["--traceback"] * (how == "flag") + ["--plugin", "crash.py", "run", "m.json"]
    proc = _cli(crash, *argv, env={"FSM_TRACEBACK": "1"} if how == "env" else None)
    assert proc.returncode == 1
    assert proc.stderr.startswith("Traceback (most recent call last):")
    assert f'File "{crash / "crash.py"}", line 13, in on_enter' in proc.stderr
    assert f'File "{crash / "crash.py"}", line 5, in helper' in proc.stderr
    assert proc.stderr.splitlines()[-1].startswith("fsmctl run: m.json: state 'go' raised AttributeError")


def test_a_usage_error_with_traceback_shows_where_it_was_raised(crash: Path) -> None:
    proc = _cli(crash, "--traceback", "--plugin", "nonexistent.py", "types")
    assert proc.returncode == 2
    assert proc.stderr.startswith("Traceback (most recent call last):") and "registry.py" in proc.stderr
    assert proc.stderr.splitlines()[-1] == ("fsmctl: error: --plugin nonexistent.py: no such file; give a .py file "
                                            "or a module name")


def test_fsmctl_test_shows_the_failing_plugins_place_and_traceback(crash: Path) -> None:
    plain = _cli(crash, "test", "m.scenario.json")
    assert plain.returncode == 1 and "Traceback" not in plain.stderr
    assert f"(at {crash / 'crash.py'}:5)" in plain.stdout
    traced = _cli(crash, "--traceback", "test", "m.scenario.json")
    assert traced.returncode == 1
    assert f'File "{crash / "crash.py"}", line 5, in helper' in traced.stderr


def test_a_scenarios_broken_plugin_shows_its_frames_when_asked(crash: Path) -> None:
    (crash / "broken.py").write_text("import json\n\n\ndef f():\n    return 1 / 0\n\n\nf()\n")
    (crash / "b.scenario.json").write_text(json.dumps({"machine": "m.json", "plugins": ["broken.py"],
                                                       "duration": 1, "expect": [{"visits": ["go"]}]}))
    plain = _cli(crash, "test", "b.scenario.json")
    assert plain.returncode == 1 and "Traceback" not in plain.stderr
    assert f"(it failed at {crash / 'broken.py'}:5)" in plain.stderr
    traced = _cli(crash, "--traceback", "test", "b.scenario.json")
    assert traced.returncode == 1
    assert f'File "{crash / "broken.py"}", line 5, in f' in traced.stderr and "ZeroDivisionError" in traced.stderr


def test_a_broken_plugin_import_shows_its_own_frames(crash: Path) -> None:
    (crash / "broken.py").write_text("import json\n\n\ndef f():\n    return 1 / 0\n\n\nf()\n")
    proc = _cli(crash, "--traceback", "--plugin", "broken.py", "types")
    assert proc.returncode == 1
    assert f'File "{crash / "broken.py"}", line 5, in f' in proc.stderr and "ZeroDivisionError" in proc.stderr
    assert proc.stderr.splitlines()[-1].startswith(f"{crash / 'broken.py'}:5: error: plugin broken.py:")


def test_a_scenario_without_a_world_is_told_one_that_exists_from_where_it_is(tmp_path: Path,
                                                                            capsys: pytest.CaptureFixture[str]) -> None:
    import shutil

    (tmp_path / "machines" / "worlds").mkdir(parents=True)
    shutil.copy(CORNER, tmp_path / "machines" / "turn.json")
    shutil.copy(REPO / "diagrams" / "worlds" / "hallway.json", tmp_path / "machines" / "worlds")
    (tmp_path / "scenarios").mkdir()
    scenario = tmp_path / "scenarios" / "turn.scenario.json"
    scenario.write_text(json.dumps({"machine": "../machines/turn.json", "duration": 1,
                                    "expect": [{"visits": ["follow"]}]}))
    code, _, err = fsmctl(capsys, "test", str(scenario))
    assert code == 1
    hint = '"world": "../machines/worlds/hallway.json", the world fsmctl run takes for this machine, relative to'
    assert f"this machine drives the car; name the world to drive it in (add {hint}" in err
    assert (scenario.parent / "../machines/worlds/hallway.json").is_file()
