"""One run of a sweep: a plain dict in, a plain dict out, the same code on a local process and on a Ray worker.

The run is what ``fsmctl run`` does (check, ``--set`` overrides, build, drive the simulated car, summarise with
``Simulation.summary``), so the printed ``fsmctl run`` command reproduces it alone. Anything a run raises
becomes a record with ``ok: false`` and the error; the sweep goes on.
"""

from __future__ import annotations

import os
import time
import traceback
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from fsm.sim.loop import Simulation

#: Fields of a summary that depend on the machine the run ran on, not on the run: left out of comparisons.
TIMING = ("wall_time", "realtime_factor", "realtime_factor_with_outputs")
#: Trajectory points kept per run for the report's small multiples.
TRACK_POINTS = 300
#: The checked machine per (file, plugins), in this worker process.
_CHECKED: dict[tuple[str, tuple[str, ...]], Any] = {}
#: The machine document each run's trace header carries, by machine file (per worker, like the check).
_DOCUMENTS: dict[str, Any] = {}


def init_worker() -> None:
    """Each worker uses one thread for OpenCV and BLAS: the pool's processes are the parallelism. Ctrl-C is the
    parent's to handle (it stops the pool and writes what finished)."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)  # a Ctrl-C pending since the start is dropped, then unblocked
    if hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(var, "1")
    # what every run needs, imported while the parent still plans the sweep
    import fsm.sim.car  # noqa: F401
    import fsm.sim.loop  # noqa: F401
    from fsm.loading.registry import default_registry

    default_registry()


def _one_cv2_thread() -> None:
    """OpenCV's own thread pool off (called once a run's camera can see a marker: importing cv2 costs 0.1 s)."""
    import cv2

    cv2.setNumThreads(1)


def run_one(job: dict[str, Any]) -> dict[str, Any]:
    """Run one point of the grid; ``job`` holds only JSON-able values (it may travel to another machine)."""
    t0 = time.perf_counter()
    record: dict[str, Any] = {"id": job["id"], "index": job["index"], "key": job["key"], "world": job["world"],
                              "seed": job["seed"], "run_seed": job["run_seed"], "params": job["params"],
                              "command": job["command"]}
    try:
        summary, track, dwell = _simulate(job)
        record["ok"] = True
        record["states"] = summary.pop("states_seen", [])
        record["summary"] = summary
        record["track"] = track
        record["dwell"] = dwell
    except Exception as exc:  # noqa: BLE001 - a failing run is a result, not the end of the sweep
        record["ok"] = False
        record["error"] = f"{type(exc).__name__}: {exc}"
        record["traceback"] = traceback.format_exc(limit=6)
    record["seconds"] = round(time.perf_counter() - t0, 3)
    return record


class Dwell:
    """Seconds spent in each state (every level), for the report's dwell times across runs."""

    def __init__(self) -> None:
        self.since: dict[str, float] = {}
        self.total: dict[str, float] = {}

    def on_transition(self, ctx: Any, source: Any, target: Any, transition: Any) -> None:
        now = ctx.now
        if source is not None:
            gone = [p for p in self.since if p == source.path or p.startswith(source.path + "/")]
            for p in gone:
                self.total[p] = self.total.get(p, 0.0) + now - self.since.pop(p)
        self.since[target.path] = now

    def on_tick(self, machine: Any) -> None:
        pass

    def result(self, now: float) -> dict[str, float]:
        out = dict(self.total)
        for p, t in self.since.items():
            out[p] = out.get(p, 0.0) + now - t
        return {p: round(v, 4) for p, v in sorted(out.items())}


def _simulate(job: dict[str, Any]) -> tuple[dict[str, Any], list[list[float]], dict[str, float]]:
    from fsm.loading.loader import compile as compile_spec
    from fsm.session.session import StopRules

    from ..recording import run_recorder  # the same trace as `fsmctl run --trace`
    from .overrides import apply

    spec = apply(_checked(job), [(path, param, value) for path, param, value in job["sets"]])
    plan = compile_spec(spec)
    out_dir, trace_file = _out_files(job)
    session = None
    try:
        session, sim = _open(job, plan, spec, StopRules(job["duration"]))
        session.record(run_recorder(
            trace_file, job["machine"], session.car if sim is not None else None, world_file=job["world"],
            seed=job["run_seed"], noise=job["noise"], overrides=job["overrides"], initial_vars=job["vars"],
            document=_document(job["machine"]) if trace_file is not None else None))
        dwell = session.add_listener(Dwell())
        video = _video(sim, out_dir) if sim is not None and out_dir is not None and job.get("video") else None
        session.run()
        result = session.summary()
        track = [] if sim is None else _car_outputs(sim, result, video, out_dir, job)
        return result, track, dwell.result(session.now)
    finally:
        if trace_file is not None:
            if session is not None and session.recorder is not None:
                session.finish()
            _finish_trace(trace_file, out_dir, job)


