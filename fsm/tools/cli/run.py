"""``fsmctl run``: run a machine on the simulated clock (and, when it drives, on the simulated TRAL car).

A machine that uses car states or transitions (``FollowWall``, ``SensorLevel``, ...), or any machine
run with ``--world``, drives the simulated car in a world (default ``diagrams/worlds/hallway.json``).
It reports the outcome, the states visited, and writes trace, summary, video and plot on request.
Ctrl-C (or SIGTERM) stops the run cleanly after the current tick: the summary (``"interrupted": true``), trace,
video and plot still get written, and the exit status is 130. Every output goes through
:mod:`fsm.tools.files` and is checked before the run starts.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

from fsm.model.errors import StateRuntimeError, UsageError, print_traceback, printable, traceback_wanted
from fsm.runtime.clock import DEFAULT_DURATION as DEFAULT_MAX_DURATION
from fsm.sim import DEFAULT_WORLD

from ..runs.args import (
    EXIT_FAIL,
    EXIT_INTERRUPTED,
    EXIT_OK,
    Interrupts,
    apply_overrides,
    checked,
    input_name,
    read_inputs,
    registry_from,
)
from ..runs.ending import end_run, run_guarded, trace_stream
from ..runs.outputs import RunOutputs, run_outputs
from .common import Subcommands, bounded_float, positive_float, signal_arg, whole_number

#: Runs of more ticks than this are refused unless --max-ticks asks for them (a tiny --dt is usually a typo).
MAX_TICKS = 10_000_000
VIDEO_SUFFIXES = (".mp4", ".m4v", ".mov", ".avi")


def register(sub: Subcommands) -> None:
    p = sub.add_parser("run", help="run a machine until it finishes (or a limit) and print what it did",
                       description="Run a machine. Machines that drive (car states or transitions) run on the "
                                   "simulated TRAL car in a world file; others run on the simulated clock alone.")
    p.add_argument("file", metavar="FILE", help="the machine (.json or .uxf); '-' reads it from standard input")
    p.add_argument("--max-ticks", type=whole_number(1), metavar="N",
                   help=f"stop after N ticks (runs of more than {MAX_TICKS:,} ticks need it said explicitly)")
    p.add_argument("--duration", type=positive_float, metavar="SECONDS",
                   help=f"stop after this much machine time (default: at most {DEFAULT_MAX_DURATION:g} s "
                        "when no --max-ticks is given)")
    p.add_argument("--dt", type=positive_float, metavar="SECONDS", default=None,
                   help="tick period (default 0.0125 s = 80 Hz, the TRAL car's)")

    p.add_argument("--signal", action="append", default=[], metavar="NAME[=0|1]@T", type=signal_arg,
                   help="set input signal NAME high (or to the value given) at machine time T (repeatable)")
    p.add_argument("--set", action="append", default=[], metavar="PATH.PARAM=VALUE", dest="overrides",
                   help="set a parameter of the state at PATH before the run, e.g. home.speed=0.8 or "
                        "lap1/bottom.speed=1.0 (repeatable; as `fsmctl sweep --set` does for one of its runs)")
    p.add_argument("--var", action="append", default=[], metavar="NAME=VALUE", dest="variables",
                   help="start with blackboard variable NAME = VALUE (a number, true/false or text; repeatable)")
    p.add_argument("--trace", metavar="OUT.jsonl",
                   help="write a JSONL trace: one line per tick with a transition (with the car: its sensors, "
                        "commands and pose); '-' for standard output")
    p.add_argument("--report", metavar="OUT.html",
                   help="write the run's HTML report (statechart, state lanes, map, plots; one offline file), as "
                        "`fsmctl report TRACE` does")
    p.add_argument("--sample-rate", type=bounded_float(0.1, 1000, "--sample-rate"), default=20.0, metavar="HZ",
                   help="how often the trace (and report) samples the car's pose, sensors and commands "
                        "(0.1 to 1000 Hz, default 20)")
    p.add_argument("--summary", metavar="OUT.json", help="write a JSON summary of the run; '-' for standard output")
    p.add_argument("--expect", metavar="OUTCOME",
                   help="exit 1 unless the machine finishes with OUTCOME (and, when a car runs, it collided at most "
                        "--max-collisions times, default 0)")
    p.add_argument("--max-collisions", type=whole_number(0), metavar="N",
                   help="exit 1 if the car collided more than N times (default: 0 with --expect; without "
                        "--expect or this option collisions never fail a run)")
    p.add_argument("-q", "--quiet", action="store_true", help="print nothing but errors")
    car = p.add_argument_group("the simulated car (for machines that drive, or with --world)")
    car.add_argument("--world", metavar="WORLD.json",
                     help=f"world file (default: {DEFAULT_WORLD} from the worlds folder next to the machine, "
                          "or diagrams/worlds/)")
    car.add_argument("--car", metavar="CAR.json", help="car file replacing the world's car parameters")
    car.add_argument("--seed", type=whole_number(0, 2**63 - 1, "2**63-1"), default=0, metavar="N",
                     help="seed of the sensor noise (default 0)")
    car.add_argument("--no-noise", action="store_true", help="turn the ultrasonic noise off")
    car.add_argument("--video", metavar="OUT.mp4",
                     help="write a top-down video (.mp4 H.264, or .avi MJPEG; '-' writes MP4 to standard output "
                          "when it is not a terminal)")
    car.add_argument("--video-speed", type=bounded_float(0.01, 10000, "--video-speed"), default=4.0, metavar="X",
                     help="simulated seconds per video second (0.01 to 10000, default 4)")
    car.add_argument("--fps", type=bounded_float(1, 240, "--fps"), default=25.0,
                     help="video frames per second (1 to 240, default 25)")
    car.add_argument("--plot", metavar="OUT.png",
                     help="write a PNG of the trajectory coloured by active state ('-' for standard output)")
    car.add_argument("--frames", metavar="DIR",
                     help="save the camera's raw frames (PNG) into this new folder, with camera.yaml (the "
                          "calibration) and frames.jsonl (the pose of each), for fsmctl detect")
    car.add_argument("--frames-every", type=whole_number(1), default=10, metavar="N",
                     help="with --frames, save every Nth rendered frame (default 10: 2 a second at 20 Hz)")
    ros = p.add_argument_group("a car on ROS 2 topics (the ros2 extra; docs/ros.md)")
    ros.add_argument("--ros", metavar="PROFILE.json",
                     help="drive the car the I/O profile binds to ROS 2 topics, over Zenoh (or rclpy where ROS 2 is "
                          "installed), on the wall clock at the profile's rate (a real car, or `fsmctl sim --ros` "
                          "in another process)")
    ros.add_argument("--bag", metavar="DIR",
                     help="with --ros: also record the run as rosbag2 (MCAP) in the new folder DIR")
    from ..ros.common import add_endpoint_options

    add_endpoint_options(p, "advance in lock-step with `fsmctl sim --ros --lockstep` on the profile's clock topic "
                            "instead of the wall clock (fast, reproducible runs against the simulator)", managed=True)
    bar = car.add_mutually_exclusive_group()
    bar.add_argument("--progress", dest="progress", action="store_true", default=None,
                     help="show a progress bar (default: only when standard error is a terminal)")
    bar.add_argument("--no-progress", dest="progress", action="store_false", help="no progress bar")
    from ..live.runner import add_arguments as add_live_arguments

    add_live_arguments(p)
    p.set_defaults(func=cmd_run)


# -- deciding whether a machine drives ---------------------------------------------------------------


# -- the command -------------------------------------------------------------------------------------
def _suffix_ok(name: str | None, suffixes: tuple[str, ...]) -> bool:
    """A regular file name must end in one of ``suffixes``; ``-`` and device paths carry no suffix."""
    if name is None or name == "-" or name.startswith("/dev/") or name.startswith("/proc/self/fd/"):
        return True
    return Path(name).suffix.lower() in suffixes


def parse_vars(texts: list[str]) -> dict[str, Any]:
    """``--var NAME=VALUE`` as a dict (VALUE a JSON scalar, or text)."""
    from ..sweep.overrides import parse_value

    out: dict[str, Any] = {}
    for text in texts:
        name, sep, value = text.partition("=")
        if not sep or not name.strip().isidentifier():
            raise UsageError(f"--var {text!r}: write NAME=VALUE, e.g. --var speed=0.8")
        out[name.strip()] = parse_value(value.strip())
    return out


def _check_usage(args: argparse.Namespace) -> None:
    from ..ros.run import check_usage

    check_usage(args)
    if not _suffix_ok(args.plot, (".png",)):
        raise UsageError(f"--plot {args.plot}: the plot is a PNG; name it with the suffix .png")
    if args.frames is not None:
        if args.ros or args.live:
            raise UsageError(f"--frames {args.frames}: saves the simulated camera's frames; it goes with neither "
                             "--ros nor --live")
        from ..files import NewFolder

        NewFolder(args.frames, "--frames").check()
    if not _suffix_ok(args.video, VIDEO_SUFFIXES):
        raise UsageError(f"--video {args.video}: unsupported video format "
                         f"'{Path(args.video).suffix or '(no suffix)'}'; use .mp4 (H.264) or .avi (MJPEG)")


def _tick_limit(args: argparse.Namespace, dt: float) -> tuple[float | None, int | None]:
    """The run's ``duration`` and ``max_ticks``; a usage error when a simulated run would take more than MAX_TICKS
    ticks without --max-ticks saying so. Runs on the wall clock (``--ros``, ``--live`` at a pace) take any duration:
    their car is stopped by hand, and their bookkeeping stays within bounds (docs/car.md)."""
    if args.max_ticks is not None:  # with --duration too, the tighter of the two
        if args.duration is not None and args.duration / dt <= args.max_ticks:
            return args.duration, args.max_ticks
        return None, args.max_ticks
    if args.duration is not None and (
            getattr(args, "ros", False) or (getattr(args, "live", False) and getattr(args, "speed", None) is not None)):
        return args.duration, None
    duration = args.duration if args.duration is not None else DEFAULT_MAX_DURATION
    ticks = duration / dt  # may be inf for a denormal dt
    if not ticks <= MAX_TICKS:
        shown = f"{ticks:.3g}" if ticks != float("inf") else "infinitely many"
        raise UsageError(f"--dt {dt:g} with a run of {duration:g} s makes {shown} ticks, more than {MAX_TICKS:,}; "
                         "give --max-ticks N to allow a run that long, or a larger --dt / shorter --duration")
    return duration, None


def _seconds(wall: float) -> str:
    """A wall time as a person reads it: two decimals under 10 s (a short run is not "0.0 s"), one above."""
    return f"{wall:.2f} s" if wall < 10 else f"{wall:.1f} s"

def signal_warnings(signals: list[tuple[str, bool, float]], spec: Any, file: str, duration: float | None,
                    max_ticks: int | None, dt: float) -> list[str]:
    """What is suspicious about the ``--signal`` options: a name no transition reads (a typo, most likely),
    and a time after the run's end (the signal would never be seen)."""
    import difflib

    from fsm.loading.loader import signal_names

    known = signal_names(spec)
    ends = [x for x in (duration, max_ticks * dt if max_ticks is not None else None) if x is not None]
    end = min(ends) if ends else None
    out: list[str] = []
    for name in sorted({n for n, _v, _t in signals} - known):
        close = difflib.get_close_matches(name, sorted(known), n=1)
        reads = ", ".join(sorted(known)) if known else "no signal at all"
        out.append(f"--signal {name}: {file} reads no signal '{name}'"
                   + (f" (did you mean {close[0]}?)" if close else f" (it reads {reads})"))
    for name, _value, at in signals:
        if end is not None and at > end:
            out.append(f"--signal {name}@{at:g}: after the end of the run ({end:g} s of machine time), so never seen")
    return out


