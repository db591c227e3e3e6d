"""The trace as the one record of a run (issue 11): its lines follow fsm/schema/trace.schema.json, every tick
replays from it exactly, a cut-off trace still reads, and what is not a trace is said so; the HTML report and the
MCAP export are built from it (the browser tests are in test_report_browser.py)."""

from __future__ import annotations

import io
import json
import re
from pathlib import Path
from typing import Any

import jsonschema
import pytest

import fsm
from fsm.trace.recorder import Recorder, jsonable
from fsm.trace.replay import TraceError, parse_trace, read_trace
from helpers import cli

REPO = Path(__file__).resolve().parents[1]
SCHEMA = json.loads((REPO / "fsm" / "schema" / "trace.schema.json").read_text())
MISSION = REPO / "diagrams" / "mission.json"
OBSTACLE = REPO / "diagrams" / "worlds" / "obstacle.json"


def _mission_trace(pause: bool = True) -> tuple[str, list[tuple[int, list[str], dict[str, Any]]]]:
    """The car mission (sequences, monitors, a pause, variables) in the obstacle world, traced as `fsmctl run`
    traces it, and the live configuration and variables after every tick."""
    from fsm.sim.car import SimCar
    from fsm.sim.loop import (
        CAR_SAMPLE_FIELDS,
        Simulation,
        car_trace_fields,
        car_trace_frames,
        car_trace_header,
        car_trace_sample,
    )
    from fsm.sim.world import load_world

    car = SimCar(load_world(OBSTACLE), seed=3)
    m = fsm.load(MISSION, car=car)
    if pause:
        m.schedule_signal("pause", 5.0)
        m.schedule_signal("pause", 5.1, False)
        m.schedule_signal("pause", 8.0)
        m.schedule_signal("pause", 8.1, False)
    from fsm.tools.recording import header_document

    out = io.StringIO()
    header = {"source": str(MISSION), "machine": header_document(str(MISSION)),
              **car_trace_header(car, OBSTACLE, 3, True)}
    rec = m.add_listener(Recorder(out, extra=car_trace_fields(car), sample=car_trace_sample(car),
                                  sample_fields=CAR_SAMPLE_FIELDS, frames=car_trace_frames(car), header=header))
    live: list[tuple[int, list[str], dict[str, Any]]] = []

    def after_tick() -> bool:
        live.append((m.ctx.tick, m.active_paths, jsonable(dict(m.ctx.vars))))
        return False

    m.start()
    rec.flush(m)
    live.append((0, m.active_paths, jsonable(dict(m.ctx.vars))))
    Simulation(m, car).run(max_ticks=4000, stop=after_tick)
    rec.finish(m)
    return out.getvalue(), live


@pytest.fixture(scope="module")
def mission() -> tuple[str, list[tuple[int, list[str], dict[str, Any]]]]:
    return _mission_trace()


def test_every_line_follows_the_trace_schema(mission: Any) -> None:
    text, _ = mission
    validator = jsonschema.Draft202012Validator(SCHEMA)
    lines = [json.loads(line) for line in text.splitlines()]
    kinds = {line["type"] for line in lines}
    assert kinds == {"header", "event", "keyframe", "samples", "end"}
    for number, line in enumerate(lines, 1):
        errors = list(validator.iter_errors(line))
        assert not errors, f"line {number}: {errors[0].message}"
    assert lines[0]["type"] == "header" and lines[-1]["type"] == "end"
    header = lines[0]
    assert header["dt"] == 0.0125 and header["sample_period"] == 0.05 and header["keyframe_period"] == 1.0
    assert "world" in header and header["seed"] == 3
    samples = parse_trace(text.encode()).samples
    assert [s["tick"] for s in samples[:3]] == [0, 4, 8]  # 20 Hz at 80 Hz ticks
    assert len(samples) == (lines[-1]["tick"]) // 4 + 1
    assert {"x", "y", "heading", "odometry", "left", "front", "right", "speed_command",
            "steering"} <= set(samples[5]["car"])
    events = [line for line in lines if line["type"] == "event"]
    assert any("monitors" in e for e in events) and any("paused" in e for e in events)


