"""The transport of ROS 2 topics: :class:`Bus` is what the driver and the simulated robot need of one; :class:`Link`
is Zenoh's, :class:`fsm.ros.rclpy_link.RclpyLink` rclpy's; :func:`open_bus` picks one (``transport.via``).

Zenoh for ROS 2 topics: one session (peer mode on explicit endpoints, or a client of a router), topic keys named
as rmw_zenoh or zenoh-bridge-ros2dds name them, messages as CDR bytes.

rmw_zenoh keys are ``<domain>/<topic>/<pkg>::msg::dds_::<Type>_/<RIHS01 hash>`` and each sample carries an
attachment (sequence number, source timestamp in ns, a 16-byte publisher id); subscriptions here match any hash,
so a robot of another distribution still talks. The bridge names a topic by its name alone.
"""

from __future__ import annotations

import json
import os
import re
import struct
import threading
import time
from collections.abc import Callable
from typing import Any, Protocol

from fsm.model.errors import FsmError
from fsm.ros.profile import Binding, Profile, domain_of, normalise_type

#: Who is waited for, in messages, by default.
ROBOT = "the robot (rmw_zenoh, the Zenoh bridge, or `fsmctl sim --ros`)"
#: How often an endpoint that did not answer is tried again (ms).
RETRY = {"period_init_ms": 100, "period_max_ms": 500, "period_increase_factor": 1.5}
#: How long closing a session may take, s. Zenoh's close waits for a connection attempt still in its handshake (up
#: to 10 s against a peer that accepted the TCP connection and never answered): the run does not wait for that.
CLOSE_WAIT = 1.0


class TopicPublisher(Protocol):
    """One topic's publisher on any transport."""

    def matched(self) -> bool:
        """True once a subscriber of the topic is known."""
        ...

    def put(self, payload: bytes) -> None:
        """Publish one message (CDR bytes)."""
        ...


class Bus(Protocol):
    """What :class:`~fsm.ros.driver.RosDriver` and :class:`~fsm.ros.robot.SimRobot` need of a transport: topics
    by :class:`~fsm.ros.profile.Binding`, messages as CDR bytes (the encoding of ROS 2 on every RMW)."""

    profile: Profile

    def describe(self) -> str:
        """Where the robot is looked for, in words, for messages."""
        ...

    def open(self) -> Bus: ...

    def close(self) -> None: ...

    def wait_for_peer(self, timeout: float, what: str = ROBOT, stop: Callable[[], bool] | None = None) -> None:
        """Return once another participant is there, or as soon as ``stop()`` holds (Ctrl-C); :class:`PeerTimeout`
        naming where it was looked for."""
        ...

    def publisher(self, binding: Binding) -> TopicPublisher: ...

    def subscribe(self, binding: Binding, callback: Callable[[bytes], None]) -> None:
        """Call ``callback(cdr_bytes)`` (on the transport's thread) for each message of the topic."""
        ...


def rclpy_available() -> bool:
    """rclpy can be imported (ROS 2 is installed and sourced)."""
    import importlib.util

    try:
        return importlib.util.find_spec("rclpy") is not None
    except (ImportError, ValueError):
        return False


def resolve_via(profile: Profile, via: str | None = None, endpoints: bool = False) -> str:
    """``zenoh`` or ``rclpy``: ``via`` (the command line) or the profile's ``transport.via``; ``auto`` is Zenoh
    when Zenoh endpoints were named on the command line (``endpoints``: they mean nothing to rclpy), else rclpy
    when it can be imported, else Zenoh."""
    chosen = via or profile.transport.via
    if chosen == "auto":
        return "rclpy" if rclpy_available() and not endpoints else "zenoh"
    return chosen


