"""A recorded drive fed to a machine, open loop, on the bag's clock: what would this machine have decided?

The bag's input messages (the profile says which topic is which input) are offered to a
:class:`~fsm.ros.car.RosCar` before the first tick at or after their log time, exactly as the closed loop latched
them. Where the bag has the machine's commands (a bag written by ``fsmctl run --ros --bag``) the ticks happen at
their times (one per tick), so the drive replays tick for tick, and the machine's commands are compared with the
recorded ones, with the active path the recorded status topic reported, up to the first divergence. A drive
recorded without commands (anyone's robot, sensors only) is ticked at the profile's rate on the bag's clock, from
its first message.

The bag is read as the replay goes (:class:`~fsm.ros.bag.BagSource`): what is held is the messages between two
ticks, never the drive, so memory does not grow with the bag. ``start``/``stop`` (s, on the bag's clock, from its
first message) replay a part of it.
"""

from __future__ import annotations

import json
import os
from collections import deque
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from fsm.model.errors import DiagramError, FsmError, Problem
from fsm.ros import messages as M
from fsm.ros.bag import BagReadError, BagSource, roles
from fsm.ros.driver import EPS, RosDriver
from fsm.ros.profile import STRING, Profile

if TYPE_CHECKING:
    from fsm.session.session import Session


class Drive:
    """A recorded drive read as the replay goes: the inputs by time, and (where recorded) what the machine decided
    at each tick (command, the active path of the status topic)."""

    def __init__(self, source: BagSource, profile: Profile, name: str, start: float | None = None,
                 stop: float | None = None) -> None:
        self.source = source
        self.profile = profile
        bound = {"/" + b.topic.lstrip("/"): role for role, b in roles(profile).items()}
        self.by_topic = {topic: role for topic, role in bound.items() if topic in source.topics}
        command = "/" + profile.outputs.command.topic.lstrip("/")
        #: the ticks come from the recorded commands (else from the profile's rate)
        self.commanded = command in source.topics and source.counts.get(command) != 0
        self.layouts = {role: source.topics[topic][1] for topic, role in self.by_topic.items()}
        self.dt = profile.dt
        first = self._first_time()
        if first is None:
            raise FsmError(f"{name}: the bag has no messages on the profile's topics: was it recorded with this "
                           "profile?")
        self.origin = first
        start_ns = round((first + start) * 1e9) if start else None
        stop_ns = round((first + stop) * 1e9) if stop is not None else None
        self._stream: Iterator[tuple[str, int, bytes]] = source.messages(list(self.by_topic), start_ns, stop_ns)
        self.inputs: deque[tuple[float, str, bytes]] = deque()
        self.commands: deque[tuple[float, bytes]] = deque()
        self._statuses: deque[tuple[float, Any]] = deque()
        self.active: str | None = None
        self._base = 0  # the tick of commands[0]
        self._last_command = -1.0
        self.exhausted = False
        self.last_time = first
        self.t0: float | None = None
        self._pull_first()

    def _first_time(self) -> float | None:
        for _topic, ns, _raw in self.source.messages(list(self.by_topic)):
            return ns * 1e-9
        return None

    def _pull(self) -> bool:
        """One more message from the bag into the queues; False at its end."""
        if self.exhausted:
            return False
        item = next(self._stream, None)
        if item is None:
            self.exhausted = True
            return False
        topic, ns, raw = item
        t = ns * 1e-9
        self.last_time = t
        role = self.by_topic[topic]
        if role == "command":
            if t > self._last_command + EPS:  # the first command of each tick (a stop may follow at its time)
                self.commands.append((t, raw))
                self._last_command = t
        elif role == "status":
            self._statuses.append((t, raw))
        else:
            self.inputs.append((t, role, raw))
        return True

    def _pull_first(self) -> None:
        while self.t0 is None and self._pull():
            if self.commanded:
                self.t0 = self.commands[0][0] if self.commands else None
            else:
                self.t0 = self.last_time
        if self.t0 is None:
            self.t0 = self.last_time

    def time_at(self, tick: int) -> float:
        """The time of tick ``tick``: the recorded command's (past the last one, on at the profile's rate), or the
        profile's rate from the first message."""
        assert self.t0 is not None
        if not self.commanded:
            return self.t0 + tick * self.dt
        while tick - self._base >= len(self.commands) and self._pull():
            pass
        k = tick - self._base
        if 0 <= k < len(self.commands):
            return self.commands[k][0]
        last = self.commands[-1][0] if self.commands else self._last_command
        return last + (k - len(self.commands) + 1) * self.dt

    def has_tick(self, tick: int) -> bool:
        """Whether the bag goes on to tick ``tick``."""
        if self.commanded:
            self.time_at(tick)
            return tick - self._base < len(self.commands)
        t = self.time_at(tick)
        while not self.exhausted and self.last_time < t:
            self._pull()
        return t <= self.last_time + EPS

    def inputs_until(self, time_s: float) -> Iterator[tuple[str, bytes]]:
        """The inputs logged at or before ``time_s`` not yet taken, in order; the recorded status up to then."""
        while not self.exhausted and self.last_time <= time_s + EPS:
            self._pull()
        while self.inputs and self.inputs[0][0] <= time_s + EPS:
            _t, role, raw = self.inputs.popleft()
            yield role, raw
        while self._statuses and self._statuses[0][0] <= time_s + EPS:
            _t, raw = self._statuses.popleft()
            try:
                self.active = str(json.loads(M.decode(raw, STRING).data).get("active"))
            except (M.DecodeError, ValueError, AttributeError):
                continue

    def command_of(self, tick: int) -> bytes | None:
        """The recorded command of ``tick``, forgetting those before it (None: not recorded)."""
        self.time_at(tick)
        while self.commands and self._base < tick:
            self.commands.popleft()
            self._base += 1
        return self.commands[0][1] if self.commands and self._base == tick else None