def cmd_run(args: argparse.Namespace) -> int:
    from fsm.runtime.clock import DEFAULT_DT

    from ..live.runner import check_usage as check_live_usage

    _check_usage(args)
    check_live_usage(args)
    dt = args.dt or DEFAULT_DT
    duration, max_ticks = _tick_limit(args, dt)
    outs = run_outputs(args, video_suffixes=VIDEO_SUFFIXES)  # a folder, a missing folder: before anything is read
    args.pre = read_inputs([args.file])
    file = input_name(args.file)
    spec = _checked_spec(args, file)
    args.initial_vars = parse_vars(args.variables)
    for warning in signal_warnings(args.signal, spec, file, duration, max_ticks, dt):
        print(printable(f"fsmctl run: warning: {warning}"), file=sys.stderr)
    try:
        if args.ros:
            from ..ros.run import run_ros

            return run_ros(args, spec, file, outs.all, outs.trace, outs.summary, outs.report, duration, max_ticks)
        drive, world_path = _car_world(args, spec, file)
        outs.all.open(_inputs(args, spec, world_path))  # same-as-input, unwritable folders: refused before the run
        if args.live:
            return _run_live(args, spec, file, drive, world_path, duration, max_ticks, outs)
        return _run(args, spec, file, drive, world_path, duration, max_ticks, outs)
    finally:
        outs.all.discard()


