"""``fsmctl sweep`` (issue 12): the grid, identical per-run summaries on -j 1, -j 2 and Ray, a run reproduced
alone by its printed `fsmctl run` command, a failing run, resume, the spec schema and bad input (Ctrl-C and hostile
input: test_sweep_hostile.py)."""

from __future__ import annotations

import json
import os
import shlex
import time
from pathlib import Path
from typing import Any

import jsonschema
import pytest

from helpers import cli

REPO = Path(__file__).resolve().parents[1]
LAP = REPO / "diagrams" / "corner_turn.uxf"  # short (18 s simulated): keeps the sweeps quick
TIMING = ("wall_time", "realtime_factor", "realtime_factor_with_outputs")


def summaries(out: Path) -> dict[str, dict[str, Any]]:
    recs = [json.loads(line) for line in (out / "sweep.jsonl").read_text().splitlines()]
    return {r["id"]: {k: v for k, v in r["summary"].items() if k not in TIMING} for r in recs}


def sweep(capsys: pytest.CaptureFixture[str], out: Path, *extra: str) -> tuple[int, str, str]:
    return cli(capsys, "sweep", "--machine", str(LAP), "--seeds", "0:2", "--set", "follow.speed=0.8,1.0",
               "-o", str(out), "--no-progress", *extra)


def test_schema_is_committed_and_current() -> None:
    from fsm.tools.sweep.spec import SWEEP_SCHEMA_PATH, sweep_schema

    assert json.loads(SWEEP_SCHEMA_PATH.read_text()) == sweep_schema(), \
        "regenerate it: python -m fsm.tools.sweep --schema fsm/schema/sweep.schema.json"
    jsonschema.Draft202012Validator.check_schema(sweep_schema())


