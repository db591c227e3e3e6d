"""The I/O profile: which ROS 2 topics carry the car interface, their message types, rates, QoS and silence limits.

A profile is a JSON file checked like the project's other files: read through :mod:`fsm.loading.reading` (regular files,
size cap, strict JSON), its shape against the pydantic models below (the committed
``fsm/schema/ros_profile.schema.json`` is generated from them), then its meaning (a topic bound twice, a message type
that does not fit its input, a field the message has not). Every problem is located (file, JSON pointer,
line:column) and all of them are reported at once, before any connection is opened.

Stdlib and pydantic only: the message types a profile may name are listed here, so checking a profile needs neither
rosbags nor Zenoh.
"""

from __future__ import annotations

import difflib
import math
import os
import re
from pathlib import Path
from typing import Any, Literal

from pydantic import Field, PrivateAttr, ValidationError, model_validator

from fsm.model.errors import DiagramError, Problem
from fsm.model.params import ParamsBase

#: ROS 2 topic names: tokens of letters, digits and underscores (not starting with a digit), '/'-separated.
TOPIC_PATTERN = r"^/?[A-Za-z_][A-Za-z0-9_]*(/[A-Za-z_][A-Za-z0-9_]*)*$"
#: Zenoh endpoints: a protocol, '/', an address (``tcp/127.0.0.1:7447``).
ENDPOINT_PATTERN = r"^(tcp|udp|tls|quic|ws|unixsock-stream)/\S+$"

RANGE = "sensor_msgs/msg/Range"
ODOMETRY = "nav_msgs/msg/Odometry"
COMPRESSED = "sensor_msgs/msg/CompressedImage"
IMAGE = "sensor_msgs/msg/Image"
ACKERMANN = "ackermann_msgs/msg/AckermannDriveStamped"
ACKERMANN_PLAIN = "ackermann_msgs/msg/AckermannDrive"
TWIST = "geometry_msgs/msg/Twist"
TWIST_STAMPED = "geometry_msgs/msg/TwistStamped"
STRING = "std_msgs/msg/String"
CLOCK = "rosgraph_msgs/msg/Clock"
DIAGNOSTICS = "diagnostic_msgs/msg/DiagnosticArray"
#: Counters for hall ticks: every one has a single numeric field ``data``.
COUNTERS = tuple(f"std_msgs/msg/{t}" for t in ("Int16", "Int32", "Int64", "UInt16", "UInt32", "UInt64", "Float32",
                                                 "Float64"))

#: The message types each binding takes (the keys are the profile's binding names).
ROLE_TYPES: dict[str, tuple[str, ...]] = {
    "left": (RANGE,), "right": (RANGE,), "front": (RANGE,),
    "odometry": (ODOMETRY,),
    "hall": COUNTERS,
    "camera": (COMPRESSED, IMAGE),
    "command": (ACKERMANN, ACKERMANN_PLAIN, TWIST, TWIST_STAMPED),
    "status": (STRING,),
    "clock": (CLOCK,),
}
#: Every message type a profile may name, with the numeric fields a ``field`` may pick.
KNOWN_TYPES: dict[str, tuple[str, ...]] = {RANGE: ("range",), ODOMETRY: (), COMPRESSED: (), IMAGE: (),
                                           ACKERMANN: (), ACKERMANN_PLAIN: (), TWIST: (), TWIST_STAMPED: (),
                                           STRING: (), CLOCK: (), **{t: ("data",) for t in COUNTERS}}
#: The inputs, in the order the car reads them.
INPUTS = ("left", "right", "front", "odometry", "hall", "camera")


def normalise_type(name: str) -> str:
    """``sensor_msgs/Range`` (ROS 1 style, or as ``ros2 topic`` prints it without ``msg``) is
    ``sensor_msgs/msg/Range``."""
    parts = name.split("/")
    return f"{parts[0]}/msg/{parts[1]}" if len(parts) == 2 else name


class ProfileModel(ParamsBase):
    """Strict like the other files: unknown keys, strings for numbers, NaN and infinity are errors."""


