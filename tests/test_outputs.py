"""The output writer (:mod:`fsm.tools.files`) and every command's outputs through it: one test per kind of path
(regular file, symlink, hard link, device node, FIFO, standard output, read-only folder as root and as an
unprivileged user, same file as an input, two writers at once); the user's other files are never touched."""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import stat
import subprocess
import sys
import tempfile
import threading
from pathlib import Path

import pytest

from fsm.model.errors import FsmError, UsageError
from fsm.tools.files import Output, Outputs, write_output
from helpers import cli

REPO = Path(__file__).resolve().parents[1]
EXAMPLES = REPO / "diagrams" / "examples"
FSMCTL = str(Path(sys.executable).parent / "fsmctl")
BLINK = {
    "name": "blink",
    "initial": "wait",
    "states": [{"id": "wait", "type": "Idle"}, {"id": "done", "type": "Final"}],
    "transitions": [{"type": "Timeout", "from": "wait", "to": "done", "seconds": 0.05}],
}


def snapshot(folder: Path) -> dict[str, str]:
    """Every file below ``folder`` (not following symlinks) with a hash of its content or its link target."""
    out = {}
    for p in sorted(folder.rglob("*")):
        rel = str(p.relative_to(folder))
        if p.is_symlink():
            out[rel] = "-> " + os.readlink(p)
        elif p.is_file():
            out[rel] = hashlib.sha256(p.read_bytes()).hexdigest()
        elif p.is_dir():
            out[rel] = "dir"
        else:
            out[rel] = "special"
    return out


@pytest.fixture
def blink(tmp_path: Path) -> Path:
    path = tmp_path / "blink.json"
    path.write_text(json.dumps(BLINK))
    return path


# -- regular files -------------------------------------------------------------------------------------
def test_regular_file_is_replaced_whole_keeping_its_mode(tmp_path: Path) -> None:
    target = tmp_path / "out.json"
    target.write_text("old")
    os.chmod(target, 0o640)
    inode = target.stat().st_ino
    write_output(str(target), "new\n")
    assert target.read_text() == "new\n"
    assert stat.S_IMODE(target.stat().st_mode) == 0o640
    assert target.stat().st_ino != inode  # renamed over, not rewritten in place
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.json"]  # no temporary file left


def test_new_file_gets_the_umask_mode(tmp_path: Path) -> None:
    target = tmp_path / "new.txt"
    write_output(str(target), "x")
    mask = os.umask(0)
    os.umask(mask)
    assert stat.S_IMODE(target.stat().st_mode) == 0o666 & ~mask


def test_discarded_output_leaves_the_old_file(tmp_path: Path) -> None:
    target = tmp_path / "keep.txt"
    target.write_text("precious")
    out = Output(str(target), "-o").open()
    out.write("half")
    out.discard()
    assert target.read_text() == "precious"
    assert [p.name for p in tmp_path.iterdir()] == ["keep.txt"]


def test_symlink_is_followed_and_stays_a_link(tmp_path: Path) -> None:
    real = tmp_path / "real" / "data.json"
    real.parent.mkdir()
    real.write_text("old")
    link = tmp_path / "link.json"
    link.symlink_to(real)
    write_output(str(link), "new")
    assert link.is_symlink() and os.readlink(link) == str(real)
    assert real.read_text() == "new"
    assert sorted(p.name for p in real.parent.iterdir()) == ["data.json"]