def _checked_spec(args: argparse.Namespace, file: str) -> Any:
    """The machine, checked once (a located error otherwise), with its ``--set`` overrides; ``args.plan`` is its
    plan compiled from that check (``None`` when an override changed it: it is checked again when compiled)."""
    from fsm.loading.loader import analyse, compile_checked
    from fsm.loading.reading import preloaded

    with preloaded(args.pre):
        found, analysis, problems = analyse(file, registry=registry_from(args))
    found, analysis = checked(problems, found), checked(problems, analysis)
    spec = apply_overrides(found, args.overrides, file)
    args.plan = compile_checked(spec, analysis) if spec is found else None
    return spec


def _car_world(args: argparse.Namespace, spec: Any, file: str) -> tuple[bool, Path | None]:
    """Whether the run drives the simulated car (car states or transitions, --world or --car), and its world file;
    a usage error for the car's outputs without a car."""
    from fsm.loading.loader import uses_car
    from fsm.sim.world import default_world

    if args.world is None and args.car is None and not uses_car(spec):
        if args.video or args.plot or args.frames:
            raise UsageError("--video, --plot and --frames need a car: this machine uses no car states; pass "
                             "--world to drive")
        return False, None
    return True, Path(args.world) if args.world else default_world(file if file != "<stdin>" else ".")