def open_bus(profile: Profile, *, connect: list[str] | None = None, listen: list[str] | None = None,
             via: str | None = None, node: str = "fsmctl", sim_time: bool = False) -> Bus:
    """A transport for ``profile``, not yet open (see :func:`resolve_via`); rclpy takes no endpoints (its RMW
    finds the robot: ``ROS_DOMAIN_ID``, ``RMW_IMPLEMENTATION``), so naming some with it is an error. ``node``
    begins rclpy's node name (``<node>_<profile name>``) unless the profile names it; ``sim_time``: rclpy's node
    runs with ``use_sim_time`` (lock-step: the simulator's /clock is ROS time); a Zenoh link then keeps the
    order of the messages of all topics (:meth:`Link.subscribe`)."""
    if resolve_via(profile, via, endpoints=bool(connect or listen)) == "rclpy":
        if connect or listen:
            raise TransportError("--connect/--listen are Zenoh endpoints; with rclpy the RMW finds the robot "
                                 "(ROS_DOMAIN_ID, RMW_IMPLEMENTATION): leave them out, or use --via zenoh")
        from fsm.ros.rclpy_link import RclpyLink

        return RclpyLink(profile, node, sim_time=sim_time)
    return Link(profile, connect=connect, listen=listen, node=node, ordered=sim_time)


#: Where Zenoh's password is read from (never from a file the profile names: profiles are shared).
PASSWORD_ENV = "FSM_ZENOH_PASSWORD"


def free_endpoint(host: str = "127.0.0.1", profile: Profile | None = None) -> str:
    """``tcp/HOST:PORT`` (``tls/`` when the profile configures TLS) on a port the system has free now (never
    rmw_zenoh's 7447 unless it was asked for)."""
    import socket

    protocol = "tls" if profile is not None and profile.transport.tls is not None else "tcp"
    with socket.socket() as s:
        s.bind((host, 0))
        return f"{protocol}/{host}:{s.getsockname()[1]}"


class PeerTimeout(FsmError):
    """No robot (or simulator) answered on the profile's endpoints in time."""


class TransportError(FsmError):
    """The Zenoh session could not be opened (an endpoint in use, a malformed endpoint)."""


def dds_type(type_name: str) -> str:
    """``sensor_msgs/msg/Range`` as rmw_zenoh writes it in keys: ``sensor_msgs::msg::dds_::Range_``."""
    pkg, _msg, name = normalise_type(type_name).split("/")
    return f"{pkg}::msg::dds_::{name}_"


def topic_key(profile: Profile, binding: Binding, subscriber: bool = False) -> str:
    """The Zenoh key of a topic (a subscriber's matches every type hash)."""
    topic = binding.topic.strip("/")
    if profile.transport.keys == "bridge":
        return topic
    if subscriber:
        digest = "*"
    else:
        from fsm.ros.messages import type_hash

        digest = type_hash(binding.type)
    return f"{domain_of(profile)}/{topic}/{dds_type(binding.type)}/{digest}"


# -- rmw_zenoh's liveliness tokens ----------------------------------------------------------------------------------
# So that nodes on rmw_zenoh see the bridge in `ros2 node list` / `ros2 topic list`, the session declares the tokens
# rmw_zenoh declares for a node, its publishers and its subscriptions. Format as in ros2/rmw_zenoh at commit bfc065f
# (Oct 2024, rmw_zenoh_cpp 0.0.1, the code the Jazzy release grew from): docs/design.md ("Graph Cache") and
# rmw_zenoh_cpp/src/detail/liveliness_utils.cpp (Entity::Entity, qos_to_keyexpr, zid_to_str, mangle_name):
#   @ros2_lv/<domain>/<zid>/<nid>/<id>/<NN|MP|MS>/<enclave>/<namespace>/<node>[/<topic>/<type>/<hash>/<qos>]
# with '/' inside a part written '%' (an empty namespace, '/', is '%'), <zid> the session id's 16 bytes from the
# most significant, each in hex without padding, and <qos> "rel:dur:hist,depth:deadline s,ns:lifespan s,ns:
# liveliness,lease s,ns", a part left empty where it is rmw_zenoh's default (reliable, transient local, keep last 42,
# infinite durations, automatic liveliness).
ADMIN_SPACE = "@ros2_lv"
#: rmw's enum values: RMW_QOS_POLICY_RELIABILITY_BEST_EFFORT, RMW_QOS_POLICY_DURABILITY_VOLATILE.
RMW_BEST_EFFORT, RMW_VOLATILE, RMW_ZENOH_DEFAULT_DEPTH = 2, 2, 42


