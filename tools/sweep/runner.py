"""Plan a sweep (check everything before any run starts), run it on a backend, and write what finished.

Planning reads the machine, applies and validates every override on it, expands the worlds and seeds, and
refuses an empty grid: every mistake is reported before the first run. Running streams records to
``sweep.jsonl`` as runs finish and, at the end or on Ctrl-C, writes ``sweep.csv`` and ``sweep.html``. A run
whose inputs (files, world, seed, overrides, variables, limits) are unchanged and that finished before is not
run again.
"""

from __future__ import annotations

import json
import os
import shlex
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from fsm.errors import Problem

from . import overrides as O
from .results import csv_text, html_page, read_jsonl, success
from .spec import Run, SweepSpec, expand_worlds, files_digest, grid, parse_seeds, run_key, seed_runs


@dataclass
class Plan:
    spec: SweepSpec
    name: str
    machine: Path
    runs: list[Run]
    jobs: list[dict[str, Any]]
    param_names: list[str]
    plugins: list[str] = field(default_factory=list)
    worlds: dict[str, Any] = field(default_factory=dict)


#: What ``where`` says when the sweep comes from flags, not a file.
CLI = "the command line"


class PlanError(Exception):
    def __init__(self, problems: list[Problem]) -> None:
        super().__init__("; ".join(p.message for p in problems))
        self.problems = problems


def plan(spec: SweepSpec, base: Path, name: str, where: str, out_dir: Path) -> Plan:
    """Everything checked; ``where`` names the spec (a file, or 'the command line') in messages."""
    from fsm.loader import check, machine_files, uses_car
    from fsm.registry import default_registry

    problems: list[Problem] = []

    def fail(message: str, ptr: str = "", hint: str | None = None) -> PlanError:
        if where == CLI:  # said as the flag it came from, not as a place in a file
            flag = {"seeds": "--seeds", "worlds": "--world", "set": "--set", "machine": "--machine",
                    "vars": "--var"}.get(ptr.strip("/").split("/")[0], "fsmctl sweep")
            text = message if message.startswith(("--", "worlds", "seeds")) else f"{flag}: {message}"
            return PlanError(problems + [Problem(text.replace("worlds: ", "--world: ").replace(
                "seeds ", "--seeds ", 1), "fsmctl sweep", hint=hint)])
        return PlanError(problems + [Problem(message, where, ptr, hint=hint)])

    plugins = [str(base / p) if p.endswith(".py") else p for p in spec.plugins]
    machine = (base / spec.machine).resolve()
    if not machine.is_file():
        raise fail(f"machine file not found: {machine}", "/machine")
    registry = default_registry(tuple(plugins))
    mspec, found = check(str(machine), registry=registry)
    errors = [p for p in found if p.severity == "error"]
    if mspec is None or errors:
        raise PlanError(errors or found)
    try:
        seeds = parse_seeds(spec.seeds)
    except ValueError as exc:
        raise fail(str(exc), "/seeds") from None
    sets = []
    for i, (key, values) in enumerate(spec.set.items()):
        if not isinstance(values, list) or not values:
            raise fail(f"set {key!r}: give a non-empty list of values", f"/set/{key}")
        text = f"{key}={','.join(json.dumps(v) for v in values)}"
        try:
            o = O.parse(text)
            o = O.Override(o.path, o.param, tuple(values), text)
            O.check(mspec, o)
        except O.OverrideError as exc:
            raise fail(str(exc), f"/set/{key}") from None
        sets.append((o.path, o.param, list(values)))
    for key, values in spec.vars.items():
        if not isinstance(values, list) or not values:
            raise fail(f"vars {key!r}: give a non-empty list of values", f"/vars/{key}")
    try:
        worlds: list[Path | None] = list(expand_worlds(spec.worlds, base))
    except ValueError as exc:
        raise fail(str(exc), "/worlds") from None
    if not worlds:
        if uses_car(mspec):
            from fsm.sim.world import default_world

            worlds = [default_world(str(machine)).resolve()]
        else:
            worlds = [None]
    world_walls: dict[str, Any] = {}
    for w in worlds:
        if w is None:
            continue
        from fsm.sim.world import load_world

        try:
            world = load_world(w)
        except Exception as exc:  # noqa: BLE001 - a bad world file is the user's: its own message
            raise fail(f"world {w}: {' '.join(str(exc).split())[:400]}", "/worlds") from None
        world_walls[str(w)] = [[list(pt) for pt in wall.points] + ([list(wall.points[0])] if wall.closed else [])
                               for wall in world.walls]
    runs = grid(worlds, seeds, sets, spec.vars)
    if not runs:
        raise fail("the grid is empty: no world, seed or value to run", "", hint="give --seeds and --world")
    seed_runs(runs)
    files = machine_files(mspec) + [str(w) for w in worlds if w is not None]
    digest = files_digest(files)
    param_names = list(runs[0].params)
    jobs = []
    for run in runs:
        run.key = run_key(run, digest, spec)
        jobs.append(_job(run, spec, machine, plugins, out_dir))
    return Plan(spec, name, machine, runs, jobs, param_names, plugins, world_walls)