def test_every_tick_replays_from_the_trace_exactly(mission: Any) -> None:
    text, live = mission
    trace = parse_trace(text.encode())
    assert not trace.warnings
    assert trace.end is not None and trace.end["outcome"] == "succeeded" and len(live) == trace.end["tick"] + 1
    mismatches = [(tick, active, trace.at(tick)) for tick, active, variables in live
                  if trace.at(tick) != (active, variables)]
    assert not mismatches, mismatches[:3]
    assert live[-1][2]["evasions"] == 1  # the variables did change during the run


def test_replay_sees_variables_removed_and_set_between_ticks_and_parallel_regions() -> None:
    doc = {"initial": "p", "vars": {"n": 0}, "states": [
        {"id": "p", "type": "Parallel", "regions": [
            {"name": "left", "initial": "a", "states": [{"id": "a", "type": "Idle"}, {"id": "b", "type": "Idle"}],
             "transitions": [{"type": "Timeout", "from": "a", "to": "b", "seconds": 0.1, "set": {"n": "n + 1"}},
                             {"type": "Timeout", "from": "b", "to": "a", "seconds": 0.05}]},
            {"initial": "x", "states": [{"id": "x", "type": "Idle"}, {"id": "y", "type": "Idle"}],
             "transitions": [{"type": "Timeout", "from": "x", "to": "y", "seconds": 0.3},
                             {"type": "Timeout", "from": "y", "to": "x", "seconds": 0.2}]}]}]}
    m = fsm.load(doc)
    out = io.StringIO()
    rec = m.add_listener(Recorder(out, keyframe_period=0.1))
    m.start()
    rec.flush(m)
    live = [(0, m.active_paths, jsonable(dict(m.ctx.vars)))]
    for tick in range(1, 200):
        if tick == 30:
            m.ctx.vars["extra"] = None  # a variable whose value is None is not a removed one
        if tick == 61:
            del m.ctx.vars["extra"]
        if tick == 90:
            m.ctx.vars["obj"] = object()  # stored as its repr
        m.tick()
        live.append((tick, m.active_paths, jsonable(dict(m.ctx.vars))))
    trace = parse_trace(out.getvalue().encode())
    assert {p for _, active, _ in live for p in active} >= {"p/left/a", "p/left/b", "p/region2/x", "p/region2/y"}
    assert all(trace.at(tick) == (active, variables) for tick, active, variables in live)
    assert any(e.get("unset") == ["extra"] for e in trace.events)


def _sampled(sample: Any, ticks: int = 120) -> tuple[str, list[tuple[int, Any]]]:
    """A one-state machine traced with ``sample`` (called with the tick) as its sample callable, and what it
    returned at each tick it was called."""
    m = fsm.load({"initial": "a", "states": [{"id": "a", "type": "Idle"}]}, dt=0.01)
    taken: list[tuple[int, Any]] = []

    def take() -> Any:
        taken.append((m.ctx.tick, sample(m.ctx.tick)))
        return taken[-1][1]

    out = io.StringIO()
    rec = m.add_listener(Recorder(out, sample=take, sample_fields=["v.a", "v.b", "v.n", "v.r"], keyframe_period=0.25))
    m.start()
    rec.flush(m)
    for _ in range(ticks):
        m.tick()
    rec.finish(m)
    return out.getvalue(), taken