class Qos(ProfileModel):
    """The QoS that matters over Zenoh: reliability (how congestion is handled) and priority."""

    reliability: Literal["reliable", "best_effort"] = Field(
        default="reliable", description="reliable: a congested link blocks the sender; best_effort: drops.")
    durability: Literal["volatile"] = Field(
        default="volatile", description="Only volatile: a late subscriber gets no history.")
    depth: int = Field(default=1, ge=1, le=1000, description="Messages kept per topic (the car reads the latest).")
    priority: Literal["real_time", "interactive_high", "data", "background"] = Field(
        default="data", description="Zenoh priority of the topic's messages.")
    express: bool = Field(default=False, description="Send at once, without batching (lower latency).")


class Binding(ProfileModel):
    """One topic of the car: its name, message type and QoS."""

    topic: str = Field(pattern=TOPIC_PATTERN, description="The ROS 2 topic name, e.g. /tral/ultrasonic/front.")
    type: str = Field(min_length=1, description="The message type, e.g. sensor_msgs/msg/Range.")
    qos: Qos = Field(default_factory=Qos, description="Quality of service.")


class Input(Binding):
    """A sensor topic: its rate and how long it may stay silent before the car is stopped."""

    rate: float = Field(default=20.0, gt=0, le=10000, description="Messages per second the robot publishes.")
    max_silence: float = Field(default=0.5, gt=0, le=3600,
                               description="Seconds the input may stay silent; longer: the car gets zero speed.")
    field: str | None = Field(default=None, min_length=1,
                              description="The numeric field that carries the value (counters: data).")


class Camera(Input):
    """The camera: images (raw or compressed), with its calibration and mount, detected on the laptop."""

    calibration: str | None = Field(default=None, min_length=1,
                                    description="Calibration file (OpenCV YAML/XML, JSON, ROS camera_info YAML), "
                                                "relative to the profile.")
    width: int = Field(default=640, ge=16, le=8192, description="Image width without a calibration file, px.")
    height: int = Field(default=480, ge=16, le=8192, description="Image height without a calibration file, px.")
    fx: float = Field(default=500.0, gt=0, le=1e5, description="Focal length without a calibration file, px.")
    mount: tuple[float, float, float, float, float] = Field(
        default=(0.2, 0.0, 0.15, 0.0, 0.0), description="x, y, z (m, car frame), yaw, pitch (degrees).")
    dictionary: str = Field(default="DICT_4X4_50", description="ArUco dictionary of the markers.")
    marker_size: float = Field(default=0.15, gt=0, le=5, description="Side of the markers' black square, m.")


class Inputs(ProfileModel):
    """The sensor topics: three ultrasonic ranges and odometry are required; hall ticks and camera are optional."""

    left: Input
    right: Input
    front: Input
    odometry: Input
    hall: Input | None = None
    camera: Camera | None = None


class Command(Binding):
    """The drive command, published once per tick."""

    qos: Qos = Field(default_factory=lambda: Qos(priority="real_time", express=True), description="Quality of service.")


class Status(Binding):
    """The machine's status (active path, outcome, monitor firings) as JSON text, ``rate`` times a second."""

    rate: float = Field(default=10.0, gt=0, le=1000, description="Status messages per second.")


class Outputs(ProfileModel):
    command: Command
    status: Status | None = None


class CarGeometry(ProfileModel):
    """What the laptop must know of the car to turn the car interface into commands and back."""

    wheelbase: float = Field(default=0.26, gt=0, le=5, description="Distance between the axles, m.")
    max_steering_angle: float = Field(default=24.0, gt=0, lt=60, description="Wheel angle at steering 1, degrees.")
    max_speed: float = Field(default=2.5, gt=0, le=20, description="Speed commands are clamped to this, m/s.")
    hall_units_per_m: float = Field(default=1500 / 1.60, gt=0, description="Hall units per metre.")
    max_range: float = Field(default=4.0, gt=0, le=100, description="Ultrasonic reading without an echo, m.")


