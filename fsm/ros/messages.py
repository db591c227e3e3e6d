"""ROS 2 messages without ROS: rosbags' typestores, ackermann_msgs registered from its message text, CDR bytes.

Messages are written in Jazzy's layout. They are read in any distribution's (:data:`LAYOUTS`: Jazzy, Humble, Kilted;
a Humble ``sensor_msgs/Range`` has no ``variance``): in the layout the sender's type hash names where it is known (a
bag's connection), else in each layout that differs, in that order, until one reads the whole message.

The functions here turn the car interface's values into messages and back; they are the only place that knows
field names, units and conventions (REP 103: x forward, y left, yaw counter-clockwise; steering positive = left).
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import Any

from fsm.ros.profile import (
    ACKERMANN,
    ACKERMANN_PLAIN,
    CLOCK,
    COMPRESSED,
    IMAGE,
    ODOMETRY,
    RANGE,
    STRING,
    TWIST,
    TWIST_STAMPED,
    normalise_type,
)

#: ackermann_msgs is not in rosbags' typestores: its two messages, as the package defines them.
ACKERMANN_DRIVE_MSG = """
float32 steering_angle
float32 steering_angle_velocity
float32 speed
float32 acceleration
float32 jerk
"""
ACKERMANN_STAMPED_MSG = """
std_msgs/Header header
ackermann_msgs/AckermannDrive drive
"""


class DecodeError(ValueError):
    """A message's bytes are not a message of the expected type."""


#: The distributions whose message layouts are read, in the order they are tried (the first is the one written).
LAYOUTS = ("jazzy", "humble", "kilted")


@lru_cache(maxsize=None)
def typestore(layout: str = "jazzy") -> Any:
    """rosbags' typestore of a distribution (:data:`LAYOUTS`) with ackermann_msgs registered (built once)."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(getattr(Stores, f"ROS2_{layout.upper()}"))
    types: dict[str, Any] = {}
    types.update(get_types_from_msg(ACKERMANN_DRIVE_MSG, ACKERMANN_PLAIN))
    types.update(get_types_from_msg(ACKERMANN_STAMPED_MSG, ACKERMANN))
    store.register(types)
    return store


@lru_cache(maxsize=None)
def layouts_of(type_name: str) -> tuple[str, ...]:
    """The layouts of ``type_name`` that differ, in :data:`LAYOUTS` order (one per distinct type hash)."""
    out: list[str] = []
    seen: set[str] = set()
    for layout in LAYOUTS:
        digest = str(typestore(layout).hash_rihs01(type_name))
        if digest not in seen:
            seen.add(digest)
            out.append(layout)
    return tuple(out)


@lru_cache(maxsize=None)
def layout_of_hash(type_name: str, digest: str) -> str | None:
    """The layout whose RIHS01 hash of ``type_name`` is ``digest`` (a bag's or a peer's), or None."""
    full = normalise_type(type_name)
    for layout in LAYOUTS:
        if str(typestore(layout).hash_rihs01(full)) == digest:
            return layout
    return None


def message_class(type_name: str) -> Any:
    return typestore().types[normalise_type(type_name)]


def encode(message: Any) -> bytes:
    """A message's CDR bytes (little endian, with the encapsulation header), as ROS 2 sends them."""
    return bytes(typestore().serialize_cdr(message, message.__msgtype__))


def decode(raw: bytes, type_name: str, layout: str | None = None) -> Any:
    """A message of ``type_name`` from CDR bytes, in ``layout`` first if given, else in each layout in turn;
    :class:`DecodeError` (naming the layouts tried) when they are none."""
    return decode_layout(raw, type_name, layout)[0]


def decode_layout(raw: bytes, type_name: str, layout: str | None = None) -> tuple[Any, str]:
    """:func:`decode`, and the layout that read it (to try first next time)."""
    full = normalise_type(type_name)
    order = layouts_of(full)
    if layout is not None and layout in order:
        order = (layout, *(x for x in order if x != layout))
    first: Exception | None = None
    for candidate in order:
        try:
            return typestore(candidate).deserialize_cdr(raw, full), candidate
        except Exception as exc:  # rosbags raises several kinds (SerdeError, struct.error, IndexError, ...)
            first = first or exc
    tried = f" (in the layouts of {', '.join(order)})" if len(order) > 1 else ""
    raise DecodeError(f"{full}: {first}{tried}") from None


