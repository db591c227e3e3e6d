"""Traces are inputs like any other (issue 22): read by the reading rule (regular files or '-', the size cap), every
line strict JSON checked against fsm/schema/trace.schema.json before use, the first bad line named with what was
expected; the report and the MCAP export of whatever the reader accepts never fail; version checks say what they
found; a report or export killed by a signal leaves no temporary file."""

from __future__ import annotations

import io
import json
import os
import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fsm.loading.reading import MAX_JSON_DEPTH, parse_json_line
from fsm.trace.replay import MAX_TICK, Trace, TraceError, parse_trace
from helpers import cli
from trace_lines import CAR, LINES, V1, WILD

FSMCTL = str(Path(sys.executable).parent / "fsmctl")


def _text(lines: list[Any]) -> str:
    return "".join((line if isinstance(line, str) else json.dumps(line)) + "\n" for line in lines)


def _trace(**replace: Any) -> str:
    """The trace of LINES, each line replaced by keyword (a dict, or raw text)."""
    return _text([replace.get(kind, line) for kind, line in LINES.items()])


def _number(kind: str) -> int:
    return list(LINES).index(kind) + 1


def _reads_and_renders(trace: Trace, page: bool = True) -> None:
    """What report and export do with a trace the reader accepted: neither may fail (``page``: the whole page,
    else the data it embeds)."""
    from fsm.tools.recording.mcap import write_mcap
    from fsm.tools.report import build_model, report_html

    if page:
        report_html(trace)
    else:
        json.dumps(build_model(trace), allow_nan=False)
    write_mcap(trace, io.BytesIO())


def test_the_lines_of_every_type_read_and_render() -> None:
    trace = parse_trace(_trace().encode(), "t.jsonl")
    assert not trace.warnings
    assert len(trace.samples) == 2 + 2 + 1 and trace.samples[0]["car"]["odometry"] == [0.0, 0.0, 0.0]
    assert trace.samples[2] == {"type": "sample", "tick": 8, "time": 0.1, "car": {"x": 1.2, "front": "inf"}, "v": None}
    assert len(trace.frames) == 1 and len(trace.events) == 2 and trace.end is not None
    _reads_and_renders(trace)


# -- strict JSON, line by line ---------------------------------------------------------------------------
@pytest.mark.parametrize(("raw", "says"), [
    (b'{"t": NaN}', "NaN is not JSON"),
    (b'{"t": Infinity}', "Infinity is not JSON"),
    (b'[-Infinity]', "-Infinity is not JSON"),
    (b'[1e400]', "number 1e400 is out of range"),
    (b'[' + b'9' * 400 + b']', "of 400 digits is out of range"),
    (b'[' + b'9' * 5000 + b']', "of 5000 digits is out of range"),
    (b'{"t": 1, "t": 2}', "key 't' appears twice"),
    (b'[' * 100000, f"nested more than {MAX_JSON_DEPTH} levels deep (column {MAX_JSON_DEPTH + 1})"),
    (b'{"a": "\xff"}', "not UTF-8: byte 0xff at column 8"),
    (b'{"a" 1}', "invalid JSON: Expecting ':' delimiter (column 6)"),
    (b'{} {}', "invalid JSON: Extra data (column 4)"),
])
def test_a_line_is_strict_json(raw: bytes, says: str) -> None:
    with pytest.raises(ValueError, match=re.escape(says)):
        parse_json_line(raw)


def test_strict_json_still_reads_what_json_allows() -> None:
    deep = b"[" * MAX_JSON_DEPTH + b"]" * MAX_JSON_DEPTH
    assert parse_json_line(b'{"a": [1.5e308, -1e-400, 12, "[[[{{{", null, true]}') == \
        {"a": [1.5e308, -0.0, 12, "[[[{{{", None, True]}
    assert parse_json_line(deep) is not None
    assert parse_json_line(b'"' + b"[" * 1000 + b'"') == "[" * 1000  # brackets in strings do not nest