def test_samples_read_back_as_they_were_taken_packed_or_not() -> None:
    # Numbers are packed (float32, base64) and read back rounded to the block's digits; integer columns stay
    # integers; an infinite reading comes back as JSON holds it elsewhere ("inf").
    text, taken = _sampled(lambda t: (t * 0.0123457, -t * 1.5 - 1000.0, t * 7, float("inf") if t == 40 else 0.25))
    lines = [json.loads(line) for line in text.splitlines()]
    blocks = [line for line in lines if line["type"] == "samples"]
    assert blocks and all("data" in b and "rows" not in b and b["integers"] == [2] for b in blocks)
    validator = jsonschema.Draft202012Validator(SCHEMA)
    assert not [e.message for line in lines for e in validator.iter_errors(line)]
    trace = parse_trace(text.encode())
    assert not trace.warnings
    assert [s["tick"] for s in trace.samples] == [t for t, _ in taken]
    for sample, (_, (a, b, n, r)) in zip(trace.samples, taken, strict=True):
        v = sample["v"]
        assert v["a"] == pytest.approx(a, abs=1.5e-4) and v["b"] == pytest.approx(b, abs=1.5e-4)
        assert v["n"] == n and type(v["n"]) is int
        assert v["r"] == ("inf" if r == float("inf") else r)
    # rows that are not all numbers (a string, an integer beyond a float32's exact range) are written as JSON
    for sample in (lambda t: (t * 0.5, "on" if t % 2 else "off", t, 1.0), lambda t: (0.5, 1.0, t + 2 ** 25, 1.0)):
        text, taken = _sampled(sample)
        assert '"rows"' in text and '"data"' not in text
        trace = parse_trace(text.encode())
        assert [tuple(s["v"][k] for k in "abnr") for s in trace.samples] == [v for _, v in taken]


@pytest.mark.parametrize("damage, says", [
    (lambda b: {**b, "data": b["data"][:-8]}, "holds"),
    (lambda b: {**b, "data": "not base64!"}, "at /data: expected base64 text, found 'not base64!'"),
    (lambda b: {**b, "encoding": "float64-hex"}, "at /encoding: expected 'float32-base64', found 'float64-hex'"),
    (lambda b: {**b, "integers": [9]}, "integers name column 9, but it has 4 fields"),
])
def test_a_damaged_samples_block_is_read_up_to_the_line_before(damage: Any, says: str) -> None:
    text, _ = _sampled(lambda t: (t * 0.5, 1.0, t, 1.0))
    lines = text.splitlines()
    number = next(i for i, line in enumerate(lines, 1) if '"samples"' in line and '"tick":25' in line)
    lines[number - 1] = json.dumps(damage(json.loads(lines[number - 1])))
    trace = parse_trace("\n".join(lines).encode() + b"\n", "run.jsonl")
    assert len(trace.warnings) >= 1 and f"run.jsonl:{number}: line {number} is damaged" in trace.warnings[0]
    assert says in trace.warnings[0]
    assert trace.samples and trace.samples[-1]["tick"] < 25