def _out_files(job: dict[str, Any]) -> tuple[Path | None, Any]:
    """The run's folder (made) when it writes anything there, and its trace file when a trace or report is wanted."""
    from .folder import OutFile

    if not job.get("out"):
        return None, None
    out_dir = Path(job["out"])
    out_dir.mkdir(parents=True, exist_ok=True)
    return out_dir, OutFile(out_dir / "trace.jsonl", "w+") if job.get("trace") or job.get("report") else None


def _car_outputs(sim: Any, result: dict[str, Any], video: Any, out_dir: Path | None,
                 job: dict[str, Any]) -> list[list[float]]:
    """A run of the car: its video closed, its plot drawn, the states it saw added to ``result``; its track (at
    most :data:`TRACK_POINTS` points)."""
    if video is not None:
        video.close()
    _plot(sim, out_dir, job)
    step = max(1, len(sim.track) // TRACK_POINTS)
    result["states_seen"] = list(sim.states_seen)
    return [[round(x, 3), round(y, 3), k] for _t, x, y, k in sim.track[::step]]


def _checked(job: dict[str, Any]) -> Any:
    """The job's machine, checked: each worker reads and checks a machine once (the files do not change during a
    sweep)."""
    from fsm.loading.loader import check
    from fsm.loading.registry import default_registry
    from fsm.model.errors import DiagramError

    plugins = tuple(job.get("plugins") or ())
    key = (job["machine"], plugins)
    spec = _CHECKED.get(key)
    if spec is None:
        spec, problems = check(job["machine"], registry=default_registry(plugins))
        errors = [p for p in problems if p.severity == "error"]
        if spec is None or errors:
            raise DiagramError(errors or problems)
        _CHECKED[key] = spec
    return spec


def _open(job: dict[str, Any], plan: Any, spec: Any, stop: Any) -> tuple[Any, Simulation | None]:
    """The run's session: with the simulated car (and its simulation) when there is a world or the machine drives
    the car, else the machine alone."""
    from fsm.loading.loader import uses_car
    from fsm.session.session import Session

    if job["world"] is None and not uses_car(spec):
        return Session.open(plan, variables=job["vars"], stop=stop), None
    from fsm.sim import simulate
    from fsm.sim.loop import Simulation

    session = simulate(plan, world=job["world"], seed=job["run_seed"], noise=job["noise"], variables=job["vars"],
                       stop=stop)
    assert isinstance(session.driver, Simulation)  # simulate() drives the session with the simulated car
    car = session.car
    if car.params.camera.enabled and (car.world.gates or car.world.markers):  # else no frame is rendered
        _one_cv2_thread()
    return session, session.driver


def _document(machine: str) -> Any:
    """The machine's document for the trace's header, read and converted once per worker, as the check is."""
    from ..recording import header_document

    if machine not in _DOCUMENTS:
        _DOCUMENTS[machine] = header_document(machine)
    return _DOCUMENTS[machine]


def _video(sim: Simulation, out_dir: Path) -> Any:
    from fsm.sim.render import VideoRecorder

    return VideoRecorder(sim, str(out_dir / "video.mp4"))


def _plot(sim: Simulation, out_dir: Path | None, job: dict[str, Any]) -> None:
    if out_dir is not None and job.get("plot"):
        from fsm.sim.render import plot_png

        from .folder import write_file

        write_file(out_dir / "plot.png", plot_png(sim))


def _finish_trace(trace_file: Any, out_dir: Path | None, job: dict[str, Any]) -> None:
    """Close the run's trace; write its report.html from it when asked (and drop the trace unless asked for)."""
    from .folder import write_file

    try:
        if out_dir is not None and job.get("report"):
            from fsm.trace.replay import parse_trace

            from ..report import report_html

            trace_file.flush()
            trace_file.seek(0)
            trace = parse_trace(trace_file.read().encode("utf-8"), str(out_dir / "trace.jsonl"))
            write_file(out_dir / "report.html", report_html(trace))
    finally:
        trace_file.close()
        if out_dir is not None and not job.get("trace"):
            (out_dir / "trace.jsonl").unlink(missing_ok=True)