def test_hard_linked_file_is_refused_and_left_alone(tmp_path: Path, blink: Path,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    a = tmp_path / "a.json"
    a.write_text("shared")
    os.link(a, tmp_path / "b.json")
    code, _, err = cli(capsys, "run", str(blink), "--summary", str(a))
    assert code == 2 and "hard links" in err and err.count("\n") == 1
    assert a.read_text() == "shared" and (tmp_path / "b.json").read_text() == "shared"


# -- devices, FIFOs, standard output -------------------------------------------------------------------
@pytest.mark.skipif(not os.path.exists("/dev/null"), reason="no /dev/null")
def test_dev_null_is_written_not_replaced(blink: Path, capsys: pytest.CaptureFixture[str]) -> None:
    before = os.stat("/dev/null")
    code, _, _ = cli(capsys, "run", str(blink), "--trace", "/dev/null", "--summary", "/dev/null")
    assert code == 0
    after = os.stat("/dev/null")
    assert stat.S_ISCHR(after.st_mode) and after.st_ino == before.st_ino and after.st_rdev == before.st_rdev


def test_character_device_made_with_mknod_is_written_directly(tmp_path: Path, blink: Path,
                                                                capsys: pytest.CaptureFixture[str]) -> None:
    node = tmp_path / "null"
    try:
        os.mknod(node, 0o666 | stat.S_IFCHR, os.makedev(1, 3))  # the null device
        with open(node, "w") as fh:
            fh.write("probe")
    except (PermissionError, OSError) as exc:
        pytest.skip(f"mknod not permitted here: {exc}")
    code, _, _ = cli(capsys, "run", str(blink), "--trace", str(node))
    assert code == 0 and stat.S_ISCHR(node.stat().st_mode)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["blink.json", "null"]


def test_fifo_is_written_directly(tmp_path: Path, blink: Path, capsys: pytest.CaptureFixture[str]) -> None:
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    got: list[bytes] = []
    reader = threading.Thread(target=lambda: got.append(fifo.read_bytes()), daemon=True)
    reader.start()
    code, _, _ = cli(capsys, "run", str(blink), "--summary", str(fifo))
    reader.join(10)
    assert code == 0 and stat.S_ISFIFO(fifo.stat().st_mode)
    assert json.loads(got[0])["outcome"] == "succeeded"


def test_dash_is_standard_output_and_the_report_moves_to_stderr(blink: Path,
                                                                 capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = cli(capsys, "run", str(blink), "--summary", "-")
    assert code == 0 and json.loads(out)["outcome"] == "succeeded"
    assert "outcome succeeded" in err
    code, out, _ = cli(capsys, "run", str(blink), "--trace", "-", "-q")
    assert code == 0 and all(json.loads(line) for line in out.splitlines())


def test_one_standard_output_per_run(blink: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = cli(capsys, "run", str(blink), "--summary", "-", "--trace", "/dev/stdout")
    assert code == 2 and "standard output is already taken" in err


def test_binary_output_to_a_terminal_is_a_usage_error(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(sys.stdout, "isatty", lambda: True, raising=False)
    with pytest.raises(UsageError, match="terminal"):
        Output("-", "--video", binary=True).open()


def test_dev_fd_that_is_not_open_is_a_usage_error(blink: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = cli(capsys, "run", str(blink), "--summary", "/dev/fd/97")
    assert code == 2 and "not open" in err


def test_write_error_is_one_line(blink: Path, capsys: pytest.CaptureFixture[str]) -> None:
    if not os.path.exists("/dev/full"):
        pytest.skip("no /dev/full")
    code, _, err = cli(capsys, "run", str(blink), "--summary", "/dev/full")
    assert code == 1 and "No space left" in err and err.count("\n") == 1


# -- paths that cannot be outputs: refused before anything runs -----------------------------------------
@pytest.mark.parametrize("make", ["directory", "missing folder", "proc", "too long", "nul", "below a file"])
def test_unusable_output_is_a_usage_error_before_the_run(make: str, tmp_path: Path, blink: Path,
                                                         capsys: pytest.CaptureFixture[str]) -> None:
    target = {"directory": str(tmp_path), "missing folder": str(tmp_path / "nope" / "t.jsonl"),
              "proc": "/proc/fsmctl-test.jsonl", "too long": str(tmp_path / ("x" * 300)),
              "nul": str(tmp_path / "a\0b"), "below a file": str(blink / "t.jsonl")}[make]
    before = snapshot(tmp_path)
    code, out, err = cli(capsys, "run", str(blink), "--trace", target)
    assert code == 2, err
    assert err.startswith("fsmctl: error: --trace") and err.count("\n") == 1
    assert "outcome" not in out  # the run never started
    assert snapshot(tmp_path) == before


def test_read_only_folder_as_root_or_user(tmp_path: Path, blink: Path, capsys: pytest.CaptureFixture[str]) -> None:
    folder = tmp_path / "ro"
    folder.mkdir()
    os.chmod(folder, 0o555)
    try:
        code, _, err = cli(capsys, "run", str(blink), "--trace", str(folder / "t.jsonl"))
        if os.geteuid() == 0:
            assert code == 0  # root writes anyway: permission bits do not bind it
        else:
            assert code == 2 and "cannot create a file" in err
    finally:
        os.chmod(folder, 0o755)


def _unprivileged() -> list[str] | None:
    if os.geteuid() != 0:
        return []
    setpriv = shutil.which("setpriv")
    try:
        import pwd

        pwd.getpwnam("nobody")
    except (ImportError, KeyError):
        return None
    if setpriv is None:
        return None
    return [setpriv, "--reuid=nobody", "--regid=nogroup", "--clear-groups"]


def test_read_only_folder_as_an_unprivileged_user() -> None:
    prefix = _unprivileged()
    if prefix is None:
        pytest.skip("no unprivileged user to run as")
    base = Path(tempfile.mkdtemp(prefix="fsmctl-ro-"))
    try:
        os.chmod(base, 0o755)
        (base / "blink.json").write_text(json.dumps(BLINK))
        os.chmod(base / "blink.json", 0o644)
        (base / "ro").mkdir()
        os.chmod(base / "ro", 0o555)
        probe = subprocess.run(prefix + [FSMCTL, "--version"], capture_output=True, text=True, timeout=60)
        if probe.returncode != 0:
            pytest.skip(f"cannot run fsmctl as nobody: {probe.stderr.strip()[:200]}")
        proc = subprocess.run(prefix + [FSMCTL, "run", "blink.json", "--trace", "ro/t.jsonl", "--summary", "s.json"],
                              cwd=base, capture_output=True, text=True, timeout=60)
        assert proc.returncode == 2, proc.stderr
        assert "Traceback" not in proc.stderr
        assert proc.stderr.startswith("fsmctl: error: --trace ro/t.jsonl: cannot create a file") and \
            "Permission denied" in proc.stderr
        assert list((base / "ro").iterdir()) == []
    finally:
        os.chmod(base / "ro", 0o755)
        shutil.rmtree(base)


# -- the same file as an input ---------------------------------------------------------------------------
def test_output_same_as_input_is_refused(tmp_path: Path, blink: Path, capsys: pytest.CaptureFixture[str],
                                         monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    link = tmp_path / "alias.json"
    link.symlink_to(blink)
    sub = tmp_path / "sub"
    sub.mkdir()
    before = snapshot(tmp_path)
    for argv in (["run", "blink.json", "--trace", "blink.json"],
                 ["run", str(blink), "--summary", "alias.json"],
                 ["run", "alias.json", "--summary", "sub/../blink.json"],
                 ["graph", "blink.json", "-o", "./blink.json"],
                 ["export", "alias.json", "-o", "blink.json"]):
        code, _, err = cli(capsys, *argv)
        assert code == 2 and "is the same file as the input" in err, (argv, err)
    assert snapshot(tmp_path) == before


def test_an_included_file_is_an_input(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    shutil.copy(EXAMPLES / "mission.json", tmp_path)
    shutil.copy(EXAMPLES / "grip.json", tmp_path)
    before = snapshot(tmp_path)
    code, _, err = cli(capsys, "run", str(tmp_path / "mission.json"), "--trace", str(tmp_path / "grip.json"))
    assert code == 2 and "grip.json" in err and "same file" in err
    assert snapshot(tmp_path) == before


def test_world_and_car_files_are_inputs(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    world = tmp_path / "w.json"
    shutil.copy(REPO / "diagrams" / "worlds" / "obstacle.json", world)
    before = snapshot(tmp_path)
    code, _, err = cli(capsys, "run", str(REPO / "diagrams" / "lane_change.json"), "--world", str(world),
                       "--summary", str(world))
    assert code == 2 and "same file" in err
    assert snapshot(tmp_path) == before


def test_two_outputs_naming_one_file(tmp_path: Path, blink: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = cli(capsys, "run", str(blink), "--trace", str(tmp_path / "x"), "--summary", str(tmp_path / "x"))
    assert code == 2 and "same file as --trace" in err


def test_export_without_o_never_overwrites_the_diagram(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    diagram = tmp_path / "blinker.uxf"
    shutil.copy(EXAMPLES / "blinker.uxf", diagram)
    before = snapshot(tmp_path)
    code, _, err = cli(capsys, "export", str(diagram))
    assert code == 2 and "give -o" in err
    assert snapshot(tmp_path) == before


def test_convert_of_xml2json_next_to_itself_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    src = tmp_path / "x.json"
    src.write_text("{}")
    code, _, err = cli(capsys, "convert", str(src))
    assert code == 2 and "same file" in err and src.read_text() == "{}"


def test_generated_outputs_go_through_the_writer(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    for cmd in ("schema", "palette"):
        code, _, err = cli(capsys, cmd, "-o", str(tmp_path))
        assert code == 2 and "is a directory" in err
        target = tmp_path / f"{cmd}.out"
        assert cli(capsys, cmd, "-o", str(target))[0] == 0 and target.stat().st_size > 100


# -- concurrency -----------------------------------------------------------------------------------------
def test_concurrent_writers_never_mix(tmp_path: Path) -> None:
    """Two processes write the same output again and again; every version seen is one writer's whole text."""
    target = tmp_path / "out.txt"
    code = ("import sys\nfrom fsm.tools.files import write_output\n"
            "for i in range(40): write_output(sys.argv[1], sys.argv[2] * 20000)\n")
    procs = [subprocess.Popen([sys.executable, "-c", code, str(target), ch]) for ch in "AB"]
    seen = set()
    while any(p.poll() is None for p in procs):
        try:
            data = target.read_text()
        except FileNotFoundError:
            continue
        seen.add((data[:1], len(data), len(set(data))))
    assert all(p.wait(60) == 0 for p in procs)
    final = target.read_text()
    assert final in ("A" * 20000, "B" * 20000)
    assert all(n == 20000 and kinds == 1 for _, n, kinds in seen), seen
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.txt"]


def test_two_videos_into_one_folder_use_unique_temporary_files(tmp_path: Path) -> None:
    from fsm.sim import render

    a = render._scratch_next_to(tmp_path / "v.mp4", ".mp4")
    b = render._scratch_next_to(tmp_path / "v.mp4", ".mp4")
    assert a != b and a.parent == tmp_path and a.name.endswith(".mp4")


def test_outputs_are_checked_together_before_any_is_created(tmp_path: Path) -> None:
    outs = Outputs()
    outs.add(str(tmp_path / "a.txt"), "--trace")
    outs.add(str(tmp_path / "missing" / "b.txt"), "--summary")
    with pytest.raises(UsageError, match="--summary"):
        outs.open()
    assert list(tmp_path.iterdir()) == []


def test_write_errors_are_fsm_errors(tmp_path: Path) -> None:
    if not os.path.exists("/dev/full"):
        pytest.skip("no /dev/full")
    with pytest.raises(FsmError, match="No space left"):
        write_output("/dev/full", "x" * 100000)
