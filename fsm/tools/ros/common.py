"""What the ROS 2 commands share: the extra's presence, the profile with the command line's endpoints, the bag
folder's checks, the trace recorder of a car on topics."""

from __future__ import annotations

import argparse
import os
from collections.abc import Iterable
from typing import TYPE_CHECKING, Any

from fsm.model.errors import FsmError, UsageError

if TYPE_CHECKING:
    from _typeshed import SupportsWrite

#: What to install when the extra is missing.
EXTRA_HINT = "pip install 'tral-fsm[ros2]' (rosbags and eclipse-zenoh)"


def require_extra(what: str, zenoh: bool = True) -> None:
    """The ``ros2`` extra must be installed (without Zenoh when rclpy carries the topics): one message saying how,
    exit 1."""
    missing = []
    for module in ("zenoh", "rosbags") if zenoh else ("rosbags",):
        try:
            __import__(module)
        except ImportError:
            missing.append(module)
    if missing:
        raise FsmError(f"{what} needs {' and '.join(missing)}: {EXTRA_HINT}")


def choose_transport(profile: Any, args: argparse.Namespace, file: str, what: str) -> str:
    """``zenoh`` or ``rclpy`` for this command, its needs checked before anything connects: the ``ros2`` extra;
    with rclpy, rclpy itself (one message naming the ``rclpy`` extra) and every bound type's message package
    (located profile errors)."""
    from fsm.ros.transport import TransportError, rclpy_available, resolve_via

    via = resolve_via(profile, args.via, endpoints=bool(args.connect or args.listen))
    require_extra(what, zenoh=via == "zenoh")
    if via == "rclpy":
        from fsm.ros.rclpy_link import RCLPY_HINT, check_types

        if not rclpy_available():
            raise TransportError(f"{what} --via rclpy needs rclpy: {RCLPY_HINT}; or use --via zenoh")
        check_types(profile, file)
    return via


def add_endpoint_options(p: argparse.ArgumentParser, lockstep_help: str, managed: bool = False) -> None:
    """The transport's options; ``managed``: also ``--lifecycle`` (fsmctl run)."""
    g = p.add_argument_group("the transport (replacing the profile's)")
    g.add_argument("--connect", action="append", metavar="ENDPOINT",
                   help="connect to ENDPOINT, e.g. tcp/127.0.0.1:7447 (repeatable)")
    g.add_argument("--listen", action="append", metavar="ENDPOINT",
                   help="listen on ENDPOINT, e.g. tcp/127.0.0.1:7447 (repeatable)")
    g.add_argument("--via", choices=("auto", "zenoh", "rclpy"),
                   help="the transport (default: the profile's transport.via, auto: rclpy when it can be imported, "
                        "Zenoh otherwise)")
    g.add_argument("--remap", action="append", default=[], metavar="FROM:=TO",
                   help="rename a topic of the profile (/tral/cmd:=/car1/cmd), or rclpy's node (__node:=NAME) or "
                        "namespace (__ns:=/NS), as ROS 2's -r (repeatable; after the profile's transport.remap)")
    g.add_argument("--lockstep", action="store_true", help=lockstep_help)
    if managed:
        g.add_argument("--lifecycle", action="store_true",
                       help="with --via rclpy: the bridge is a ROS 2 managed node; configure loads the document, "
                            "activate starts ticking, deactivate stops the car and pauses, shutdown ends the run")
        g.add_argument("--tunable", action="append", default=[], metavar="PATH.PARAM",
                       help="with --via rclpy: let a ROS 2 client set this state parameter (states.PATH.PARAM on "
                            "the node; the others are read-only), e.g. follow.speed (repeatable)")


def check_endpoints(args: argparse.Namespace) -> None:
    import re

    from fsm.ros.profile import ENDPOINT_PATTERN

    for option in ("connect", "listen"):
        for endpoint in getattr(args, option) or []:
            if not re.match(ENDPOINT_PATTERN, endpoint):
                raise UsageError(f"--{option} {endpoint}: not a Zenoh endpoint; write PROTOCOL/ADDRESS, "
                                 "e.g. tcp/127.0.0.1:7447")


def load(path: str, remaps: list[str] | None = None) -> Any:
    """The profile (located errors before anything starts), its camera calibration checked too, its remappings and
    ``remaps`` (``--remap``) applied."""
    from fsm.ros.profile import check_camera, load_profile, remapped

    profile = load_profile(path)
    check_camera(profile)
    try:
        return remapped(profile, remaps or [])
    except ValueError as exc:
        raise UsageError(f"--remap: {exc}") from None


def check_bag_folder(name: str | None, inputs: Iterable[str | os.PathLike[str]] = (),
                     outputs: Iterable[Any] = ()) -> str | None:
    """``--bag DIR``: a new folder (not there yet, not a symlink, not an input, not another output's name) in a
    folder that exists and can be written; the rules of :func:`tools.files.check_new_folder`."""
    from ..files import check_new_folder

    if name is None:
        return None
    return check_new_folder(name, "--bag", inputs, outputs)


def car_recorder(stream: SupportsWrite[str] | None, file: str, car: Any, profile: Any, document: Any = None,
                 preloaded: dict[str, Any] | None = None, sample_rate: float = 20.0,
                 extra_header: dict[str, Any] | None = None) -> Any:
    """The trace of a run on topics: the machine's header, the profile, the car's readings and commands as the
    machine saw them (the odometry pose stands where the simulator has ground truth)."""
    from fsm.trace.recorder import Recorder

    from ..recording import header_document

    if stream is None:
        return Recorder()
    header: dict[str, Any] = {"source": file,
                              "machine": document if document is not None else header_document(file, preloaded),
                              "ros": {"profile": profile.name, "rate": profile.rate,
                                      "topics": {name: b.topic for name, b in profile.inputs_bound().items()}
                                      | {"command": profile.outputs.command.topic}},
                              **(extra_header or {})}
    fields = ["car.odometry[0]", "car.odometry[1]", "car.odometry[2]", "car.left", "car.right", "car.front",
              "car.distance", "car.speed", "car.speed_command", "car.steering", "car.odometry_jumps"]

    def sample() -> tuple[Any, ...]:
        x, y, th = car.pose()
        return (x, y, th, car.left, car.right, car.front, car.distance, car.speed, car.speed_command, car.steering,
                car.odometry_jumps)

    def extra() -> dict[str, Any]:
        x, y, th = car.pose()
        return {"car": {"odometry": [round(x, 4), round(y, 4), round(th, 4)], "left": round(car.left, 4),
                        "right": round(car.right, 4), "front": round(car.front, 4),
                        "distance": round(car.distance, 4), "speed": round(car.speed, 4),
                        "speed_command": round(car.speed_command, 4), "steering": round(car.steering, 4),
                        "odometry_jumps": car.odometry_jumps}}

    return Recorder(stream, extra=extra, header=header, sample=sample, sample_period=1.0 / sample_rate,
                    sample_fields=fields)
