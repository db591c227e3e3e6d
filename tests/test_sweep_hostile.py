"""``fsmctl sweep`` on hostile input (issue 22): links and inputs inside the output folder, a FIFO or a cut-off
last line in sweep.jsonl, records of the wrong shape, grids too large to plan, durations ``fsmctl run`` refuses,
bad seeds, missing plugins, full disks, and Ctrl-C at any moment. Every case: no traceback, one message naming
the file, nothing of the user's touched."""

from __future__ import annotations

import json
import os
import resource
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from helpers import cli

REPO = Path(__file__).resolve().parents[1]
#: A machine without a car: its runs take milliseconds.
MISSION = REPO / "diagrams" / "mission.json"
LAP = REPO / "diagrams" / "hallway_lap.json"
HALLWAY = REPO / "diagrams" / "worlds" / "hallway.json"
#: The runs of the sweep interrupted once its first record is written: a run of 0.5 s takes about 50 ms, so four
#: runs could all end between two looks of the test at a busy moment; 24 leave it over a second.
RUNS_TO_INTERRUPT = 24
FSMCTL = str(Path(sys.executable).parent / "fsmctl")


@pytest.fixture
def machine(tmp_path: Path) -> Path:
    """A copy of a small machine that the sweep must never write to."""
    path = tmp_path / "mission.json"
    path.write_bytes(MISSION.read_bytes())
    return path


def sweep(capsys: pytest.CaptureFixture[str], machine: Path, out: Path, *extra: str) -> tuple[int, str, str]:
    return cli(capsys, "sweep", "--machine", str(machine), "--duration", "0.5", "-j", "1", "-o", str(out),
               "--no-progress", *extra)


def lines(path: Path) -> list[dict]:
    text = path.read_text()
    assert text == "" or text.endswith("\n"), "sweep.jsonl must end on a line"
    return [json.loads(line) for line in text.splitlines()]


# -- the output folder ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("link", ["sweep.html", "sweep.jsonl", "sweep.csv", "runs", "runs/0000",
                                  "runs/0000/summary.json"])
