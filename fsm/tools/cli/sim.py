"""``fsmctl sim --ros PROFILE``: the simulated TRAL car as a ROS 2 robot on the profile's topics (over Zenoh), for
``fsmctl run --ros`` in another process to drive exactly as it would drive the real car. See docs/ros.md."""

from __future__ import annotations

import argparse

from .common import Subcommands, positive_float, whole_number


def register(sub: Subcommands) -> None:
    from ..ros.common import add_endpoint_options

    p = sub.add_parser("sim", help="serve the simulated car as a ROS 2 robot (for fsmctl run --ros)",
                       description="Serve the simulated TRAL car as a ROS 2 robot: publish its sensors and obey the "
                                   "commands on the I/O profile's topics, over Zenoh. Without --listen/--connect it "
                                   "listens on the endpoints the profile connects to.")
    p.add_argument("--ros", metavar="PROFILE.json", required=True, help="the I/O profile (topics, types, rates)")
    p.add_argument("--world", metavar="WORLD.json", help="world file (default: diagrams/worlds/hallway.json)")
    p.add_argument("--seed", type=whole_number(0, 2**63 - 1, "2**63-1"), default=0, metavar="N",
                   help="seed of the sensor noise (default 0)")
    p.add_argument("--no-noise", action="store_true", help="turn the ultrasonic noise off")
    p.add_argument("--duration", type=positive_float, default=600.0, metavar="SECONDS",
                   help="stop after this much simulated time (default 600)")
    p.add_argument("--wait", type=positive_float, default=30.0, metavar="SECONDS",
                   help="how long to wait for the machine's side to connect (and, in lock-step, for each command) "
                        "(default 30)")
    p.add_argument("--summary", metavar="OUT.json", help="write the simulator's summary (distance, collisions, gates)")
    p.add_argument("-q", "--quiet", action="store_true", help="print nothing but errors")
    add_endpoint_options(p, "publish the simulation's clock on the profile's clock topic and advance one tick per "
                            "command of `fsmctl run --ros --lockstep` instead of on the wall clock (fast, "
                            "reproducible runs)")
    p.set_defaults(func=cmd_sim)


def cmd_sim(args: argparse.Namespace) -> int:
    from ..ros.sim import run_sim

    return run_sim(args)
