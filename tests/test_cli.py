"""``fsmctl``: validate/schema/types/run, their exit codes and outputs, usage errors without tracebacks,
nothing written for a bad document, and ``--plugin`` modules (in a subprocess, so the process-wide
registry of this test session stays untouched)."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import jsonschema
import pytest

import fsm
from fsm import RegistrationError, State, StateParams
from fsm.loading.registry import Registry, default_registry, register_state, using
from fsm.tools.cli import main
from helpers import cli

REPO = Path(__file__).resolve().parents[1]
COMMITTED_SCHEMA = REPO / "fsm" / "schema" / "machine.schema.json"
SUMMARY_KEYS = {"outcome", "finished", "ticks", "sim_time", "transitions", "visited", "vars"}

BLINK = {
    "name": "blink",
    "initial": "wait",
    "states": [
        {"id": "wait", "type": "Idle"},
        {"id": "go", "type": "Idle"},
        {"id": "done", "type": "Final", "outcome": "succeeded"},
    ],
    "transitions": [
        {"type": "Signal", "from": "wait", "to": "go", "signal": "start"},
        {"type": "Timeout", "from": "go", "to": "done", "seconds": 0.5},
    ],
}

BAD = (
    '{\n  "initial": "a",\n  "states": [\n    {"id": "a", "type": "Idle"},\n    {"id": "b", "type": "Idel"}\n'
    '  ],\n  "transitions": [\n    {"type": "Timeout", "from": "a", "to": "b", "seconds": -1}\n  ]\n}\n'
)

UNREACHABLE = {
    "initial": "a",
    "states": [{"id": "a", "type": "Idle"}, {"id": "b", "type": "Final"}, {"id": "island", "type": "Idle"}],
    "transitions": [{"type": "Timeout", "from": "a", "to": "b", "seconds": 0.1}],
}


@pytest.fixture
def blink(tmp_path: Path) -> Path:
    path = tmp_path / "blink.json"
    path.write_text(json.dumps(BLINK, indent=2))
    return path


@pytest.fixture
def bad(tmp_path: Path) -> Path:
    path = tmp_path / "bad.json"
    path.write_text(BAD)
    return path


@pytest.fixture
def unreachable(tmp_path: Path) -> Path:
    path = tmp_path / "unreachable.json"
    path.write_text(json.dumps(UNREACHABLE, indent=2))
    return path


def line_col(text: str, needle: str) -> tuple[int, int]:
    offset = text.index(needle)
    return text.count("\n", 0, offset) + 1, offset - (text.rfind("\n", 0, offset) + 1) + 1


# -- validate -------------------------------------------------------------------------------------------
def test_validate_valid_file_exits_0(capsys: pytest.CaptureFixture[str], blink: Path) -> None:
    code, out, err = cli(capsys, "validate", str(blink))
    assert code == 0
    assert f"{blink}: ok" in out
    assert err == ""


def test_validate_invalid_file_exits_1_with_every_problem(capsys: pytest.CaptureFixture[str], bad: Path) -> None:
    code, out, err = cli(capsys, "validate", str(bad))
    assert code == 1
    lines = err.strip().splitlines()
    assert len(lines) == 2
    assert lines[0].startswith(f"{bad}:%d:%d at /states/1/type" % line_col(BAD, '"type": "Idel"'))
    assert lines[1].startswith(f"{bad}:%d:%d at /transitions/0/seconds" % line_col(BAD, '"seconds"'))
    assert f"{bad}: 2 errors" in out


def test_validate_several_files_exits_1_if_any_is_invalid(capsys: pytest.CaptureFixture[str], blink: Path,
                                                          bad: Path) -> None:
    code, out, _err = cli(capsys, "validate", str(blink), str(bad))
    assert code == 1
    assert f"{blink}: ok" in out and f"{bad}: 2 errors" in out
    code, _out, _err = cli(capsys, "validate", str(blink), str(blink))
    assert code == 0


@pytest.mark.parametrize("argv", [
    ["validate"],                                   # no file
    ["validate", "--format", "xml", "x.json"],      # unknown format
    ["validate", "--no-such-option", "x.json"],     # unknown option
    ["frobnicate"],                                  # unknown command
    [],                                              # no command
])
def test_validate_usage_errors_exit_2(capsys: pytest.CaptureFixture[str], argv: list[str]) -> None:
    code, _out, err = cli(capsys, *argv)
    assert code == 2
    assert "usage" in err.lower()


def test_validate_missing_file_exits_1(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    code, _out, err = cli(capsys, "validate", str(tmp_path / "absent.json"))
    assert code == 1
    assert "not found" in err


def test_validate_format_json(capsys: pytest.CaptureFixture[str], blink: Path, bad: Path) -> None:
    code, out, _err = cli(capsys, "validate", "--format", "json", str(blink), str(bad))
    assert code == 1
    report = json.loads(out)
    assert [(r["file"], r["valid"]) for r in report] == [(str(blink), True), (str(bad), False)]
    assert report[0]["problems"] == []
    problems = report[1]["problems"]
    assert [(p["pointer"], p["line"], p["column"]) for p in problems] == [
        ("/states/1/type", *line_col(BAD, '"type": "Idel"')),
        ("/transitions/0/seconds", *line_col(BAD, '"seconds"')),
    ]
    for p in problems:
        assert set(p) >= {"severity", "file", "line", "column", "pointer", "element", "message", "hint"}
        assert p["severity"] == "error" and p["file"] == str(bad)
    assert problems[0]["element"] == "state 'b'"
    assert "Idle" in problems[0]["hint"]


GITHUB = re.compile(r"^::(error|warning) file=([^,]+),line=(\d+),col=(\d+)(?:,title=[^:]*)?::(.+)$")


def test_validate_format_github(capsys: pytest.CaptureFixture[str], bad: Path) -> None:
    code, out, _err = cli(capsys, "validate", "--format", "github", str(bad))
    assert code == 1
    lines = out.strip().splitlines()
    assert len(lines) == 2
    parsed = [GITHUB.match(line) for line in lines]
    assert all(parsed), lines
    assert [(m[1], m[2], int(m[3]), int(m[4])) for m in parsed if m] == [
        ("error", str(bad), *line_col(BAD, '"type": "Idel"')),
        ("error", str(bad), *line_col(BAD, '"seconds"')),
    ]
    assert parsed[0] and "unknown state type 'Idel'" in parsed[0][5] and "/states/1/type" in parsed[0][5]


def test_validate_format_github_warning(capsys: pytest.CaptureFixture[str], unreachable: Path) -> None:
    code, out, _err = cli(capsys, "validate", "--format", "github", str(unreachable))
    assert code == 0
    lines = out.strip().splitlines()
    assert len(lines) == 1
    m = GITHUB.match(lines[0])
    assert m and m[1] == "warning" and "island" in m[5]


def test_validate_format_github_escapes_newlines_in_messages(capsys: pytest.CaptureFixture[str],
                                                             tmp_path: Path) -> None:
    """A workflow command is one line: an id with a newline must be escaped (%0A), not break the line."""
    path = tmp_path / "nl.json"
    path.write_text(json.dumps({"initial": "a", "states": [{"id": "a", "type": "Idle"}],
                                "transitions": [{"type": "Always", "from": "a", "to": "x\ny"}]}))
    code, out, _err = cli(capsys, "validate", "--format", "github", str(path))
    assert code == 1
    lines = out.strip().splitlines()
    assert len(lines) == 1 and GITHUB.match(lines[0]) and "%0A" in lines[0]


def test_validate_strict_makes_warnings_errors(capsys: pytest.CaptureFixture[str], unreachable: Path) -> None:
    code, out, _err = cli(capsys, "validate", str(unreachable))
    assert code == 0
    assert "warning" in out and "island" in out and "1 warning" in out
    code, _out, err = cli(capsys, "validate", "--strict", str(unreachable))
    assert code == 1
    assert "error" in err and "island" in err


def test_validate_quiet_prints_problems_only(capsys: pytest.CaptureFixture[str], blink: Path, bad: Path) -> None:
    code, out, err = cli(capsys, "validate", "-q", str(blink), str(bad))
    assert code == 1
    assert out == ""
    assert len(err.strip().splitlines()) == 2


# -- schema ---------------------------------------------------------------------------------------------
def test_schema_prints_a_valid_json_schema(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _err = cli(capsys, "schema")
    assert code == 0
    schema = json.loads(out)
    jsonschema.Draft202012Validator.check_schema(schema)
    assert schema["$schema"] == "https://json-schema.org/draft/2020-12/schema"
    validator = jsonschema.Draft202012Validator(schema)
    assert validator.is_valid(BLINK)
    assert not validator.is_valid({**BLINK, "colour": "red"})


def test_schema_check_against_the_committed_file_passes(capsys: pytest.CaptureFixture[str]) -> None:
    code, _out, err = cli(capsys, "schema", "--check", str(COMMITTED_SCHEMA))
    assert code == 0, err


def test_schema_check_against_a_stale_file_fails(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    stale = tmp_path / "machine.schema.json"
    data = json.loads(COMMITTED_SCHEMA.read_text())
    data["description"] = "an old version"
    stale.write_text(json.dumps(data, indent=2) + "\n")
    code, _out, err = cli(capsys, "schema", "--check", str(stale))
    assert code == 1
    assert "stale" in err and f"fsmctl schema -o {stale}" in err


def test_schema_check_of_a_missing_file_fails_cleanly(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    code, _out, err = cli(capsys, "schema", "--check", str(tmp_path / "absent.json"))
    assert code == 1
    assert "absent.json" in err


def test_schema_output_writes_the_same_text(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    out_file = tmp_path / "schema.json"
    code, out, _err = cli(capsys, "schema", "-o", str(out_file))
    assert code == 0 and out == ""
    code, printed, _err = cli(capsys, "schema")
    assert out_file.read_text(encoding="utf-8") == printed
    code, _out, _err = cli(capsys, "schema", "--check", str(out_file))
    assert code == 0


def test_schema_output_into_a_missing_folder_is_a_usage_error(capsys: pytest.CaptureFixture[str],
                                                              tmp_path: Path) -> None:
    code, _out, err = cli(capsys, "schema", "-o", str(tmp_path / "no" / "such" / "schema.json"))
    assert code == 2
    assert "does not exist" in err


# -- types ----------------------------------------------------------------------------------------------
def test_types_lists_every_registered_type_with_parameters_and_defaults(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _err = cli(capsys, "types")
    assert code == 0
    registry = default_registry()
    listed = set(re.findall(r"^  (\w+)(?: \[finishes\])?: ", out, re.M))
    assert listed == set(registry.states) | set(registry.transitions) | set(registry.conditions)
    assert "\nConditions\n" in out
    for name in ("Idle", "Final", "FSMState", "Parallel", "Always", "Finished", "Timeout", "Signal", "Var",
                 "InState"):
        assert name in listed
    # parameters with their defaults (or "required")
    assert re.search(r"^\s+outcome: .*\(default \"succeeded\"\)", out, re.M)
    assert re.search(r"^\s+seconds: number > 0 \(required\)", out, re.M)
    assert re.search(r"^\s+edge: .*\(default \"rising\"\)", out, re.M)
    assert re.search(r"^\s+join: .*\(default \"all\"\)", out, re.M)
    assert "Final [finishes]" in out and "Idle [finishes]" not in out
    # a parameter without a default is left out, never written as null: it says so, not "default null"
    assert re.search(r"^\s+snap: number > 0, <= 180 \(optional\)", out, re.M) and "default null" not in out


def test_types_json_has_every_parameter_of_every_model(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _err = cli(capsys, "types", "--format", "json")
    assert code == 0
    rows = {(r["kind"], r["name"]): r for r in json.loads(out)}
    registry = default_registry()
    assert set(rows) == ({("state", n) for n in registry.states} | {("transition", n) for n in registry.transitions}
                         | {("condition", n) for n in registry.conditions})
    common = {"id", "type", "description", "layout", "from", "to", "priority", "preempt", "guard", "set",
              *StateParams.STEP_KEYS}
    for kind, name, cls in registry.every():
        row = rows[(kind, name)]
        assert row["kind"] == kind
        own = {f.alias or n for n, f in cls.Params.model_fields.items()} - common
        assert {p["name"] for p in row["params"]} == own, name
        for p in row["params"]:
            field = next(f for n, f in cls.Params.model_fields.items() if (f.alias or n) == p["name"])
            assert p["required"] == field.is_required()
            if not field.is_required() and field.default is not None:
                assert p["default"] == field.default
    assert rows[("state", "Final")]["can_finish"] is True and rows[("state", "Idle")]["can_finish"] is False


def test_types_with_names_shows_only_those(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _err = cli(capsys, "types", "Timeout")
    assert code == 0
    assert "Timeout" in out and "Signal" not in out and "Idle" not in out


def test_types_unknown_name_suggests(capsys: pytest.CaptureFixture[str]) -> None:
    code, _out, err = cli(capsys, "types", "Timout")
    assert code == 1
    assert "Timout" in err and "did you mean" in err and "Timeout" in err


# -- run ------------------------------------------------------------------------------------------------
def test_run_with_signal_trace_summary_expect(capsys: pytest.CaptureFixture[str], blink: Path,
                                             tmp_path: Path) -> None:
    trace, summary = tmp_path / "t.jsonl", tmp_path / "s.json"
    code, out, err = cli(capsys, "run", str(blink), "--signal", "start@1.0", "--trace", str(trace),
                         "--summary", str(summary), "--expect", "succeeded")
    assert code == 0, err
    assert "outcome succeeded" in out
    assert "wait -> go -> done" in out
    result = json.loads(summary.read_text())
    assert set(result) == SUMMARY_KEYS
    assert result["outcome"] == "succeeded" and result["finished"] is True
    assert result["ticks"] == 120 and result["sim_time"] == pytest.approx(1.5)
    assert result["transitions"] == 2
    assert result["visited"] == ["wait", "go", "done"]

    lines = [line for line in map(json.loads, trace.read_text().splitlines()) if line["type"] == "event"]
    assert lines, "empty trace"
    fired = []
    for line in lines:
        assert {"tick", "time", "transitions"} <= set(line)
        for t in line["transitions"]:
            assert set(t) >= {"tick", "time", "from", "to", "type"}
            assert t["tick"] == line["tick"]
            fired.append((t["tick"], t["time"], t["from"], t["to"], t["type"]))
    assert fired == [
        (0, 0.0, None, "wait", "initial"),
        (80, 1.0, "wait", "go", "Signal"),
        (120, 1.5, "go", "done", "Timeout"),
    ]
    assert len([f for f in fired if f[4] != "initial"]) == result["transitions"]


def test_run_max_ticks_stops_unfinished(capsys: pytest.CaptureFixture[str], blink: Path, tmp_path: Path) -> None:
    summary = tmp_path / "s.json"
    code, out, _err = cli(capsys, "run", str(blink), "--max-ticks", "10", "--summary", str(summary))
    assert code == 0
    assert "not finished" in out and "active: wait" in out
    result = json.loads(summary.read_text())
    assert set(result) == SUMMARY_KEYS
    assert result["ticks"] == 10 and result["finished"] is False and result["outcome"] is None


def test_run_duration_stops_at_machine_time(capsys: pytest.CaptureFixture[str], blink: Path, tmp_path: Path) -> None:
    summary = tmp_path / "s.json"
    code, _out, _err = cli(capsys, "run", str(blink), "--duration", "0.5", "--summary", str(summary))
    assert code == 0
    result = json.loads(summary.read_text())
    assert result["ticks"] == 40 and result["sim_time"] == pytest.approx(0.5)


def test_run_signal_after_the_duration_never_arrives(capsys: pytest.CaptureFixture[str], blink: Path,
                                                     tmp_path: Path) -> None:
    summary = tmp_path / "s.json"
    code, _out, _err = cli(capsys, "run", str(blink), "--duration", "2", "--signal", "start@1.8",
                           "--summary", str(summary))
    assert code == 0
    result = json.loads(summary.read_text())
    assert result["visited"] == ["wait", "go"] and result["finished"] is False


def test_run_expect_other_outcome_exits_1(capsys: pytest.CaptureFixture[str], blink: Path) -> None:
    code, _out, err = cli(capsys, "run", str(blink), "--signal", "start@0", "--expect", "aborted")
    assert code == 1
    assert "aborted" in err and "succeeded" in err


def test_run_expect_unfinished_exits_1(capsys: pytest.CaptureFixture[str], blink: Path) -> None:
    code, _out, _err = cli(capsys, "run", str(blink), "--max-ticks", "5", "--expect", "succeeded")
    assert code == 1


def test_run_quiet_prints_nothing(capsys: pytest.CaptureFixture[str], blink: Path) -> None:
    code, out, err = cli(capsys, "run", "-q", str(blink), "--signal", "start@0")
    assert code == 0 and out == "" and err == ""


@pytest.mark.parametrize("argv", [
    ["--signal", "start"],          # no @T
    ["--signal", "start@soon"],     # T not a number
    ["--signal", "start@-1"],       # negative time
    ["--signal", "@1"],             # no name
    ["--signal", "start=maybe@1"],  # bad value
    ["--duration", "-1"],
    ["--duration", "0"],
    ["--duration", "nan"],
    ["--max-ticks", "0"],
    ["--max-ticks", "ten"],
    ["--dt", "-0.01"],
])
def test_run_usage_errors_exit_2_without_traceback(capsys: pytest.CaptureFixture[str], blink: Path,
                                                   tmp_path: Path, argv: list[str]) -> None:
    summary = tmp_path / "s.json"
    code, out, err = cli(capsys, "run", str(blink), "--summary", str(summary), *argv)
    assert code == 2
    assert "error" in err
    assert not summary.exists()


def test_run_missing_file_exits_1(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    summary = tmp_path / "s.json"
    code, _out, err = cli(capsys, "run", str(tmp_path / "absent.json"), "--summary", str(summary))
    assert code == 1
    assert "not found" in err
    assert not summary.exists()


def test_run_output_into_a_missing_folder_is_a_usage_error(capsys: pytest.CaptureFixture[str], blink: Path,
                                                           tmp_path: Path) -> None:
    code, _out, err = cli(capsys, "run", str(blink), "--trace", str(tmp_path / "nope" / "t.jsonl"))
    assert code == 2
    assert "does not exist" in err


def test_run_bad_document_writes_nothing(capsys: pytest.CaptureFixture[str], bad: Path, tmp_path: Path) -> None:
    trace, summary = tmp_path / "t.jsonl", tmp_path / "s.json"
    code, out, err = cli(capsys, "run", str(bad), "--trace", str(trace), "--summary", str(summary))
    assert code == 1
    assert len(err.strip().splitlines()) == 2
    assert out == ""
    assert not trace.exists() and not summary.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.json"]


def test_plugin_of_a_missing_module_exits_2(capsys: pytest.CaptureFixture[str], blink: Path) -> None:
    code, _out, err = cli(capsys, "--plugin", "no_such_module_for_fsm_tests", "validate", str(blink))
    assert code == 2
    assert "no_such_module_for_fsm_tests" in err


# -- subprocess: the installed console script and python -m -------------------------------------------
def _fsmctl_exe() -> str:
    exe = Path(sys.executable).parent / "fsmctl"
    if exe.exists():
        return str(exe)
    found = shutil.which("fsmctl")
    assert found, "the fsmctl console script is not installed"
    return found


def _env(extra_path: Path | None = None) -> dict[str, str]:
    env = dict(os.environ)
    if extra_path is not None:
        env["PYTHONPATH"] = str(extra_path) + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    return env


def _run(argv: list[str], cwd: Path, extra_path: Path | None = None) -> subprocess.CompletedProcess[str]:
    proc = subprocess.run(argv, cwd=cwd, env=_env(extra_path), capture_output=True, text=True, timeout=120)
    assert "Traceback" not in proc.stderr and "Traceback" not in proc.stdout, proc.stderr
    return proc


def test_console_script_exit_codes(blink: Path, bad: Path, tmp_path: Path) -> None:
    exe = _fsmctl_exe()
    assert _run([exe, "validate", str(blink)], tmp_path).returncode == 0
    proc = _run([exe, "validate", "--format", "github", str(bad)], tmp_path)
    assert proc.returncode == 1
    assert all(GITHUB.match(line) for line in proc.stdout.strip().splitlines())
    assert _run([exe, "validate"], tmp_path).returncode == 2
    assert _run([exe, "run", str(blink), "--signal", "oops"], tmp_path).returncode == 2
    proc = _run([exe, "--plugin", "no_such_module_for_fsm_tests", "types"], tmp_path)
    assert proc.returncode == 2 and "no_such_module_for_fsm_tests" in proc.stderr


def test_python_dash_m_runs_a_machine(blink: Path, tmp_path: Path) -> None:
    summary = tmp_path / "s.json"
    proc = _run([sys.executable, "-m", "fsm.tools.cli", "run", str(blink), "--signal", "start@0.25",
                 "--summary", str(summary), "--expect", "succeeded"], tmp_path)
    assert proc.returncode == 0, proc.stderr
    result = json.loads(summary.read_text())
    assert set(result) == SUMMARY_KEYS and result["outcome"] == "succeeded" and result["ticks"] == 60


def test_console_script_bad_document_writes_nothing(bad: Path, tmp_path: Path) -> None:
    trace, summary = tmp_path / "t.jsonl", tmp_path / "s.json"
    proc = _run([_fsmctl_exe(), "run", str(bad), "--trace", str(trace), "--summary", str(summary)], tmp_path)
    assert proc.returncode == 1
    assert not trace.exists() and not summary.exists()


PLUGIN = '''
"""A third-party state type for the tests: finishes after `ticks` ticks with `outcome`."""
from pydantic import Field

from fsm import State, StateParams, register_state


@register_state
class CountDown(State):
    """Finishes after `ticks` ticks."""

    __slots__ = ("left",)
    can_finish = True
    outcomes = None

    class Params(StateParams):
        ticks: int = Field(default=3, gt=0, description="Ticks until it finishes.")
        outcome: str = Field(default="counted", description="The outcome.")

    @classmethod
    def possible_outcomes(cls, params):
        return {params.outcome}

    def on_enter(self, ctx):
        self.left = self.params.ticks

    def tick(self, ctx):
        self.left -= 1
        if self.left <= 0:
            self.finish(self.params.outcome)


@register_state
class Crash(State):
    """Raises in its tick."""

    __slots__ = ()

    def tick(self, ctx):
        raise RuntimeError("sensor unplugged")
'''

PLUGIN_DOC = {
    "initial": "count",
    "states": [
        {"id": "count", "type": "CountDown", "ticks": 5, "outcome": "zero"},
        {"id": "done", "type": "Final", "outcome": "landed"},
    ],
    "transitions": [{"type": "Finished", "from": "count", "to": "done", "outcome": "zero"}],
}


@pytest.fixture
def plugin_dir(tmp_path: Path) -> Path:
    folder = tmp_path / "plugins"
    folder.mkdir()
    (folder / "fsm_test_countdown.py").write_text(PLUGIN)
    (folder / "fsm_test_duplicate.py").write_text(textwrap.dedent('''
        from fsm import State, register_state

        @register_state
        class Idle(State):
            """Claims a built-in name."""
    '''))
    (folder / "fsm_test_broken.py").write_text("import fsm\nraise ImportError('half-installed dependency')\n")
    return folder


def test_plugin_registers_a_state_type_usable_in_a_document(plugin_dir: Path, tmp_path: Path) -> None:
    exe = _fsmctl_exe()
    doc = tmp_path / "count.json"
    doc.write_text(json.dumps(PLUGIN_DOC))
    summary = tmp_path / "s.json"

    proc = _run([exe, "validate", str(doc)], tmp_path, plugin_dir)  # without the plugin: unknown type
    assert proc.returncode == 1 and "unknown state type 'CountDown'" in proc.stderr

    proc = _run([exe, "--plugin", "fsm_test_countdown", "validate", str(doc)], tmp_path, plugin_dir)
    assert proc.returncode == 0, proc.stderr

    proc = _run([exe, "--plugin", "fsm_test_countdown", "run", str(doc), "--summary", str(summary),
                 "--expect", "landed"], tmp_path, plugin_dir)
    assert proc.returncode == 0, proc.stderr
    result = json.loads(summary.read_text())
    assert result["visited"] == ["count", "done"] and result["ticks"] == 5

    proc = _run([exe, "--plugin", "fsm_test_countdown", "types", "CountDown"], tmp_path, plugin_dir)
    assert proc.returncode == 0
    assert re.search(r"ticks: .*\(default 3\)", proc.stdout) and "CountDown [finishes]" in proc.stdout

    # the plugin's Params are checked like the built-ins'
    doc.write_text(json.dumps({**PLUGIN_DOC, "states": [{"id": "count", "type": "CountDown", "ticks": 0},
                                                        {"id": "done", "type": "Final"}]}))
    proc = _run([exe, "--plugin", "fsm_test_countdown", "validate", str(doc)], tmp_path, plugin_dir)
    assert proc.returncode == 1 and "/states/0/ticks" in proc.stderr


def test_plugin_finished_outcome_is_checked(plugin_dir: Path, tmp_path: Path) -> None:
    doc = tmp_path / "count.json"
    doc.write_text(json.dumps({**PLUGIN_DOC, "transitions": [
        {"type": "Finished", "from": "count", "to": "done", "outcome": "other"}]}))
    proc = _run([_fsmctl_exe(), "--plugin", "fsm_test_countdown", "validate", str(doc)], tmp_path, plugin_dir)
    assert proc.returncode == 1 and "never finishes with outcome 'other'" in proc.stderr


def test_plugin_with_a_duplicate_type_name_is_refused(plugin_dir: Path, tmp_path: Path, blink: Path) -> None:
    proc = _run([_fsmctl_exe(), "--plugin", "fsm_test_duplicate", "validate", str(blink)], tmp_path, plugin_dir)
    assert proc.returncode == 1
    assert "Idle" in proc.stderr and "already registered" in proc.stderr


def test_plugin_that_fails_to_import_is_one_line(plugin_dir: Path, tmp_path: Path, blink: Path) -> None:
    proc = _run([_fsmctl_exe(), "--plugin", "fsm_test_broken", "validate", str(blink)], tmp_path, plugin_dir)
    assert proc.returncode in (1, 2)
    assert "half-installed dependency" in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1


def test_state_raising_at_run_time_is_reported_with_path_and_tick(plugin_dir: Path, tmp_path: Path) -> None:
    doc = tmp_path / "crash.json"
    doc.write_text(json.dumps({"initial": "c", "states": [{"id": "c", "type": "Crash"}]}))
    summary = tmp_path / "s.json"
    proc = _run([_fsmctl_exe(), "--plugin", "fsm_test_countdown", "run", str(doc), "--summary", str(summary)],
                tmp_path, plugin_dir)
    assert proc.returncode == 1
    assert "'c'" in proc.stderr and "tick 1" in proc.stderr and "sensor unplugged" in proc.stderr
    result = json.loads(summary.read_text())
    assert result["error"]["state"] == "c" and result["error"]["tick"] == 1


# -- registration ---------------------------------------------------------------------------------------
def test_registering_a_duplicate_state_name_raises() -> None:
    registry = Registry()

    class Lamp(State):
        """A lamp."""

    class Lamp2(State):
        """Another lamp."""

    registry.add_state(Lamp)
    with pytest.raises(RegistrationError, match="already registered"):
        registry.add_state(Lamp2, "Lamp")
    assert registry.states["Lamp"] is Lamp


def test_registering_a_duplicate_by_decorator_raises() -> None:
    registry = Registry()
    with using(registry):
        @register_state
        class Beacon(State):
            """A beacon."""

        with pytest.raises(RegistrationError):
            @register_state(name="Beacon")
            class Other(State):
                """Another."""
    assert list(registry.states) == ["Beacon"]


def test_registering_a_duplicate_of_a_builtin_into_the_default_registry_raises() -> None:
    registry = default_registry()
    before = dict(registry.states)

    class Final(State):  # noqa: D401 - same name as the built-in
        """Not the real one."""

    with pytest.raises(RegistrationError, match="Final"):
        registry.add_state(Final)
    assert registry.states == before


def test_registering_a_state_without_state_params_raises() -> None:
    class Odd(State):
        """Params of the wrong base."""

        Params = fsm.TransitionParams  # type: ignore[assignment]

    with pytest.raises(RegistrationError):
        Registry().add_state(Odd)


def test_a_document_can_use_a_type_of_its_own_registry() -> None:
    registry = Registry()
    for _kind, name, cls in default_registry():
        (registry.add_state if _kind == "state" else registry.add_transition)(cls, name)

    class Lamp(State):
        """A lamp."""

        class Params(StateParams):
            watts: float = 5.0

    registry.add_state(Lamp)
    machine = fsm.load({"initial": "l", "states": [{"id": "l", "type": "Lamp", "watts": 7.5}]}, registry=registry)
    fsm.run(machine, max_ticks=3)
    assert machine.active_path == "l"
    with pytest.raises(fsm.DiagramError, match="unknown state type 'Lamp'"):
        fsm.load({"initial": "l", "states": [{"id": "l", "type": "Lamp"}]})  # not in the default registry


def test_validate_checks_world_files_as_worlds(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A world file is validated as a world (not reported as a machine missing 'states')."""
    from fsm.tools.cli import main

    repo = Path(__file__).resolve().parents[1]
    assert main(["validate", str(repo / "diagrams" / "worlds" / "hallway.json")]) == 0
    bad = tmp_path / "world.json"
    bad.write_text('{"walls": [{"points": [[0, 0], [4, 0]]}],\n "start": {"x": 1, "y": NaN, "heading": 0}}\n')
    capsys.readouterr()
    assert main(["validate", str(bad)]) == 1
    err = capsys.readouterr().err
    assert f"{bad}:2:" in err and "/start/y" in err and "states" not in err