# -- what the reader refuses, and says -----------------------------------------------------------------
ITEM = LINES["event"]["transitions"][0]
#: (line type, the line as damaged, what the warning says after "line N is damaged (")
DAMAGED = [
    ("event", '{"type":"event","tick":1,"time":NaN,"active":[],"transitions":[]}', "NaN is not JSON"),
    ("event", '{"type":"event","tick":1,"time":Infinity,"active":[],"transitions":[]}', "Infinity is not JSON"),
    ("event", {**LINES["event"], "time": 1e308}, "event line at /time: expected a number at most 1e+09, found 1e+308"),
    ("event", {**LINES["event"], "transitions": [{**ITEM, "time": 1e308}]},
     "event line at /transitions/0/time: expected a number at most 1e+09"),
    ("event", {**LINES["event"], "tick": MAX_TICK + 1}, f"expected a number at most {MAX_TICK}"),
    ("event", '{"type":"event","vars":{"x":' + "[" * 5000 + "]" * 5000 + "}}", "nested more than 400 levels deep"),
    ("event", {**LINES["event"], "transitions": "abc"},
     "event line at /transitions: expected a list, found 'abc' (a string)"),
    ("event", {**LINES["event"], "transitions": ["abc"]}, "at /transitions/0: expected an object, found 'abc'"),
    ("event", {**LINES["event"], "active": [["a"]]}, "event line at /active/0: expected a string, found a list of 1"),
    ("event", {k: v for k, v in LINES["event"].items() if k != "time"}, "event line: 'time' is missing"),
    ("event", {**LINES["event"], "monitors": ["x"]}, "at /monitors/0: expected an object"),
    ("event", '{"type":"event","tick":1,"tick":2}', "key 'tick' appears twice in one object"),
    ("event", {**LINES["event"], "type": "header"}, "unknown line type 'header' (a string)"),
    ("event", [1, 2], "not a JSON object but a list of 2"),
    ("keyframe", {**LINES["keyframe"], "extra": 1}, "unexpected property 'extra'"),
    ("sample", {**LINES["sample"], "car": {**CAR, "x": "abc"}},
     "sample line at /car/x: expected a number, found 'abc'"),
    ("sample", {**LINES["sample"], "car": {**CAR, "steering": 1e308}}, "at /car/steering: expected a number at most"),
    ("rows", {**LINES["rows"], "rows": [[1.0, [1], None]]}, "at /rows/0/1: expected a number, a string or null"),
    ("rows", {**LINES["rows"], "rows": [[1e308, 1, None]]}, "at /rows/0/0: expected a number at most 3.40282e+38"),
    ("rows", {**LINES["rows"], "rows": [[1.0, 2.0]]}, "rows must be as long as its 3 fields"),
    ("rows", {**LINES["rows"], "fields": ["car.x", "car.x[0]", "v"]}, "field 'car.x[0]' clashes"),
    ("rows", {**LINES["rows"], "fields": ["car", "car.x", "v"]}, "field 'car.x' clashes"),
    ("rows", {**LINES["rows"], "fields": ["car.x[a]", "b", "c"]}, "at /fields/0: expected a field name"),
    ("rows", {**LINES["rows"], "fields": ["tick", "b", "c"]}, "at /fields/0: expected a field name"),
    ("rows", {**LINES["rows"], "tick": MAX_TICK - 1}, "rows run past tick"),
    ("samples", {**LINES["samples"], "fields": []}, "at /fields: expected at least 1 items, found 0"),
    ("samples", {**LINES["samples"], "count": 3}, "data holds 18 values, not 3 rows of 9"),
    ("samples", {**LINES["samples"], "rows": [], "count": 2}, "fits 2 of its allowed forms"),
    ("samples", {k: v for k, v in LINES["samples"].items() if k != "data"}, "fits none of its 2 allowed forms"),
    ("samples", {**LINES["samples"], "digits": 10 ** 30}, "at /digits: expected a number at most 17"),
    ("frame", {**LINES["frame"], "detections": "x"}, "frame line at /detections: expected a list"),
    ("frame", {**LINES["frame"], "detections": [{"id": 1, "corners": [1, 2, 3, 4]}]},
     "at /detections/0/corners/0: expected a list, found 1"),
    ("frame", {**LINES["frame"], "jpeg": "<script>"}, "at /jpeg: expected base64 text"),
    ("end", {**LINES["end"], "finished": "yes"}, "end line at /finished: expected true or false, found 'yes'"),
]


@pytest.mark.parametrize(("kind", "line", "says"), DAMAGED, ids=[f"{k}-{i}" for i, (k, _, _) in enumerate(DAMAGED)])
def test_the_first_damaged_line_is_named_with_what_was_expected(kind: str, line: Any, says: str) -> None:
    trace = parse_trace(_trace(**{kind: line}).encode(), "t.jsonl")
    n = _number(kind)
    [warning] = trace.warnings  # no "cut off" besides: the run may have ended, its end line unread
    assert warning.startswith(f"t.jsonl:{n}: line {n} is damaged (") and says in warning, warning
    assert warning.endswith(f"; the lines after it are not read either; read up to line {n - 1}")
    before = parse_trace(_text(list(LINES.values())[:n - 1]).encode())
    assert trace.end is None and (trace.events, trace.samples, trace.frames) == (before.events, before.samples,
                                                                                before.frames)
    _reads_and_renders(trace)


