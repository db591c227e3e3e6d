"""rclpy as the transport (:class:`fsm.ros.transport.Bus`): ROS 2 Jazzy's wheels from the package index
(``pip install 'tral-fsm[rclpy]'``), or a sourced ROS 2 installation.

One node (``fsmctl_<profile name>``) spun by rclpy's EventsExecutor (C++, :func:`make_executor`) on a thread of its
own, which calls ``spin_once`` in slices so that closing never waits inside its ``spin``; publishers and
subscriptions carry serialised messages (CDR bytes, ``raw=True``), so the rest of :mod:`fsm.ros` is the same on
rclpy as on Zenoh. The message classes are imported from their packages (``from sensor_msgs.msg import Range``;
``rosidl_runtime_py`` has no wheel); a type whose package is not installed is a located profile error before
anything starts (:func:`type_problems`), and ``ackermann_msgs``, which has no wheel, offers ``geometry_msgs/Twist``.

Tested against plain rclpy nodes over Fast DDS on localhost (tests/test_ros_rclpy.py).
"""

from __future__ import annotations

import contextlib
import importlib
import os
import re
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from typing import TYPE_CHECKING, Any

from fsm.model.errors import DiagramError, Problem
from fsm.ros.parameters import Tunable
from fsm.ros.profile import Binding, Profile, domain_of, normalise_type, status_companions
from fsm.ros.transport import ROBOT, PeerTimeout, TransportError, node_name

if TYPE_CHECKING:
    from fsm.ros.lifecycle import Managed

#: What to install for rclpy (the extra pins ROS 2 Jazzy's wheels).
RCLPY_HINT = "pip install 'tral-fsm[rclpy]' (ROS 2 Jazzy's wheels), or source a ROS 2 installation"
#: Message packages with no wheel on the package index, and what to use instead.
NO_WHEEL = {"ackermann_msgs": "geometry_msgs/msg/Twist (or TwistStamped), which the car must then obey"}


def _module(name: str) -> Any:
    return importlib.import_module(name)


def missing_package(type_name: str) -> str | None:
    """Why ``type_name``'s Python message package cannot be imported, or None when it can."""
    import importlib.util

    package = normalise_type(type_name).split("/")[0]
    try:
        found = importlib.util.find_spec(f"{package}.msg") is not None
    except (ImportError, ValueError):
        found = False
    if found:
        return None
    if package in NO_WHEEL:
        return f"{package} has no wheel on the package index and is not installed"
    return f"its package {package} is not installed (pip install ros-jazzy-{package.replace('_', '-')})"


def type_problems(profile: Profile, file: str) -> list[Problem]:
    """Every bound type rclpy cannot load, located in the profile ``file``: the package missing, and for
    ``ackermann_msgs`` (no wheel) the type to use instead."""
    problems: list[Problem] = []
    bound: list[tuple[str, Binding]] = [(f"/inputs/{name}", b) for name, b in profile.inputs_bound().items()]
    bound.append(("/outputs/command", profile.outputs.command))
    if profile.outputs.status is not None:
        bound.append(("/outputs/status", profile.outputs.status))
    bound.append(("/clock", profile.clock))
    bound += [("/outputs/status", b) for b in status_companions(profile).values()]
    for ptr, binding in bound:
        why = missing_package(binding.type)
        if why is not None:
            package = normalise_type(binding.type).split("/")[0]
            hint = (f"use {NO_WHEEL[package]}; or --via zenoh" if package in NO_WHEEL
                    else "install it, or use --via zenoh")
            problems.append(Problem(f"rclpy cannot load {normalise_type(binding.type)}: {why}", file, f"{ptr}/type",
                                    hint=hint))
    return problems


def check_types(profile: Profile, file: str) -> None:
    """:class:`DiagramError` with :func:`type_problems`, located by line and column, if there are any."""
    problems = type_problems(profile, file)
    if not problems:
        return
    from pathlib import Path

    from fsm.loading.reading import parse_json_bytes, place, read_file_bytes

    try:
        _data, source = parse_json_bytes(read_file_bytes(Path(file), "I/O profile"), file)
        place(problems, source.locator)
    except Exception:  # the file was read a moment ago; without it the pointers still say where
        pass
    raise DiagramError(problems)


def parameter_value(value: Any) -> Any:
    """A variable's value as a ROS 2 parameter can hold it: bool, int, float, str as they are (NaN, too); anything
    else (lists, objects, None) as its JSON text."""
    import json

    if isinstance(value, (bool, int, float, str)):
        return value
    return json.dumps(value, separators=(",", ":"))


