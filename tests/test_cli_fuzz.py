"""``fsmctl`` driven with random flag combinations and random paths (an existing file, a missing one, a directory,
/dev/null, a symlink, a unicode name, an empty name, a FIFO without writer...): never a traceback, an exit status
in {0, 1, 2}, and no file in the sandbox changed except the outputs the command line named."""

from __future__ import annotations

import hashlib
import json
import os
import shutil
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fsm.tools.cli import main

REPO = Path(__file__).resolve().parents[1]
BLINK = {"initial": "a", "states": [{"id": "a", "type": "Idle"}, {"id": "b", "type": "Final"}],
         "transitions": [{"type": "Timeout", "from": "a", "to": "b", "seconds": 0.05}]}

#: Paths relative to the sandbox (or absolute); "@" marks names the sandbox fixture creates.
PATHS = ["m.json", "bad.json", "d.uxf", "missing.json", "dir", "dir/", "link.json", "dangling.json", "fifo",
         "/dev/null", "ünï cødé.json", "", "-", "sub/out.json", "nofolder/x.json", "hl.json", "ro/x.json",
         "a\0b", "x" * 300, "out.json", "out.png", "out.mp4", "out.jsonl", "/proc/fsmctl-fuzz"]
OUTPUT_OPTIONS = {"run": ["--trace", "--summary", "--plot", "--video"], "convert": ["-o"], "export": ["-o"],
                  "graph": ["-o"], "schema": ["-o"], "palette": ["-o"]}
FLAGS = {
    "run": [["--max-ticks", "5"], ["--max-ticks", "0"], ["--duration", "0.05"], ["--dt", "5e-324"], ["--dt", "1e-9"],
            ["--dt", "0.5"], ["--fps", "1e9"], ["--video-speed", "0"], ["--seed", "-3"], ["--expect", "succeeded"],
            ["--max-collisions", "0"], ["--signal", "go@0.1"], ["--signal", "bad"], ["-q"], ["--no-noise"]],
    "validate": [["--format", "json"], ["--format", "github"], ["--strict"], ["-q"], ["--format", "xml"]],
    "convert": [["--check"], ["--format", "github"], ["--machine", "x"]],
    "export": [],
    "graph": [["--format", "svg"], ["--format", "dot"], ["--machine", "x"]],
    "schema": [["--check", "m.json"]],
    "palette": [["--check"]],
    "types": [["--format", "json"], ["Idle"], ["Nope"]],
}


def digest(root: Path) -> dict[str, str]:
    out = {}
    for dirpath, dirnames, filenames in os.walk(root):
        for name in filenames + dirnames:
            p = Path(dirpath) / name
            rel = str(p.relative_to(root))
            if p.is_symlink():
                out[rel] = "-> " + os.readlink(p)
            elif p.is_file():
                out[rel] = hashlib.sha256(p.read_bytes()).hexdigest()
            else:
                out[rel] = "other"
    return out


@pytest.fixture(scope="module")
def sandbox(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("fuzz")
    (root / "m.json").write_text(json.dumps(BLINK))
    (root / "bad.json").write_text('{"initial": 1')
    shutil.copy(REPO / "diagrams" / "examples" / "blinker.uxf", root / "d.uxf")
    (root / "dir").mkdir()
    (root / "sub").mkdir()
    (root / "ro").mkdir()
    os.chmod(root / "ro", 0o555)
    (root / "link.json").symlink_to(root / "m.json")
    (root / "dangling.json").symlink_to(root / "nowhere.json")
    os.mkfifo(root / "fifo")
    (root / "ünï cødé.json").write_text(json.dumps(BLINK))
    (root / "hl.json").write_text("{}")
    os.link(root / "hl.json", root / "hl2.json")
    for name in ("m.json", "bad.json", "d.uxf", "ünï cødé.json"):
        ORIGINALS[name] = (root / name).read_bytes()
    return root


ORIGINALS: dict[str, bytes] = {}


command_lines = st.sampled_from(sorted(FLAGS)).flatmap(lambda cmd: st.tuples(
    st.just(cmd),
    st.sampled_from(PATHS),
    st.lists(st.sampled_from(FLAGS[cmd]), max_size=3) if FLAGS[cmd] else st.just([]),
    st.lists(st.tuples(st.sampled_from(OUTPUT_OPTIONS.get(cmd, ["-o"])), st.sampled_from(PATHS)), max_size=2)
    if cmd in OUTPUT_OPTIONS else st.just([]),
    st.sampled_from([[], ["--plugin", "nope"], ["--plugin", "dir/"]]),
))


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(line=command_lines)
def test_random_command_lines(line: tuple[str, str, list[list[str]], list[tuple[str, str]], list[str]],
                              sandbox: Path, capsys: pytest.CaptureFixture[str],
                              monkeypatch: pytest.MonkeyPatch) -> None:
    cmd, path, flags, outputs, plugin = line
    named = [p for _, p in outputs]
    if any(p == "fifo" for p in named):
        return  # writing to a FIFO without a reader blocks, as the shell's `>` does; tests/test_outputs covers it
    if cmd == "palette" and ["--check"] in flags:
        outputs = outputs[:1]  # --check compares with -o
    argv = [*plugin, cmd]
    if cmd not in ("schema", "palette", "types"):
        argv.append(path)
    for f in flags:
        argv += f
    for opt, p in outputs:
        argv += [opt, p]
    monkeypatch.chdir(sandbox)
    monkeypatch.setattr("sys.stdin", open(os.devnull))  # '-' reads an empty document
    before = digest(sandbox)
    try:
        code = main(argv)
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else 2
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err, (argv, err)
    assert code in (0, 1, 2), (argv, code, err)
    if code != 0:
        assert (err + out).strip(), (argv, "a failure must say why")
    after = digest(sandbox)
    allowed = {os.path.normpath(p) for p in named if p and "\0" not in p}
    if cmd == "convert" and not outputs and path.endswith(".uxf"):
        allowed.add(path[:-4] + ".json")
    if cmd == "export" and not outputs:
        allowed.add(os.path.splitext(path)[0] + ".uxf")
    changed = {k for k in set(before) | set(after) if before.get(k) != after.get(k)}
    through_links = {os.path.relpath(os.path.realpath(p), sandbox) for p in allowed if "\0" not in p}
    assert changed <= allowed | through_links, (argv, changed)
    for name in changed:  # leave the sandbox as it was for the next example
        target = sandbox / name
        if name in ORIGINALS:
            target.write_bytes(ORIGINALS[name])
        elif target.is_file() and not target.is_symlink() and name not in before:
            target.unlink()
    assert not [n for n in os.listdir(sandbox) if ".part" in n], "a temporary file was left behind"
