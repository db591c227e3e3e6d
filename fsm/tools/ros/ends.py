"""The two ends of a run over ROS 2, shared by ``fsmctl run --ros`` (:mod:`.run`) and the managed node
(:mod:`.lifecycle`): the states' parameters, the recorder at the start, and at the end the zero-speed command, the
trace's end line, summary, report and the exit status."""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from fsm.model.errors import StateRuntimeError, printable

from ..runs.args import EXIT_FAIL, EXIT_INTERRUPTED, EXIT_OK
from .common import car_recorder


def state_parameters(args: argparse.Namespace, spec: Any, via: str) -> list[Any]:
    """The states' parameters as ROS 2 parameters (over rclpy; Zenoh has none)."""
    if via != "rclpy":
        return []
    from .parameters import tunables

    return tunables(spec, list(getattr(args, "tunable", None) or []), list(getattr(args, "overrides", None) or []))


def start_recording(args: argparse.Namespace, session: Any, profile: Any, file: str, trace_out: Any,
                    report_out: Any) -> Any:
    """The session's recorder: the trace's stream (and the report's copy of it)."""
    from ..runs.ending import trace_stream

    return session.record(car_recorder(trace_stream(trace_out, report_out), file, session.driver.car, profile,
                                       preloaded=args.pre, sample_rate=args.sample_rate))


def finish_run(args: argparse.Namespace, session: Any, file: str, outputs: Any, summary_out: Any, report_out: Any,
               recorder: Any, error: StateRuntimeError | None, interrupted: bool) -> int:
    """The run is over, however: the car gets zero speed before the trace's end, summary and report are written;
    the exit status."""
    from ..runs.ending import end_run

    driver = session.driver
    driver.stop()
    report = sys.stderr if outputs.to_stdout else sys.stdout
    stopped = session.result.stopped if session.result is not None else "not started"
    end: dict[str, Any] = {"stopped": stopped}
    if driver.time_offset:  # the bag's times are ROS time: t_bag = time_offset + t_trace
        end["ros_time_offset"] = driver.time_offset
    result = end_run(session, error, interrupted, report_out=report_out, result={"stopped": stopped}, end=end,
                     report_name=args.trace if args.trace not in (None, "-") else file)
    if summary_out is not None:
        summary_out.write(json.dumps(result, indent=2) + "\n")
    outputs.commit()
    return verdict(args, session, file, error, interrupted, stopped, report, recorder)


def verdict(args: argparse.Namespace, session: Any, file: str, error: StateRuntimeError | None, interrupted: bool,
             stopped: str, report: Any, recorder: Any) -> int:
    machine = session.machine
    driver = session.driver
    if error is not None:
        print(printable(f"fsmctl run: {file}: {error} (the car was sent zero speed)"), file=sys.stderr)
        return EXIT_FAIL
    if not args.quiet:
        from ..recording import end_lines

        print("\n".join(end_lines(file, machine, recorder, interrupted=interrupted,
                                  note="; the car was sent zero speed", where=f" on {driver.profile.name} over ROS 2")),
              file=report)
        m = driver.metrics()["ros"]
        print(f"ros: {m['commands']} commands ({m['zero_speed_commands']} at zero speed), "
              f"{sum(m['received'].values())} messages in, {m['silences']} silences, "
              f"{sum(m['decode_failures'].values())} undecodable", file=report)
    if interrupted:
        return EXIT_INTERRUPTED
    if stopped == "silence":
        print(printable(f"fsmctl run: stopped: {', '.join(driver.silent) or 'the clock'} silent longer than "
                        f"{driver.profile.name} allows (the car was sent zero speed)"), file=sys.stderr)
        return EXIT_FAIL
    if args.expect is not None and machine.outcome != args.expect:
        print(printable(f"fsmctl run: expected outcome {args.expect!r}, got {machine.outcome!r}"), file=sys.stderr)
        return EXIT_FAIL
    return EXIT_OK
