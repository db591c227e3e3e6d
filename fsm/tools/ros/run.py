"""``fsmctl run MACHINE --ros PROFILE``: the machine drives a car on ROS 2 topics over Zenoh.

The order of things: the profile and every output are checked before anything connects; the session waits for
the robot (a peer, then a message on every input: no peer within the profile's ``peer_timeout`` is one message
naming the endpoints and exit 1); the machine runs on the wall clock at the profile's rate (or in lock-step with
``fsmctl sim --lockstep``). However the run ends (finished, a limit, silence, Ctrl-C, a state that failed, any
exception) a zero-speed command is sent first; then trace, report, summary and bag are written; Ctrl-C exits 130.
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from fsm.model.errors import FsmError, StateRuntimeError, UsageError, printable

from ..runs.args import EXIT_FAIL, EXIT_INTERRUPTED, EXIT_OK, Interrupts
from .common import car_recorder, check_bag_folder, check_endpoints, choose_transport, load

#: Options of ``fsmctl run`` that drive the simulated car in-process, refused with --ros.
SIM_ONLY = ("world", "car", "video", "plot")


def check_usage(args: argparse.Namespace) -> None:
    """--ros goes with neither the in-process simulator's options nor (without --ros) --bag and the endpoints."""
    if not args.ros:
        for option in ("bag", "connect", "listen", "via"):
            if getattr(args, option, None):
                raise UsageError(f"--{option} needs --ros PROFILE (it records or reaches a car on ROS 2 topics)")
        for flag in ("lockstep", "lifecycle", "tunable"):
            if getattr(args, flag, False):
                raise UsageError(f"--{flag} needs --ros PROFILE")
        return
    for option in SIM_ONLY:
        if getattr(args, option, None):
            raise UsageError(f"--{option} is for the in-process simulator; with --ros the car is on the network "
                             "(run `fsmctl sim --ros PROFILE --world ...` for a simulated one)")
    if args.dt is not None:
        raise UsageError("--dt: with --ros the tick rate is the profile's 'rate'")
    check_endpoints(args)
    check_bag_folder(args.bag, [args.ros] + ([args.file] if getattr(args, "file", None) else []))


def run_ros(args: argparse.Namespace, spec: Any, file: str, outputs: Any, trace_out: Any, summary_out: Any,
            report_out: Any, duration: float | None, max_ticks: int | None) -> int:
    from fsm.loading.loader import compile as compile_spec
    from fsm.loading.loader import machine_files
    from fsm.ros.bag import BagRecorder
    from fsm.ros.driver import ros_session
    from fsm.ros.transport import free_endpoint, open_bus
    from fsm.session.session import SetSignal, StopRules

    profile = load(args.ros, args.remap)
    via = choose_transport(profile, args, args.ros, "--ros")
    if getattr(args, "lifecycle", False):
        from .lifecycle import check_usage as check_lifecycle

        check_lifecycle(args, via)
    if getattr(args, "tunable", None) and via != "rclpy":
        raise UsageError("--tunable makes state parameters ROS 2 parameters, which rclpy provides: add --via rclpy")
    tunables = state_parameters(args, spec, via)  # a --tunable naming nothing: said before anything starts
    inputs = machine_files(spec) + [args.ros]
    outputs.open(inputs)
    check_bag_folder(args.bag, inputs, outputs.items)  # the input itself, another output's name: refused now
    plan = compile_spec(spec)
    connect, listen = args.connect, args.listen
    t = profile.transport
    if via == "zenoh" and not (connect or listen or t.connect or t.listen or t.multicast):
        listen = [free_endpoint(profile=profile)]  # nowhere to connect to: the robot connects here (printed below)
    link = open_bus(profile, connect=connect, listen=listen, via=args.via, sim_time=args.lockstep)
    if getattr(args, "lifecycle", False):
        return _managed(args, file, profile, link, outputs, {"trace": trace_out, "summary": summary_out,
                                                             "report": report_out}, StopRules(duration, max_ticks))
    bag = None
    # from here on Ctrl-C asks the run to stop (connecting takes a while): the outputs are written, exit 130
    interrupts = Interrupts()
    with interrupts:
        try:
            link.open()
            if listen and not args.quiet:
                print(printable(f"fsmctl run: {link.describe()}; waiting for the robot"), file=sys.stderr, flush=True)
            bag = BagRecorder(args.bag, profile) if args.bag else None
            session = ros_session(plan, profile, link, lockstep=args.lockstep, bag=bag,
                                  variables=args.initial_vars, stop=StopRules(duration, max_ticks),
                                  signals=list(getattr(spec, "inputs", None) or []),
                                  tunables=tunables)
            for name, value, at in args.signal:
                session.schedule(at, SetSignal(name, value))
            code = _drive(args, session, profile, file, outputs, trace_out, summary_out, report_out, interrupts)
            if bag is not None:
                bag.commit()
                bag = None
            return code
        finally:
            if bag is not None:
                bag.discard()
            link.close()