def test_a_symlink_inside_the_output_folder_is_refused(link: str, machine: Path, tmp_path: Path,
                                                       capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out"
    where = out / link
    where.parent.mkdir(parents=True, exist_ok=True)
    target = os.path.relpath(machine if not link.startswith("runs") or "." in link else tmp_path, where.parent)
    where.symlink_to(target)
    before = machine.read_bytes()
    code, _out, err = sweep(capsys, machine, out)
    assert code == 2, err
    assert f"{where} is a symlink to {target}" in err and len(err.strip().splitlines()) == 1
    assert machine.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mission.json", "out"]


@pytest.mark.parametrize("which", ["machine", "world", "sweep file"])
def test_an_output_that_is_an_input_is_refused(which: str, machine: Path, tmp_path: Path,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out"
    out.mkdir()
    spec = {"machine": "mission.json", "duration": 0.5}
    if which == "machine":
        (out / "sweep.html").write_bytes(machine.read_bytes())
        spec["machine"] = "out/sweep.html"
    elif which == "world":
        (out / "runs" / "0000").mkdir(parents=True)
        (out / "runs" / "0000" / "summary.json").write_bytes(HALLWAY.read_bytes())
        spec["worlds"] = ["out/runs/0000/summary.json"]
    spec_file = tmp_path / "s.json"
    if which == "sweep file":
        spec_file, spec["machine"] = out / "sweep.csv", "../mission.json"
    spec_file.write_text(json.dumps(spec))
    before = {p: p.read_bytes() for p in out.rglob("*") if p.is_file()}
    code, _out, err = cli(capsys, "sweep", str(spec_file), "-o", str(out), "-j", "1", "--no-progress")
    assert code == 2, err
    assert "is the same file as the input" in err
    assert {p: p.read_bytes() for p in out.rglob("*") if p.is_file()} == before


def test_a_fifo_as_sweep_jsonl_is_refused_at_once(machine: Path, tmp_path: Path,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out"
    out.mkdir()
    os.mkfifo(out / "sweep.jsonl")
    t0 = time.perf_counter()
    code, _out, err = sweep(capsys, machine, out)
    assert code == 2 and "sweep.jsonl is a FIFO" in err
    assert time.perf_counter() - t0 < 20


# -- resuming ---------------------------------------------------------------------------------------------------
def test_resume_drops_a_cut_off_line_and_ignores_records_of_the_wrong_shape(machine: Path, tmp_path: Path,
                                                                           capsys: pytest.CaptureFixture[str]) -> None:
    """Lines that are not records (non-objects, missing keys, wrong types, not UTF-8) are ignored with one warning;
    a last line without its end of line (a sweep killed while writing it) is removed with a warning; their runs
    run again, and the first new record starts on a line of its own."""
    out = tmp_path / "out"
    assert sweep(capsys, machine, out, "--seeds", "0:3")[0] == 0
    jsonl = out / "sweep.jsonl"
    good = sorted(lines(jsonl), key=lambda r: r["id"])
    broken = dict(good[0], params=5, summary=[], track=[[1e308, "x"]])
    junk = [b"[1, 2]", b'{"key": 5}', b'"text"', b"{}", b"not json", b"\xff", json.dumps(broken).encode()]
    cut = json.dumps(good[2]).encode()[:200]
    jsonl.write_bytes(b"\n".join(junk + [json.dumps(good[1]).encode(), cut]))
    code, printed, err = sweep(capsys, machine, out, "--seeds", "0:3")
    assert code == 0, err
    assert f"{jsonl}:1: warning: not the record of a finished run (a JSON list, not an object), and 6 more lines " \
           "like it: ignored; such a run runs again" in err
    assert f"{jsonl}:9: warning: the last line has no end of line (200 bytes left by a sweep that was stopped " \
           "while writing it): removed; its run runs again" in err
    assert "(2 ran, 1 finished before)" in printed
    after = jsonl.read_bytes()
    assert after.startswith(b"\n".join(junk + [json.dumps(good[1]).encode()]) + b"\n") and after.endswith(b"\n")
    assert sorted(json.loads(line)["id"] for line in after.splitlines()[8:]) == ["0000", "0002"]
    assert len((out / "sweep.csv").read_text().splitlines()) == 4


def test_a_failing_write_names_the_file_and_leaves_whole_lines(machine: Path, tmp_path: Path,
                                                               capsys: pytest.CaptureFixture[str]) -> None:
    """A file size limit makes the third record's write fail (as a full disk does): the message names
    sweep.jsonl, the record is cut back, and the next sweep goes on from the two that finished."""
    out = tmp_path / "out"
    args = ["--machine", str(machine), "--seeds", "0:4", "--duration", "0.5", "-j", "1", "-o", str(out),
            "--no-progress"]

    def limit() -> None:
        resource.setrlimit(resource.RLIMIT_FSIZE, (3800, 3800))  # two records (about 1.5 KB each), not three

    done = subprocess.run([FSMCTL, "sweep", *args], capture_output=True, text=True, timeout=120, preexec_fn=limit)
    assert done.returncode == 1, done.stderr
    assert done.stderr.strip().splitlines()[-1] == f"fsmctl: error: {out / 'sweep.jsonl'}: cannot write: File too large"
    assert len(lines(out / "sweep.jsonl")) == 2
    code, printed, err = cli(capsys, "sweep", *args)
    assert code == 0 and "(2 ran, 2 finished before)" in printed, err


# -- what is checked before planning ---------------------------------------------------------------------------
def test_a_grid_too_large_is_refused_before_it_is_built(machine: Path, tmp_path: Path,
                                                        capsys: pytest.CaptureFixture[str]) -> None:
    t0 = time.perf_counter()
    code, _out, err = sweep(capsys, machine, tmp_path / "o", "--seeds", "0:10000000", "--set",
                            "wait.seconds=1,2")
    assert code == 2  # of a flag: a usage error
    assert "--seeds: the sweep would make 20,000,000 runs (10,000,000 seeds x 2 values of wait.seconds), " \
           "more than 10,000 (give --max-runs 20000000" in err
    assert time.perf_counter() - t0 < 5
    code, _out, err = sweep(capsys, machine, tmp_path / "o", "--seeds", "0:4", "--max-runs", "3")
    assert code == 2 and "4 runs" in err and "more than 3" in err
    assert not (tmp_path / "o").exists()
    code, printed, err = sweep(capsys, machine, tmp_path / "o", "--seeds", "0:3", "--max-runs", "3")
    assert code == 0 and "3 runs: 3 to run" in printed, err


@pytest.mark.parametrize("seeds, message", [
    ([-1, 2], "at /seeds/0: error: seeds: -1 is not a seed"),
    ([1, 2**63], "at /seeds/1: error: seeds: 9223372036854775808 is not a seed"),
    ("0:1e9", "at /seeds: error: seeds '0:1e9': write START:STOP"),
    ("-3:2", "at /seeds: error: seeds '-3:2'"),
    ([], "the grid is empty"),
    ([3, 3], "at /seeds/1: error: seeds: 3 is given twice (items 0 and 1)"),
])
def test_bad_seeds_in_a_sweep_file(seeds: object, message: str, machine: Path, tmp_path: Path,
                                   capsys: pytest.CaptureFixture[str]) -> None:
    spec = tmp_path / "s.json"
    spec.write_text(json.dumps({"machine": "mission.json", "seeds": seeds}))
    code, _out, err = cli(capsys, "sweep", str(spec), "-o", str(tmp_path / "o"))
    assert code == 1, err
    assert message in err and str(spec) in err


def test_a_duration_fsmctl_run_refuses_is_refused(machine: Path, tmp_path: Path,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    code, _out, err = sweep(capsys, machine, tmp_path / "o", "--duration", "1e308", "-q")
    assert code == 2
    assert err.strip() == ("fsmctl: error: --duration 1e+308: more than 10,000,000 ticks of 0.0125 s, the longest "
                           "run `fsmctl run` accepts without --max-ticks; give at most 125000 s")
    spec = tmp_path / "s.json"
    spec.write_text(json.dumps({"machine": "mission.json", "duration": 125000.5}))
    code, _out, err = cli(capsys, "sweep", str(spec), "-o", str(tmp_path / "o"))
    assert code == 1 and f"{spec} at /duration: error: duration 125000.5: more than 10,000,000 ticks" in err
    assert not (tmp_path / "o").exists()


def test_the_longest_sweep_duration_is_one_fsmctl_run_accepts() -> None:
    import argparse

    from fsm.runtime.clock import DEFAULT_DT
    from fsm.tools.cli import run
    from fsm.tools.sweep import spec

    assert spec.MAX_TICKS == run.MAX_TICKS
    longest = spec.MAX_TICKS * DEFAULT_DT
    assert spec.check_duration(longest) is None
    assert run._tick_limit(argparse.Namespace(duration=longest, max_ticks=None), DEFAULT_DT)[0] == longest
    assert spec.check_duration(longest * (1 + 1e-12)) is not None


def test_the_reproduce_command_carries_the_duration_exactly(machine: Path, tmp_path: Path) -> None:
    """``0.123456789`` is not cut to six digits (``%g``): the run alone stops where the sweep's did."""
    from fsm.tools.sweep.runner import CLI, plan
    from fsm.tools.sweep.spec import SweepSpec

    spec = SweepSpec(machine=str(machine), duration=0.123456789)
    command = plan(spec, tmp_path, "x", CLI, tmp_path / "o").jobs[0]["command"]
    assert "--duration 0.123456789 " in command


def test_a_world_or_value_given_twice_is_refused(machine: Path, tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    """Two runs that would be the same run (a world named twice, by a glob and by name; a value twice)."""
    (tmp_path / "worlds").mkdir()
    (tmp_path / "worlds" / "hallway.json").write_bytes(HALLWAY.read_bytes())
    spec = tmp_path / "s.json"
    spec.write_text(json.dumps({"machine": "mission.json", "worlds": ["worlds/*.json", "./worlds/hallway.json"]}))
    code, _out, err = cli(capsys, "sweep", str(spec), "-o", str(tmp_path / "o"))
    assert code == 1 and f"at /worlds/1: error: worlds: {tmp_path / 'worlds' / 'hallway.json'} is named twice (by " \
                         "'worlds/*.json' and './worlds/hallway.json')" in err, err
    spec.write_text(json.dumps({"machine": "mission.json", "set": {"mission/halt.still": [0.5, 1, 0.5]}}))
    code, _out, err = cli(capsys, "sweep", str(spec), "-o", str(tmp_path / "o"))
    assert code == 1 and "at /set/mission~1halt.still/2: error: set mission/halt.still: 0.5 is given twice" in err


@pytest.mark.parametrize("key, values, message", [
    ("1x", [1], "vars '1x': a variable's name is a word"),
    ("limit", [{"a": 1}], "vars limit: {\"a\": 1} is not a number, true/false or text"),
    ("limit", [], "vars 'limit': give a non-empty list of values"),
])
def test_variables_fsmctl_run_could_not_take_are_refused(key: str, values: list, message: str, machine: Path,
                                                         tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    spec = tmp_path / "s.json"
    spec.write_text(json.dumps({"machine": "mission.json", "vars": {key: values}}))
    code, _out, err = cli(capsys, "sweep", str(spec), "-o", str(tmp_path / "o"))
    assert code == 1 and message in err and "at /vars/" in err, err


def test_a_missing_plugin_is_blamed_on_the_sweep_file_or_the_flag_that_named_it(
        machine: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    spec = tmp_path / "s.json"
    spec.write_text(json.dumps({"machine": "mission.json", "plugins": ["no_such_plugin_module"]}))
    code, _out, err = cli(capsys, "sweep", str(spec), "-o", str(tmp_path / "o"))
    assert code == 1
    assert err.startswith(f"{spec} at /plugins/0: error: plugin 'no_such_plugin_module': no module named")
    assert "--plugin" not in err
    code, _out, err = cli(capsys, "--plugin", "no_such_flag_plugin", "sweep", str(spec), "-o", str(tmp_path / "o"))
    assert code == 2 and "--plugin no_such_flag_plugin: no module named" in err


def test_the_global_plugin_flag_reaches_the_workers(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "boom.py").write_text("from fsm import State, register_state\n\n@register_state\nclass Boom(State):\n"
                                      "    def tick(self, ctx):\n        raise RuntimeError('always')\n")
    (tmp_path / "m.json").write_text(json.dumps({"initial": "b", "states": [{"id": "b", "type": "Boom"}]}))
    monkeypatch.chdir(tmp_path)
    code, printed, err = cli(capsys, "--plugin", "boom.py", "sweep", "--machine", "m.json", "--duration", "0.5",
                             "-o", "out", "-j", "1", "-q")
    assert code == 1 and printed == ""
    assert err.strip().splitlines() == [
        "fsmctl sweep: 1 of 1 runs raised (run 0000: StateRuntimeError: state 'b' raised RuntimeError in tick at "
        f"tick 1 (t=0.0125 s): always (at {tmp_path / 'boom.py'}:6)); see out/sweep.html"]
    assert f"--plugin {tmp_path / 'boom.py'} run" in lines(tmp_path / "out" / "sweep.jsonl")[0]["command"]


# -- Ctrl-C -----------------------------------------------------------------------------------------------------
def _cpu_seconds(pid: int) -> float:
    """CPU time a process has used (0 once it is gone)."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return 0.0
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads /proc")
def test_ctrl_c_at_any_moment_of_the_first_second(tmp_path: Path) -> None:
    """Ctrl-C (SIGINT to the whole process group, as a terminal sends it) at moments spread over the sweep's first
    second, workers starting included, and SIGINT to the sweep alone once a run finished: exit 130, no traceback
    from any process, sweep.jsonl holds whole records only, and running the same sweep again goes on from there.
    The moments count from when the process has used 0.1 s of CPU: before that, Python itself starts (its site
    module, the console script's first lines), where no code of the project runs yet."""
    moments = [0.0, 0.2, 0.45, 0.75, None]  # None: once the first record is written, to the sweep's process alone
    procs = []
    for i, moment in enumerate(moments):
        out = tmp_path / f"o{i}"
        seeds = f"0:{RUNS_TO_INTERRUPT}" if moment is None else "0:4"  # enough runs left to stop it among them
        args = [FSMCTL, "sweep", "--machine", str(LAP), "--world", str(HALLWAY), "--seeds", seeds, "--duration", "0.5",
                "-j", "1" if moment is None else "2", "-o", str(out), "--no-progress"]
        procs.append((moment, out, args, subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                                          text=True, start_new_session=True)))
    started: dict[int, float] = {}
    pending = list(range(len(procs)))
    deadline = time.monotonic() + 120
    while pending and time.monotonic() < deadline:
        for i in list(pending):
            moment, out, _args, proc = procs[i]
            now = time.monotonic()
            if i not in started and _cpu_seconds(proc.pid) >= 0.1:
                started[i] = now
            jsonl = out / "sweep.jsonl"
            due = (moment is None and jsonl.exists() and jsonl.stat().st_size > 0) or \
                (moment is not None and i in started and now - started[i] >= moment) or proc.poll() is not None
            if due:
                if proc.poll() is None and moment is None:
                    os.kill(proc.pid, signal.SIGINT)
                elif proc.poll() is None:
                    os.killpg(proc.pid, signal.SIGINT)
                pending.remove(i)
        time.sleep(0.01)
    assert not pending, "the sweeps did not start"
    kept = {}
    for moment, out, _args, proc in procs:
        _out, err = proc.communicate(timeout=120)
        assert "Traceback" not in err and "Error" not in err and "leaked" not in err, (moment, err)
        assert proc.returncode in (130, 0), (moment, proc.returncode, err)  # 0: it finished before the signal
        jsonl = out / "sweep.jsonl"
        kept[moment] = lines(jsonl) if jsonl.exists() else []
        assert len({r["id"] for r in kept[moment]}) == len(kept[moment])
        if (out / "sweep.csv").exists():
            assert len((out / "sweep.csv").read_text().splitlines()) == 1 + len(kept[moment])
    assert procs[-1][3].returncode == 130 and 1 <= len(kept[None]) < RUNS_TO_INTERRUPT
    _moment, out, args, _proc = procs[-1]
    again = subprocess.run(args, capture_output=True, text=True, timeout=120)
    assert again.returncode == 0, again.stderr
    assert f"({RUNS_TO_INTERRUPT - len(kept[None])} ran, {len(kept[None])} finished before)" in again.stdout


def test_the_console_script_ends_quietly_on_a_ctrl_c_before_the_command_runs(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    """fsmctl_entry.py: a KeyboardInterrupt while tral-fsm is imported or the parser is built (before
    fsm/tools/cli/app.py catches it) is exit 130 and one line; afterwards a late Ctrl-C is ignored."""
    import fsmctl_entry
    from fsm.tools.cli import app

    def interrupted() -> int:
        raise KeyboardInterrupt

    monkeypatch.setattr(app, "main", interrupted)
    old = signal.getsignal(signal.SIGINT)
    try:
        assert fsmctl_entry.main() == 130
        assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
    finally:
        signal.signal(signal.SIGINT, old)
    assert capsys.readouterr().err == "fsmctl: interrupted\n"
