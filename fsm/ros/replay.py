"""A recorded drive fed to a machine, open loop, on the bag's clock: what would this machine have decided?

The bag's input messages (the profile says which topic is which input) are offered to a
:class:`~fsm.ros.car.RosCar` before the first tick at or after their log time, exactly as the closed loop latched
them; the ticks happen at the times of the recorded commands (one per tick), so a bag written by
``fsmctl run --ros --bag`` replays tick for tick. The machine's commands go nowhere (open loop): they are compared
with the recorded ones, with the active path the recorded status topic reported, up to the first divergence.
"""

from __future__ import annotations

import bisect
import json
import os
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from fsm.model.errors import DiagramError, FsmError, Problem
from fsm.ros import messages as M
from fsm.ros.bag import roles
from fsm.ros.driver import EPS, RosDriver
from fsm.ros.profile import STRING, Profile

if TYPE_CHECKING:
    from fsm.session.session import Session


@dataclass
class Drive:
    """A recorded drive: the inputs by time, and what the machine decided at each tick (command, active path)."""

    inputs: list[tuple[float, str, bytes]]
    ticks: list[float]
    commands: list[bytes]
    statuses: list[tuple[float, dict[str, Any]]] = field(default_factory=list)

    def active_at(self, k: int) -> str | None:
        """The active path the status topic reported at tick ``k`` (None: no status topic in the bag)."""
        if not self.statuses:
            return None
        times = [t for t, _s in self.statuses]
        i = bisect.bisect_right(times, self.ticks[k] + EPS) - 1
        return str(self.statuses[i][1].get("active")) if i >= 0 else None


def load_drive(path: str | os.PathLike[str], profile: Profile) -> Drive:
    """Read a rosbag2 folder recorded with ``profile``; located errors for a folder that is not one, or a bag
    without the profile's topics."""
    from fsm.loading.reading import max_input_bytes
    from fsm.ros.bag import read_bag

    folder = Path(path)
    name = str(path)
    if not os.path.lexists(folder):
        raise DiagramError([Problem("no such folder", name, hint="give the folder `fsmctl run --ros ... --bag DIR` "
                                                                 "wrote")])
    if not folder.is_dir() or not (folder / "metadata.yaml").is_file():
        raise DiagramError([Problem("not a rosbag2 folder (no metadata.yaml in it)", name,
                                    hint="give the folder `fsmctl run --ros ... --bag DIR` wrote")])
    size = sum(p.stat().st_size for p in folder.iterdir() if p.is_file())
    if size > max_input_bytes():
        raise DiagramError([Problem(f"bag is too big ({size / 1048576:.1f} MiB; the limit is "
                                    f"{max_input_bytes() / 1048576:g} MiB)", name,
                                    hint="set FSM_MAX_INPUT_BYTES to a larger number of bytes to read it")])
    try:
        messages = read_bag(folder)
    except Exception as exc:  # rosbags' ReaderError and what a damaged file makes it raise
        reason = " ".join(str(exc).split())
        raise DiagramError([Problem(f"cannot read the bag: {reason}", name)]) from None
    by_topic = {"/" + b.topic.lstrip("/"): role for role, b in roles(profile).items()}
    inputs: list[tuple[float, str, bytes]] = []
    ticks: list[float] = []
    commands: list[bytes] = []
    statuses: list[tuple[float, dict[str, Any]]] = []
    for topic, _typ, ns, raw in messages:
        role = by_topic.get(topic)
        t = ns * 1e-9
        if role == "command":
            if not ticks or t > ticks[-1] + EPS:  # the first command of each tick (a stop may follow at its time)
                ticks.append(t)
                commands.append(raw)
        elif role == "status":
            try:
                statuses.append((t, json.loads(M.decode(raw, STRING).data)))
            except (M.DecodeError, ValueError):
                continue
        elif role is not None:
            inputs.append((t, role, raw))
    missing = [f"{b.topic} ({role})" for role, b in profile.inputs_bound().items()
               if role != "camera" and not any(r == role for _t, r, _raw in inputs)]
    if not ticks:
        missing.insert(0, f"{profile.outputs.command.topic} (command)")
    if missing:
        raise FsmError(f"{name}: the bag has no messages on {', '.join(missing)}: was it recorded with this "
                       "profile (`fsmctl run --ros PROFILE --bag`)?")
    return Drive(inputs, ticks, commands, statuses)


class BagClock:
    """The bag's clock: tick ``n`` happens when the recorded drive's tick ``n`` did."""

    __slots__ = ("dt", "ticks")
    realtime = True

    def __init__(self, ticks: list[float], dt: float) -> None:
        self.ticks = ticks
        self.dt = dt

    def time_at(self, tick: int) -> float:
        if tick < len(self.ticks):
            return self.ticks[tick]
        return self.ticks[-1] + (tick - len(self.ticks) + 1) * self.dt

    def wait_for(self, tick: int) -> None:
        """A bag's time does not wait."""


class ReplayDriver(RosDriver):
    """The recorded drive as the session's world: its inputs offered by log time, the commands kept."""

    def __init__(self, profile: Profile, drive: Drive) -> None:
        super().__init__(profile, None)
        self.drive = drive
        self._next = 0
        self.active: list[str] = []

    def _offer_until(self, time_s: float) -> None:
        inputs = self.drive.inputs
        k = self._next
        while k < len(inputs) and inputs[k][0] <= time_s + EPS:
            _t, role, raw = inputs[k]
            self.car.offer(role, raw)
            k += 1
        self._next = k

    def prime(self, timeout: float | None = None, stop: Callable[[], bool] | None = None) -> bool:
        self._offer_until(self.drive.ticks[0])
        self._latch(self.drive.ticks[0])
        return True

    def before_tick(self, time_s: float) -> None:
        self._offer_until(time_s)
        self._latch(time_s)

    def after_tick(self) -> None:
        super().after_tick()
        assert self.machine is not None
        self.active.append(self.machine.active_path)


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
    """A session that runs ``plan`` open loop on ``drive`` (stops after its last recorded tick)."""
    from fsm.loading.building import build
    from fsm.session.session import Session, StopRules

    driver = ReplayDriver(profile, drive)
    machine = build(plan, clock=BagClock(drive.ticks, profile.dt), car=driver.car)
    return Session(machine, driver=driver, stop=StopRules(max_ticks=len(drive.ticks) - 1))


def compare(drive: Drive, driver: ReplayDriver, profile: Profile) -> tuple[int, Divergence | None]:
    """How many ticks were compared, and the first divergence (None: the same decisions at every tick)."""
    sent = driver.sent
    n = min(len(sent), len(drive.commands))
    wheelbase = profile.car.wheelbase
    command_type = profile.outputs.command.type
    for k in range(n):
        recorded_active = drive.active_at(k)
        replayed_active = driver.active[k] if k < len(driver.active) else None
        same_path = recorded_active is None or recorded_active == replayed_active
        if sent[k][1] != drive.commands[k] or not same_path:
            rs, ra, _ = M.command_values(M.decode(drive.commands[k], command_type), wheelbase)
            ps, pa, _ = M.command_values(M.decode(sent[k][1], command_type), wheelbase)
            return n, Divergence(k, drive.ticks[k], {"active": recorded_active, "speed": rs, "angle": ra},
                                 {"active": replayed_active, "speed": ps, "angle": pa})
    return n, None
