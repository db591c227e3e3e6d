"""Plan a sweep (check everything before any run starts), run it on a backend, and write what finished.

Planning reads the machine, applies and validates every override on it, expands the worlds and seeds, and
refuses an empty grid: every mistake is reported before the first run. Running streams records to
``sweep.jsonl`` as runs finish and, at the end or on Ctrl-C, writes ``sweep.csv`` and ``sweep.html``. A run
whose inputs (files, world, seed, overrides, variables, limits) are unchanged and that finished before is not
run again.
"""

from __future__ import annotations

import json
import multiprocessing
import os
import shlex
import sys
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from fsm.loading.loader import check, machine_files, uses_car
from fsm.loading.registry import default_registry
from fsm.model.errors import DiagramError, FsmError, Problem, UsageError

from ..files import Outputs
from . import overrides as O
from .backends import local_pool, ray_pool, shutdown_ray
from .folder import Folder, RecordLog, Resume, jsonl_text, write_file
from .results import csv_text, html_page, success, with_flags
from .spec import (
    MAX_RUNS,
    Run,
    SpecError,
    SweepSpec,
    check_duration,
    check_unique,
    check_vars,
    count_runs,
    escape_pointer,
    expand_worlds,
    files_digest,
    grid,
    parse_seeds,
    run_key,
    seed_runs,
)
from .worker import run_one


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
    #: Every file the sweep reads (machine and includes, worlds, the sweep file, plugin files): no output may be one.
    inputs: list[str] = field(default_factory=list)


#: What ``where`` says when the sweep comes from flags, not a file.
CLI = "the command line"
#: The flag that gives each key of a sweep file on the command line.
FLAGS = {"seeds": "--seeds", "worlds": "--world", "set": "--set", "machine": "--machine", "vars": "--var",
         "duration": "--duration", "plugins": "--plugin"}


class PlanError(DiagramError):
    """A sweep that cannot run: every problem is said before the first run."""

    #: True when the problem is of a command-line flag: a usage error (``fsmctl`` exits 2)
    usage = False


class _Fail:
    """Makes the :class:`PlanError` of a problem: located in the sweep file, or said as the flag it came from."""

    def __init__(self, where: str, flags: Iterable[str]) -> None:
        self.where = where
        self.from_flags = set(flags)

    def __call__(self, message: str, ptr: str = "", hint: str | None = None) -> PlanError:
        top = ptr.strip("/").split("/")[0]
        flagged = any(ptr == f or ptr.startswith(f + "/") for f in self.from_flags)
        if self.where == CLI or flagged:  # said as the flag it came from, not as a place in a file
            flag = FLAGS.get(top, "")
            head, _, rest = message.partition(" ")
            if flag and head.rstrip(":") == top:
                text = f"{flag}{':' if head.endswith(':') else ''} {rest}"
            else:
                text = f"{flag}: {message}" if flag and not message.startswith(flag + " ") else message
            err = PlanError([Problem(text, "fsmctl sweep", hint=hint)])
            err.usage = True
            return err
        return PlanError([Problem(message, self.where, ptr, hint=hint)])


def plan(spec: SweepSpec, base: Path, name: str, where: str, out_dir: Path, *, flags: Iterable[str] = (),
         flag_plugins: Iterable[str] = (), max_runs: int = MAX_RUNS) -> Plan:
    """Everything checked; ``where`` names the spec (a file, or 'the command line') in messages, and the keys in
    ``flags`` (JSON pointers: ``/seeds``, ``/set/home.speed``) are said as the flags they came from.
    ``flag_plugins`` (``fsmctl --plugin``, already loaded here) are loaded by the workers too. The grid's size is
    computed before it is built: more than ``max_runs`` runs are refused."""
    fail = _Fail(where, flags)
    plugins = [str(base / p) if p.endswith(".py") else p for p in spec.plugins]
    registry = _registry(spec, plugins, fail)
    seeds, sets, worlds = _axes(spec, base, fail)
    _check_size(spec, worlds, seeds, sets, max_runs, fail)
    machine, mspec = _checked_machine(spec, base, registry, sets, fail)
    worlds, world_walls = _worlds(worlds, mspec, machine, fail)
    runs = grid(worlds, seeds, sets, spec.vars)
    seed_runs(runs)
    files = machine_files(mspec) + [str(w) for w in worlds if w is not None]
    all_plugins = plugins + list(flag_plugins)
    jobs = _jobs(runs, files_digest(files), spec, machine, all_plugins, out_dir, fail)
    inputs = files + [where] * (where != CLI) + [p for p in all_plugins if p.endswith(".py")]
    return Plan(spec, name, machine, runs, jobs, list(runs[0].params), all_plugins, world_walls, inputs)


