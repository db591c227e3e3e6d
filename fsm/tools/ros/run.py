"""``fsmctl run MACHINE --ros PROFILE``: the machine drives a car on ROS 2 topics over Zenoh.

The order of things: the profile and every output are checked before anything connects; the session waits for
the robot (a peer, then a message on every input: no peer within the profile's ``peer_timeout`` is one message
naming the endpoints and exit 1); the machine runs on the wall clock at the profile's rate (or in lock-step with
``fsmctl sim --lockstep``). However the run ends (finished, a limit, silence, Ctrl-C, a state that failed, any
exception) a zero-speed command is sent first; then trace, report, summary and bag are written; Ctrl-C exits 130.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from typing import Any

from fsm.model.errors import FsmError, UsageError, printable

from ..runs.args import Interrupts
from ..runs.ending import run_guarded
from .common import check_bag_folder, check_endpoints, choose_transport, load
from .ends import finish_run, start_recording, state_parameters

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
    from fsm.ros.transport import open_bus
    from fsm.session.session import StopRules

    profile = load(args.ros, args.remap)
    via = choose_transport(profile, args, args.ros, "--ros")
    _check_node_options(args, via)
    tunables = state_parameters(args, spec, via)  # a --tunable naming nothing: said before anything starts
    inputs = machine_files(spec) + [args.ros]
    outputs.open(inputs)
    check_bag_folder(args.bag, inputs, outputs.items)  # the input itself, another output's name: refused now
    plan = compile_spec(spec)
    listen = _listen(args, profile, via)
    link = open_bus(profile, connect=args.connect, listen=listen, via=args.via, sim_time=args.lockstep)
    files = {"trace": trace_out, "summary": summary_out, "report": report_out}
    if getattr(args, "lifecycle", False):
        return _managed(args, file, profile, link, outputs, files, StopRules(duration, max_ticks))
    # from here on Ctrl-C asks the run to stop (connecting takes a while): the outputs are written, exit 130
    interrupts = Interrupts()
    with interrupts:
        try:
            link.open()
            if listen and not args.quiet:
                print(printable(f"fsmctl run: {link.describe()}; waiting for the robot"), file=sys.stderr, flush=True)
            return _recorded(args, spec, plan, profile, link, StopRules(duration, max_ticks), tunables,
                             lambda session: _drive(args, session, profile, file, outputs, trace_out, summary_out,
                                                    report_out, interrupts))
        finally:
            link.close()


def _check_node_options(args: argparse.Namespace, via: str) -> None:
    """--lifecycle and --tunable make the machine a ROS 2 node's: they need the transport that has nodes."""
    if getattr(args, "lifecycle", False):
        from .lifecycle import check_usage as check_lifecycle

        check_lifecycle(args, via)
    if getattr(args, "tunable", None) and via != "rclpy":
        raise UsageError("--tunable makes state parameters ROS 2 parameters, which rclpy provides: add --via rclpy")


def _listen(args: argparse.Namespace, profile: Any, via: str) -> list[str] | None:
    """Where the machine's side listens: --listen, or (over Zenoh, with nowhere to connect to) a free port the
    robot connects to (printed when the link opens)."""
    from fsm.ros.transport import free_endpoint

    t = profile.transport
    if via == "zenoh" and not (args.connect or args.listen or t.connect or t.listen or t.multicast):
        return [free_endpoint(profile=profile)]
    listen: list[str] | None = args.listen
    return listen


def _recorded(args: argparse.Namespace, spec: Any, plan: Any, profile: Any, link: Any, stop: Any, tunables: Any,
              drive: Callable[[Any], int]) -> int:
    """The session on the open link, driven by ``drive``, with the run recorded as a bag (--bag: kept only when
    the run's outputs were written)."""
    from fsm.ros.bag import BagRecorder
    from fsm.ros.driver import ros_session
    from fsm.session.session import SetSignal

    bag = BagRecorder(args.bag, profile) if args.bag else None
    try:
        session = ros_session(plan, profile, link, lockstep=args.lockstep, bag=bag, variables=args.initial_vars,
                              stop=stop, signals=list(getattr(spec, "inputs", None) or []), tunables=tunables)
        for name, value, at in args.signal:
            session.schedule(at, SetSignal(name, value))
        code = drive(session)
        if bag is not None:
            bag.commit()
            bag = None
        return code
    finally:
        if bag is not None:
            bag.discard()


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
    recorder = start_recording(args, session, profile, file, trace_out, report_out)

    def run() -> None:
        primed = driver.prime(stop=interrupts.stop)
        if primed and not args.quiet:
            print(printable(f"fsmctl run: {driver.profile.name} answered ({driver.link.describe()}); driving"),
                  file=sys.stderr, flush=True)
        if not interrupts.stop():
            session.run(stop=interrupts.stop)

    error = run_guarded(session, recorder, interrupts, run, halt=driver.stop)
    return finish_run(args, session, file, outputs, summary_out, report_out, recorder, error, interrupts.interrupted)


__all__ = ["FsmError", "check_usage", "run_ros"]