def test_a_sweep_writes_records_csv_html_and_summaries(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = sweep(capsys, tmp_path, "-j", "2", "--plot")
    assert code == 0, err
    assert "4 of 4 runs" in out
    recs = [json.loads(line) for line in (tmp_path / "sweep.jsonl").read_text().splitlines()]
    assert sorted(r["id"] for r in recs) == ["0000", "0001", "0002", "0003"]
    assert {(r["seed"], r["params"]["follow.speed"]) for r in recs} == {(0, 0.8), (0, 1.0), (1, 0.8), (1, 1.0)}
    assert all(r["ok"] and r["summary"]["outcome"] == "succeeded" for r in recs)
    assert len({r["run_seed"] for r in recs}) == 4  # SeedSequence: every run its own seed
    rows = (tmp_path / "sweep.csv").read_text().splitlines()
    assert rows[0].startswith("id,ok,outcome,world,seed,follow.speed") and [r[:4] for r in rows[1:]] == \
        ["0000", "0001", "0002", "0003"]
    page = (tmp_path / "sweep.html").read_text()
    assert "Success rate per parameter value" in page and "<svg" in page and "Dwell time" in page
    assert "http" not in page.replace("https://", "")  # nothing fetched
    for r in recs:
        folder = tmp_path / "runs" / r["id"]
        assert json.loads((folder / "summary.json").read_text())["outcome"] == "succeeded"
        assert (folder / "plot.png").read_bytes()[:4] == b"\x89PNG"


def test_summaries_are_identical_on_one_and_two_processes_and_on_ray(tmp_path: Path,
                                                                     capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("ray") if not os.environ.get("CI") else None  # CI installs the extra: it must run there
    one, two, ray = tmp_path / "one", tmp_path / "two", tmp_path / "ray"
    assert sweep(capsys, one, "-j", "1")[0] == 0
    assert sweep(capsys, two, "-j", "2")[0] == 0
    code, _out, err = sweep(capsys, ray, "-j", "2", "--backend", "ray")
    assert code == 0, err
    assert summaries(one) == summaries(two) == summaries(ray)
    assert len(summaries(one)) == 4


def test_the_printed_command_reproduces_a_run_alone(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    assert sweep(capsys, tmp_path / "s", "-j", "2")[0] == 0
    rec = next(json.loads(line) for line in (tmp_path / "s" / "sweep.jsonl").read_text().splitlines()
               if json.loads(line)["id"] == "0003")
    argv = shlex.split(rec["command"])
    assert argv[0] == "fsmctl" and "--set" in argv and "--seed" in argv
    monkeypatch.chdir(tmp_path)  # restored after the test: later tests of this worker read paths from the checkout
    code, _out, err = cli(capsys, *argv[1:], "-q")
    assert code == 0, err
    alone = {k: v for k, v in json.loads((tmp_path / "summary.json").read_text()).items() if k not in TIMING}
    assert alone == summaries(tmp_path / "s")["0003"]


def test_a_run_that_raises_is_a_record_and_the_sweep_goes_on(tmp_path: Path,
                                                              capsys: pytest.CaptureFixture[str]) -> None:
    plugin = tmp_path / "boom.py"
    plugin.write_text("from fsm import State, register_state\n\n@register_state\nclass Boom(State):\n"
                      "    def tick(self, ctx):\n        if ctx.vars['n'] > 1:\n            raise RuntimeError('n is '"
                      " + str(ctx.vars['n']))\n")
    machine = tmp_path / "m.json"
    machine.write_text(json.dumps({"initial": "b", "vars": {"n": 0}, "states": [{"id": "b", "type": "Boom"}]}))
    spec = tmp_path / "s.json"
    spec.write_text(json.dumps({"machine": "m.json", "plugins": ["boom.py"], "vars": {"n": [0, 1, 2]},
                                "duration": 1}))
    code, out, err = cli(capsys, "sweep", str(spec), "-o", str(tmp_path / "out"), "-j", "2", "--no-progress")
    assert code == 1
    lines = (tmp_path / "out" / "sweep.jsonl").read_text().splitlines()
    recs = {r["params"]["vars.n"]: r for r in map(json.loads, lines)}
    assert recs[0]["ok"] and recs[1]["ok"] and not recs[2]["ok"]
    assert "raised RuntimeError in tick" in recs[2]["error"] and "n is 2" in recs[2]["error"]
    assert "reproduce: fsmctl" in err
    assert "1 raised" in out
    assert "n is 2" in (tmp_path / "out" / "sweep.html").read_text()


def test_running_again_skips_finished_runs(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert sweep(capsys, tmp_path, "-j", "2")[0] == 0
    t0 = time.perf_counter()
    code, out, _ = sweep(capsys, tmp_path, "-j", "2")
    assert code == 0 and "(0 ran, 4 finished before)" in out
    assert time.perf_counter() - t0 < 3
    code, out, _ = cli(capsys, "sweep", "--machine", str(LAP), "--seeds", "0:3", "--set", "follow.speed=0.8,1.0",
                       "-o", str(tmp_path), "--no-progress", "-j", "2")
    assert code == 0 and "(2 ran, 4 finished before)" in out  # one more seed: only its two runs


@pytest.mark.parametrize("args, message", [
    (["--set", "folow.speed=1"], "no state at path 'folow'; did you mean 'follow'"),
    (["--set", "follow.sped=1"], "has no parameter 'sped'; did you mean 'speed'"),
    (["--set", "follow.speed=fast"], 'speed="fast" is not valid for \'follow\''),
    (["--world", "nowhere/*.json"], "matches no file"),
    (["--seeds", "5:2"], "seeds '5:2': write START:STOP"),
])
def test_bad_input_is_reported_before_any_run(args: list[str], message: str, tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    code, _out, err = cli(capsys, "sweep", "--machine", str(LAP), "-o", str(tmp_path / "o"), *args)
    assert code == 2, err  # a flag's value: a usage error
    assert message in err and "Traceback" not in err
    assert not (tmp_path / "o").exists()


def test_an_unreachable_ray_address_is_an_error_before_any_run(tmp_path: Path,
                                                                capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("ray") if not os.environ.get("CI") else None
    code, _out, err = cli(capsys, "sweep", "--machine", str(LAP), "-o", str(tmp_path / "o"), "--backend", "ray",
                          "--address", "127.0.0.1:1", "--no-progress")
    assert code == 1
    assert "cannot start or reach a Ray cluster at 127.0.0.1:1" in err
    assert not (tmp_path / "o" / "sweep.jsonl").exists() or not (tmp_path / "o" / "sweep.jsonl").read_text()
