"""``fsmctl run``: run a machine on the simulated clock and report the outcome, states visited, trace, summary."""

from __future__ import annotations

import argparse
import json
import sys

from fsm.errors import StateRuntimeError

from .cli import EXIT_FAIL, EXIT_OK, check_writable, positive_float, positive_int, registry_from, signal_arg


DEFAULT_MAX_DURATION = 600.0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("run", help="run a machine until it finishes (or a limit) and print what it did")
    p.add_argument("file", metavar="FILE")
    p.add_argument("--max-ticks", type=positive_int, metavar="N", help="stop after N ticks")
    p.add_argument("--duration", type=positive_float, metavar="SECONDS",
                   help=f"stop after this much machine time (default: at most {DEFAULT_MAX_DURATION:g} s "
                        "when no --max-ticks is given)")
    p.add_argument("--dt", type=positive_float, metavar="SECONDS", default=None,
                   help="tick period (default 0.0125 s = 80 Hz, the TRAL car's)")
    p.add_argument("--signal", action="append", default=[], metavar="NAME[=0|1]@T", type=signal_arg,
                   help="set input signal NAME high (or to the value given) at machine time T (repeatable)")
    p.add_argument("--trace", metavar="OUT.jsonl", help="write a JSONL trace: one line per tick with a transition")
    p.add_argument("--summary", metavar="OUT.json", help="write a JSON summary of the run")
    p.add_argument("--expect", metavar="OUTCOME", help="exit 1 unless the machine finishes with OUTCOME")
    p.add_argument("-q", "--quiet", action="store_true", help="print nothing but errors")
    p.set_defaults(func=cmd_run)


def cmd_run(args: argparse.Namespace) -> int:
    from fsm.clock import SimulatedClock
    from fsm.loader import load
    from fsm.trace import Recorder, summary

    from .files import AtomicFile, write_atomic

    for out in (args.trace, args.summary):
        if out:
            check_writable(out)
    registry = registry_from(args)
    clock = SimulatedClock(args.dt) if args.dt else None
    machine = load(args.file, registry=registry, clock=clock)
    for name, value, at in args.signal:
        machine.schedule_signal(name, at, value)
    duration = args.duration
    if duration is None and args.max_ticks is None:
        duration = DEFAULT_MAX_DURATION

    trace_file = AtomicFile(args.trace) if args.trace else None
    out = trace_file.__enter__() if trace_file else None
    recorder = machine.add_listener(Recorder(out))
    error: StateRuntimeError | None = None
    interrupted = False
    try:
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
        if trace_file is not None:
            trace_file.__exit__(None, None, None)
    result = summary(machine, recorder)
    if error is not None:
        result["error"] = {"state": error.path, "phase": error.phase, "tick": error.tick, "message": str(error.cause)}
    if interrupted:
        result["interrupted"] = True
    if args.summary:
        write_atomic(args.summary, json.dumps(result, indent=2) + "\n")
    if error is not None:
        print(f"fsmctl run: {args.file}: {error}", file=sys.stderr)
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
    if interrupted:
        return 130
    if args.expect is not None and machine.outcome != args.expect:
        print(f"fsmctl run: expected outcome {args.expect!r}, got {machine.outcome!r}", file=sys.stderr)
        return EXIT_FAIL
    return EXIT_OK
