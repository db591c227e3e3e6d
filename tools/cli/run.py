"""``fsmctl run``: run a machine on the simulated clock (and, when it drives, on the simulated TRAL car).

A machine that uses car states or transitions (``FollowWall``, ``SensorLevel``, ...), or any machine
run with ``--world``, drives the simulated car in a world (default ``diagrams/worlds/hallway.json``).
It reports the outcome, the states visited, and writes trace, summary, video and plot on request.
Ctrl-C stops the run cleanly: the summary, trace, video and plot still get written.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from fsm.errors import StateRuntimeError, UsageError

from .common import EXIT_FAIL, EXIT_OK, check_writable, positive_float, positive_int, registry_from, signal_arg

DEFAULT_MAX_DURATION = 600.0
DEFAULT_WORLD = "hallway.json"


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("run", help="run a machine until it finishes (or a limit) and print what it did",
                       description="Run a machine. Machines that drive (car states or transitions) run on the "
                                   "simulated TRAL car in a world file; others run on the simulated clock alone.")
    p.add_argument("file", metavar="FILE")
    p.add_argument("--max-ticks", type=positive_int, metavar="N", help="stop after N ticks")
    p.add_argument("--duration", type=positive_float, metavar="SECONDS",
                   help=f"stop after this much machine time (default: at most {DEFAULT_MAX_DURATION:g} s "
                        "when no --max-ticks is given)")
    p.add_argument("--dt", type=positive_float, metavar="SECONDS", default=None,
                   help="tick period (default 0.0125 s = 80 Hz, the TRAL car's)")
    p.add_argument("--signal", action="append", default=[], metavar="NAME[=0|1]@T", type=signal_arg,
                   help="set input signal NAME high (or to the value given) at machine time T (repeatable)")
    p.add_argument("--trace", metavar="OUT.jsonl",
                   help="write a JSONL trace: one line per tick with a transition (with the car: its sensors, "
                        "commands and pose)")
    p.add_argument("--summary", metavar="OUT.json", help="write a JSON summary of the run")
    p.add_argument("--expect", metavar="OUTCOME", help="exit 1 unless the machine finishes with OUTCOME")
    p.add_argument("-q", "--quiet", action="store_true", help="print nothing but errors")
    car = p.add_argument_group("the simulated car (for machines that drive, or with --world)")
    car.add_argument("--world", metavar="WORLD.json",
                     help=f"world file (default: {DEFAULT_WORLD} from the worlds folder next to the machine, "
                          "or diagrams/worlds/)")
    car.add_argument("--car", metavar="CAR.json", help="car file replacing the world's car parameters")
    car.add_argument("--seed", type=int, default=0, metavar="N", help="seed of the sensor noise (default 0)")
    car.add_argument("--no-noise", action="store_true", help="turn the ultrasonic noise off")
    car.add_argument("--video", metavar="OUT.mp4", help="write a top-down video (.mp4 or .avi)")
    car.add_argument("--video-speed", type=positive_float, default=4.0, metavar="X",
                     help="simulated seconds per video second (default 4)")
    car.add_argument("--fps", type=positive_float, default=25.0, help="video frames per second (default 25)")
    car.add_argument("--plot", metavar="OUT.png", help="write a PNG of the trajectory coloured by active state")
    bar = car.add_mutually_exclusive_group()
    bar.add_argument("--progress", dest="progress", action="store_true", default=None,
                     help="show a progress bar (default: only when standard error is a terminal)")
    bar.add_argument("--no-progress", dest="progress", action="store_false", help="no progress bar")
    p.set_defaults(func=cmd_run)


# -- deciding whether a machine drives ---------------------------------------------------------------
def uses_car(spec: Any) -> bool:
    """True when any state or transition type in the checked machine (sub-machines included) needs a car."""
    if spec is None:
        return False
    for st in spec.states:
        if st.cls.needs_car:
            return True
        for _name, sub, _ptr in st.subs:
            if uses_car(sub):
                return True
    return any(tr.cls.needs_car for tr in spec.transitions)


def default_world(machine_file: str) -> Path:
    """``hallway.json`` from ``worlds/`` next to the machine, else ``diagrams/worlds/`` here, else the worlds
    installed with the package (``fsm.worlds``, which is ``diagrams/worlds`` of the repository)."""
    candidates = [Path(machine_file).resolve().parent / "worlds" / DEFAULT_WORLD,
                  Path.cwd() / "diagrams" / "worlds" / DEFAULT_WORLD]
    from importlib.resources import files

    try:  # installed from a wheel
        candidates.append(Path(str(files("fsm.worlds") / DEFAULT_WORLD)))
    except (ModuleNotFoundError, TypeError):
        import fsm  # an editable install: the checkout's diagrams/worlds

        candidates.append(Path(fsm.__file__).resolve().parent.parent / "diagrams" / "worlds" / DEFAULT_WORLD)
    for c in candidates:
        if c.is_file():
            return c
    raise UsageError(f"no world given and no {DEFAULT_WORLD} found (looked in "
                     + ", ".join(str(c.parent) for c in candidates) + "); pass --world WORLD.json")


# -- the command -------------------------------------------------------------------------------------
def cmd_run(args: argparse.Namespace) -> int:
    from fsm.clock import SimulatedClock
    from fsm.loader import build, check
    from fsm.errors import DiagramError
    from fsm.trace import Recorder, summary

    from ..files import AtomicFile, write_atomic

    for out in (args.trace, args.summary, args.video, args.plot):
        if out:
            check_writable(out)
    registry = registry_from(args)
    clock = SimulatedClock(args.dt) if args.dt else None
    spec, problems = check(args.file, registry=registry)
    errors = [p for p in problems if p.severity == "error"]
    if spec is None or errors:
        raise DiagramError(errors or problems)

    drive = args.world is not None or args.car is not None or uses_car(spec)
    car = world = None
    world_path = None
    if drive:
        from fsm.sim.car import SimCar
        from fsm.sim.world import load_world

        world_path = Path(args.world) if args.world else default_world(args.file)
        world = load_world(world_path, car=args.car)
        car = SimCar(world, seed=args.seed, noise=not args.no_noise)
    elif args.video or args.plot:
        raise UsageError("--video and --plot need a car: this machine uses no car states; pass --world to drive")
    machine = build(spec, clock=clock, car=car)
    for name, value, at in args.signal:
        machine.schedule_signal(name, at, value)
    duration = args.duration
    if duration is None and args.max_ticks is None:
        duration = DEFAULT_MAX_DURATION

    sim = None
    video = None
    progress = None
    if car is not None:
        from fsm.sim.loop import Simulation

        sim = Simulation(machine, car)
        if args.video:
            from fsm.sim.render import VideoRecorder

            video = VideoRecorder(sim, args.video, speed=args.video_speed, fps=args.fps)
        show = args.progress if args.progress is not None else sys.stderr.isatty()
        if show and not args.quiet:
            limit = args.duration if args.duration is not None else (
                args.max_ticks * machine._dt if args.max_ticks is not None else None)
            progress = ProgressBar(limit)

    trace_file = AtomicFile(args.trace) if args.trace else None
    out = trace_file.__enter__() if trace_file else None
    recorder = machine.add_listener(Recorder(out, extra=_car_fields(car) if car is not None else None))
    error: StateRuntimeError | None = None
    interrupted = False
    try:
        if sim is not None:
            machine.start()
            recorder.flush(machine)
            sim.run(duration=duration, max_ticks=args.max_ticks, progress=progress)
        else:
            machine.start()
            recorder.flush(machine)
            machine.run(max_ticks=args.max_ticks, duration=duration)
    except StateRuntimeError as exc:
        error = exc
        recorder.flush(machine)
    except KeyboardInterrupt:
        interrupted = True
        recorder.flush(machine)
    finally:
        if progress is not None:
            progress.done()
        if trace_file is not None:
            trace_file.__exit__(None, None, None)
    result = summary(machine, recorder)
    if sim is not None:
        result.update(sim.metrics())
        result["world"] = str(world_path)
        result["seed"] = args.seed
        result["noise"] = not args.no_noise
    if error is not None:
        result["error"] = {"state": error.path, "phase": error.phase, "tick": error.tick, "time": error.time,
                           "message": f"{type(error.cause).__name__}: {error.cause}"}
    if interrupted:
        result["interrupted"] = True
    if video is not None:
        video.close()
        result["video"] = {"file": args.video, "frames": video.frames, "codec": video.codec}
    if args.plot and sim is not None:
        from fsm.sim.render import plot

        plot(sim, args.plot)
    if args.summary:
        write_atomic(args.summary, json.dumps(result, indent=2) + "\n")
    if error is not None:
        stopped = " (the car was stopped)" if car is not None else ""
        print(f"fsmctl run: {args.file}: {error}{stopped}", file=sys.stderr)
        return EXIT_FAIL
    if not args.quiet:
        status = f"outcome {machine.outcome}" if machine.finished else "not finished"
        if interrupted:
            status += " (interrupted)"
        print(f"{args.file}: {status} after {machine.ticks} ticks ({machine.now:.3f} s), "
              f"{machine.transition_count} transitions")
        print("visited: " + " -> ".join(recorder.visited))
        if not machine.finished:
            print(f"active: {machine.active_path}")
        if sim is not None:
            m = sim.metrics()
            rms, near = m["wall_error_rms_m"], m["min_wall_distance_m"]
            print(f"car: {m['distance_m']:.2f} m, {m['collisions']} collisions, min wall distance "
                  + (f"{near:.3f} m" if near is not None else "n/a") + ", wall error on straights "
                  + (f"{rms * 100:.1f} cm RMS" if rms is not None else "n/a")
                  + f"; {m['realtime_factor']}x real time")
            if m.get("gates_total"):
                print(f"gates: {m['gates_passed']}/{m['gates_total']} passed; odometry error at the end "
                      f"{m['odometry_error_m']:.2f} m")
    if interrupted:
        return 130
    if args.expect is not None and machine.outcome != args.expect:
        print(f"fsmctl run: expected outcome {args.expect!r}, got {machine.outcome!r}", file=sys.stderr)
        return EXIT_FAIL
    return EXIT_OK


def _car_fields(car: Any) -> Any:
    """The trace's extra fields: sensors, commands and pose of the car at the line's tick."""

    def fields() -> dict[str, Any]:
        x, y, th = car.true_pose()  # ground truth, for reports; "odometry" is what the car believed
        ox, oy, oth = car.pose()
        return {"car": {
            "x": round(x, 4), "y": round(y, 4), "heading": round(th, 4),
            "odometry": [round(ox, 4), round(oy, 4), round(oth, 4)],
            "left": round(car.left, 4), "right": round(car.right, 4), "front": round(car.front, 4),
            "distance": round(car.distance, 4), "speed": round(car.speed, 4),
            "speed_command": round(car.speed_command, 4), "steering": round(car.steering, 4),
            "collisions": car.collisions,
        }}

    return fields


class ProgressBar:
    """One line on standard error (only used when it is a terminal): a bar when the run has a limit the user
    set, else the simulated time; redrawn at most ten times a second."""

    def __init__(self, total: float | None) -> None:
        self.total = total
        self.width = 30
        self._last = 0.0

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
            head = ""
        sys.stderr.write(f"\r{head}{sim.now:7.1f} s  {sim.car.distance:7.1f} m  {sim.active_path[:40]:40s}")
        sys.stderr.flush()

    def done(self) -> None:
        sys.stderr.write("\r" + " " * (self.width + 75) + "\r")
        sys.stderr.flush()