def node_name(profile: Profile, node: str = "fsmctl") -> str:
    """The node's name on either transport: the profile's ``transport.node``, else ``<node>_<profile name>``."""
    return profile.transport.node or re.sub(r"[^A-Za-z0-9_]", "_", f"{node}_{profile.name}")


def mangle(name: str) -> str:
    return name.replace("/", "%")


def zid_text(zid: Any) -> str:
    """A Zenoh session id as rmw_zenoh writes it (``zid_to_str``)."""
    value = int(str(zid), 16)
    return "".join(f"{b:x}" for b in value.to_bytes(16, "big"))


def qos_text(binding: Binding) -> str:
    """``qos_to_keyexpr`` of rmw_zenoh for a binding's QoS (volatile, keep last ``depth``)."""
    reliability = str(RMW_BEST_EFFORT) if binding.qos.reliability == "best_effort" else ""
    depth = "" if binding.qos.depth == RMW_ZENOH_DEFAULT_DEPTH else str(binding.qos.depth)
    return f"{reliability}:{RMW_VOLATILE}:,{depth}:,:,:,,"


def liveliness_key(profile: Profile, zid: Any, node: str, entity: int, kind: str,
                   binding: Binding | None = None) -> str:
    """The liveliness token of the node (``NN``, entity 0) or of one of its publishers (``MP``) or subscriptions
    (``MS``)."""
    namespace = profile.transport.namespace or "/"
    parts = [ADMIN_SPACE, str(domain_of(profile)), zid_text(zid), "0", str(entity), kind, mangle("/"),
             mangle(namespace), node]
    if binding is not None:
        from fsm.ros.messages import type_hash

        parts += [mangle("/" + binding.topic.lstrip("/")), dds_type(binding.type), type_hash(binding.type),
                  qos_text(binding)]
    return "/".join(parts)


class Publisher:
    """Publishes one topic's messages (already encoded CDR bytes) with its QoS."""

    def __init__(self, link: Link, binding: Binding) -> None:
        import zenoh

        qos = binding.qos
        self.link = link
        self.key = topic_key(link.profile, binding)
        self._rmw = link.profile.transport.keys == "rmw_zenoh"
        self._seq = 0
        self._gid = os.urandom(16)
        priority = {"real_time": zenoh.Priority.REAL_TIME, "interactive_high": zenoh.Priority.INTERACTIVE_HIGH,
                    "data": zenoh.Priority.DATA, "background": zenoh.Priority.BACKGROUND}[qos.priority]
        congestion = zenoh.CongestionControl.BLOCK if qos.reliability == "reliable" else zenoh.CongestionControl.DROP
        self._pub = link.session.declare_publisher(self.key, congestion_control=congestion, priority=priority,
                                                   express=qos.express)

    def matched(self) -> bool:
        """True once a subscriber of the topic is known to this session."""
        return bool(self._pub.matching_status.matching)

    def put(self, payload: bytes) -> None:
        if self._rmw:
            self._seq += 1
            attachment = struct.pack("<qq", self._seq, time.time_ns()) + self._gid
            self._pub.put(payload, attachment=attachment)
        else:
            self._pub.put(payload)