def _job(run: Run, spec: SweepSpec, machine: Path, plugins: list[str], out_dir: Path) -> dict[str, Any]:
    wants = spec.outputs.trace or spec.outputs.report or spec.outputs.plot or spec.outputs.video
    cmd = ["fsmctl"] + [a for p in plugins for a in ("--plugin", p)] + ["run", str(machine)]
    if run.world is not None:
        cmd += ["--world", str(run.world), "--seed", str(run.run_seed)]
    if not spec.noise:
        cmd.append("--no-noise")
    if spec.duration is not None:
        cmd += ["--duration", f"{spec.duration:g}"]
    overrides = [f"{path}.{param}={json.dumps(value)}" for path, param, value in run.sets]
    for text in overrides:
        cmd += ["--set", text]
    for name, value in run.variables.items():
        cmd += ["--var", f"{name}={json.dumps(value)}"]
    cmd += ["--summary", "summary.json"]
    return {"id": run.id, "index": run.index, "key": run.key, "machine": str(machine), "plugins": plugins,
            "world": str(run.world) if run.world is not None else None, "seed": run.seed, "run_seed": run.run_seed,
            "sets": [list(s) for s in run.sets], "overrides": overrides, "vars": run.variables, "params": run.params,
            "duration": spec.duration, "noise": spec.noise,
            "out": str(out_dir / "runs" / run.id) if wants else None,
            "trace": spec.outputs.trace, "report": spec.outputs.report, "plot": spec.outputs.plot, "video": spec.outputs.video,
            "command": shlex.join(cmd)}


@dataclass
class Outcome:
    records: list[dict[str, Any]]
    ran: int
    skipped: int
    interrupted: bool
    seconds: float


def execute(p: Plan, out_dir: Path, *, backend: str = "process", jobs: int = 1, address: str | None = None,
            progress: bool = False, pool: Any = None) -> Outcome:
    """Run what is not finished yet; write sweep.jsonl as runs finish, then sweep.csv and sweep.html."""
    from .backends import local_pool, ray_pool, shutdown_ray

    jsonl = out_dir / "sweep.jsonl"
    keys = {job["key"] for job in p.jobs}
    done: dict[str, dict[str, Any]] = {}
    for rec in read_jsonl(jsonl):
        if rec["key"] in keys and rec.get("ok"):
            done[rec["key"]] = rec
    todo = [job for job in p.jobs if job["key"] not in done]
    results = dict(done)
    t0 = time.perf_counter()
    interrupted = False
    bar = Progress(len(todo), enabled=progress)
    if not todo and pool is not None:
        pool.terminate()
        pool.join()
    if todo:
        if pool is None:  # may refuse (Ray): nothing is written yet
            pool = ray_pool(jobs, address) if backend == "ray" else local_pool(jobs)
        out_dir.mkdir(parents=True, exist_ok=True)
        from .worker import run_one

        try:
            with open(jsonl, "a", encoding="utf-8") as stream:
                for rec in pool.imap_unordered(run_one, todo):
                    rec["files"] = _write_run(out_dir, rec)
                    stream.write(json.dumps(rec, separators=(",", ":")) + "\n")
                    stream.flush()
                    results[rec["key"]] = rec
                    bar.step(rec)
            pool.close()  # the workers exit while the reports are written
        except KeyboardInterrupt:
            interrupted = True
            pool.terminate()
        except BaseException:
            pool.terminate()
            raise
        finally:
            bar.done()
    records = [results[job["key"]] for job in p.jobs if job["key"] in results]
    out_dir.mkdir(parents=True, exist_ok=True)
    try:
        write_reports(p, out_dir, records)
    finally:
        if pool is not None and todo:
            pool.join()
            if backend == "ray":
                shutdown_ray()
    return Outcome(records, len(records) - len(done), len(done), interrupted, time.perf_counter() - t0)