def _inputs(args: argparse.Namespace, spec: Any, world_path: Path | None) -> list[str]:
    """The files the run reads (the machine's, the world's and the car's), which no output may overwrite."""
    from fsm.loading.loader import machine_files

    return machine_files(spec) + ([str(world_path)] + ([args.car] if args.car else []) if world_path else [])


def _session(args: argparse.Namespace, spec: Any, drive: bool, world_path: Path | None, duration: float | None,
             max_ticks: int | None) -> Any:
    """The run's session: the machine on the simulated car in its world, or on the simulated clock alone."""
    from fsm.loading.loader import compile as compile_spec
    from fsm.model.plan import MachinePlan
    from fsm.session.session import Session, SetSignal, StopRules

    given = getattr(args, "plan", None)
    plan = spec if isinstance(spec, MachinePlan) else given if given is not None else compile_spec(spec)
    stop = StopRules(duration, max_ticks)
    if drive:
        from fsm.sim import simulate

        assert world_path is not None
        session = simulate(plan, world=world_path, car_file=args.car, seed=args.seed, noise=not args.no_noise,
                           variables=args.initial_vars, dt=args.dt, stop=stop)
    else:
        session = Session.open(plan, variables=args.initial_vars, dt=args.dt, stop=stop)
    for name, value, at in args.signal:
        session.schedule(at, SetSignal(name, value))
    return session