class Link:
    """A Zenoh session for a profile; ``connect`` / ``listen`` replace the profile's endpoints (``--connect``)."""

    def __init__(self, profile: Profile, *, connect: list[str] | None = None, listen: list[str] | None = None,
                 node: str = "fsmctl", ordered: bool = False) -> None:
        self.profile = profile
        #: every rmw_zenoh topic through one subscriber, in the order sent (lock-step; see :meth:`subscribe`)
        self.ordered = ordered
        #: the node name of the liveliness tokens (as rclpy's would be)
        self.node_name = node_name(profile, node)
        self._tokens: list[Any] = []
        t = profile.transport
        self.connect = list(t.connect if connect is None else connect)
        self.listen = list(t.listen if listen is None else listen)
        self.session: Any = None
        self._subscribers: list[Any] = []
        self._lock = threading.Lock()
        self._dictionary: str | None = None
        #: rmw_zenoh keys: the callback of each topic's key (without its type hash), behind one subscriber
        self._routes: dict[str, Callable[[bytes], None]] = {}
        self._routed: bool | None = None

    def describe(self) -> str:
        """The endpoints in words, for messages."""
        parts = []
        if self.connect:
            parts.append("connecting to " + ", ".join(self.connect))
        if self.listen:
            parts.append("listening on " + ", ".join(self.listen))
        return " and ".join(parts) or "with no endpoint (multicast scouting only)"

    def config(self) -> Any:
        import zenoh

        t = self.profile.transport
        conf = zenoh.Config()
        conf.insert_json5("mode", json.dumps(t.mode))
        conf.insert_json5("scouting/multicast/enabled", json.dumps(t.multicast))
        conf.insert_json5("connect/endpoints", json.dumps(self.connect))
        conf.insert_json5("listen/endpoints", json.dumps(self.listen))
        # a robot that comes up after us is found within a fraction of a second (Zenoh's default waits seconds)
        conf.insert_json5("connect/retry", json.dumps(RETRY))
        if t.user is not None:
            self._auth(conf, t.user)
        if t.tls is not None:
            self._tls(conf)
        return conf

    def _tls(self, conf: Any) -> None:
        """Zenoh's TLS (``transport/link/tls``, keys as zenoh 1.x names them; see the profile's ``transport.tls``):
        the CA that signs the peers' certificates, this side's certificate and key for listening and (mutual TLS)
        connecting; only TLS links are accepted, so a peer cannot fall back to plain TCP."""
        tls = self.profile.transport.tls
        assert tls is not None
        paths = self.profile.tls_paths()
        for what, path in paths.items():
            if not path.is_file():
                raise TransportError(f"the profile's transport.tls.{what} {path}: no such file")
        plain = [e for e in self.connect + self.listen if not e.startswith("tls/")]
        if plain:
            raise TransportError(f"the profile configures TLS (transport.tls), but {', '.join(plain)} is not a TLS "
                                 "endpoint: write tls/HOST:PORT")
        if self.listen and "certificate" not in paths:
            raise TransportError("listening on TLS needs this side's certificate and key: transport.tls.certificate "
                                 "and transport.tls.key")
        settings: dict[str, Any] = {"root_ca_certificate": str(paths["ca"]), "enable_mtls": tls.mutual,
                                    "verify_name_on_connect": tls.verify_name}
        if "certificate" in paths:
            settings |= {"listen_certificate": str(paths["certificate"]), "listen_private_key": str(paths["key"]),
                         "connect_certificate": str(paths["certificate"]), "connect_private_key": str(paths["key"])}
        conf.insert_json5("transport/link/tls", json.dumps(settings))
        conf.insert_json5("transport/link/protocols", json.dumps(["tls"]))

    def _auth(self, conf: Any, user: str) -> None:
        """Zenoh's user/password authentication (both ways: the user and password this side shows, and the
        dictionary it checks a peer's against, a file of its own readable by this user only, removed at close)."""
        import tempfile

        password = os.environ.get(PASSWORD_ENV)
        if not password:
            raise TransportError(f"the profile's transport.user is {user!r}: set its password in the environment "
                                 f"variable {PASSWORD_ENV}")
        fd, self._dictionary = tempfile.mkstemp(prefix="fsm-zenoh-", suffix=".txt")
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(f"{user}:{password}\n")
        conf.insert_json5("transport/auth/usrpwd/user", json.dumps(user))
        conf.insert_json5("transport/auth/usrpwd/password", json.dumps(password))
        conf.insert_json5("transport/auth/usrpwd/dictionary_file", json.dumps(self._dictionary))

    def open(self) -> Link:
        import zenoh

        try:
            self.session = zenoh.open(self.config())
        except TransportError:
            self._forget_dictionary()
            raise
        except Exception as exc:  # zenoh.ZError: a port in use, an endpoint it cannot parse
            self._forget_dictionary()
            raise TransportError(f"cannot open the Zenoh session {self.describe()}: {exc}") from None
        self._declare_token("NN")
        return self

    def _declare_token(self, kind: str, binding: Binding | None = None) -> None:
        """rmw_zenoh's liveliness token of the node or of an entity (see :func:`liveliness_key`)."""
        if self.profile.transport.keys != "rmw_zenoh":
            return
        key = liveliness_key(self.profile, self.session.zid(), self.node_name, len(self._tokens), kind, binding)
        self._tokens.append(self.session.liveliness().declare_token(key))

    def _forget_dictionary(self) -> None:
        path, self._dictionary = self._dictionary, None
        if path is not None:
            try:
                os.unlink(path)
            except OSError:
                pass

    def peers(self) -> int:
        info = self.session.info
        return len(info.peers_zid()) + len(info.routers_zid())

    def wait_for_peer(self, timeout: float, what: str = ROBOT, stop: Callable[[], bool] | None = None) -> None:
        """Return once another Zenoh session is connected, or as soon as ``stop()`` holds; :class:`PeerTimeout`
        naming the endpoints after ``timeout`` seconds."""
        end = time.monotonic() + timeout
        while self.peers() == 0:
            if stop is not None and stop():
                return
            if time.monotonic() >= end:
                raise PeerTimeout(f"no peer reached within {timeout:g} s {self.describe()}: is {what} running "
                                  "there?")
            time.sleep(0.02)

    def publisher(self, binding: Binding) -> Publisher:
        publisher = Publisher(self, binding)
        self._declare_token("MP", binding)
        return publisher

    def subscribe(self, binding: Binding, callback: Callable[[bytes], None]) -> None:
        """Call ``callback(cdr_bytes)`` (on a Zenoh thread) for each message of the topic.

        ``ordered`` (lock-step) with rmw_zenoh's keys: every topic comes through one Zenoh subscriber on the
        domain, routed by key; one subscriber's callbacks run one at a time in the order the messages came, so a
        tick's sensors are taken before the clock the simulator sends after them (one subscriber per topic calls
        back on Zenoh's threads in any order, and lock-step would now and then latch the tick before's)."""
        self._declare_token("MS", binding)
        if self.profile.transport.keys != "rmw_zenoh" or not self.ordered:
            key = topic_key(self.profile, binding, subscriber=True)

            def handler(sample: Any) -> None:
                callback(sample.payload.to_bytes())

            self._subscribers.append(self.session.declare_subscriber(key, handler))
            return
        prefix = topic_key(self.profile, binding, subscriber=True).rsplit("/", 1)[0]
        with self._lock:
            self._routes[prefix] = callback
            first = self._routed is None
            if first:
                self._routed = True
        if first:
            routes = self._routes

            def route(sample: Any) -> None:
                target = routes.get(str(sample.key_expr).rsplit("/", 1)[0])
                if target is not None:
                    target(sample.payload.to_bytes())

            self._subscribers.append(self.session.declare_subscriber(f"{domain_of(self.profile)}/**", route))

    def close(self) -> None:
        self._forget_dictionary()
        with self._lock:
            session, self.session = self.session, None
        if session is not None:
            for sub in [*self._subscribers, *self._tokens]:
                try:
                    sub.undeclare()
                except Exception:  # closing anyway
                    pass
            self._subscribers.clear()
            self._tokens.clear()
            # in a thread of its own, waited for at most CLOSE_WAIT: the sockets go with the process otherwise
            closing = threading.Thread(target=session.close, name="zenoh-close", daemon=True)
            closing.start()
            closing.join(CLOSE_WAIT)

    def __enter__(self) -> Link:
        return self.open() if self.session is None else self

    def __exit__(self, *exc: object) -> None:
        self.close()
