"""``fsmctl sim --ros PROFILE``: serve the simulated car on the profile's topics until the duration, the machine
finishing (its status topic says so), the machine's side going away (lock-step) or Ctrl-C (exit 130)."""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from fsm.model.errors import printable

from ..runs.args import EXIT_INTERRUPTED, EXIT_OK, Interrupts
from .common import check_endpoints, choose_transport, load


def run_sim(args: argparse.Namespace) -> int:
    from fsm.ros.robot import SimRobot
    from fsm.ros.transport import open_bus
    from fsm.sim.world import default_world, load_world

    from ..files import Outputs

    check_endpoints(args)
    outputs = Outputs()
    summary_out = outputs.add(args.summary, "--summary")
    outputs.check()
    profile = load(args.ros, args.remap)
    world = args.world or str(default_world("."))
    load_world(world)  # located errors before anything connects
    zenoh = choose_transport(profile, args, args.ros, "fsmctl sim --ros") == "zenoh"
    outputs.open([args.ros, world])
    connect, listen = _endpoints(args, profile, zenoh)
    link = open_bus(profile, connect=connect, listen=listen, via=args.via, node="fsmctl_sim", sim_time=args.lockstep)

    def say(text: str) -> None:
        if not args.quiet:
            print(printable(f"fsmctl sim: {text}"), file=sys.stderr, flush=True)

    try:
        link.open()
        robot = SimRobot(profile, link, world, seed=args.seed, noise=not args.no_noise, lockstep=args.lockstep,
                         log=say)
        interrupts = Interrupts()
        with interrupts:
            say(f"{profile.name} in {world}, {link.describe()}; waiting for the machine")
            why = _serve(args, robot, interrupts)
            robot.car.emergency_stop()
            interrupts.writing = True
            result = robot.summary() | {"stopped": why}
            if summary_out is not None:
                summary_out.write(json.dumps(result, indent=2) + "\n")
            outputs.commit()
        say(f"{why} at {robot.time:.3f} s: {result['distance_m']:.2f} m, {result['collisions']} collisions"
            + (f", gates {result['gates_passed']}/{result['gates_total']}" if result.get("gates_total") else ""))
        return EXIT_INTERRUPTED if interrupts.interrupted else EXIT_OK
    finally:
        outputs.discard()
        link.close()


def _endpoints(args: argparse.Namespace, profile: Any, zenoh: bool) -> tuple[list[str], list[str]]:
    """(connect, listen): the options', or over Zenoh without them the robot's side of the profile: listen where
    the machine connects, else on a free port (printed when the link opens)."""
    from fsm.ros.transport import free_endpoint

    if zenoh and args.listen is None and args.connect is None:
        return [], list(profile.transport.listen or profile.transport.connect) or [free_endpoint(profile=profile)]
    return args.connect or [], args.listen or []


def _serve(args: argparse.Namespace, robot: Any, interrupts: Interrupts) -> str:
    """Wait for the machine, then serve it until the run ends: why it ended."""
    robot.wait_for_controller(args.wait, stop=interrupts.stop)
    if interrupts.stop():
        return "stopped"
    if args.lockstep:
        why: str = robot.run_lockstep(args.duration, args.wait, stop=interrupts.stop)
        return why
    why = robot.run_realtime(args.duration, stop=interrupts.stop)
    return why