def _run(args: argparse.Namespace, spec: Any, file: str, drive: bool, world_path: Path | None,
         duration: float | None, max_ticks: int | None, outs: RunOutputs) -> int:
    session = _session(args, spec, drive, world_path, duration, max_ticks)
    frames = _frames(args, session, world_path)
    try:
        return _drive(args, session, file, duration, max_ticks, outs, world_path, frames)
    finally:
        if frames is not None:
            frames.folder.discard()


def _frames(args: argparse.Namespace, session: Any, world_path: Path | None) -> Any:
    """``--frames DIR``: the saver of the camera's frames (its folder opened), or ``None``."""
    if args.frames is None:
        return None
    from ..files import NewFolder
    from ..recording.frames import FrameSaver

    car = session.car
    if car is None or car.camera() is None:
        raise UsageError(f"--frames {args.frames}: the car in {world_path} has no camera (its car.camera.enabled "
                         "is false); enable it or leave --frames out")
    folder = NewFolder(args.frames, "--frames")
    folder.open()
    try:
        saver = FrameSaver(car, folder, every=args.frames_every)
    except BaseException:
        folder.discard()
        raise
    session.driver.add_observer(session.machine.dt, saver)  # timed as an output, as the video is
    return saver


def _drive(args: argparse.Namespace, session: Any, file: str, duration: float | None, max_ticks: int | None,
           outs: RunOutputs, world_path: Path | None, frames: Any) -> int:
    """Run the session with its outputs, write them, and say how it went (the exit status)."""
    started = time.perf_counter()  # the wall time with outputs: the run, then the video, plot, trace... written
    video = _video(args, session, outs.video)
    progress = _progress(args, session, duration, max_ticks)
    report = sys.stderr if outs.all.to_stdout else sys.stdout  # standard output may carry an output
    session.record(_recorder(args, file, session.car, world_path, outs.trace, outs.report))
    interrupts = Interrupts()
    with interrupts:
        error = _run_until_stopped(session, interrupts, progress)
        interrupted = interrupts.interrupted
        result = end_run(session, error, interrupted, report_out=outs.report,
                         report_name=args.trace if args.trace not in (None, "-") else file)
        _write_outputs(args, session, result, video, outs.plot, frames, outs.summary)
        outs.all.commit()
        if frames is not None:
            frames.folder.commit()
    if error is not None:
        return _failed(file, error, session.car)
    if not args.quiet:
        _print_end(file, session, interrupted, report, started)
    if interrupted:
        return EXIT_INTERRUPTED
    return _verdict(args, session)


def _video(args: argparse.Namespace, session: Any, video_out: Any) -> Any:
    """``--video``: the recorder of the car's video (``None`` without it, or without a car)."""
    if session.driver is None or video_out is None:
        return None
    from fsm.sim.render import VideoRecorder

    return VideoRecorder(session.driver, args.video, speed=args.video_speed, fps=args.fps, scratch=video_out.path,
                         fmt=video_out.suffix)


def _progress(args: argparse.Namespace, session: Any, duration: float | None, max_ticks: int | None) -> Any:
    """The progress line on a terminal (``--progress``), called every half second of simulated time, or ``None``."""
    show = args.progress if args.progress is not None else sys.stderr.isatty()
    if session.driver is None or not show or args.quiet:
        return None
    # a bar only against a limit the user set; otherwise the machine's end is the stop rule, which no bar
    # can measure: a spinner with the simulated time (and the cap it never passes)
    limit = (args.duration if args.duration is not None else
             max_ticks * session.machine.dt if args.max_ticks is not None and max_ticks is not None else None)
    progress = ProgressBar(limit, cap=duration)
    session.every(0.5, progress)
    return progress


def _run_until_stopped(session: Any, interrupts: Interrupts, progress: Any) -> StateRuntimeError | None:
    """Run until a stop rule, the machine's end or Ctrl-C; a state's exception is returned (the trace flushed)."""

    def run() -> None:
        if not interrupts.stop():
            session.run(stop=interrupts.stop)
        else:
            session.start()

    try:
        return run_guarded(session, session.recorder, interrupts, run)
    finally:
        if progress is not None:
            progress.done()