def load_drive(path: str | os.PathLike[str], profile: Profile, start: float | None = None,
               stop: float | None = None, warn: Callable[[str], None] | None = None) -> Drive:
    """Open a recorded drive (a rosbag2 folder, or a folder or file of MCAP); located errors for a folder that is
    not one, or a bag without the profile's inputs. The size cap of input files does not apply: the bag is
    streamed."""
    folder = Path(path)
    name = str(path)
    if not os.path.lexists(folder):
        raise DiagramError([Problem("no such folder", name, hint="give the folder `fsmctl run --ros ... --bag DIR` "
                                                                 "or `ros2 bag record` wrote")])
    try:
        source = BagSource(folder, warn=warn)
    except BagReadError as exc:
        raise DiagramError([Problem(f"cannot read the bag: {exc}", name,
                                    hint="give the folder `fsmctl run --ros ... --bag DIR` or `ros2 bag record` "
                                         "wrote")]) from None
    missing = [f"{b.topic} ({role})" for role, b in profile.inputs_bound().items()
               if role != "camera" and "/" + b.topic.lstrip("/") not in source.topics]
    if missing:
        source.close()
        raise FsmError(f"{name}: the bag has no messages on {', '.join(missing)}: was it recorded with this "
                       "profile? (its topics: " + ", ".join(sorted(source.topics)) + ")")
    try:
        return Drive(source, profile, name, start, stop)
    except BaseException:
        source.close()
        raise


class BagClock:
    """The bag's clock: tick ``n`` happens when the recorded drive's tick ``n`` did."""

    __slots__ = ("drive", "dt")
    realtime = True

    def __init__(self, drive: Drive) -> None:
        self.drive = drive
        self.dt = drive.dt

    def time_at(self, tick: int) -> float:
        return self.drive.time_at(tick)

    def wait_for(self, tick: int) -> None:
        """A bag's time does not wait."""


class ReplayDriver(RosDriver):
    """The recorded drive as the session's world: its inputs offered by log time; each tick's command compared
    with the recorded one at once (nothing kept but the first divergence)."""

    def __init__(self, profile: Profile, drive: Drive) -> None:
        super().__init__(profile, None)
        self.drive = drive
        self.ticks = 0
        self.compared = 0
        self.divergence: Divergence | None = None
        for role, layout in drive.layouts.items():
            if role in self.car.slots:
                self.car.slots[role].layout = layout

    def _publish_command(self, now: float, speed: float) -> None:
        if self.drive.commanded:  # encoded to be compared; else there is nothing to compare with
            super()._publish_command(now, speed)
            return
        self.commands += 1
        if speed == 0.0:
            self.zero_commands += 1

    def _offer_until(self, time_s: float) -> None:
        for role, raw in self.drive.inputs_until(time_s):
            self.car.offer(role, raw)

    def prime(self, timeout: float | None = None, stop: Callable[[], bool] | None = None) -> bool:
        t = self.drive.time_at(0)
        self._offer_until(t)
        self._latch(t)
        return True

    def before_tick(self, time_s: float) -> None:
        self._offer_until(time_s)
        self._latch(time_s)

    def after_tick(self) -> None:
        super().after_tick()
        assert self.machine is not None
        self.ticks = self.machine.ticks
        self._compare(self.ticks, self.machine.active_path)

    def _compare(self, tick: int, replayed_active: str) -> None:
        """Tick ``tick``'s command (just published) and active path against the recorded ones."""
        if self.divergence is not None or not self.drive.commanded or self.last_sent is None:
            return
        recorded = self.drive.command_of(tick)
        if recorded is None:
            return
        self.compared += 1
        replayed = self.last_sent[1]
        recorded_active = self.drive.active
        same_path = recorded_active is None or recorded_active == replayed_active
        wheelbase = self.profile.car.wheelbase
        command_type = self.profile.outputs.command.type
        # the values, not the bytes: the header stamps are ROS time, which float seconds do not carry to the ns
        rs, ra, _ = M.command_values(M.decode(recorded, command_type), wheelbase)
        ps, pa, _ = M.command_values(M.decode(replayed, command_type), wheelbase)
        if (rs, ra) != (ps, pa) or not same_path:
            self.divergence = Divergence(tick, self.drive.time_at(tick),
                                         {"active": recorded_active, "speed": rs, "angle": ra},
                                         {"active": replayed_active, "speed": ps, "angle": pa})

    def should_stop(self) -> str | None:
        assert self.machine is not None
        return None if self.drive.has_tick(self.machine.ticks + 1) else "end of bag"


@dataclass
class Divergence:
    """The first tick at which the replayed machine decided otherwise than the recorded one."""

    tick: int
    time: float
    recorded: dict[str, Any]
    replayed: dict[str, Any]

    def describe(self) -> str:
        def one(d: dict[str, Any]) -> str:
            active = f"active '{d['active']}', " if d.get("active") is not None else ""
            return f"{active}speed {d['speed']:.4g} m/s, steering angle {d['angle']:.4g} rad"

        return (f"first divergence at tick {self.tick} ({self.time:.4f} s): recorded {one(self.recorded)}; "
                f"replayed {one(self.replayed)}")


def replay_session(drive: Drive, plan: Any, profile: Profile) -> Session:
    """A session that runs ``plan`` open loop on ``drive`` (stops after its last tick)."""
    import sys

    from fsm.loading.building import build
    from fsm.session.session import Session, StopRules

    driver = ReplayDriver(profile, drive)
    machine = build(plan, clock=BagClock(drive), car=driver.car)
    return Session(machine, driver=driver, stop=StopRules(max_ticks=sys.maxsize))