def _registry(spec: SweepSpec, plugins: list[str], fail: _Fail) -> Any:
    """The registry with the sweep's plugins loaded."""
    registry = default_registry(())
    for i, plugin in enumerate(plugins):
        try:
            registry.load_module(plugin)
        except UsageError as exc:
            text = str(exc).removeprefix(f"--plugin {plugin}: ").removeprefix(f"--plugin {plugin!r}: ")
            raise fail(f"plugin {spec.plugins[i]!r}: {text}", f"/plugins/{i}") from None
    return registry


def _axes(spec: SweepSpec, base: Path, fail: _Fail
          ) -> tuple[Sequence[int], list[tuple[str, str, list[Any]]], list[Path | None]]:
    """The seeds, the ``set`` axes and the worlds, each checked (no value given twice)."""
    try:
        seeds = parse_seeds(spec.seeds)
        if (problem := check_duration(spec.duration)) is not None:
            raise SpecError(problem, "/duration")
        sets = _set_axes(spec.set)
        check_vars(spec.vars)
        worlds: list[Path | None] = list(expand_worlds(spec.worlds, base))
        check_unique(seeds, "seeds", "/seeds")
        for path, param, values in sets:
            check_unique(values, f"set {path}.{param}", f"/set/{escape_pointer(f'{path}.{param}')}")
        for key, values in spec.vars.items():
            check_unique(values, f"vars {key}", f"/vars/{escape_pointer(key)}")
    except SpecError as exc:
        raise fail(str(exc), exc.pointer) from None
    return seeds, sets, worlds


def _check_size(spec: SweepSpec, worlds: list[Path | None], seeds: Sequence[int],
                sets: list[tuple[str, str, list[Any]]], max_runs: int, fail: _Fail) -> None:
    """The grid's size, computed before it is built: empty, or more than ``max_runs`` runs, is refused."""
    axes = [(f"{len(values)} values of {path}.{param}", len(values)) for path, param, values in sets]
    axes += [(f"{len(values)} values of {key}", len(values)) for key, values in spec.vars.items()]
    count = count_runs(len(worlds) or 1, len(seeds), [n for _, n in axes])
    if not count:
        raise fail("the grid is empty: no seed to run", "/seeds", hint="give --seeds START:STOP")
    if count > max_runs:
        sizes = " x ".join([f"{len(worlds)} world{'s' * (len(worlds) > 1)}"] * bool(worlds)
                           + [f"{len(seeds):,} seed{'s' * (len(seeds) != 1)}"] + [t for t, _ in axes])
        raise fail(f"the sweep would make {count:,} runs ({sizes}), more than {max_runs:,}",
                   "/seeds" if count // max(len(seeds), 1) <= max_runs else "",
                   hint=f"give --max-runs {count} to run them all, or fewer seeds, worlds or values")


def _checked_machine(spec: SweepSpec, base: Path, registry: Any, sets: list[tuple[str, str, list[Any]]],
                     fail: _Fail) -> tuple[Path, Any]:
    """The machine file, checked, and each ``set`` path against it."""
    try:
        machine = (base / spec.machine).resolve()
        found_machine = machine.is_file()
    except (OSError, ValueError):
        machine, found_machine = base / spec.machine, False
    if not found_machine:
        raise fail(f"machine file not found: {machine}", "/machine")
    mspec, found = check(str(machine), registry=registry)
    errors = [p for p in found if p.severity == "error"]
    if mspec is None or errors:
        raise PlanError(errors or found)
    for path, param, values in sets:
        key = f"{path}.{param}"
        try:
            O.check(mspec, O.Override(path, param, tuple(values), f"{key}={','.join(json.dumps(v) for v in values)}"))
        except O.OverrideError as exc:
            raise fail(str(exc), f"/set/{escape_pointer(key)}") from None
    return machine, mspec


def _worlds(worlds: list[Path | None], mspec: Any, machine: Path, fail: _Fail
            ) -> tuple[list[Path | None], dict[str, Any]]:
    """The worlds to run in (none given: the machine's default world if it drives the car) and their walls."""
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
    return worlds, world_walls