def _write_outputs(args: argparse.Namespace, session: Any, result: dict[str, Any], video: Any, plot_out: Any,
                   frames: Any, summary_out: Any) -> None:
    """The video, plot, frames and summary of the run (the summary last: it names the others)."""
    if video is not None:
        video.close()
        result["video"] = {"file": args.video, "frames": video.frames, "codec": video.codec}
    if plot_out is not None and session.driver is not None:
        from fsm.sim.render import plot_png

        plot_out.write(plot_png(session.driver))
    if frames is not None:
        frames.finish()
        result["frames"] = {"folder": args.frames, "saved": frames.saved, "every": frames.every}
    if summary_out is not None:
        summary_out.write(json.dumps(result, indent=2) + "\n")


def _failed(file: str, error: StateRuntimeError, car: Any) -> int:
    """A state raised: say which, where and when (the traceback with FSM_TRACEBACK=1)."""
    if traceback_wanted():
        print_traceback(error)
    stopped = " (the car was stopped)" if car is not None else ""
    print(printable(f"fsmctl run: {file}: {error}{stopped}"), file=sys.stderr)
    return EXIT_FAIL


def _print_end(file: str, session: Any, interrupted: bool, report: Any, started: float) -> None:
    """The end lines (where the machine ended, what it did) and, with a car, how the car drove."""
    from ..recording import end_lines

    print("\n".join(end_lines(file, session.machine, session.recorder, interrupted=interrupted)), file=report)
    sim = session.driver
    if sim is None:
        return
    m = sim.metrics()
    rms, near = m["wall_error_rms_m"], m["min_wall_distance_m"]
    print(f"car: {m['distance_m']:.2f} m, {m['collisions']} collisions, min wall distance "
          + (f"{near:.3f} m" if near is not None else "n/a") + ", wall error on straights "
          + (f"{rms * 100:.1f} cm RMS" if rms is not None else "n/a")
          + f"; {m['sim_time']:.1f} s simulated in {_seconds(time.perf_counter() - started)} with outputs, "
          f"the simulation alone {m['realtime_factor']}x real time", file=report)
    if m.get("gates_total"):
        print(f"gates: {m['gates_passed']}/{m['gates_total']} passed; odometry error at the end "
              f"{m['odometry_error_m']:.2f} m", file=report)


def _verdict(args: argparse.Namespace, session: Any) -> int:
    """The exit status of a run that ended: ``--expect``'s outcome and the collisions ``--max-collisions`` allows."""
    missed = _missed_outcome(args.expect, session.machine)
    collided, too_many = _collisions(args, session.car)
    for line in (missed, collided):
        if line is not None:
            print(line, file=sys.stderr)
    return EXIT_FAIL if missed is not None or too_many else EXIT_OK


def _missed_outcome(expect: str | None, machine: Any) -> str | None:
    """What ``--expect OUTCOME`` says of a machine that did not end with it (``None`` when it did)."""
    if expect is None or machine.outcome == expect:
        return None
    got = (f"got {machine.outcome!r}" if machine.outcome is not None else
           f"not finished after {machine.now:g} s (--duration sets how long it may run)")
    return printable(f"fsmctl run: expected outcome {expect!r}, {got}")


def _collisions(args: argparse.Namespace, car: Any) -> tuple[str | None, bool]:
    """What to say of the car's collisions, and whether they fail the run: more than ``--max-collisions`` (0 with
    ``--expect``) do; without either, a run's status is its machine's (a sweep or CI says how many it allows), but
    collisions are never silent."""
    limit = args.max_collisions if args.max_collisions is not None else (0 if args.expect is not None else None)
    count = car.collisions if car is not None else 0
    times = f"{count} time{'s' * (count != 1)}"
    if limit is not None and count > limit:
        why = "--max-collisions" if args.max_collisions is not None else "with --expect, unless --max-collisions says"
        return f"fsmctl run: the car collided {times}, more than the {limit} allowed ({why})", True
    if limit is None and count and not args.quiet:
        return (f"fsmctl run: warning: the car collided {times}; the exit status does not count collisions unless "
                "--max-collisions N (or --expect) is given"), False
    return None, False


