"""Hostile inputs and arguments: files that are not regular files, too big, unreadable paths; standard input as
``-``; tick counts and video settings beyond sense; each file read once; the palette in ``validate``; the README's
CI snippet as written; ``--max-collisions``. One line per error, the right exit code, never a traceback."""

from __future__ import annotations

import io
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from helpers import cli

REPO = Path(__file__).resolve().parents[1]
EXAMPLES = REPO / "diagrams" / "examples"
BLINK = {"initial": "a", "states": [{"id": "a", "type": "Idle"}, {"id": "b", "type": "Final"}],
         "transitions": [{"type": "Timeout", "from": "a", "to": "b", "seconds": 0.05}]}
CRASH = {"initial": "go", "states": [{"id": "go", "type": "Motor", "speed": 1.0, "steering": -1.0, "distance": 3.0},
                                     {"id": "done", "type": "Final"}],
         "transitions": [{"type": "Finished", "from": "go", "to": "done"}]}


@pytest.fixture
def blink(tmp_path: Path) -> Path:
    path = tmp_path / "blink.json"
    path.write_text(json.dumps(BLINK))
    return path


# -- inputs that are not regular files ------------------------------------------------------------------
def _make(kind: str, tmp_path: Path) -> str:
    if kind == "fifo":
        os.mkfifo(tmp_path / "fifo")  # no writer: reading it would hang
        return str(tmp_path / "fifo")
    if kind == "loop":
        (tmp_path / "l1").symlink_to(tmp_path / "l2")
        (tmp_path / "l2").symlink_to(tmp_path / "l1")
        return str(tmp_path / "l1")
    if kind == "dangling":
        (tmp_path / "d.json").symlink_to(tmp_path / "gone.json")
        return str(tmp_path / "d.json")
    return {"dev_zero": "/dev/zero", "dir": str(tmp_path), "missing": str(tmp_path / "no.json"),
            "long": str(tmp_path / ("y" * 300 + ".json")), "nul": str(tmp_path / "a\0.json"),
            "below_file": str(Path(__file__) / "x.json")}[kind]


KINDS = ["dev_zero", "fifo", "dir", "loop", "dangling", "missing", "long", "nul", "below_file"]
WORDS = {"dev_zero": "not a regular file (a device)", "fifo": "not a regular file (a FIFO)",
         "dir": "is a directory", "loop": "symlink loop", "dangling": "symlink to a missing file",
         "missing": "not found", "long": "too long", "nul": "not a usable file name", "below_file": "not found"}


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("command", ["validate", "run", "graph", "export", "convert", "world"])
def test_input_that_cannot_be_read(kind: str, command: str, tmp_path: Path, blink: Path,
                                   capsys: pytest.CaptureFixture[str]) -> None:
    path = _make(kind, tmp_path)
    argv = {"validate": ["validate", path], "run": ["run", path], "graph": ["graph", path],
            "export": ["export", path, "-o", str(tmp_path / "o.uxf")],
            "convert": ["convert", path, "-o", str(tmp_path / "o.json")],
            "world": ["run", str(blink), "--world", path]}[command]
    code, _out, err = cli(capsys, *argv)
    assert code == 1, err
    assert WORDS[kind] in err, err
    assert len(err.strip().splitlines()) == 1
    assert not (tmp_path / "o.uxf").exists() and not (tmp_path / "o.json").exists()


def test_size_cap(tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch) -> None:
    big = tmp_path / "big.json"
    big.write_text(json.dumps(BLINK) + " " * 5000)
    monkeypatch.setenv("FSM_MAX_INPUT_BYTES", "4096")
    for argv in (["validate", str(big)], ["run", str(big)]):
        code, _, err = cli(capsys, *argv)
        assert code == 1 and "too big" in err and "FSM_MAX_INPUT_BYTES" in err
    monkeypatch.setenv("FSM_MAX_INPUT_BYTES", str(1 << 20))
    assert cli(capsys, "validate", str(big))[0] == 0


def test_default_cap_is_above_the_benchmarks_52_mb() -> None:
    from fsm.loading.reading import MAX_INPUT_BYTES

    assert MAX_INPUT_BYTES >= 60 * 1024 * 1024


# -- standard input -------------------------------------------------------------------------------------
def _stdin(monkeypatch: pytest.MonkeyPatch, data: bytes) -> None:
    monkeypatch.setattr(sys, "stdin", io.TextIOWrapper(io.BytesIO(data)))