def test_every_committed_diagram_and_world_validates_strictly(capsys: pytest.CaptureFixture[str]) -> None:
    """What a user's CI would run over this repository: every machine, diagram and world is clean."""
    from fsm.tools.cli import main

    diagrams = Path(__file__).resolve().parents[1] / "diagrams"
    files = [p for p in sorted(diagrams.rglob("*")) if p.suffix in (".json", ".uxf")
             and p.name != "TRAL_State-Machine.uxf"]  # the palette is a palette, not a machine
    assert len(files) > 15
    plugin = diagrams.parent / "examples" / "eeros" / "eeros_plant.py"  # the EEROS cases' plants and steps
    assert main(["--plugin", str(plugin), "validate", "--strict", *map(str, files)]) == 0, capsys.readouterr().err


def test_signal_warnings_name_a_typo_and_a_time_after_the_end(capsys: pytest.CaptureFixture[str]) -> None:
    mission = str(Path(__file__).resolve().parents[1] / "diagrams" / "examples" / "mission.json")
    code = main(["run", mission, "--signal", "strat@0.5", "--signal", "gripped@1", "--signal", "start@900",
                 "--max-ticks", "100"])
    err = capsys.readouterr().err
    assert code == 0
    assert "warning: --signal strat:" in err and "did you mean start?" in err
    assert "warning: --signal start@900: after the end of the run (1.25 s" in err
    assert "gripped" not in err  # read by the machine, and in time
    code = main(["run", mission, "--signal", "start@0.5", "--signal", "gripped@3"])
    assert code == 0 and "warning" not in capsys.readouterr().err