def _jobs(runs: list[Run], digest: str, spec: SweepSpec, machine: Path, plugins: list[str], out_dir: Path,
          fail: _Fail) -> list[dict[str, Any]]:
    """Each run's key and job; two runs with one key (a world, seed or value given twice) are refused."""
    jobs = []
    seen: dict[str, Run] = {}
    for run in runs:
        run.key = run_key(run, digest, spec)
        twin = seen.setdefault(run.key, run)
        if twin is not run:
            raise fail(f"runs {twin.id} and {run.id} would be the same run (world, seed and values): a world, seed "
                       "or value is given twice", "", hint="give each once")
        jobs.append(_job(run, spec, machine, plugins, out_dir))
    return jobs


def _set_axes(sets: dict[str, list[Any]]) -> list[tuple[str, str, list[Any]]]:
    """The ``set`` key of a sweep: each ``PATH.PARAM`` with a non-empty list of values (checked against the machine
    later), as ``(path, param, values)``."""
    axes = []
    for key, values in sets.items():
        where = f"/set/{escape_pointer(key)}"
        path, dot, param = key.strip().rpartition(".")
        if not dot or not path.strip("/") or not param.strip():
            raise SpecError(f"set {key!r}: write STATE_PATH.PARAMETER, e.g. home.speed", where)
        if not isinstance(values, list) or not values:
            raise SpecError(f"set {key!r}: give a non-empty list of values", where)
        axes.append((path.strip().strip("/"), param.strip(), list(values)))
    return axes


def _job(run: Run, spec: SweepSpec, machine: Path, plugins: list[str], out_dir: Path) -> dict[str, Any]:
    """What a worker needs to run ``run`` (and the record keeps), with the command that runs it alone."""
    wants = spec.outputs.trace or spec.outputs.report or spec.outputs.plot or spec.outputs.video
    overrides = [f"{path}.{param}={json.dumps(value)}" for path, param, value in run.sets]
    cmd = _command(run, spec, machine, plugins, overrides)
    return {"id": run.id, "index": run.index, "key": run.key, "machine": str(machine), "plugins": plugins,
            "world": str(run.world) if run.world is not None else None, "seed": run.seed, "run_seed": run.run_seed,
            "sets": [list(s) for s in run.sets], "overrides": overrides, "vars": run.variables, "params": run.params,
            "duration": spec.duration, "noise": spec.noise,
            "out": str(out_dir / "runs" / run.id) if wants else None,
            "trace": spec.outputs.trace, "report": spec.outputs.report, "plot": spec.outputs.plot,
            "video": spec.outputs.video,
            "command": shlex.join(cmd)}


def _command(run: Run, spec: SweepSpec, machine: Path, plugins: list[str], overrides: list[str]) -> list[str]:
    """The ``fsmctl run`` command line that reproduces ``run`` alone (its summary in summary.json)."""
    cmd = ["fsmctl"] + [a for p in plugins for a in ("--plugin", p)] + ["run", str(machine)]
    if run.world is not None:
        cmd += ["--world", str(run.world), "--seed", str(run.run_seed)]
    if not spec.noise:
        cmd.append("--no-noise")
    if spec.duration is not None:
        cmd += ["--duration", repr(float(spec.duration))]  # every digit: the run alone stops where the sweep's did
    cmd += [a for text in overrides for a in ("--set", text)]
    cmd += [a for name, value in run.variables.items() for a in ("--var", f"{name}={json.dumps(value)}")]
    return cmd + ["--summary", "summary.json"]


@dataclass
class Outcome:
    records: list[dict[str, Any]]
    ran: int
    skipped: int
    interrupted: bool
    seconds: float


#: How often (seconds) the loop that collects results looks whether Ctrl-C asked it to stop.
POLL = 0.2