class Tls(ProfileModel):
    """Zenoh over TLS (endpoints ``tls/HOST:PORT``; plain TCP is then refused): certificates in PEM files, paths
    relative to the profile's folder. Zenoh reads them (transport/link/tls)."""

    ca: str = Field(min_length=1, description="The certificate of the CA that signed the peers' certificates "
                                              "(root_ca_certificate): a peer whose certificate it did not sign is "
                                              "refused.")
    certificate: str | None = Field(default=None, min_length=1,
                                    description="This side's certificate (listen_certificate, and with mutual "
                                                "connect_certificate); needed to listen.")
    key: str | None = Field(default=None, min_length=1,
                            description="This side's private key (listen_private_key / connect_private_key); "
                                        "readable by its user only.")
    mutual: bool = Field(default=False, description="Mutual TLS (enable_mtls): the listening side also checks the "
                                                    "connecting side's certificate; both need certificate and key.")
    verify_name: bool = Field(default=True, description="Check that the listening side's certificate names the "
                                                        "host connected to (verify_name_on_connect).")

    @model_validator(mode="after")
    def _pairs(self) -> Tls:
        if (self.certificate is None) != (self.key is None):
            raise ValueError("certificate and key go together: give both or neither")
        if self.mutual and self.certificate is None:
            raise ValueError("mutual TLS: each side shows its own certificate; give certificate and key")
        return self


class Transport(ProfileModel):
    """The Zenoh session: peer mode on explicit endpoints (multicast scouting off by default), or a router."""

    mode: Literal["peer", "client"] = Field(default="peer", description="peer: direct; client: through a router.")
    connect: list[str] = Field(default_factory=list, description="Endpoints to connect to, e.g. tcp/127.0.0.1:7447.")
    listen: list[str] = Field(default_factory=list, description="Endpoints to listen on.")
    multicast: bool = Field(default=False, description="Multicast scouting (off: only the endpoints given).")
    peer_timeout: float = Field(default=5.0, gt=0, le=600,
                                description="Seconds to wait for the robot before giving up (exit 1).")
    gone_after: float = Field(default=10.0, gt=0, le=3600,
                              description="Lock-step: seconds of wall time without the simulator's next clock after "
                                          "which it is gone (the run ends, exit 1). Silences are simulated time.")
    keys: Literal["rmw_zenoh", "bridge"] = Field(
        default="rmw_zenoh", description="Key expressions as rmw_zenoh names topics (<domain>/<topic>/<type>/<hash>), "
                                         "or as zenoh-bridge-ros2dds does (the topic name).")
    domain: int | None = Field(default=None, ge=0, le=232,
                               description="The ROS domain (rmw_zenoh keys; rclpy's domain); without it "
                                           "$ROS_DOMAIN_ID, else 0.")
    node: str | None = Field(default=None, pattern=r"^[A-Za-z_][A-Za-z0-9_]*$",
                             description="rclpy's node name (default fsmctl_<name>, fsmctl_sim_<name> for the "
                                         "simulator); --remap __node:=NAME replaces it.")
    namespace: str = Field(default="", pattern=r"^(/[A-Za-z_][A-Za-z0-9_]*)*$",
                           description="rclpy's node namespace, e.g. /car1; --remap __ns:=/NS replaces it.")
    remap: list[str] = Field(default_factory=list,
                             description="Topic remappings FROM:=TO applied to every binding (as ROS 2's -r), "
                                         "before the command line's --remap.")
    user: str | None = Field(default=None, min_length=1, max_length=100, pattern=r"^[^:\s]+$",
                             description="Zenoh's user/password authentication: the user; the password is read "
                                         "from the environment variable FSM_ZENOH_PASSWORD. A peer without them is "
                                         "refused.")
    via: Literal["auto", "zenoh", "rclpy"] = Field(
        default="auto", description="auto: rclpy when it can be imported (ROS 2 installed and sourced), Zenoh "
                                    "otherwise; zenoh or rclpy: that one.")
    tls: Tls | None = Field(default=None, description="Zenoh over TLS: the CA, this side's certificate and key, "
                                                      "mutual TLS. Endpoints are then tls/HOST:PORT.")


class Safety(ProfileModel):
    """What the run does beyond the zero-speed command on silence, pause, Ctrl-C and errors."""

    stop_after: float | None = Field(default=None, gt=0, le=3600,
                                     description="End the run when an input has been silent this long (s); "
                                                 "without it the run goes on with the car stopped.")