def _write_run(out_dir: Path, rec: dict[str, Any]) -> list[str]:
    """OUT/runs/<id>/summary.json (the run's `fsmctl run --summary`), next to what the worker wrote there."""
    folder = out_dir / "runs" / rec["id"]
    folder.mkdir(parents=True, exist_ok=True)
    data = rec["summary"] if rec.get("ok") else {"error": rec.get("error"), "traceback": rec.get("traceback")}
    (folder / "summary.json").write_text(json.dumps(data, indent=2) + "\n", encoding="utf-8")
    return sorted(f.name for f in folder.iterdir() if f.is_file())


def write_reports(p: Plan, out_dir: Path, records: list[dict[str, Any]]) -> None:
    from ..files import Output

    for name, text in (("sweep.csv", csv_text(records, p.param_names)),
                       ("sweep.html", html_page(p.name, records, p.param_names, p.worlds))):
        out = Output(str(out_dir / name), f"sweep {name}")
        out.classify()
        out.open()
        out.write(text)
        out.commit()


class Progress:
    """A one-line progress bar with the time left, on a terminal only."""

    def __init__(self, total: int, enabled: bool) -> None:
        self.total = total
        self.enabled = enabled and total > 0
        self.count = 0
        self.failed = 0
        self.t0 = time.perf_counter()

    def step(self, rec: dict[str, Any]) -> None:
        self.count += 1
        self.failed += 0 if success(rec) else 1
        if not self.enabled:
            return
        elapsed = time.perf_counter() - self.t0
        left = elapsed / self.count * (self.total - self.count)
        width = 30
        filled = int(width * self.count / self.total)
        sys.stderr.write(f"\r[{'#' * filled}{'.' * (width - filled)}] {self.count}/{self.total} runs, "
                         f"{self.failed} not succeeded, {int(left) // 60}:{int(left) % 60:02d} left ")
        sys.stderr.flush()

    def done(self) -> None:
        if self.enabled:
            sys.stderr.write("\n")
            sys.stderr.flush()


def load_spec_file(path: Path) -> tuple[SweepSpec, list[Problem]]:
    """A sweep file, validated against the model (located problems)."""
    from pydantic import ValidationError

    from fsm.document import Source, problems_from_validation
    from fsm.reading import parse_json_bytes, place, read_file_bytes

    raw = read_file_bytes(path, "sweep")
    data, source = parse_json_bytes(raw, str(path), path.parent)
    if not isinstance(data, dict):
        return SweepSpec(machine="?"), [Problem("a sweep file is a JSON object with 'machine'", str(path))]
    try:
        return SweepSpec.model_validate(data), []
    except ValidationError as err:
        problems = problems_from_validation(err, source=Source(name=str(path)), base="", element=None,
                                            model=SweepSpec, kind="key", data=data)
        place(problems, source.locator)
        return SweepSpec(machine="?"), problems


def _env_cpus() -> int:
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
