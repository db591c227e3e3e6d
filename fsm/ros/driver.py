"""RosDriver: a real car (or the simulated one in another process) as a session's driver, over Zenoh.

Each tick: ``before_tick`` latches the newest message of every input into the :class:`~fsm.ros.car.RosCar` (in
lock-step, first waiting for the simulator's clock to reach the tick); the machine ticks; ``after_tick`` publishes
one drive command and, at the status rate or when something changed, the machine's status.

The safety rule: the command's speed is 0 while an input has been silent longer than the profile allows, while a
state of the machine is paused, and after a state failed; :meth:`RosDriver.stop` sends the same zero command at
once (Ctrl-C, an exception). Steering is kept, so a car rolling out does not swerve.
"""

from __future__ import annotations

import json
import sys
import threading
import time
from collections import deque
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from fsm.ros import messages as M
from fsm.ros.car import Log, RosCar
from fsm.ros.parameters import Tunable, apply_tunable
from fsm.ros.profile import Profile, status_companions
from fsm.ros.transport import Bus, PeerTimeout, TopicPublisher
from fsm.runtime.machine import Listener

if TYPE_CHECKING:
    from fsm.ros.bag import BagRecorder
    from fsm.runtime.context import Context
    from fsm.runtime.machine import Fired, Machine
    from fsm.runtime.state import State
    from fsm.runtime.supervisor import Monitor
    from fsm.session.session import Session

#: Slack when comparing the simulator's clock with a tick's time.
EPS = 1e-9


def stderr_log(text: str) -> None:
    print(f"fsmctl: {text}", file=sys.stderr, flush=True)


class _Watch(Listener):
    """What the status topic reports besides the active path: monitor firings and paused states."""

    def __init__(self) -> None:
        self.changed = True
        self.paused: set[str] = set()
        self.monitors: list[dict[str, Any]] = []
        self.fired = 0

    def on_transition(self, ctx: Context, source: State[Any] | None, target: State[Any],
                      transition: Fired | None) -> None:
        self.changed = True

    def on_monitor(self, ctx: Context, owner: State[Any], monitor: Monitor) -> None:
        self.fired += 1
        self.monitors.append({"state": owner.path, "monitor": monitor.label, "kind": monitor.kind,
                              "time": round(ctx.now, 6)})
        del self.monitors[:-20]
        self.changed = True

    def on_pause(self, ctx: Context, state: State[Any], paused: bool) -> None:
        (self.paused.add if paused else self.paused.discard)(state.path)
        self.changed = True