class Profile(ProfileModel):
    """An I/O profile: the car interface bound to ROS 2 topics."""

    schema_: str | None = Field(default=None, alias="$schema", description="The JSON Schema (for editors).")
    name: str = Field(default="car", min_length=1, max_length=100, description="A name for messages and the status.")
    rate: float = Field(default=80.0, gt=0, le=1000, description="The machine's tick rate on the car, Hz.")
    transport: Transport = Field(default_factory=Transport, description="The Zenoh session.")
    car: CarGeometry = Field(default_factory=CarGeometry, description="The car's geometry and limits.")
    inputs: Inputs = Field(description="The sensor topics.")
    outputs: Outputs = Field(description="The command and status topics.")
    clock: Binding = Field(default_factory=lambda: Binding(topic="/clock", type=CLOCK,
                                                           qos=Qos(express=True)),
                           description="The simulation clock (lock-step runs against `fsmctl sim --lockstep`).")
    safety: Safety = Field(default_factory=Safety, description="Safety beyond the zero-speed command.")
    #: where the file was (calibration files are relative to it); not a key of the file
    _base_dir: str | None = PrivateAttr(default=None)

    @property
    def dt(self) -> float:
        return 1.0 / self.rate

    def inputs_bound(self) -> dict[str, Input]:
        """The inputs the profile binds, by name, in :data:`INPUTS` order."""
        out: dict[str, Input] = {}
        for name in INPUTS:
            value = getattr(self.inputs, name)
            if value is not None:
                out[name] = value
        return out

    def tls_paths(self) -> dict[str, Path]:
        """The TLS files the profile names (``ca``, ``certificate``, ``key``), relative to its folder."""
        tls = self.transport.tls
        if tls is None:
            return {}
        named = {"ca": tls.ca, "certificate": tls.certificate, "key": tls.key}
        return {k: Path(self._base_dir or ".") / v for k, v in named.items() if v is not None}

    def calibration_path(self) -> Path | None:
        camera = self.inputs.camera
        if camera is None or camera.calibration is None:
            return None
        return Path(self._base_dir or ".") / camera.calibration


def status_companions(profile: Profile) -> dict[str, Binding]:
    """With a status topic, what is published beside its JSON: the machine's status as ROS's
    ``diagnostic_msgs/DiagnosticArray`` on ``/diagnostics`` (where ``rqt_runtime_monitor`` looks) and the active
    path as a ``std_msgs/String`` on ``<status topic>/active``."""
    status = profile.outputs.status
    if status is None:
        return {}
    return {"diagnostics": Binding(topic="/diagnostics", type=DIAGNOSTICS, qos=status.qos),
            "active": Binding(topic="/" + status.topic.strip("/") + "/active", type=STRING, qos=status.qos)}


REMAP_PATTERN = r"^(__node|__ns|/?[A-Za-z_][A-Za-z0-9_/]*):=(/?[A-Za-z_][A-Za-z0-9_/]*)$"


def remapped(profile: Profile, remaps: list[str]) -> Profile:
    """The profile with its ``transport.remap`` and then ``remaps`` applied, as ROS 2's ``-r FROM:=TO``: a topic
    FROM (with or without the leading '/') of any binding becomes TO; ``__node:=NAME`` names rclpy's node,
    ``__ns:=/NS`` its namespace. A remapping of a topic no binding has is a :class:`ValueError` (a typo)."""
    topics: dict[str, str] = {}
    node, namespace = profile.transport.node, profile.transport.namespace
    for rule in [*profile.transport.remap, *remaps]:
        found = re.match(REMAP_PATTERN, rule)
        if found is None:
            raise ValueError(f"remapping {rule!r}: write FROM:=TO, e.g. /tral/cmd:=/car1/cmd, __node:=driver or "
                             "__ns:=/car1")
        src, dst = found.group(1), found.group(2)
        if src == "__node":
            node = dst.strip("/")
        elif src == "__ns":
            namespace = "/" + dst.strip("/")
        else:
            topics["/" + src.lstrip("/")] = "/" + dst.lstrip("/")
    bound: list[tuple[str, Any]] = [(f"inputs.{n}", b) for n, b in profile.inputs_bound().items()]
    bound += [("outputs.command", profile.outputs.command), ("clock", profile.clock)]
    if profile.outputs.status is not None:
        bound.append(("outputs.status", profile.outputs.status))
    known = {"/" + b.topic.lstrip("/") for _n, b in bound}
    unknown = sorted(set(topics) - known)
    if unknown:
        raise ValueError(f"remapping of {', '.join(unknown)}: no binding of the profile has that topic (its topics: "
                         f"{', '.join(sorted(known))})")

    def fix(b: Any) -> Any:
        to = topics.get("/" + b.topic.lstrip("/"))
        return b if to is None else b.model_copy(update={"topic": to})

    inputs = profile.inputs.model_copy(update={n: fix(b) for n, b in profile.inputs_bound().items()})
    outputs = profile.outputs.model_copy(update={"command": fix(profile.outputs.command)} | (
        {"status": fix(profile.outputs.status)} if profile.outputs.status is not None else {}))
    transport = profile.transport.model_copy(update={"node": node, "namespace": namespace})
    out = profile.model_copy(update={"inputs": inputs, "outputs": outputs, "clock": fix(profile.clock),
                                     "transport": transport})
    out._base_dir = profile._base_dir
    return out