def execute(p: Plan, folder: Folder, todo: list[dict[str, Any]], resume: Resume, interrupts: Any, *,
            backend: str = "process", jobs: int = 1, address: str | None = None, progress: bool = False,
            pool: Any = None, on_record: Callable[[dict[str, Any]], None] | None = None) -> Outcome:
    """Run ``todo`` (the jobs of ``p`` that ``resume`` has no record of); append each record to sweep.jsonl as
    its run finishes, then write sweep.csv and sweep.html. ``interrupts.stop()`` (Ctrl-C, SIGTERM) stops the
    pool: what finished is kept and written, and the outcome says it was interrupted. ``on_record`` is told of
    each record as it is logged (the live page's list of runs)."""
    results = dict(resume.records)
    t0 = time.perf_counter()
    bar = Progress(len(todo), enabled=progress)
    interrupts.writing = True  # a Ctrl-C stops the loop below at once; only a fourth one raises KeyboardInterrupt
    try:
        with _pool_for(todo, pool, backend, jobs, address) as pool:
            if todo or resume.cut_at is not None:
                folder.mkdir(folder.out)
                with RecordLog(folder.out / "sweep.jsonl", resume.cut_at) as log:
                    if todo:
                        _collect(pool, todo, folder, log, results, bar, interrupts, on_record)
            if pool is not None and interrupts.stop():
                pool.terminate()
            elif pool is not None:
                pool.close()  # the workers exit while the reports are written
            records = [results[job["key"]] for job in p.jobs if job["key"] in results]
            folder.mkdir(folder.out)
            write_reports(p, folder.out, records)
    finally:
        bar.done()
    ran = len(records) - len(resume.records)
    return Outcome(records, ran, len(resume.records), interrupts.stop(), time.perf_counter() - t0)


@contextmanager
def _pool_for(todo: list[dict[str, Any]], pool: Any, backend: str, jobs: int, address: str | None) -> Iterator[Any]:
    """The pool that runs ``todo`` (``pool`` when one is given, else a new one; none when there is nothing to
    run); terminated on any exception, joined at the end (and Ray shut down)."""
    if not todo and pool is not None:
        pool.terminate()
        pool.join()
        pool = None
    if todo and pool is None:  # may refuse (Ray): nothing is written yet
        pool = ray_pool(jobs, address) if backend == "ray" else local_pool(jobs)
    try:
        yield pool
    except BaseException:
        if pool is not None:
            pool.terminate()
        raise
    finally:
        if pool is not None:
            pool.join()
            if backend == "ray":
                shutdown_ray()


def _collect(pool: Any, todo: list[dict[str, Any]], folder: Folder, log: RecordLog, results: dict[str, Any],
             bar: Progress, interrupts: Any, on_record: Callable[[dict[str, Any]], None] | None = None) -> None:
    """Take the records as runs finish, until every run is done or Ctrl-C asks to stop."""
    waiting = (TimeoutError, multiprocessing.TimeoutError)
    it = pool.imap_unordered(run_one, todo)
    while not interrupts.stop():
        try:
            rec = it.next(timeout=POLL)
        except StopIteration:
            return
        except waiting:
            continue
        rec["files"] = _write_run(folder, rec)
        log.append(json.dumps(rec, separators=(",", ":")) + "\n")
        results[rec["key"]] = rec
        bar.step(rec)
        if on_record is not None:
            on_record(rec)


def _write_run(folder: Folder, rec: dict[str, Any]) -> list[str]:
    """OUT/runs/<id>/summary.json (the run's `fsmctl run --summary`), next to what the worker wrote there."""
    path = folder.out / "runs" / rec["id"]
    folder.mkdir(path)
    data = rec["summary"] if rec.get("ok") else {"error": rec.get("error"), "traceback": rec.get("traceback")}
    write_file(path / "summary.json", json.dumps(data, indent=2) + "\n")
    try:
        return sorted(e.name for e in os.scandir(path) if e.is_file(follow_symlinks=False))
    except OSError as exc:
        raise FsmError(f"{path}: cannot list: {exc.strerror or exc}") from None


def write_reports(p: Plan, out_dir: Path, records: list[dict[str, Any]]) -> None:
    """sweep.csv and sweep.html, and sweep.jsonl again with each record's ``flags`` (the runs that stand out, known
    only once every run finished), each whole or not at all (fsm/tools/files.py), none of them an input."""
    records = with_flags(records)
    texts: dict[str, str | bytes] = {"sweep.csv": csv_text(records, p.param_names),
                                     "sweep.html": html_page(p.name, records, p.param_names, p.worlds)}
    jsonl = jsonl_text(out_dir / "sweep.jsonl", records)
    if jsonl is not None:
        texts["sweep.jsonl"] = jsonl
    outputs = Outputs()
    for name, text in texts.items():
        outputs.add(str(out_dir / name), f"sweep {name}", binary=isinstance(text, bytes))
    outputs.open(p.inputs)
    try:
        for out, text in zip(outputs.items, texts.values(), strict=True):
            out.write(text)
        outputs.commit()
    finally:
        outputs.discard()


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


def usable_cpus() -> int:
    """How many processors this process may run on: a sweep's default -j."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