@pytest.mark.parametrize(("header", "says"), [
    ([1, 2], "t.jsonl:1: not a trace: the first line is not a JSON object (a list of 2)"),
    ({**LINES["header"], "regions": "abc"}, "t.jsonl:1: the trace's header is damaged (at /regions: expected a list, "
                                            "found 'abc' (a string))"),
    ({**LINES["header"], "regions": ["abc"]}, "(at /regions/0: expected an object"),
    ({**LINES["header"], "dt": 1e308}, "(at /dt: expected a number at most 1e+09, found 1e+308)"),
    ({**LINES["header"], "world": [1]}, "(at /world: expected an object, found a list of 1)"),
    ({**LINES["header"], "sample_fields": [3]}, "(at /sample_fields/0: expected a string, found 3)"),
    ('{"type":"header","format":"tral-fsm-trace","version":3,"dt":NaN}', "not a JSON object (NaN is not JSON"),
    ("[" * 100000, "not a JSON object (JSON nested more than 400 levels deep (column 401); it begins '[[[["),
    ({**V1, "active": [1]}, "the first line of this version-1 trace is damaged (at /active: fits none"),
    ({**LINES["header"], "version": "3"}, "trace version '3' (a string) is not a version: a version is a whole number "
                                          "(this tral-fsm reads trace versions 2 and 3)"),
    ({k: v for k, v in LINES["header"].items() if k != "version"}, "the trace's header has no version (this tral-fsm "
                                                                   "reads trace versions 2 and 3)"),
    ({**LINES["header"], "version": -5}, "trace version -5 is not a version: versions count from 1"),
    ({**LINES["header"], "version": 0}, "trace version 0 is not a version"),
    ({**LINES["header"], "version": True}, "trace version true (a boolean) is not a version"),
    ({**LINES["header"], "version": 3.0}, "trace version 3.0 is not a version"),
    ({**LINES["header"], "version": None}, "trace version null is not a version"),
    ({**LINES["header"], "version": 1}, "a header saying trace version 1 is not a trace: version-1 traces have no "
                                        "header"),
    ({**LINES["header"], "version": 4}, "trace version 4 is newer than this tral-fsm reads (up to 3); update tral-fsm"),
    ({k: v for k, v in LINES["header"].items() if k != "format"}, "not a trace: the header's format is missing"),
    ({**LINES["header"], "format": 7}, "not a trace: the header's format is 7, not 'tral-fsm-trace'"),
])
def test_a_first_line_that_begins_no_trace_is_an_error_saying_what_was_found(header: Any, says: str, tmp_path: Path,
                                                                           capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(TraceError) as caught:
        parse_trace(_trace(header=header).encode(), "t.jsonl")
    assert says in str(caught.value)
    f = tmp_path / "t.jsonl"
    f.write_text(_trace(header=header))
    for argv in (("report", str(f), "-o", str(tmp_path / "t.html")),
                 ("export", str(f), "--mcap", str(tmp_path / "t.mcap"))):
        code, _, err = cli(capsys, *argv)
        assert code == 1 and says.partition("t.jsonl:1: ")[2] in err and err.count("\n") == 1, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.jsonl"]


def test_parse_trace_of_deep_brackets_is_a_trace_error() -> None:
    with pytest.raises(TraceError, match="nested more than 400 levels deep"):
        parse_trace(b"[" * 100000)


def test_samples_are_capped_by_the_input_size_cap(monkeypatch: pytest.MonkeyPatch) -> None:
    # a samples row can be 4 bytes of text and become a sample of hundreds: one sample per 64 bytes of the cap
    monkeypatch.setenv("FSM_MAX_INPUT_BYTES", str(64 * 4))
    trace = parse_trace(_trace().encode(), "t.jsonl")
    n = _number("sample")
    assert len(trace.samples) == 4 and trace.warnings == [
        f"t.jsonl:{n}: line {n} would make the trace hold more than 4 samples (one per 64 bytes of the input size "
        f"cap; set FSM_MAX_INPUT_BYTES higher to read more); read up to line {n - 1}"]
    rows = {"type": "samples", "tick": 0, "time": 0, "every": 1, "fields": ["a"], "rows": [[0]] * 5}
    for block in (rows, {**LINES["samples"], "count": 10 ** 12}):  # said before the rows are checked or unpacked
        trace = parse_trace(_text([LINES["header"], block]).encode(), "t.jsonl")
        assert not trace.samples and "would make the trace hold more than 4 samples" in trace.warnings[0]


def test_a_version_1_trace_is_checked_too() -> None:
    good = parse_trace(_text([V1, {**V1, "tick": 8, "time": 0.1, "active": "b"}]).encode())
    assert good.version == 1 and good.at(8) == (["b"], {"n": 1})
    bad = parse_trace(_text([V1, {**V1, "tick": 8, "time": "soon"}]).encode(), "old.jsonl")
    assert "line 2 is damaged (event_v1 line at /time: expected a number, found 'soon' (a string))" in bad.warnings[-1]
    _reads_and_renders(bad)


def test_a_trace_cut_off_mid_line_still_reads_up_to_its_last_whole_line() -> None:
    text = _trace()
    cut = text[: text.index('"type": "frame"') + 20]
    trace = parse_trace(cut.encode(), "t.jsonl")
    n = _number("frame")
    assert trace.warnings[0] == f"t.jsonl:{n}: line {n} is cut off (the run was stopped while it was written); " \
                                f"read up to line {n - 1}"
    assert trace.warnings[1] == "t.jsonl: no end line: the run was cut off after tick 16"


# -- fuzzing: only TraceError comes out, and what is read renders ----------------------------------------
def _paths(value: Any, here: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    """Every place in a JSON value (keys and indexes), the value itself first."""
    out = [here]
    if isinstance(value, dict):
        for k, v in value.items():
            out += _paths(v, here + (k,))
    elif isinstance(value, list):
        for i, v in enumerate(value):
            out += _paths(v, here + (i,))
    return out


def _mutated(value: Any, path: tuple[Any, ...], new: Any, delete: bool) -> Any:
    if not path:
        return new
    copy = dict(value) if isinstance(value, dict) else list(value)
    head, rest = path[0], path[1:]
    if delete and not rest and isinstance(copy, dict):
        del copy[head]
    else:
        copy[head] = _mutated(copy[head], rest, new, delete)
    return copy


@st.composite
def damaged_traces(draw: Any) -> str:
    """The trace of LINES (or a version-1 trace) with one to three values of its lines replaced or removed."""
    lines = dict(LINES) if draw(st.integers(0, 5)) else {"first": V1, "second": {**V1, "tick": 8}}
    for _ in range(draw(st.integers(1, 3))):
        kind = draw(st.sampled_from(sorted(lines)))
        path = draw(st.sampled_from(_paths(lines[kind])))
        lines[kind] = _mutated(lines[kind], path, draw(WILD), draw(st.booleans()))
    return _text(list(lines.values()))


def _read_or_refuse(data: bytes) -> None:
    try:
        trace = parse_trace(data, "fuzz.jsonl")
    except TraceError:
        return
    _reads_and_renders(trace, page=False)


FUZZ = settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@FUZZ
@given(damaged_traces())
def test_fuzz_right_shapes_with_wrong_values(text: str) -> None:
    _read_or_refuse(text.encode())


@FUZZ
@given(st.binary(max_size=400), st.booleans())
def test_fuzz_random_bytes(data: bytes, after_a_header: bool) -> None:
    _read_or_refuse((_text([LINES["header"]]).encode() if after_a_header else b"") + data)


@FUZZ
@given(st.integers(0, len(_trace().encode())), st.binary(max_size=3))
def test_fuzz_truncated_traces(at: int, tail: bytes) -> None:
    data = _trace().encode()[:at] + tail
    _read_or_refuse(data)


# -- the reading rule on the command line -----------------------------------------------------------------
def test_a_fifo_is_refused_at_once_not_read(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                           monkeypatch: pytest.MonkeyPatch) -> None:
    os.mkfifo(tmp_path / "fifo")  # no writer: reading it would hang
    monkeypatch.chdir(tmp_path)
    unblock = threading.Timer(30, lambda: open(tmp_path / "fifo", "wb").close())  # should it hang after all
    unblock.daemon = True
    unblock.start()
    try:
        for argv in (["report", "fifo", "-o", "x.html"], ["export", "fifo", "--mcap", "x.mcap"]):
            code, _, err = cli(capsys, *argv)
            assert code == 1 and err == "fifo: error: not a regular file (a FIFO); a trace file must be a regular " \
                                        "file (pass '-' to read standard input)\n", err
    finally:
        unblock.cancel()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fifo"]


def test_a_device_is_refused_and_standard_input_is_capped(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    code, _, err = cli(capsys, "export", "/dev/zero", "--mcap", "x.mcap")
    assert code == 1 and "/dev/zero: error: not a regular file (a device)" in err
    monkeypatch.setenv("FSM_MAX_INPUT_BYTES", str(2 ** 17))
    for argv in (["report", "-", "-o", "x.html"], ["export", "-", "--mcap", "x.mcap"]):
        with open("/dev/zero", "rb") as zero:
            monkeypatch.setattr(sys, "stdin", io.TextIOWrapper(zero))
            code, _, err = cli(capsys, *argv)
        assert code == 1 and "<stdin>: error: file is too big" in err and "the limit is 0.125 MiB" in err, err
    big = tmp_path / "big.jsonl"
    big.write_text(_trace() * 60)
    assert big.stat().st_size > 2 ** 17
    code, _, err = cli(capsys, "report", str(big), "-o", "x.html")
    assert code == 1 and "big.jsonl: error: file is too big" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["big.jsonl"]


def test_a_trace_on_standard_input(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                   monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(sys, "stdin", io.TextIOWrapper(io.BytesIO(_trace().encode())))
    code, _, err = cli(capsys, "report", "-", "-o", str(tmp_path / "r.html"))
    assert code == 0 and not err, err
    assert '"trace":"\\u003cstdin\\u003e"' in (tmp_path / "r.html").read_text()
    monkeypatch.setattr(sys, "stdin", io.TextIOWrapper(io.BytesIO(_trace(end="{").encode())))
    code, _, err = cli(capsys, "export", "-", "--mcap", str(tmp_path / "r.mcap"))
    n = _number("end")
    assert code == 0 and f"<stdin>:{n}: line {n} is damaged (invalid JSON" in err
    assert (tmp_path / "r.mcap").read_bytes().startswith(b"\x89MCAP")


# -- a signal leaves no temporary file ----------------------------------------------------------------------
def _stopped(argv: list[str], signum: int, cwd: Path) -> tuple[int, str, list[str]]:
    """Start fsmctl reading standard input (a pipe that stays open: it waits with its output prepared), signal it
    once the temporary output file exists, and return its exit status, standard error and the temporary files
    seen before the signal."""
    proc = subprocess.Popen([FSMCTL, *argv], cwd=cwd, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)
    try:
        end = time.monotonic() + 60
        while time.monotonic() < end and not list(cwd.glob(".*.part*")):
            time.sleep(0.02)
        seen = [p.name for p in cwd.glob(".*.part*")]
        time.sleep(0.3)  # the temporary file is registered right after it is made
        proc.send_signal(signum)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    return proc.returncode, err.decode(), seen


@pytest.mark.parametrize(("argv", "signum", "status"), [
    (["report", "-", "-o", "r.html"], signal.SIGTERM, -signal.SIGTERM),
    (["export", "-", "--mcap", "r.mcap"], signal.SIGTERM, -signal.SIGTERM),
    (["report", "-", "-o", "r.html"], signal.SIGINT, 130),
])
def test_a_command_stopped_by_a_signal_leaves_no_temporary_file(argv: list[str], signum: int, status: int,
                                                                tmp_path: Path) -> None:
    code, err, seen = _stopped(argv, signum, tmp_path)
    assert seen and code == status and "Traceback" not in err, err
    assert list(tmp_path.iterdir()) == []


def test_any_output_loses_its_temporary_file_to_sigterm(tmp_path: Path) -> None:
    script = ("import os, signal\nfrom fsm.tools.files import Output\n"
              "out = Output('x.txt', '-o').open()\nout.write('half')\n"
              "os.kill(os.getpid(), signal.SIGTERM)\nprint('not reached')\n")
    done = subprocess.run([sys.executable, "-c", script], cwd=tmp_path, capture_output=True, text=True, timeout=60)
    assert done.returncode == -signal.SIGTERM and "not reached" not in done.stdout, done.stderr
    assert list(tmp_path.iterdir()) == []


def test_a_forked_child_leaves_its_parents_temporary_files_alone(tmp_path: Path) -> None:
    script = ("import os, signal, sys\nfrom fsm.tools.files import Output\n"
              "out = Output('x.txt', '-o').open()\nchild = os.fork()\n"
              "if child == 0:\n    os.kill(os.getpid(), signal.SIGTERM)\n"
              "_, status = os.waitpid(child, 0)\n"
              "print(os.WTERMSIG(status), len([n for n in os.listdir('.') if '.part' in n]))\n"
              "out.write('x')\nout.commit()\n")
    done = subprocess.run([sys.executable, "-c", script], cwd=tmp_path, capture_output=True, text=True, timeout=60)
    assert done.returncode == 0 and done.stdout.split() == [str(int(signal.SIGTERM)), "1"], done.stderr
    assert [p.name for p in tmp_path.iterdir()] == ["x.txt"]