def domain_of(profile: Profile) -> int:
    """The ROS domain: the profile's ``transport.domain``, else ``$ROS_DOMAIN_ID`` as ROS 2 reads it, else 0."""
    if profile.transport.domain is not None:
        return profile.transport.domain
    env = os.environ.get("ROS_DOMAIN_ID", "").strip()
    return int(env) if env.isdigit() and int(env) <= 232 else 0


# -- checking ------------------------------------------------------------------------------------------------
def bindings(data: dict[str, Any]) -> list[tuple[str, str, dict[str, Any]]]:
    """``(role, pointer, binding)`` of every topic the profile data binds, in file order."""
    out: list[tuple[str, str, dict[str, Any]]] = []
    for group in ("inputs", "outputs"):
        section = data.get(group)
        if isinstance(section, dict):
            for role, value in section.items():
                if isinstance(value, dict):
                    out.append((role, f"/{group}/{role}", value))
    clock = data.get("clock")
    if isinstance(clock, dict):
        out.append(("clock", "/clock", clock))
    return out


def meaning_problems(data: dict[str, Any], name: str) -> list[Problem]:
    """What the shape cannot say: message types that do not fit their binding, fields the type has not, a topic
    bound twice."""
    problems: list[Problem] = []
    seen: dict[str, str] = {}
    for role, ptr, binding in bindings(data):
        problems += _type_problems(role, ptr, binding, name)
        topic = binding.get("topic")
        if isinstance(topic, str) and re.match(TOPIC_PATTERN, topic):
            key = "/" + topic.lstrip("/")
            if key in seen:
                problems.append(Problem(f"topic '{topic}' is bound twice: already by {seen[key]}", name,
                                        f"{ptr}/topic", hint="each topic carries one input or output; rename one"))
            else:
                seen[key] = ptr
    return problems


def _type_problems(role: str, ptr: str, binding: dict[str, Any], name: str) -> list[Problem]:
    typ = binding.get("type")
    if not isinstance(typ, str) or role not in ROLE_TYPES:
        return []
    full = normalise_type(typ)
    allowed = ROLE_TYPES[role]
    if full not in KNOWN_TYPES:
        close = difflib.get_close_matches(full, sorted(KNOWN_TYPES), n=1)
        hint = f"did you mean '{close[0]}'?" if close else "known here: " + ", ".join(allowed)
        return [Problem(f"unknown message type '{typ}'", name, f"{ptr}/type", hint=hint)]
    if full not in allowed:
        return [Problem(f"'{role}' cannot be carried by {full}", name, f"{ptr}/type",
                        hint="use " + " or ".join(allowed))]
    field = binding.get("field")
    if isinstance(field, str):
        fields = KNOWN_TYPES[full]
        if field not in fields:
            has = ("its numeric field is " + ", ".join(fields)) if fields else "leave 'field' out for this type"
            return [Problem(f"{full} has no field '{field}' for '{role}'", name, f"{ptr}/field", hint=has)]
    return []


def _known_keys() -> list[str]:
    keys: set[str] = set()
    for model in (Profile, Transport, CarGeometry, Inputs, Outputs, Input, Camera, Command, Status, Qos, Safety):
        keys.update(f.alias or n for n, f in model.model_fields.items())
    return sorted(keys)