def test_validate_and_run_read_standard_input(monkeypatch: pytest.MonkeyPatch,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    _stdin(monkeypatch, json.dumps(BLINK).encode())
    code, out, _ = cli(capsys, "validate", "-")
    assert code == 0 and out == "<stdin>: ok\n"
    _stdin(monkeypatch, json.dumps(BLINK).encode())
    code, out, _ = cli(capsys, "run", "-")
    assert code == 0 and out.startswith("<stdin>: outcome succeeded")
    _stdin(monkeypatch, (EXAMPLES / "blinker.uxf").read_bytes())
    code, out, _ = cli(capsys, "validate", "-")
    assert code == 0 and out == "<stdin>: ok\n"


def test_standard_input_problems_are_named_stdin(monkeypatch: pytest.MonkeyPatch,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    _stdin(monkeypatch, b'{"initial": "a",\n "states": [{"id": "a", "type": "Idel"}]}')
    code, _, err = cli(capsys, "validate", "-")
    assert code == 1 and err.startswith("<stdin>:2:")
    _stdin(monkeypatch, b"<diagram><broken")
    code, _, err = cli(capsys, "validate", "-")
    assert code == 1 and err.startswith("<stdin>")
    _stdin(monkeypatch, b"x" * 5000)
    monkeypatch.setenv("FSM_MAX_INPUT_BYTES", "1000")
    code, _, err = cli(capsys, "run", "-")
    assert code == 1 and "too big" in err


def test_standard_input_is_read_once(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    _stdin(monkeypatch, json.dumps(BLINK).encode())
    code, out, _ = cli(capsys, "validate", "-", "-")
    assert code == 0 and out == "<stdin>: ok\n<stdin>: ok\n"


# -- each file read once -------------------------------------------------------------------------------
def _count_opens(monkeypatch: pytest.MonkeyPatch) -> dict[str, int]:
    import fsm.loading.reading

    counts: dict[str, int] = {}
    real_open = os.open
    real_read_bytes = Path.read_bytes

    def counting_open(path: object, *a: object, **k: object) -> int:
        counts[os.path.basename(str(path))] = counts.get(os.path.basename(str(path)), 0) + 1
        return real_open(path, *a, **k)  # type: ignore[arg-type]

    def counting_read_bytes(self: Path) -> bytes:
        counts[self.name] = counts.get(self.name, 0) + 1
        return real_read_bytes(self)

    monkeypatch.setattr(fsm.loading.reading.os, "open", counting_open)
    monkeypatch.setattr(Path, "read_bytes", counting_read_bytes)
    return counts


@pytest.mark.parametrize("argv, name", [
    (["validate", str(EXAMPLES / "blinker.json")], "blinker.json"),
    (["validate", str(EXAMPLES / "blinker.uxf")], "blinker.uxf"),
    (["validate", str(REPO / "diagrams" / "worlds" / "hallway.json")], "hallway.json"),
    (["graph", str(EXAMPLES / "blinker.json")], "blinker.json"),
    (["graph", str(EXAMPLES / "blinker.uxf"), "--format", "dot"], "blinker.uxf"),
    (["export", str(EXAMPLES / "blinker.json"), "-o", "-"], "blinker.json"),
])
def test_each_file_is_read_once(argv: list[str], name: str, monkeypatch: pytest.MonkeyPatch,
                                capsys: pytest.CaptureFixture[str]) -> None:
    counts = _count_opens(monkeypatch)
    code, _, err = cli(capsys, *argv)
    assert code == 0, err
    assert counts.get(name) == 1, counts


# -- arguments beyond sense -----------------------------------------------------------------------------
@pytest.mark.parametrize("args, words", [
    (["--dt", "5e-324"], "ticks"),
    (["--dt", "1e-9"], "--max-ticks"),
    (["--duration", "1e308"], "ticks"),
    (["--dt", "nan"], "--dt"),
    (["--dt", "-1"], "--dt"),
    (["--max-ticks", "0"], "--max-ticks"),
    (["--max-ticks", "1.5"], "--max-ticks"),
    (["--fps", "0"], "--fps"),
    (["--fps", "1e9"], "--fps"),
    (["--fps", "nan"], "--fps"),
    (["--video-speed", "1e-300"], "--video-speed"),
    (["--video-speed", "inf"], "--video-speed"),
    (["--seed", "-1"], "--seed"),
    (["--seed", "99999999999999999999999"], "--seed"),
    (["--max-collisions", "-1"], "--max-collisions"),
    (["--plot", "x.jpg"], "suffix .png"),
    (["--plot", "x"], "suffix .png"),
    (["--video", "x.gif"], "unsupported video format"),
    (["--video", "noext"], "unsupported video format"),
    (["--signal", "a@inf"], "--signal"),
    (["--trace", ""], "empty file name"),
])
def test_usage_mistakes_exit_2(args: list[str], words: str, blink: Path, tmp_path: Path,
                               capsys: pytest.CaptureFixture[str]) -> None:
    before = sorted(os.listdir(tmp_path))
    code, out, err = cli(capsys, "run", str(blink), *args)
    assert code == 2 and words in err, err
    assert "outcome" not in out and sorted(os.listdir(tmp_path)) == before


@pytest.mark.parametrize("args", [["export", "{doc}", "-o", ""], ["export", "{doc}", "-o", "bad.json", "-o", ""],
                                  ["report", "{doc}", "-o", ""], ["schema", "-o", ""], ["palette", "-o", ""],
                                  ["schema", "--check", ""], ["palette", "--check", "-o", ""]])
def test_an_empty_output_name_is_a_usage_error_not_the_default(args: list[str], blink: Path, tmp_path: Path,
                                                                capsys: pytest.CaptureFixture[str],
                                                                monkeypatch: pytest.MonkeyPatch) -> None:
    """``-o ''`` names no file: refused, not taken as "no -o given" (export wrote FILE.uxf beside the document,
    schema and palette printed to standard output). Found by tests/test_cli_fuzz.py."""
    monkeypatch.chdir(tmp_path)
    before = sorted(os.listdir(tmp_path))
    code, out, err = cli(capsys, *(a.replace("{doc}", str(blink)) for a in args))
    assert code == 2 and "empty file name" in err, (code, err)
    assert out == "" and sorted(os.listdir(tmp_path)) == before


@pytest.mark.parametrize("args", [["--dt", "1e-9", "--max-ticks", "20"], ["--dt", "1e300"],
                                  ["--max-ticks", "99999999999999999999", "--duration", "0.1"],
                                  ["--dt", "5e-324", "--max-ticks", "3"]])
def test_extreme_but_explicit_runs_work(args: list[str], blink: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = cli(capsys, "run", str(blink), *args)
    assert code == 0, err


# -- validate: the palette and the README's CI snippet ---------------------------------------------------
def test_palette_is_recognised(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    palette = REPO / "diagrams" / "TRAL_State-Machine.uxf"
    code, out, _ = cli(capsys, "validate", str(palette))
    assert code == 0 and out.endswith(": ok\n")
    stale = tmp_path / "palette.uxf"
    stale.write_text(palette.read_text().replace("// ", "// stale ", 1))
    code, _, err = cli(capsys, "validate", str(stale))
    assert code == 1 and "palette" in err and "fsmctl palette -o" in err


def test_a_machine_is_not_taken_for_a_palette(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    for diagram in sorted((REPO / "diagrams").glob("*.uxf")) + sorted(EXAMPLES.glob("*.uxf")):
        if diagram.name == "TRAL_State-Machine.uxf":
            continue
        from fsm.loading.registry import default_registry
        from fsm.tools.umlet.palette import palette_problems

        assert palette_problems(diagram.read_bytes(), str(diagram), default_registry()) is None, diagram


def test_ci_snippet_works_as_written() -> None:
    """The documented GitHub Actions steps (docs/umlet.md, linked from the README) pass on this repository."""
    page = (REPO / "docs" / "umlet.md").read_text()
    commands = [ln.split("- run:", 1)[1].strip() for ln in page.splitlines()
                if ln.startswith("- run: ") and "fsmctl" in ln]
    assert commands == ["fsmctl validate --format github diagrams/*.uxf diagrams/*.json",
                        'for f in diagrams/*.uxf; do fsmctl convert --check "$f" || exit 1; done']
    env = dict(os.environ, PATH=str(Path(sys.executable).parent) + os.pathsep + os.environ.get("PATH", ""))
    for command in commands:
        proc = subprocess.run(command, shell=True, cwd=REPO, env=env, capture_output=True, text=True, timeout=300)
        assert proc.returncode == 0, command + "\n" + proc.stdout + proc.stderr
        assert "::error" not in proc.stdout and "Traceback" not in proc.stderr


def test_convert_of_the_palette_checks_it_instead(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    palette = REPO / "diagrams" / "TRAL_State-Machine.uxf"
    code, _, err = cli(capsys, "convert", "--check", str(palette))
    assert code == 0, err
    stale = tmp_path / "TRAL_State-Machine.uxf"
    stale.write_text(palette.read_text().replace("speed=", "speed_=", 1))
    code, _, err = cli(capsys, "convert", "--check", str(stale))
    assert code == 1 and "palette" in err and "fsmctl palette -o" in err
    code, _, err = cli(capsys, "convert", str(palette), "-o", str(tmp_path / "p.json"))
    assert code == 1 and "nothing to convert" in err and not (tmp_path / "p.json").exists()


# -- --max-collisions -----------------------------------------------------------------------------------
def test_collisions_fail_with_expect_or_max_collisions(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    crash = tmp_path / "crash.json"
    crash.write_text(json.dumps(CRASH))
    code, out, _ = cli(capsys, "run", str(crash), "--duration", "5")
    assert code == 0 and "1 collisions" in out  # collisions alone never fail a run
    code, _, err = cli(capsys, "run", str(crash), "--duration", "5", "--expect", "succeeded")
    assert code == 1 and "collided 1 time" in err
    code, _, err = cli(capsys, "run", str(crash), "--duration", "5", "--max-collisions", "0")
    assert code == 1 and "--max-collisions" in err
    code, _, _ = cli(capsys, "run", str(crash), "--duration", "5", "--expect", "succeeded", "--max-collisions", "1")
    assert code == 0


def test_no_car_no_collision_check(blink: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert cli(capsys, "run", str(blink), "--expect", "succeeded", "--max-collisions", "0")[0] == 0


def test_video_and_plot_to_devices(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    crash = tmp_path / "crash.json"
    crash.write_text(json.dumps(CRASH))
    code, _, err = cli(capsys, "run", str(crash), "--duration", "0.5", "--video", "/dev/null", "--plot", "/dev/null",
                       "--fps", "5")
    assert code == 0, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["crash.json"]
    shutil.rmtree(tmp_path / "nothing", ignore_errors=True)


def test_export_of_a_trace_without_mcap_says_how(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    """``fsmctl export TRACE.jsonl -o OUT.mcap`` (or without -o) read the trace as a machine document: "invalid JSON:
    Extra data" at its second line. It is a usage error that names --mcap, and writes nothing; --mcap works."""
    monkeypatch.chdir(tmp_path)
    doc = tmp_path / "m.json"
    doc.write_text(json.dumps({"initial": "a", "states": [{"id": "a", "type": "Idle"}]}), encoding="utf-8")
    assert cli(capsys, "run", str(doc), "--max-ticks", "5", "--trace", "t.jsonl", "-q")[0] == 0
    for argv in (["export", "t.jsonl", "-o", "t.mcap"], ["export", "t.jsonl"], ["export", str(doc), "-o", "x.mcap"]):
        code, _out, err = cli(capsys, *argv)
        assert code == 2 and "--mcap" in err and "invalid JSON" not in err, (argv, err)
        assert err.count("\n") == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.json", "t.jsonl"]
    assert cli(capsys, "export", "t.jsonl", "--mcap", "t.mcap")[0] == 0 and (tmp_path / "t.mcap").stat().st_size


@pytest.mark.parametrize("command", ["validate", "run", "graph"])
def test_a_trace_given_as_a_document_is_named_a_trace(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                      monkeypatch: pytest.MonkeyPatch, command: str) -> None:
    """A trace where a document belongs said "invalid JSON: Extra data" at its second line; it is named for what it
    is, with the commands that read traces. Other JSON Lines keep the JSON reader's own words."""
    monkeypatch.chdir(tmp_path)
    doc = tmp_path / "m.json"
    doc.write_text(json.dumps({"initial": "a", "states": [{"id": "a", "type": "Idle"}]}), encoding="utf-8")
    assert cli(capsys, "run", str(doc), "--max-ticks", "5", "--trace", "t.jsonl", "-q")[0] == 0
    code, _out, err = cli(capsys, command, "t.jsonl")
    assert code == 1 and "t.jsonl:1:1: error: this is a run's trace" in err and "fsmctl report" in err, err
    (tmp_path / "lines.json").write_text('{"a": 1}\n{"b": 2}\n', encoding="utf-8")
    code, _out, err = cli(capsys, command, "lines.json")
    assert code == 1 and "lines.json:2:1: error: invalid JSON: Extra data" in err, err