def state_parameters(args: argparse.Namespace, spec: Any, via: str) -> list[Any]:
    """The states' parameters as ROS 2 parameters (over rclpy; Zenoh has none)."""
    if via != "rclpy":
        return []
    from .parameters import tunables

    return tunables(spec, list(getattr(args, "tunable", None) or []), list(getattr(args, "overrides", None) or []))


def _managed(args: argparse.Namespace, file: str, profile: Any, link: Any, outputs: Any, files: dict[str, Any],
             stop_rules: Any) -> int:
    """--lifecycle: the node is managed (:mod:`.lifecycle`); the machine is built at its configure."""
    from .lifecycle import LifecycleRun

    interrupts = Interrupts()
    run = LifecycleRun(args, file, profile, link, outputs, files, stop_rules, interrupts)
    link.managed = run
    with interrupts:
        try:
            link.open()
            return run.serve()
        finally:
            run.discard()
            link.close()


def _drive(args: argparse.Namespace, session: Any, profile: Any, file: str, outputs: Any, trace_out: Any,
           summary_out: Any, report_out: Any, interrupts: Interrupts) -> int:
    driver = session.driver
    machine = session.machine
    recorder = start_recording(args, session, profile, file, trace_out, report_out)
    error: StateRuntimeError | None = None
    try:
        primed = driver.prime(stop=interrupts.stop)
        if primed and not args.quiet:
            print(printable(f"fsmctl run: {driver.profile.name} answered ({driver.link.describe()}); driving"),
                  file=sys.stderr, flush=True)
        if not interrupts.stop():
            session.run(stop=interrupts.stop)
    except StateRuntimeError as exc:
        error = exc
        driver.stop()
        recorder.flush(machine)
    except KeyboardInterrupt:  # a second Ctrl-C while a state did not return
        driver.stop()
        interrupts.received = interrupts.received or 2
        recorder.flush(machine)
    except BaseException:
        driver.stop()  # before anything else: the car must not drive on
        raise
    finally:
        interrupts.writing = True
    return finish_run(args, session, file, outputs, summary_out, report_out, recorder, error, interrupts.interrupted)


def start_recording(args: argparse.Namespace, session: Any, profile: Any, file: str, trace_out: Any,
                    report_out: Any) -> Any:
    """The session's recorder: the trace's stream (and the report's copy of it)."""
    from ..runs.ending import Tee

    stream = trace_out.stream() if trace_out is not None else None
    if report_out is not None:
        stream = Tee(stream)
    return session.record(car_recorder(stream, file, session.driver.car, profile, preloaded=args.pre,
                                       sample_rate=args.sample_rate))


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
    return _verdict(args, session, file, error, interrupted, stopped, report, recorder)


def _verdict(args: argparse.Namespace, session: Any, file: str, error: StateRuntimeError | None, interrupted: bool,
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


__all__ = ["FsmError", "check_usage", "run_ros"]