class RosDriver:
    """The session's driver for a car on ROS 2 topics (see the module's docstring)."""

    def __init__(self, profile: Profile, link: Bus | None, *, lockstep: bool = False,
                 bag: BagRecorder | None = None, log: Log | None = None) -> None:
        self.profile = profile
        self.link = link
        self.lockstep = lockstep
        self.bag = bag
        self.log = log or stderr_log
        self.car = RosCar(profile, log=self.log, on_stop=self.stop)
        self.session: Session | None = None
        self.machine: Machine | None = None
        self._watch = _Watch()
        status = profile.outputs.status
        self._status_every = 1.0 / status.rate if status is not None else 0.0
        self._next_status = 0.0
        #: without a link (replay): the last command published, (machine time, CDR bytes), and the last status;
        #: nothing more is kept, however long the run
        self.last_sent: tuple[float, bytes] | None = None
        self.last_status: tuple[float, dict[str, Any]] | None = None
        self._clock = -1.0
        self._clock_cond = threading.Condition()
        self._command: TopicPublisher | None = None
        self._status: TopicPublisher | None = None
        #: beside the status's JSON: DiagnosticArray on /diagnostics, the active path on <status>/active
        self._companions: dict[str, TopicPublisher] = {}
        if link is not None:
            self._command = link.publisher(profile.outputs.command)
            self._status = link.publisher(status) if status is not None else None
            self._companions = {k: link.publisher(b) for k, b in status_companions(profile).items()}
            for name, binding in profile.inputs_bound().items():
                link.subscribe(binding, self.car.subscriber(name))
            if lockstep:  # subscribed last: once the simulator sees it, it sees the inputs' subscriptions too
                link.subscribe(profile.clock, self._on_clock)
        self.clock_lost = False
        #: the inputs silent now, and since when (machine time)
        self.silent: list[str] = []
        self._silent_since: float | None = None
        self.silences = 0
        self.commands = 0
        self.zero_commands = 0
        self.held_by: str | None = None
        #: a managed node deactivated (:mod:`fsm.ros.lifecycle`): every command has zero speed, the tick in
        #: progress's too
        self.inactive = False
        self.stop_sent = 0
        #: the input signals the document declares (settable from outside: ROS 2 parameters over rclpy)
        self.signals: list[str] = []
        self._signals_in: deque[tuple[str, bool]] = deque()
        #: the states' parameters as ROS 2 parameters (over rclpy), and those set from outside so far
        self.tunables: list[Tunable] = []
        self._tunables_in: deque[tuple[Tunable, Any]] = deque()
        self.tunables_set: list[dict[str, Any]] = []
        #: ROS time (s since 1970) at machine time 0: header stamps and bag times are ROS time, as a robot that
        #: drops stale commands needs. The wall clock's at the start (set by :meth:`prime`); in lock-step 0, the
        #: simulator's /clock being ROS time there (use_sim_time)
        self.time_offset = 0.0

    # -- the simulator's clock (lock-step) -----------------------------------------------------------------------
    def _on_clock(self, raw: bytes) -> None:
        try:
            t = M.stamp_of_clock(M.decode(raw, self.profile.clock.type))
        except M.DecodeError:
            return
        with self._clock_cond:
            self._clock = t
            self._clock_cond.notify_all()

    def _wait_clock(self, time_s: float, timeout: float) -> bool:
        end = time.monotonic() + timeout
        with self._clock_cond:
            while self._clock < time_s - EPS:
                left = end - time.monotonic()
                if left <= 0:
                    return False
                self._clock_cond.wait(left)
        return True


    # -- starting ------------------------------------------------------------------------------------------------
    def prime(self, timeout: float | None = None, stop: Callable[[], bool] | None = None) -> bool:
        """Before the machine starts: wait for a peer, then for a message of every input (and in lock-step for the
        simulator's clock at 0), and latch them as the car's values at time 0. :class:`PeerTimeout` naming the
        endpoints when nothing comes within the profile's ``peer_timeout``; False (nothing latched) as soon as
        ``stop()`` holds (Ctrl-C while waiting for the robot)."""
        timeout = self.profile.transport.peer_timeout if timeout is None else timeout
        end = time.monotonic() + timeout
        link = self.link
        assert link is not None

        def stopped() -> bool:
            return stop is not None and stop()

        link.wait_for_peer(timeout, stop=stop)
        if stopped():
            return False
        while self.lockstep and not self._wait_clock(0.0, min(0.05, max(0.0, end - time.monotonic()))):
            if stopped():
                return False
            if time.monotonic() >= end:
                raise PeerTimeout(f"no clock on {self.profile.clock.topic} within {timeout:g} s "
                                  f"({link.describe()}): is `fsmctl sim --ros ... --lockstep` running there?")
        while True:
            missing = [name for name, n in self.car.received().items() if n == 0 and name != "camera"]
            if not missing:
                break
            if stopped():
                return False
            if time.monotonic() >= end:
                topics = ", ".join(self.profile.inputs_bound()[m].topic for m in missing)
                raise PeerTimeout(f"a peer answered ({link.describe()}) but nothing came on {topics} "
                                  f"within {timeout:g} s: check the topic names and types in the profile")
            time.sleep(0.005)
        if not self.lockstep:
            self.time_offset = time.time()
        self._latch(0.0)
        return True

    # -- the driver ------------------------------------------------------------------------------------------------
    def attach(self, session: Session) -> None:
        self.session = session
        self.machine = session.machine
        session.machine.add_listener(self._watch)
        expose = getattr(self.link, "expose_parameters", None)
        if expose is not None:  # rclpy: the variables as read-only parameters, the document's inputs writable
            expose(dict(session.machine.ctx.vars), list(self.signals), self._signal_from_outside,
                   self.tunables, self._tunable_from_outside)

    def _signal_from_outside(self, name: str, value: bool) -> None:
        """A signal set as a ROS 2 parameter (the executor's thread): applied before the next tick."""
        self._signals_in.append((name, value))

    def _tunable_from_outside(self, tunable: Tunable, params: Any) -> None:
        """A state's parameter set as a ROS 2 parameter (the executor's thread, checked): applied before the next
        tick."""
        self._tunables_in.append((tunable, params))

    def before_tick(self, time_s: float) -> None:
        while self._tunables_in and self.machine is not None:
            tunable, params = self._tunables_in.popleft()
            params = apply_tunable(self.machine, tunable, params)
            self.tunables_set.append({"tick": self.machine.ticks + 1, "parameter": tunable.name,
                                      "value": params.model_dump(mode="json", by_alias=True).get(tunable.param)})
            self.log(f"at {self.machine.now:.3f} s: {tunable.path}.{tunable.param} set from outside "
                     f"({tunable.name})")
        while self._signals_in and self.session is not None:
            from fsm.session.session import SetSignal

            name, value = self._signals_in.popleft()
            self.session.submit(SetSignal(name, value))
        # lock-step: the simulator's time is the only time; a wall-clock limit only tells a simulator that is gone
        # from a slow one (a loaded machine), so it is long (transport.gone_after)
        gone_after = self.profile.transport.gone_after
        if self.lockstep and not self.clock_lost and not self._wait_clock(time_s, gone_after):
            self.clock_lost = True
            self.log(f"the simulator's clock on {self.profile.clock.topic} stopped before {time_s:.3f} s (nothing "
                     f"for {gone_after:g} s of wall time: transport.gone_after)")
        self._latch(time_s)

    def _latch(self, time_s: float) -> None:
        taken = self.car.latch(time_s)
        if self.bag is not None:
            for name, raw in taken:
                self.bag.write(name, raw, self.time_offset + time_s)

    def after_tick(self) -> None:
        machine = self.machine
        assert machine is not None
        now = machine.now
        car = self.car
        silent = car.silent_inputs(now)
        if silent != self.silent:
            if silent and not self.silent:
                self.silences += 1
                self._silent_since = now
                self.log(f"at {now:.3f} s: silent longer than the profile allows: {', '.join(silent)}; "
                         "the car gets zero speed")
            elif not silent:
                self.log(f"at {now:.3f} s: every input is back")
                self._silent_since = None
            self.silent = silent
            self._watch.changed = True
        held = ("silence" if silent else "inactive" if self.inactive else "pause" if self._watch.paused
                else "stopped" if car.stopped else None)
        self.held_by = held
        self._publish_command(now, 0.0 if held else car.speed_command)
        if self.profile.outputs.status is not None and (self._watch.changed or now + EPS >= self._next_status):
            self._publish_status(machine, now)

    def _publish_command(self, now: float, speed: float) -> None:
        car = self.car
        angle = car.steering * car.max_steering_angle
        message = M.command_message(self.profile.outputs.command.type, self.time_offset + now, speed, angle,
                                    car.wheelbase)
        raw = M.encode(message)
        if self._command is not None:
            self._command.put(raw)
        else:
            self.last_sent = (now, raw)
        self.commands += 1
        if speed == 0.0:
            self.zero_commands += 1
        if self.bag is not None:
            self.bag.write("command", raw, self.time_offset + now)

    def status(self, machine: Machine, now: float) -> dict[str, Any]:
        """The status topic's JSON: active path, outcome, monitor firings, what holds the car."""
        return {"profile": self.profile.name, "tick": machine.ticks, "time": round(now, 6),
                "active": machine.active_path, "finished": machine.finished, "outcome": machine.outcome,
                "paused": sorted(self._watch.paused), "monitors_fired": self._watch.fired, "commands": self.commands,
                "monitors": list(self._watch.monitors), "silent": list(self.silent), "held_by": self.held_by,
                "command": {"speed": 0.0 if self.held_by else self.car.speed_command,
                            "steering": self.car.steering}}

    def _publish_status(self, machine: Machine, now: float) -> None:
        status = self.status(machine, now)
        raw = M.encode(M.status_message(json.dumps(status, separators=(",", ":"))))
        if self._status is not None:
            self._status.put(raw)
            if self._companions:
                self._companions["diagnostics"].put(M.encode(self._diagnostics(status, now)))
                self._companions["active"].put(M.encode(M.status_message(status["active"])))
        else:
            self.last_status = (now, status)
        self._watch.changed = False
        self._next_status = now + self._status_every
        update = getattr(self.link, "update_parameters", None)
        if update is not None:
            update(machine.ctx.vars)
        if self.bag is not None:
            self.bag.write("status", raw, self.time_offset + now)

    def _diagnostics(self, status: dict[str, Any], now: float) -> Any:
        """The status as ROS's diagnostics: OK while driving or finished well, WARN while something holds the car,
        ERROR once the machine finished otherwise than 'succeeded'."""
        outcome = status["outcome"]
        if status["finished"] and outcome not in (None, "succeeded"):
            level, text = M.ERROR, f"finished: {outcome}"
        elif status["held_by"]:
            silent = f" ({', '.join(status['silent'])})" if status["silent"] else ""
            level, text = M.WARN, f"held at zero speed by {status['held_by']}{silent}"
        elif status["finished"]:
            level, text = M.OK, f"finished: {outcome}"
        else:
            level, text = M.OK, f"active: {status['active']}"
        values = {k: status[k] for k in ("tick", "time", "active", "finished", "outcome", "held_by", "silent",
                                         "commands", "monitors_fired")}
        return M.diagnostics_message(self.time_offset + now, f"fsmctl: {self.profile.name}", level, text, values)

    def should_stop(self) -> str | None:
        if self.clock_lost:
            return "silence"
        stop_after = self.profile.safety.stop_after
        if stop_after is not None and self._silent_since is not None and self.machine is not None:
            if self.machine.now - self._silent_since >= stop_after - EPS:
                return "silence"
        return None

    def stop(self) -> None:
        """Send a zero-speed command now (Ctrl-C, an exception, a state that failed); safe to call from anywhere,
        several times."""
        try:
            now = self.machine.now if self.machine is not None else 0.0
            self.car.speed_command = 0.0
            self.held_by = self.held_by or "stopped"
            self._publish_command(now, 0.0)
            self.stop_sent += 1
        except Exception:  # the session may be closing: the robot's own command timeout stops it then
            pass

    def metrics(self) -> dict[str, Any]:
        car = self.car
        return {"ros": {"profile": self.profile.name, "lockstep": self.lockstep, "time_offset": self.time_offset,
                        "received": car.received(),
                        "decode_failures": car.failures(), "dropped_readings": dict(car.dropped),
                        "odometry_jumps": car.odometry_jumps, "silences": self.silences,
                        "silent_at_end": list(self.silent), "commands": self.commands,
                        "zero_speed_commands": self.zero_commands, "stop_commands": self.stop_sent,
                        "monitors_fired": self._watch.fired, "parameters_set": self.tunables_set[-100:]},
                "distance_m": round(car.distance, 4), "collisions": 0}


def ros_session(plan: Any, profile: Profile, link: Bus, *, lockstep: bool = False, bag: BagRecorder | None = None,
                log: Log | None = None, stop: Any = None, variables: dict[str, Any] | None = None,
                signals: list[str] | None = None, clock: Any = None,
                tunables: list[Tunable] | None = None) -> Session:
    """A session that runs the machine of ``plan`` (a compiled :class:`fsm.model.plan.MachinePlan`) on the car behind
    ``link``: on the wall clock at the profile's rate, or in lock-step with a simulator's clock (``clock``: another
    clock, e.g. :class:`fsm.ros.lifecycle.HoldableClock`)."""
    from fsm.loading.building import build
    from fsm.runtime.clock import RealTimeClock, SimulatedClock
    from fsm.session.session import Session

    driver = RosDriver(profile, link, lockstep=lockstep, bag=bag, log=log)
    driver.signals = list(signals or [])
    driver.tunables = list(tunables or [])
    if clock is None:
        clock = SimulatedClock(profile.dt) if lockstep else RealTimeClock(profile.dt)
    machine = build(plan, clock=clock, car=driver.car)
    if variables:
        machine.ctx.vars.update(variables)
    return Session(machine, driver=driver, stop=stop)
