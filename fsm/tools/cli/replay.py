"""``fsmctl replay BAG --machine M --profile P``: feed a recorded drive's sensor topics to a machine, open loop on
the bag's clock; write trace, report and summary, and name the first tick at which its decisions differ from the
recorded ones. See docs/ros.md."""

from __future__ import annotations

import argparse

from .common import Subcommands, bounded_float


def register(sub: Subcommands) -> None:
    p = sub.add_parser("replay", help="run a machine open loop on a recorded drive (a rosbag2)",
                       description="Feed the sensor topics of a recorded drive (a rosbag2 folder written by "
                                   "`fsmctl run --ros ... --bag`) to a machine, open loop on the bag's clock: what "
                                   "would this machine have decided? Its decisions (commands, active path) are "
                                   "compared with the recorded ones tick by tick up to the first divergence. A drive "
                                   "recorded without commands (sensors only, any robot's) is ticked at the profile's "
                                   "rate on the bag's clock.")
    p.add_argument("bag", metavar="BAG", help="the rosbag2 folder (MCAP or sqlite3), or an MCAP file")
    p.add_argument("--machine", metavar="FILE", required=True, help="the machine (.json or .uxf)")
    p.add_argument("--profile", metavar="PROFILE.json", required=True,
                   help="the I/O profile the bag was recorded with (which topic is which input)")
    p.add_argument("--set", action="append", default=[], metavar="PATH.PARAM=VALUE", dest="overrides",
                   help="replay with a parameter changed, e.g. bottom_slow.speed=0.5 (repeatable; as fsmctl run --set)")
    p.add_argument("--trace", metavar="OUT.jsonl", help="write the replay's JSONL trace ('-' for standard output)")
    p.add_argument("--report", metavar="OUT.html", help="write the replay's HTML report")
    p.add_argument("--summary", metavar="OUT.json",
                   help="write a JSON summary with the comparison ('-' for standard output)")
    p.add_argument("--sample-rate", type=bounded_float(0.1, 1000, "--sample-rate"), default=20.0, metavar="HZ",
                   help="how often the trace samples the car's readings and commands (default 20)")
    p.add_argument("--from", type=bounded_float(0, 1e9, "--from"), dest="start", metavar="SECONDS",
                   help="replay from this time on the bag's clock, seconds after its first message")
    p.add_argument("--to", type=bounded_float(0, 1e9, "--to"), dest="stop", metavar="SECONDS",
                   help="replay up to this time on the bag's clock, seconds after its first message")
    p.add_argument("--expect-same", action="store_true",
                   help="exit 1 when the decisions differ from the recorded ones at some tick")
    p.add_argument("-q", "--quiet", action="store_true", help="print nothing but errors")
    p.set_defaults(func=cmd_replay)


def cmd_replay(args: argparse.Namespace) -> int:
    from ..ros.replay import run_replay

    return run_replay(args)