def type_hash(type_name: str) -> str:
    """The type's RIHS01 hash (rmw_zenoh's topic keys carry it)."""
    return str(typestore().hash_rihs01(normalise_type(type_name)))


# -- building blocks ------------------------------------------------------------------------------------------
def stamp(seconds: float) -> Any:
    store = typestore()
    ns = max(0, round(seconds * 1e9))
    return store.types["builtin_interfaces/msg/Time"](sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def stamp_seconds(message: Any) -> float:
    s = message.header.stamp
    return float(s.sec) + float(s.nanosec) * 1e-9


def header(seconds: float, frame: str) -> Any:
    return typestore().types["std_msgs/msg/Header"](stamp=stamp(seconds), frame_id=frame)


def quaternion_yaw(q: Any) -> float:
    """The yaw (rad) of a quaternion (rotation about z)."""
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


# -- sensors --------------------------------------------------------------------------------------------------
def range_message(seconds: float, frame: str, value: float, max_range: float, min_range: float = 0.02,
                  field_of_view: float = 0.26) -> Any:
    cls = message_class(RANGE)
    return cls(header=header(seconds, frame), radiation_type=0, field_of_view=field_of_view, min_range=min_range,
               max_range=max_range, range=value, variance=0.0)


def odometry_message(seconds: float, x: float, y: float, yaw: float, speed: float, yaw_rate: float) -> Any:
    store = typestore()
    t = store.types
    pose = t["geometry_msgs/msg/Pose"](
        position=t["geometry_msgs/msg/Point"](x=x, y=y, z=0.0),
        orientation=t["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2)))
    twist = t["geometry_msgs/msg/Twist"](linear=t["geometry_msgs/msg/Vector3"](x=speed, y=0.0, z=0.0),
                                         angular=t["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=yaw_rate))
    import numpy as np

    cov = np.zeros(36, dtype=np.float64)
    return t[ODOMETRY](header=header(seconds, "odom"), child_frame_id="base_link",
                       pose=t["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=cov),
                       twist=t["geometry_msgs/msg/TwistWithCovariance"](twist=twist, covariance=cov.copy()))


def counter_message(type_name: str, value: int) -> Any:
    return message_class(type_name)(data=value)


def clock_message(seconds: float) -> Any:
    return message_class(CLOCK)(clock=stamp(seconds))


def compressed_image_message(seconds: float, jpeg: bytes) -> Any:
    import numpy as np

    return message_class(COMPRESSED)(header=header(seconds, "camera"), format="jpeg",
                                     data=np.frombuffer(jpeg, dtype=np.uint8))


def image_message(seconds: float, pixels: Any) -> Any:
    """A ``sensor_msgs/Image`` of a grey (``mono8``, height x width) or BGR (``bgr8``, height x width x 3) frame."""
    import numpy as np

    h, w = pixels.shape[:2]
    channels = 1 if pixels.ndim == 2 else int(pixels.shape[2])
    encoding = {1: "mono8", 3: "bgr8"}[channels]
    return message_class(IMAGE)(header=header(seconds, "camera"), height=h, width=w, encoding=encoding,
                                is_bigendian=0, step=w * channels,
                                data=np.ascontiguousarray(pixels, dtype=np.uint8).reshape(-1))


def image_pixels(message: Any) -> Any:
    """A BGR (or grey) numpy image from an Image or CompressedImage message; :class:`DecodeError` if unreadable."""
    import numpy as np

    data = np.asarray(message.data, dtype=np.uint8)
    if message.__msgtype__ == COMPRESSED:
        import cv2

        image = cv2.imdecode(data, cv2.IMREAD_COLOR)
        if image is None:
            raise DecodeError(f"{COMPRESSED}: the {message.format or 'image'} data cannot be decoded")
        return image
    channels = {"bgr8": 3, "rgb8": 3, "mono8": 1}.get(message.encoding)
    if channels is None:
        raise DecodeError(f"{IMAGE}: encoding '{message.encoding}' is not supported (bgr8, rgb8, mono8)")
    h, w = int(message.height), int(message.width)
    if data.size < h * w * channels or message.step < w * channels:
        raise DecodeError(f"{IMAGE}: {data.size} bytes for a {w}x{h} {message.encoding} image")
    rows = data[: h * message.step].reshape(h, message.step)[:, : w * channels]
    image = rows.reshape(h, w, channels) if channels == 3 else rows.reshape(h, w)
    return image[:, :, ::-1].copy() if message.encoding == "rgb8" else image


# -- commands -------------------------------------------------------------------------------------------------
def command_message(type_name: str, seconds: float, speed: float, angle: float, wheelbase: float) -> Any:
    """A drive command: ``speed`` (m/s) and the wheel ``angle`` (rad, left positive). Twist carries the yaw rate
    of the bicycle model (v tan(angle) / wheelbase) instead of the angle."""
    full = normalise_type(type_name)
    t = typestore().types
    if full in (ACKERMANN, ACKERMANN_PLAIN):
        drive = t[ACKERMANN_PLAIN](steering_angle=angle, steering_angle_velocity=0.0, speed=speed, acceleration=0.0,
                                   jerk=0.0)
        return drive if full == ACKERMANN_PLAIN else t[ACKERMANN](header=header(seconds, "base_link"), drive=drive)
    vec = t["geometry_msgs/msg/Vector3"]
    yaw_rate = speed * math.tan(angle) / wheelbase
    twist = t[TWIST](linear=vec(x=speed, y=0.0, z=0.0), angular=vec(x=0.0, y=0.0, z=yaw_rate))
    return twist if full == TWIST else t[TWIST_STAMPED](header=header(seconds, "base_link"), twist=twist)


def command_values(message: Any, wheelbase: float) -> tuple[float, float, float | None]:
    """``(speed, wheel angle, stamp or None)`` of a drive command. A Twist's yaw rate at speed 0 says nothing of
    the angle: 0 then."""
    full = message.__msgtype__
    if full == ACKERMANN:
        return float(message.drive.speed), float(message.drive.steering_angle), stamp_seconds(message)
    if full == ACKERMANN_PLAIN:
        return float(message.speed), float(message.steering_angle), None
    twist = message.twist if full == TWIST_STAMPED else message
    speed = float(twist.linear.x)
    angle = math.atan(float(twist.angular.z) * wheelbase / speed) if abs(speed) > 1e-6 else 0.0
    return speed, angle, stamp_seconds(message) if full == TWIST_STAMPED else None


def status_message(text: str) -> Any:
    return message_class(STRING)(data=text)


#: diagnostic_msgs/DiagnosticStatus levels.
OK, WARN, ERROR = 0, 1, 2


def diagnostics_message(seconds: float, name: str, level: int, text: str, values: dict[str, Any]) -> Any:
    """A ``diagnostic_msgs/DiagnosticArray`` of one status: ``level`` (:data:`OK`, :data:`WARN`, :data:`ERROR`),
    a message and key-value pairs (values as text)."""
    import json

    t = typestore().types
    kv = t["diagnostic_msgs/msg/KeyValue"]
    status = t["diagnostic_msgs/msg/DiagnosticStatus"](
        level=level, name=name, message=text, hardware_id=name,
        values=[kv(key=k, value=v if isinstance(v, str) else json.dumps(v)) for k, v in values.items()])
    return t["diagnostic_msgs/msg/DiagnosticArray"](header=header(seconds, ""), status=[status])


def stamp_of_clock(message: Any) -> float:
    """The time (s) a ``rosgraph_msgs/msg/Clock`` message carries."""
    c = message.clock
    return float(c.sec) + float(c.nanosec) * 1e-9
