"""``fsmctl sim --ros PROFILE``: serve the simulated car on the profile's topics until the duration, the machine
finishing (its status topic says so), the machine's side going away (lock-step) or Ctrl-C (exit 130)."""

from __future__ import annotations

import argparse
import json
import sys

from fsm.model.errors import printable

from ..runs.args import EXIT_INTERRUPTED, EXIT_OK, Interrupts
from .common import check_endpoints, choose_transport, load


def run_sim(args: argparse.Namespace) -> int:
    from fsm.ros.robot import SimRobot
    from fsm.ros.transport import free_endpoint, open_bus
    from fsm.sim.world import default_world, load_world

    from ..files import Outputs

    check_endpoints(args)
    outputs = Outputs()
    summary_out = outputs.add(args.summary, "--summary")
    for out in outputs.items:
        out.classify()
    profile = load(args.ros, args.remap)
    world = args.world or str(default_world("."))
    load_world(world)  # located errors before anything connects
    zenoh = choose_transport(profile, args, args.ros, "fsmctl sim --ros") == "zenoh"
    outputs.open([args.ros, world])
    listen = args.listen
    connect = args.connect
    if zenoh and listen is None and connect is None:
        # the robot's side of the profile: listen where the machine connects; else on a free port, printed below
        listen = list(profile.transport.listen or profile.transport.connect) or [free_endpoint(profile=profile)]
        connect = []
    link = open_bus(profile, connect=connect or [], listen=listen or [], via=args.via, node="fsmctl_sim",
                    sim_time=args.lockstep)

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
            robot.wait_for_controller(args.wait, stop=interrupts.stop)
            if interrupts.stop():
                why = "stopped"
            elif args.lockstep:
                why = robot.run_lockstep(args.duration, args.wait, stop=interrupts.stop)
            else:
                why = robot.run_realtime(args.duration, stop=interrupts.stop)
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
