"""rclpy as the transport (:class:`fsm.ros.transport.Bus`), where ROS 2 is installed and sourced.

One node (``fsmctl_<profile name>``) spun by a single-threaded executor on a thread of its own; publishers and
subscriptions carry serialised messages (CDR bytes, ``raw=True``), so the rest of :mod:`fsm.ros` is the same on
rclpy as on Zenoh. The message classes come from the installed packages (``rosidl_runtime_py``): a profile whose
types are not installed (``ackermann_msgs`` often is not) is one message saying which package to install.

Not tested on this project's machines (rclpy is not on the package index): the tests check how the transport is
chosen and that this module needs nothing at import time; docs/ros.md says so.
"""

from __future__ import annotations

import importlib
import threading
import time
from collections.abc import Callable
from typing import Any

from fsm.ros.profile import Binding, Profile, normalise_type
from fsm.ros.transport import ROBOT, PeerTimeout, TransportError


def _module(name: str) -> Any:
    return importlib.import_module(name)


def qos_of(binding: Binding) -> Any:
    """The rclpy QoS profile of a binding (reliability, volatile durability, keep-last depth)."""
    qos = _module("rclpy.qos")
    reliability = (qos.ReliabilityPolicy.RELIABLE if binding.qos.reliability == "reliable"
                   else qos.ReliabilityPolicy.BEST_EFFORT)
    return qos.QoSProfile(depth=binding.qos.depth, reliability=reliability,
                          durability=qos.DurabilityPolicy.VOLATILE, history=qos.HistoryPolicy.KEEP_LAST)


class RclpyPublisher:
    """One topic's rclpy publisher, publishing serialised messages."""

    def __init__(self, pub: Any) -> None:
        self._pub = pub

    def matched(self) -> bool:
        return bool(self._pub.get_subscription_count() > 0)

    def put(self, payload: bytes) -> None:
        self._pub.publish(payload)  # rclpy publishes bytes as an already serialised message


class RclpyLink:
    """The :class:`~fsm.ros.transport.Bus` of a profile over rclpy (see the module's docstring)."""

    def __init__(self, profile: Profile) -> None:
        self.profile = profile
        self.node: Any = None
        self._context: Any = None
        self._executor: Any = None
        self._thread: threading.Thread | None = None
        self._subscriptions: list[Any] = []

    def describe(self) -> str:
        import os

        rmw = os.environ.get("RMW_IMPLEMENTATION", "the default RMW")
        return f"through rclpy ({rmw}, ROS domain {self.profile.transport.domain})"

    def message_class(self, type_name: str) -> Any:
        full = normalise_type(type_name)
        try:
            return _module("rosidl_runtime_py.utilities").get_message(full)
        except (ImportError, AttributeError, ValueError) as exc:
            package = full.split("/")[0]
            raise TransportError(f"rclpy cannot load {full} ({exc}): install its package (e.g. "
                                 f"ros-$ROS_DISTRO-{package.replace('_', '-')}) or use --via zenoh") from None

    def open(self) -> RclpyLink:
        try:
            rclpy = _module("rclpy")
            executors = _module("rclpy.executors")
        except ImportError as exc:
            raise TransportError(f"rclpy cannot be imported ({exc}): source ROS 2's setup.bash first, or use "
                                 "Zenoh (--via zenoh, or \"via\": \"zenoh\" in the profile's transport)") from None
        try:
            self._context = rclpy.Context()
            self._init(rclpy)
            self.node = rclpy.create_node(f"fsmctl_{self.profile.name}".replace("-", "_"), context=self._context)
        except Exception as exc:  # an RMW that does not load, a bad domain
            raise TransportError(f"cannot start rclpy {self.describe()}: {exc}") from None
        self._executor = executors.SingleThreadedExecutor(context=self._context)
        self._executor.add_node(self.node)
        self._thread = threading.Thread(target=self._spin, name="rclpy", daemon=True)
        self._thread.start()
        return self

    def _init(self, rclpy: Any) -> None:
        """rclpy.init without rclpy's own signal handlers: Ctrl-C stays the command's (stop command first, outputs
        written, exit 130). Older rclpy (before Humble) has no option for it: its handlers are replaced by the ones
        that were there."""
        import signal

        before = {num: signal.getsignal(num) for num in (signal.SIGINT, signal.SIGTERM)}
        domain = self.profile.transport.domain
        try:
            options = _module("rclpy.signals").SignalHandlerOptions.NO
            rclpy.init(context=self._context, domain_id=domain, signal_handler_options=options)
        except (ImportError, AttributeError, TypeError):
            rclpy.init(context=self._context, domain_id=domain)
            if threading.current_thread() is threading.main_thread():
                for num, handler in before.items():
                    if handler is not None and signal.getsignal(num) is not handler:
                        signal.signal(num, handler)

    def _spin(self) -> None:
        try:
            self._executor.spin()
        except Exception:  # the context was shut down while spinning
            pass

    def wait_for_peer(self, timeout: float, what: str = ROBOT, stop: Callable[[], bool] | None = None) -> None:
        end = time.monotonic() + timeout
        own = self.node.get_name()
        while not [n for n, _ns in self.node.get_node_names_and_namespaces() if n != own]:
            if stop is not None and stop():
                return
            if time.monotonic() >= end:
                raise PeerTimeout(f"no other ROS 2 node seen within {timeout:g} s {self.describe()}: is {what} "
                                  "running in this ROS domain?")
            time.sleep(0.02)

    def publisher(self, binding: Binding) -> RclpyPublisher:
        pub = self.node.create_publisher(self.message_class(binding.type), binding.topic, qos_of(binding))
        return RclpyPublisher(pub)

    def subscribe(self, binding: Binding, callback: Callable[[bytes], None]) -> None:
        sub = self.node.create_subscription(self.message_class(binding.type), binding.topic,
                                            lambda raw: callback(bytes(raw)), qos_of(binding), raw=True)
        self._subscriptions.append(sub)

    def close(self) -> None:
        executor, self._executor = self._executor, None
        if executor is not None:
            executor.shutdown()
        if self.node is not None:
            self.node.destroy_node()
            self.node = None
        context, self._context = self._context, None
        if context is not None and context.ok():
            context.shutdown()
        if self._thread is not None:
            self._thread.join(timeout=2)
            self._thread = None

    def __enter__(self) -> RclpyLink:
        return self.open() if self.node is None else self

    def __exit__(self, *exc: object) -> None:
        self.close()