def test_a_cut_off_trace_reads_up_to_its_last_whole_line(mission: Any, tmp_path: Path,
                                                         capsys: pytest.CaptureFixture[str]) -> None:
    text, live = mission
    data = text.encode()
    cut = data[: len(data) // 2 + 17]  # killed mid-line
    trace = parse_trace(cut, "run.jsonl")
    whole = cut.count(b"\n")
    assert trace.end is None
    assert any(f"line {whole + 1} is cut off" in w and f"read up to line {whole}" in w for w in trace.warnings)
    last = trace.last_tick
    assert 0 < last < live[-1][0] and trace.at(last) == (live[last][1], live[last][2])
    (tmp_path / "cut.jsonl").write_bytes(cut)
    code, out, err = cli(capsys, "report", str(tmp_path / "cut.jsonl"), "-o", str(tmp_path / "cut.html"))
    assert code == 0, err
    assert f"line {whole + 1} is cut off" in err and "Traceback" not in err
    assert "cut off" in (tmp_path / "cut.html").read_text()


@pytest.mark.parametrize(("content", "says"), [
    (b"", "is empty"),
    (b"\n\n  \n", "is empty"),
    (b"\x89PNG\r\n\x1a\n\0\0\0IHDR", "binary file"),
    (b'{"name": "a machine", "states": []}\n', "without a trace header"),
    (b"[1, 2, 3]\n", "not a JSON object"),
    (b"hello world\n", "not a JSON object"),
    (b'{"type": "header", "format": "tral-fsm-trace", "version": 99}\n', "newer than this tral-fsm reads"),
    (b'{"type": "header", "format": "something-else", "version": 2}\n', "format is 'something-else'"),
])
def test_what_is_not_a_trace_is_an_error_with_the_reason(content: bytes, says: str, tmp_path: Path,
                                                         capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(TraceError, match=re.escape(says)):
        parse_trace(content, "x.jsonl")
    f = tmp_path / "x.jsonl"
    f.write_bytes(content)
    for argv in (("report", str(f), "-o", str(tmp_path / "x.html")),
                 ("export", str(f), "--mcap", str(tmp_path / "x.mcap"))):
        code, out, err = cli(capsys, *argv)
        assert code == 1 and says in err and "Traceback" not in err
        assert sorted(p.name for p in tmp_path.iterdir()) == ["x.jsonl"]  # nothing half-written


def test_report_and_export_of_a_missing_trace_or_a_folder(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    for argv in (("report", str(tmp_path / "nope.jsonl"), "-o", str(tmp_path / "r.html")),
                 ("report", str(tmp_path), "-o", str(tmp_path / "r.html")),
                 ("export", str(tmp_path / "nope.jsonl"), "--mcap", str(tmp_path / "r.mcap"))):
        code, _, err = cli(capsys, *argv)
        assert code == 1 and "Traceback" not in err and str(tmp_path) in err
    assert list(tmp_path.iterdir()) == []


def test_the_trace_itself_as_the_report_output_is_refused(mission: Any, tmp_path: Path,
                                                          capsys: pytest.CaptureFixture[str]) -> None:
    f = tmp_path / "run.jsonl"
    f.write_text(mission[0])
    before = f.read_bytes()
    code, _, err = cli(capsys, "report", str(f), "-o", str(f))
    assert code in (1, 2) and "Traceback" not in err
    assert f.read_bytes() == before


def test_a_version_1_trace_gives_a_report_of_what_can_be_shown(tmp_path: Path,
                                                               capsys: pytest.CaptureFixture[str]) -> None:
    old = [{"tick": 0, "time": 0.0, "active": "a", "transitions": [{"tick": 0, "time": 0.0, "from": None, "to": "a",
                                                                     "type": "initial"}], "vars": {"n": 1}},
           {"tick": 8, "time": 0.1, "active": "b", "transitions": [{"tick": 8, "time": 0.1, "from": "a", "to": "b",
                                                                     "type": "Timeout"}], "vars": {"n": 2}}]
    f = tmp_path / "old.jsonl"
    f.write_text("".join(json.dumps(line) + "\n" for line in old))
    trace = read_trace(f)
    assert trace.version == 1 and "older tral-fsm" in trace.warnings[0]
    assert trace.at(4) == (["a"], {"n": 1}) and trace.at(8) == (["b"], {"n": 2})
    code, _, err = cli(capsys, "report", str(f), "-o", str(tmp_path / "old.html"))
    assert code == 0 and "older tral-fsm" in err
    html = (tmp_path / "old.html").read_text()
    assert "older tral-fsm" in html and '"states":["a","b"]' in html


def test_a_trace_whose_machine_no_longer_draws_still_reports(mission: Any, tmp_path: Path,
                                                             capsys: pytest.CaptureFixture[str]) -> None:
    lines = mission[0].splitlines()
    header = json.loads(lines[0])
    header["machine"] = {"initial": "nowhere", "states": [{"id": 3, "type": None, "machine": {"file": 7}}]}
    header["world"] = {"walls": "none"}
    f = tmp_path / "bad.jsonl"
    f.write_text("\n".join([json.dumps(header)] + lines[1:]) + "\n")
    code, _, err = cli(capsys, "report", str(f), "-o", str(tmp_path / "bad.html"))
    assert code == 0, err
    html = (tmp_path / "bad.html").read_text()
    assert "the world in the trace does not load" in html


def test_state_names_are_text_in_the_report_never_markup(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    evil = "<img src=x onerror=alert(1)>"  # an id holds no '/'; the name, description and variables hold anything
    doc = {"name": "</script><script>alert(2)</script>", "description": "<script>alert(3)</script>",
           "initial": evil, "vars": {"v": "<b>bold</b></script><script>alert(4)</script>"},
           "states": [{"id": evil, "type": "Idle"}, {"id": "end & <done>", "type": "Final"}],
           "transitions": [{"type": "Timeout", "from": evil, "to": "end & <done>", "seconds": 0.1}]}
    f = tmp_path / "evil.json"
    f.write_text(json.dumps(doc))
    code, _, err = cli(capsys, "run", str(f), "--trace", str(tmp_path / "t.jsonl"),
                       "--report", str(tmp_path / "r.html"), "-q")
    assert code == 0, err
    html = (tmp_path / "r.html").read_text()
    assert "<script>alert" not in html and "<img src=x" not in html and "<b>bold" not in html
    assert html.count("<script") == 3  # the data, uPlot, the report's own code
    assert "&lt;img src=x onerror=alert(1)&gt;" in html  # the drawing's text, escaped


def test_fsmctl_run_report_and_trace_describe_the_same_run(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = cli(capsys, "run", str(REPO / "diagrams" / "hallway_lap.uxf"), "--duration", "30", "--trace",
                       str(tmp_path / "t.jsonl"), "--report", str(tmp_path / "r.html"), "-q")
    assert code == 0, err
    trace = read_trace(tmp_path / "t.jsonl")
    assert trace.header["machine"]["name"] == "hallway_lap" and trace.header["source"].endswith("hallway_lap.uxf")
    assert len(trace.samples) == 601 and not trace.frames  # no marker in the hallway: no camera frame
    from fsm.tools.report import build_model

    html = (tmp_path / "r.html").read_text()
    model = json.loads(re.search(r'<script type="application/json" id="data">(.*?)</script>', html, re.S)[1])
    assert model == json.loads(json.dumps(build_model(trace)))
    assert [lane["label"] for lane in model["lanes"]][:2] == ["hallway_lap (top level)", "lap1"]
    assert 'data-path="lap1/bottom"' in html  # the drawing knows the state paths


def test_camera_frames_reach_the_trace_and_the_report(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = cli(capsys, "run", str(REPO / "diagrams" / "gate_run.uxf"), "--duration", "12",
                       "--world", str(REPO / "diagrams" / "worlds" / "gates.json"),
                       "--trace", str(tmp_path / "t.jsonl"), "-q")
    assert code == 0, err
    trace = read_trace(tmp_path / "t.jsonl")
    assert trace.frames and all(f["jpeg"] for f in trace.frames)
    assert any(d["id"] >= 0 for f in trace.frames for d in f["detections"])
    assert 0.9 <= trace.frames[1]["time"] - trace.frames[0]["time"] <= 1.1  # 1 Hz


def test_mcap_export_reads_back_as_the_trace(mission: Any, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from mcap.reader import make_reader

    f = tmp_path / "run.jsonl"
    f.write_text(mission[0])
    code, _, err = cli(capsys, "export", str(f), "--mcap", str(tmp_path / "run.mcap"))
    assert code == 0, err
    trace = read_trace(f)
    with open(tmp_path / "run.mcap", "rb") as fh:
        reader = make_reader(fh)
        by_topic: dict[str, list[tuple[int, Any]]] = {}
        schemas = {}
        for schema, channel, message in reader.iter_messages():
            by_topic.setdefault(channel.topic, []).append((message.log_time, json.loads(message.data)))
            schemas[channel.topic] = (schema.name, schema.encoding, channel.message_encoding)
        meta = {m.name: m.metadata for m in reader.iter_metadata()}
        attachments = {a.name for a in reader.iter_attachments()}
    transitions = [tr for e in trace.events for tr in e["transitions"]]
    assert [(m["from"], m["to"], m["type"]) for _, m in by_topic["/fsm/transitions"]] == \
        [(tr["from"], tr["to"], tr["type"]) for tr in transitions]
    assert [t for t, _ in by_topic["/fsm/transitions"]] == [round(tr["time"] * 1e9) for tr in transitions]
    assert len(by_topic["/car/pose"]) == len(trace.samples)
    first = by_topic["/car/pose"][10][1]
    assert first["pose"]["position"]["x"] == trace.samples[10]["car"]["x"]
    assert [m["range"] for _, m in by_topic["/sensors/front"]] == [s["car"]["front"] for s in trace.samples]
    assert len(by_topic["/fsm/monitors"]) == sum(len(e.get("monitors", ())) for e in trace.events)
    assert schemas["/car/pose"] == ("foxglove.PoseInFrame", "jsonschema", "json")
    assert meta["tral-fsm"]["seed"] == "3" and {"machine.json", "world.json"} <= attachments


def test_a_sweep_writes_each_runs_report_and_links_it(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    code, _, err = cli(capsys, "sweep", "--machine", str(REPO / "diagrams" / "lap.uxf"), "--seeds", "0:2",
                       "--duration", "5", "--report", "-j", "1", "-o", str(tmp_path / "out"), "--no-progress")
    assert code == 0, err
    reports = sorted((tmp_path / "out" / "runs").glob("*/report.html"))
    assert len(reports) == 2 and not list((tmp_path / "out" / "runs").glob("*/trace.jsonl"))
    assert "report.html" in (tmp_path / "out" / "sweep.html").read_text()
    assert 'id="lanes"' in reports[0].read_text()


def test_every_package_folder_is_installed() -> None:
    """A wheel holds only the packages setuptools finds (pyproject.toml: ``packages.find`` under fsm): each folder
    of Python modules must be one of them, so it needs an ``__init__.py``."""
    from setuptools import find_packages

    found = set(find_packages(str(REPO), include=["fsm", "fsm.*"]))
    for path in (REPO / "fsm").rglob("*.py"):
        rel = path.parent.relative_to(REPO)
        if "__pycache__" in rel.parts or any(p.startswith(".") for p in rel.parts):
            continue
        name = ".".join(rel.parts)
        assert name in found, f"{path.relative_to(REPO)}: package {name} is not found by setuptools"


def test_the_report_shows_the_runs_coverage(mission: Any, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """States never entered, transitions and monitors never fired, of the machine in the trace's header (the
    mission drives the car: its structure is built on a car with nothing behind it)."""
    f = tmp_path / "m.jsonl"
    f.write_text(mission[0])
    code, _, err = cli(capsys, "report", str(f), "-o", str(tmp_path / "m.html"))
    assert code == 0, err
    html = (tmp_path / "m.html").read_text()
    start = html.index('<section id="coverage-box">')
    section = html[start:html.index("</section>", start)]
    assert "<h2>Coverage of this run</h2>" in section
    assert "states 15/15, transitions 10/10, monitors 2/2 (100.0&#8201;%)" in section  # the whole mission ran
    lines = mission[0].splitlines()
    f.write_text("\n".join(lines[:len(lines) // 4]) + "\n")  # the trace cut off early in the run
    code, _, err = cli(capsys, "report", str(f), "-o", str(tmp_path / "m.html"))
    assert code == 0, err
    html = (tmp_path / "m.html").read_text()
    start = html.index('<section id="coverage-box">')
    section = html[start:html.index("</section>", start)]
    assert "<tr><th>never entered</th><td>" in section and "mission/halt" in section
    assert "mission/approach -&gt; mission/halt (Finished #2)" in section
    header = json.loads(lines[0])
    header["machine"] = {"initial": "a", "states": [{"id": "a", "type": "NoSuchType"}]}
    f.write_text("\n".join([json.dumps(header)] + lines[1:]) + "\n")
    code, _, err = cli(capsys, "report", str(f), "-o", str(tmp_path / "b.html"))
    assert code == 0, err
    html = (tmp_path / "b.html").read_text()
    assert 'id="coverage-box"' not in html and "cannot be built (DiagramError): no coverage" in html