def parameter_type(value: Any) -> int:
    """rcl_interfaces' ParameterType of a parameter's value (bool, int, float, str)."""
    types = _module("rcl_interfaces.msg").ParameterType
    if isinstance(value, bool):
        return int(types.PARAMETER_BOOL)
    if isinstance(value, int):
        return int(types.PARAMETER_INTEGER)
    if isinstance(value, float):
        return int(types.PARAMETER_DOUBLE)
    return int(types.PARAMETER_STRING)


def qos_of(binding: Binding) -> Any:
    """The rclpy QoS profile of a binding (reliability, volatile durability, keep-last depth)."""
    qos = _module("rclpy.qos")
    reliability = (qos.ReliabilityPolicy.RELIABLE if binding.qos.reliability == "reliable"
                   else qos.ReliabilityPolicy.BEST_EFFORT)
    return qos.QoSProfile(depth=binding.qos.depth, reliability=reliability,
                          durability=qos.DurabilityPolicy.VOLATILE, history=qos.HistoryPolicy.KEEP_LAST)


#: The longest the executor's thread waits for work before it looks whether it should stop, s.
SPIN_SLICE = 0.1
#: Which executor spins the node, if not the default (``events``): ``single`` for rclpy's SingleThreadedExecutor.
EXECUTOR_ENV = "FSM_RCLPY_EXECUTOR"


def check_executor(kind: str) -> None:
    if kind not in ("events", "single"):
        raise TransportError(f"${EXECUTOR_ENV}={kind!r}: write events or single")