def _name_unknown_keys(problems: list[Problem]) -> None:
    """pydantic's words for a nested unknown key, as the project says it (with a "did you mean")."""
    for p in problems:
        if "Extra inputs are not permitted" in p.message:
            key = p.pointer.rsplit("/", 1)[-1]
            p.message = f"unknown key '{key}'"
            close = difflib.get_close_matches(key, _known_keys(), n=1)
            p.hint = f"did you mean '{close[0]}'?" if close else "see fsm/schema/ros_profile.schema.json"


def parse_profile(data: Any, name: str, locator: Any = None, base_dir: str | None = None) -> Profile:
    """A checked profile from parsed JSON; :class:`DiagramError` with every problem, located."""
    from fsm.loading.reading import place
    from fsm.model.document import Source, problems_from_validation

    problems: list[Problem] = []
    profile: Profile | None = None
    if not isinstance(data, dict):
        problems.append(Problem("an I/O profile must be a JSON object", name,
                                hint='start from {"inputs": {...}, "outputs": {"command": {...}}}'))
    else:
        try:
            profile = Profile.model_validate(data)
        except ValidationError as err:
            problems += problems_from_validation(err, source=Source(name=name), base="", element=None, model=Profile,
                                                 kind="key", data=data)
            _name_unknown_keys(problems)
        problems += meaning_problems(data, name)
    if problems:
        place(problems, locator)
        problems.sort(key=lambda p: (p.line or 0, p.column or 0))
        raise DiagramError(problems)
    assert profile is not None
    profile._base_dir = base_dir
    return profile


def load_profile(path: str | os.PathLike[str]) -> Profile:
    """Read and check a profile file (the project's reading rule: regular files, size cap, strict JSON)."""
    from fsm.loading.reading import parse_json_bytes, read_file_bytes

    p = Path(path)
    raw = read_file_bytes(p, "I/O profile")
    if not raw.strip():
        raise DiagramError([Problem("file is empty; an I/O profile is a JSON object", str(path), line=1, column=1)])
    repeated: list[Problem] = []
    data, source = parse_json_bytes(raw, str(path), p.parent, duplicates=repeated)
    try:
        profile = parse_profile(data, str(path), source.locator, base_dir=str(p.parent))
    except DiagramError as exc:
        raise DiagramError(sorted(repeated + exc.problems, key=lambda q: (q.line or 0, q.column or 0))) from None
    if repeated:
        raise DiagramError(repeated)
    return profile


def check_camera(profile: Profile) -> None:
    """Load the camera's calibration file now, so a bad one is a located error before anything starts."""
    path = profile.calibration_path()
    if path is not None:
        from fsm.vision.calibration import load_calibration

        load_calibration(path)


def steering_angle(profile: Profile, steering: float) -> float:
    """The wheel angle (rad) of a normalised steering command."""
    return steering * math.radians(profile.car.max_steering_angle)


# -- the default profile and the schema ---------------------------------------------------------------------------
DEFAULT_PROFILE_PATH = Path(__file__).resolve().parent / "tral.profile.json"
PROFILE_SCHEMA_PATH = Path(__file__).resolve().parent.parent / "schema" / "ros_profile.schema.json"


def profile_schema() -> dict[str, Any]:
    """The JSON Schema of profiles (committed as ``fsm/schema/ros_profile.schema.json``)."""
    from fsm.model.document import file_schema

    schema = file_schema(Profile, "ros_profile.schema.json", "tral-fsm ROS 2 I/O profile",
                         "Binds the car interface to ROS 2 topics; generated from fsm.ros.profile by "
                         "`python -m fsm.ros.profile --schema`.")
    return schema


def profile_schema_text() -> str:
    import json

    return json.dumps(profile_schema(), indent=2, ensure_ascii=False) + "\n"


if __name__ == "__main__":  # pragma: no cover - the maintainers' command
    import sys

    if sys.argv[1:2] == ["--schema"]:
        out = sys.argv[2] if len(sys.argv) > 2 else None
        if out:
            Path(out).write_text(profile_schema_text(), encoding="utf-8")
        else:
            sys.stdout.write(profile_schema_text())