def _run_live(args: argparse.Namespace, spec: Any, file: str, drive: bool, world_path: Path | None,
              duration: float | None, max_ticks: int | None, outs: RunOutputs) -> int:
    """``--live``: the run under the live debugger (:mod:`fsm.tools.live`), built again from the same plan for
    each rewind."""
    from fsm.loading.loader import compile as compile_spec
    from fsm.loading.loader import signal_names

    from ..live.runner import run_live
    from ..recording import header_document, run_recorder

    plan = args.plan if getattr(args, "plan", None) is not None else compile_spec(spec)
    document = header_document(file, args.pre)
    watcher = None
    if args.reload is not False and file != "<stdin>":
        from fsm.loading.loader import check, machine_files

        from ..live.reload import Watcher, loader

        registry = registry_from(args)
        load = loader(file, lambda: check(file, registry=registry),
                      lambda checked: compile_spec(apply_overrides(checked, args.overrides, file)),
                      lambda checked: {"document": header_document(file), "signals": sorted(signal_names(checked)),
                                       "files": machine_files(checked)})
        watcher = Watcher(machine_files(spec) or [file], load)

    def make_recorder(session: Any, stream: Any) -> Any:
        return run_recorder(stream, file, session.car, world_file=_shown_world(world_path), seed=args.seed,
                            noise=not args.no_noise, overrides=args.overrides, initial_vars=args.initial_vars,
                            sample_rate=args.sample_rate, document=document)

    return run_live(args, file, lambda: _session(args, plan, drive, world_path, duration, max_ticks), make_recorder,
                    sorted(signal_names(spec)), outs.all, outs.trace, outs.summary, outs.plot, outs.report, watcher)


def _shown_world(path: Path | None) -> str | None:
    """The world file as the trace's header names it (a default one relative to the current folder)."""
    from ..files import shown_path

    return None if path is None else shown_path(path)


def _recorder(args: argparse.Namespace, file: str, car: Any, world_path: Path | None, trace_out: Any,
              report_out: Any) -> Any:
    """The trace recorder (to the --trace file, and kept in memory for --report)."""
    from ..recording import run_recorder

    return run_recorder(trace_stream(trace_out, report_out), file, car, world_file=_shown_world(world_path),
                        seed=args.seed, noise=not args.no_noise, preloaded=args.pre, overrides=args.overrides,
                        initial_vars=args.initial_vars, sample_rate=args.sample_rate)


class ProgressBar:
    """One line on standard error (only used when it is a terminal): a bar when the run has a limit the user
    set, else the simulated time; redrawn at most ten times a second."""

    def __init__(self, total: float | None, cap: float | None = None) -> None:
        self.total = total
        self.cap = cap
        self.width = 30
        self._last = 0.0
        self._turn = 0

    def __call__(self, sim: Any) -> None:
        import time

        now = time.monotonic()
        if now - self._last < 0.1:
            return
        self._last = now
        if self.total:
            frac = min(1.0, sim.now / self.total)
            filled = int(frac * self.width)
            head = "[" + "#" * filled + "-" * (self.width - filled) + "] "
        else:
            self._turn += 1
            head = "|/-\\"[self._turn % 4] + " "
        tail = f" (until the machine ends, at most {self.cap:g} s)" if not self.total and self.cap else ""
        sys.stderr.write(f"\r{head}{sim.now:7.1f} s  {sim.car.distance:7.1f} m  {printable(sim.active_path)[:40]:40s}"
                         + tail)
        sys.stderr.flush()

    def done(self) -> None:
        sys.stderr.write("\r" + " " * (self.width + 115) + "\r")
        sys.stderr.flush()