def make_executor(kind: str, context: Any) -> Any:
    """The executor that spins the node: ``events``, rclpy's EventsExecutor (C++; in rclpy.experimental since
    Jazzy's 7.1), where this rclpy has it, else ``single``, the SingleThreadedExecutor (pure Python: it builds a
    wait set and a task for every callback, which puts hundreds of microseconds of interpreter time between a
    message and the machine; docs/performance.md)."""
    check_executor(kind)
    if kind == "events":
        try:
            events = _module("rclpy.experimental").EventsExecutor
        except (ImportError, AttributeError):
            pass
        else:
            return events(context=context)
    return _module("rclpy.executors").SingleThreadedExecutor(context=context)


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

    def __init__(self, profile: Profile, node: str = "fsmctl", sim_time: bool = False,
                 managed: Managed | None = None, executor: str | None = None) -> None:
        self.profile = profile
        #: "events" (rclpy's EventsExecutor, where the rclpy has it) or "single" (SingleThreadedExecutor); default
        #: $FSM_RCLPY_EXECUTOR, else "events" (see :func:`make_executor`)
        self.executor = executor or os.environ.get(EXECUTOR_ENV) or "events"
        #: a managed (lifecycle) node whose transitions call ``managed`` (:mod:`fsm.ros.lifecycle`), else a plain one
        self.managed = managed
        #: the node's name: the profile's ``transport.node``, else ``fsmctl_<profile name>`` for the machine and
        #: ``fsmctl_sim_<profile name>`` for the robot; its namespace the profile's ``transport.namespace``
        self.node_name = node_name(profile, node)
        self.namespace = profile.transport.namespace
        #: ``use_sim_time``: the node's clock is the simulator's /clock (lock-step)
        self.sim_time = sim_time
        self.node: Any = None
        self._context: Any = None
        self._executor: Any = None
        self._thread: threading.Thread | None = None
        self._spinning = False
        self._subscriptions: list[Any] = []
        self._publishers: list[Any] = []
        self._parameters: list[str] = []
        self._on_set: Any = None
        self._internal = threading.local()

    def describe(self) -> str:
        import os

        rmw = os.environ.get("RMW_IMPLEMENTATION", "the default RMW")
        name = f"{self.namespace.rstrip('/')}/{self.node_name}"
        return f"through rclpy as node {name} ({rmw}, ROS domain {domain_of(self.profile)})"

    def message_class(self, type_name: str) -> Any:
        full = normalise_type(type_name)
        package, _msg, name = full.split("/")
        try:
            return getattr(_module(f"{package}.msg"), name)
        except (ImportError, AttributeError) as exc:
            why = missing_package(full) or str(exc)
            hint = f"use {NO_WHEEL[package]}" if package in NO_WHEEL else "install it"
            raise TransportError(f"rclpy cannot load {full}: {why}: {hint}, or use --via zenoh") from None

    def open(self) -> RclpyLink:
        check_executor(self.executor)
        try:
            rclpy = _module("rclpy")
        except ImportError as exc:
            raise TransportError(f"rclpy cannot be imported ({exc}): {RCLPY_HINT}; or use Zenoh (--via zenoh, or "
                                 "\"via\": \"zenoh\" in the profile's transport)") from None
        try:
            self._context = rclpy.Context()
            self._init(rclpy)
            overrides = [_module("rclpy.parameter").Parameter("use_sim_time", value=True)] if self.sim_time else []
            if self.managed is not None:
                from fsm.ros.lifecycle import lifecycle_node

                self.node = lifecycle_node(self.node_name, self.managed, namespace=self.namespace,
                                           context=self._context, parameter_overrides=overrides)
            else:
                self.node = rclpy.create_node(self.node_name, namespace=self.namespace, context=self._context,
                                              parameter_overrides=overrides)
        except Exception as exc:  # an RMW that does not load, a bad domain
            raise TransportError(f"cannot start rclpy {self.describe()}: {exc}") from None
        self._executor = make_executor(self.executor, self._context)
        self._executor.add_node(self.node)
        self._spinning = True
        self._thread = threading.Thread(target=self._spin, name="rclpy", daemon=True)
        self._thread.start()
        return self

    def _init(self, rclpy: Any) -> None:
        """rclpy.init without rclpy's own signal handlers: Ctrl-C stays the command's (stop command first, outputs
        written, exit 130). Older rclpy (before Humble) has no option for it: its handlers are replaced by the ones
        that were there."""
        import signal

        before = {num: signal.getsignal(num) for num in (signal.SIGINT, signal.SIGTERM)}
        domain = domain_of(self.profile)
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
        executor = self._executor
        try:
            while self._spinning:
                executor.spin_once(timeout_sec=SPIN_SLICE)
        except Exception:  # the context was shut down while spinning
            pass

    # -- the machine's variables, signals and state parameters as ROS 2 parameters --------------------------------
    def expose_parameters(self, variables: dict[str, Any], signals: list[str],
                          on_signal: Callable[[str, bool], None], tunables: Sequence[Tunable] = (),
                          on_tunable: Callable[[Tunable, Any], None] | None = None) -> None:
        """Declare ``vars.<name>`` for each variable (read-only from outside: the machine sets them),
        ``signals.<name>`` for each input signal the document declares (writable, bool: ``on_signal`` is called on
        the executor's thread) and ``states.<path>.<param>`` for each of ``tunables`` (typed; read-only unless
        writable; a valid value set from outside goes to ``on_tunable`` with the state's new parameters). A set
        from outside of anything else, or of a value that is not valid, is refused with the reason."""
        rcl = _module("rcl_interfaces.msg")
        self._writable = {f"signals.{name}" for name in signals} | {t.name for t in tunables if t.writable}
        by_name = {t.name: t for t in tunables}

        def check(params: list[Any]) -> Any:
            inside = getattr(self._internal, "active", False)  # this process's own declare/update, on its thread
            why = None if inside else self._set_from_outside(params, by_name, on_signal, on_tunable)
            return rcl.SetParametersResult(successful=why is None, reason=why or "")

        # The check is in place before the first name is declared: a client that sees a parameter can set it at
        # once (the executor answers on its own thread), and must be refused from the very first one.
        self.node.add_on_set_parameters_callback(check)
        self._on_set = check
        with self._inside():
            for name, value in variables.items():
                if re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", name):
                    self._declare(f"vars.{name}", parameter_value(value), rcl.ParameterDescriptor(
                        dynamic_typing=True,
                        description=f"the machine's variable {name} (read-only: the machine sets it)"))
            for name in signals:
                if re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", name):
                    self._declare(f"signals.{name}", False, rcl.ParameterDescriptor(
                        description=f"the input signal {name} (the document's inputs: set it to drive the machine)"))
            for t in tunables:
                self._declare(t.name, t.value, rcl.ParameterDescriptor(
                    type=parameter_type(t.value), read_only=not t.writable, description=t.description))

    @contextlib.contextmanager
    def _inside(self) -> Iterator[None]:
        """Sets made by this process on the calling thread pass the outside check; a set that arrives meanwhile
        through the parameter service (on the executor's thread) is still checked."""
        self._internal.active = True
        try:
            yield
        finally:
            self._internal.active = False

    def _set_from_outside(self, params: list[Any], tunables: dict[str, Tunable],
                          on_signal: Callable[[str, bool], None],
                          on_tunable: Callable[[Tunable, Any], None] | None) -> str | None:
        """Parameters set from outside, all or none: why not, or None once each was passed on."""
        taken: list[tuple[Tunable, Any]] = []
        for param in params:
            if param.name not in self._writable:
                return (f"{param.name} is read-only: the machine sets its variables; only the signals the document "
                        "declares as inputs and the state parameters named by --tunable can be set "
                        f"({', '.join(sorted(self._writable)) or 'none'})")
            tunable = tunables.get(param.name)
            if tunable is None and not isinstance(param.value, bool):
                return f"{param.name} is a signal: true or false"
            if tunable is not None:
                try:
                    taken.append((tunable, tunable.validate(param.value)))
                except ValueError as exc:
                    return f"{param.name}: {exc}"
        for param in params:
            if param.name.startswith("signals."):
                on_signal(param.name.split(".", 1)[1], bool(param.value))
        for tunable, new in taken:
            if on_tunable is not None:
                on_tunable(tunable, new)
        return None

    def _declare(self, name: str, value: Any, descriptor: Any) -> None:
        self._parameters.append(name)
        self.node.declare_parameter(name, value, descriptor)

    def update_parameters(self, variables: dict[str, Any]) -> None:
        """The variables' current values (those declared; a new variable is declared now)."""
        param = _module("rclpy.parameter").Parameter
        node = self.node
        updates = []
        for name, value in variables.items():
            key = f"vars.{name}"
            if node.has_parameter(key):
                updates.append(param(key, value=parameter_value(value)))
        with self._inside():
            node.set_parameters(updates)

    def wait_for_peer(self, timeout: float, what: str = ROBOT, stop: Callable[[], bool] | None = None) -> None:
        end = time.monotonic() + timeout
        while len(self.node.get_node_names_and_namespaces()) < 2:  # this node, and another
            if stop is not None and stop():
                return
            if time.monotonic() >= end:
                raise PeerTimeout(f"no other ROS 2 node seen within {timeout:g} s {self.describe()}: is {what} "
                                  "running in this ROS domain?")
            time.sleep(0.02)

    def publisher(self, binding: Binding) -> RclpyPublisher:
        pub = self.node.create_publisher(self.message_class(binding.type), binding.topic, qos_of(binding))
        self._publishers.append(pub)
        return RclpyPublisher(pub)

    def subscribe(self, binding: Binding, callback: Callable[[bytes], None]) -> None:
        sub = self.node.create_subscription(self.message_class(binding.type), binding.topic,
                                            lambda raw: callback(bytes(raw)), qos_of(binding), raw=True)
        self._subscriptions.append(sub)

    def release(self) -> None:
        """Destroy the publishers, subscriptions and parameters made since :meth:`open` (a managed node's
        ``cleanup``); the node stays."""
        node = self.node
        if node is None:
            return
        for pub in self._publishers:
            node.destroy_publisher(pub)
        for sub in self._subscriptions:
            node.destroy_subscription(sub)
        self._publishers.clear()
        self._subscriptions.clear()
        if self._on_set is not None:
            node.remove_on_set_parameters_callback(self._on_set)
            self._on_set = None
        forget = getattr(node, "forget_parameter", node.undeclare_parameter)  # a managed node forgets read-only ones
        for name in self._parameters:
            if node.has_parameter(name):
                forget(name)
        self._parameters.clear()

    def close(self) -> None:
        """Stop spinning (the executor's thread ends within :data:`SPIN_SLICE`), then the executor, the node and
        the context, in that order: rclpy's EventsExecutor hangs in ``shutdown`` (and the context's) while another
        thread is inside its ``spin``."""
        self._spinning = False
        if self._thread is not None:
            self._thread.join(timeout=2)
            self._thread = None
        executor, self._executor = self._executor, None
        if executor is not None:
            executor.shutdown(timeout_sec=2)
        if self.node is not None:
            self.node.destroy_node()
            self.node = None
        context, self._context = self._context, None
        if context is not None and context.ok():
            context.shutdown()

    def __enter__(self) -> RclpyLink:
        return self.open() if self.node is None else self

    def __exit__(self, *exc: object) -> None:
        self.close()
