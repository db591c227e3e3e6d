"""Session: one run of a machine, and the one tick loop every runner uses.

``fsmctl run``, a sweep's worker, the scenario runner, a user's Python (and next the live debugger and the ROS 2
bridge) configure a session and let it loop; none of them ticks a machine itself. A session holds the machine,
the *world* around it (a :class:`Driver`: the simulated car, a real one, nothing), the inputs scheduled for it,
its listeners and recorder, and its stop rules. The rules it fixes:

- **How many ticks a duration is**: the first tick at or after it (:func:`ticks_for`), so 0.018 s at 80 Hz is
  2 ticks, with a car or without.
- **When an input applies**: between two ticks, before the first tick whose time is at or after the input's
  time (an input at 0 s applies before the initial states are entered). Anything that steers a run from
  outside (a variable set, a signal, a pause of a subtree, a debugger's command) is applied there and never
  inside a tick, so a run, steered or not, replays exactly.
- **When it stops**: when the machine finishes, at the duration or tick limit, when ``until(session)`` holds or a
  caller's ``stop()`` says so (Ctrl-C), or when a world's own rule says so (too many collisions).

Without a duration or a tick limit a run stops after :data:`DEFAULT_DURATION` of machine time.
"""

from __future__ import annotations

import bisect
import math
import os
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

from fsm.model.errors import StateRuntimeError
from fsm.runtime.clock import DEFAULT_DURATION
from fsm.trace.recorder import Recorder, jsonable, summary

if TYPE_CHECKING:
    from fsm.loading.registry import Registry
    from fsm.loading.sources import Source
    from fsm.runtime.machine import L, Machine

#: Slack when comparing machine times (80 ticks of 0.0125 s are 1 s, however the floats round).
TIME_EPS = 1e-9
#: A tick no run reaches: what a time too far for any run (1e308 s) comes to.
NEVER = 2**63


def ticks_for(duration: float, dt: float) -> int:
    """How many ticks a run of ``duration`` seconds is: the first tick at or after it (``ceil``, with slack for
    rounding: 1 s at 80 Hz is 80 ticks, 0.018 s is 2); :data:`NEVER` for a duration no run reaches."""
    return _whole(duration / dt - TIME_EPS)


def tick_at(time_s: float, dt: float) -> int:
    """The first tick whose time is at or after ``time_s`` (a nanosecond of slack): when an input given for that
    time applies; :data:`NEVER` for a time no run reaches."""
    return _whole((time_s - TIME_EPS) / dt)


def _whole(ticks: float) -> int:
    """``ticks`` rounded up and at least 0 (a float beyond any run, or infinite, has no whole number: NEVER)."""
    return max(0, math.ceil(ticks)) if ticks < NEVER else NEVER


class Driver(Protocol):
    """The world around a machine, stepped by the session: the simulated car (:class:`fsm.sim.loop.Simulation`),
    a real car's bridge, plants. ``before_tick`` brings the world to the time of the coming tick (physics, reading
    sensors), ``after_tick`` takes what the tick did (commands, measurements)."""

    def attach(self, session: Session) -> None: ...

    def before_tick(self, time_s: float) -> None: ...

    def after_tick(self) -> None: ...

    def should_stop(self) -> str | None:
        """Why the run must stop now (``"collisions"``), or None."""
        ...

    def metrics(self) -> dict[str, Any]:
        """What the summary adds for this world."""
        ...


# -- inputs ----------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class SetVars:
    """Set blackboard variables."""

    values: Mapping[str, Any]

    def apply(self, machine: Machine) -> None:
        machine.ctx.vars.update(self.values)

    def describe(self) -> str:
        return "set " + ", ".join(f"{k} = {v!r}" for k, v in self.values.items())

    def to_json(self) -> dict[str, Any]:
        return {"kind": "set", "values": {str(k): jsonable(v) for k, v in self.values.items()}}


@dataclass(frozen=True)
class SetSignal:
    """Set an input signal's level (an edge in the coming tick when the level changes)."""

    name: str
    value: bool = True

    def apply(self, machine: Machine) -> None:
        machine.ctx.set_signal(self.name, self.value)

    def describe(self) -> str:
        return f"signal {self.name} {'high' if self.value else 'low'}"

    def to_json(self) -> dict[str, Any]:
        return {"kind": "signal", "name": self.name, "value": self.value}


@dataclass(frozen=True)
class PauseState:
    """Pause (or resume) the active state at ``path`` and its subtree (``""``: the whole machine)."""

    path: str
    paused: bool = True

    def apply(self, machine: Machine) -> None:
        state = machine.root.active if not self.path else machine.state(self.path)
        if not state.active:
            return  # not active at this tick: nothing to pause or resume
        if self.paused:
            machine.pause(self.path or None)
        else:
            machine.resume(self.path or None)

    def describe(self) -> str:
        return f"{'pause' if self.paused else 'resume'} {self.path or '(machine)'}"

    def to_json(self) -> dict[str, Any]:
        return {"kind": "pause", "path": self.path, "paused": self.paused}


class Input(Protocol):
    """Something applied to the machine between two ticks."""

    def apply(self, machine: Machine) -> None: ...

    def describe(self) -> str: ...


@dataclass(order=True, frozen=True)
class Scheduled:
    """An input and the tick before which it applies (inputs of one tick in the order they were scheduled)."""

    tick: int
    order: int
    input: Input = field(compare=False)


@dataclass(frozen=True)
class StopRules:
    """When a run ends besides the machine finishing: machine time, ticks (the earlier of the two)."""

    duration: float | None = None
    max_ticks: int | None = None

    def end_tick(self, first: int, dt: float) -> int:
        duration = self.duration if self.duration is not None or self.max_ticks is not None else DEFAULT_DURATION
        ends = [first + ticks_for(duration, dt)] if duration is not None else []
        if self.max_ticks is not None:
            ends.append(first + self.max_ticks)
        return min(ends)


@dataclass
class RunResult:
    """How a run ended: the outcome (None if unfinished), why it stopped (``finished``, ``limit``, ``until``,
    ``stopped``, ``error`` or a stop rule's reason), the error of a state that failed, and where the run stood:
    its tick and machine time, the active leaf states' paths and the machine's variables (a copy)."""

    outcome: str | None
    stopped: str
    error: StateRuntimeError | None = None
    ticks: int = 0
    time: float = 0.0
    active: tuple[str, ...] = ()
    variables: dict[str, Any] = field(default_factory=dict)

    @classmethod
    def of(cls, machine: Machine, stopped: str, error: StateRuntimeError | None = None) -> RunResult:
        """Where ``machine`` stands, stopped for ``stopped``."""
        return cls(machine.outcome, stopped, error, machine.ticks, machine.now, tuple(machine.active_paths),
                   dict(machine.ctx.vars))


# -- the session -----------------------------------------------------------------------------------------------
class Session:
    """One run of ``machine`` in ``driver``'s world (none: the machine runs on its clock alone)."""

    #: what a snapshot of the run (:mod:`fsm.session.snapshot`) reads, by name
    __snapshot_fields__ = ("machine", "driver", "stop_rules", "recorder", "_record", "_inputs", "_order", "_observers",
                           "_next_observe", "_applied", "wall_time", "result")

    def __init__(self, machine: Machine, *, driver: Driver | None = None, stop: StopRules | None = None,
                 record: bool = True) -> None:
        self.machine = machine
        self.driver = driver
        self.stop_rules = stop or StopRules()
        #: what records the run: a trace recorder given to :meth:`record`, else (``record``) one that keeps only
        #: what the summary needs (visited states, counts)
        self.recorder: Recorder | None = None
        self._record = record
        self._inputs: list[Scheduled] = []
        self._order = 0
        self._observers: list[tuple[float, Callable[[Session], None]]] = []
        self._next_observe: list[float] = []
        self._applied: list[tuple[int, Input]] = []
        #: seconds of wall time spent in the loop (``realtime_factor``)
        self.wall_time = 0.0
        self.result: RunResult | None = None
        if driver is not None:
            driver.attach(self)

    # -- building one -----------------------------------------------------------------------------------------
    @classmethod
    def open(cls, source: Source, *, car: object | None = None, driver: Driver | None = None,
             registry: Registry | None = None, plugins: tuple[str, ...] = (),
             variables: Mapping[str, object] | None = None, dt: float | None = None, stop: StopRules | None = None,
             base_dir: str | os.PathLike[str] | None = None, record: bool = True) -> Session:
        """A session for the machine in ``source`` (what ``fsm.load`` loads: :mod:`fsm.loading.sources`) on ``car``
        and ``driver`` or its clock alone, its arguments checked as :func:`fsm.run` checks them; ``fsm.run`` opens
        its sessions so when it needs no simulator (:func:`fsm.session.run.open_session`).

        ``car``: anything that implements the car interface (``fsm.sim.io.CarIO``, an adapter the core does not
        import, as :class:`~fsm.runtime.context.Context` does not); a machine that drives needs
        one. For the simulated car, use :func:`fsm.run` with a ``world``, or :func:`fsm.sim.simulate`.
        """
        from fsm.loading.building import build
        from fsm.loading.loader import compile as compile_plan
        from fsm.loading.sources import checked_source
        from fsm.runtime.clock import SimulatedClock
        from fsm.session.arguments import car_argument, variables_argument

        variables = variables_argument(variables)
        car_argument(car)
        plan = compile_plan(checked_source(source), registry=registry, plugins=plugins, base_dir=base_dir)
        machine = build(plan, clock=SimulatedClock(dt) if dt is not None else None, car=car)
        if variables:
            machine.ctx.vars.update(variables)
        return cls(machine, driver=driver, stop=stop, record=record)

    # -- what runs around the machine -------------------------------------------------------------------------
    @property
    def car(self) -> Any:
        return self.machine.ctx.car

    def add_listener(self, listener: L) -> L:
        """Attach a listener to the machine (see :class:`fsm.Listener`)."""
        return self.machine.add_listener(listener)

    def record(self, recorder: Recorder) -> Recorder:
        """Record the run with ``recorder`` (a trace): flushed after the start, finished at the end."""
        self.recorder = recorder
        self.machine.add_listener(recorder)
        return recorder

    def replace_machine(self, machine: Machine) -> None:
        """Run ``machine`` from now on in place of the current one (a hot reload, :mod:`fsm.debug.reload`, between two
        ticks): it gets the current machine's listeners (the recorder among them) and the world's driver."""
        old = self.machine
        self.machine = machine
        for listener in old.listeners:
            machine.add_listener(listener)
        if self.driver is not None:
            self.driver.attach(self)
        kept: list[Any] = []  # the driver's own listener came over and was added again: once each
        for listener in machine.listeners:
            if not any(listener is other for other in kept):
                kept.append(listener)
        machine.listeners[:] = kept  # the same list: the regions hold it

    def every(self, period: float, observer: Callable[[Session], None]) -> None:
        """Call ``observer(session)`` every ``period`` seconds of machine time (after a tick; first at the start)."""
        self._observers.append((period, observer))
        self._next_observe.append(0.0)

    def schedule(self, at: float, item: Input) -> None:
        """Apply ``item`` before the first tick at or after machine time ``at`` (a time already past: before the
        next tick)."""
        self._order += 1
        bisect.insort(self._inputs, Scheduled(tick_at(at, self.dt), self._order, item))

    def submit(self, item: Input) -> None:
        """Apply ``item`` before the next tick (a command from outside: a debugger, a bridge)."""
        self._order += 1
        bisect.insort(self._inputs, Scheduled(self.machine.ticks + (1 if self.machine.started else 0), self._order,
                                              item))

    def schedule_tick(self, tick: int, item: Input) -> None:
        """Apply ``item`` before tick ``tick`` (0: before the initial states are entered; a tick already past: before
        the next one): how a run is replayed from the ticks its trace recorded inputs at."""
        if isinstance(tick, bool) or not isinstance(tick, int) or tick < 0:
            raise ValueError(f"tick must be an int >= 0, got {tick!r}")
        self._order += 1
        bisect.insort(self._inputs, Scheduled(tick, self._order, item))

    def keep_scheduled(self, keep: Callable[[Input], bool]) -> None:
        """Drop the inputs scheduled and not applied yet for which ``keep(input)`` is false (a debugger's rewind
        schedules its own again)."""
        self._inputs = [item for item in self._inputs if keep(item.input)]

    @property
    def applied(self) -> list[tuple[int, Input]]:
        """Every input applied so far (since :meth:`forget_applied`), with the tick before which it was applied."""
        return list(self._applied)

    def forget_applied(self, tick: int) -> None:
        """Let go of the inputs applied before ``tick`` or at it (a live run keeps them only within its rewind
        horizon: a run of hours holds no per-input history)."""
        applied = self._applied
        if applied and applied[0][0] <= tick:
            self._applied = [entry for entry in applied if entry[0] > tick]

    # -- state of the run ---------------------------------------------------------------------------------------
    @property
    def dt(self) -> float:
        return float(self.machine.clock.dt)

    @property
    def now(self) -> float:
        return self.machine.now

    @property
    def ticks(self) -> int:
        return self.machine.ticks

    @property
    def finished(self) -> bool:
        return self.machine.finished

    @property
    def outcome(self) -> str | None:
        return self.machine.outcome

    @property
    def active_path(self) -> str:
        return self.machine.active_path

    # -- running ------------------------------------------------------------------------------------------------
    def start(self) -> None:
        """Enter the initial states (inputs for time 0 first); done by the first step or run if not called."""
        machine = self.machine
        if machine.started:
            return
        if self.recorder is None and self._record:
            self.record(Recorder())
        self._apply_inputs(0)
        machine.start()
        if self.recorder is not None:
            self.recorder.flush(machine)
        if self.driver is not None:
            self.driver.after_tick()
        self._observe()

    def step(self, n: int = 1) -> RunResult:
        """Run at most ``n`` ticks (fewer when the machine finishes or a stop rule ends the run)."""
        if isinstance(n, bool) or not isinstance(n, int) or n < 0:
            raise ValueError(f"n must be an int >= 0, got {n!r}")
        if not self.machine.started:
            self.start()
        return self.run(stop_rules=StopRules(max_ticks=n))

    def run(self, until: Callable[[Session], bool] | None = None, stop: Callable[[], bool] | None = None,
            stop_rules: StopRules | None = None) -> RunResult:
        """Tick until the machine finishes, a stop rule ends the run, ``until(session)`` holds or ``stop()`` (checked
        after every tick: Ctrl-C) is true. Returns how it ended; a state that fails raises
        :class:`StateRuntimeError` after the car was stopped (``result.error`` keeps it too)."""
        machine = self.machine
        t0 = time.perf_counter()
        try:
            if not machine.started:
                self.start()
            ctx = machine.ctx
            end = (stop_rules or self.stop_rules).end_tick(ctx.tick, self.dt)
            driver = self.driver
            clock = machine.clock
            realtime = bool(getattr(clock, "realtime", False))
            observers = bool(self._observers)
            inputs = self._inputs
            tick = machine.tick
            dt = machine.dt
            if driver is not None:  # bound once: the lap calls them 80 times a simulated second
                before_tick, after_tick, should_stop = driver.before_tick, driver.after_tick, driver.should_stop
            stopped = "finished"
            while True:
                if machine.finished:
                    break
                n = ctx.tick
                if n >= end:
                    stopped = "limit"
                    break
                n += 1
                if inputs and inputs[0].tick <= n:
                    self._apply_inputs(n)
                if realtime:
                    clock.wait_for(n)
                if driver is not None:
                    before_tick(clock.time_at(n) if realtime else n * dt)
                tick()
                if driver is not None:
                    after_tick()
                    why = should_stop()
                    if why is not None:
                        stopped = why
                        break
                if observers:
                    self._observe()
                if until is not None and until(self):
                    stopped = "until"
                    break
                if stop is not None and stop():
                    stopped = "stopped"
                    break
            self.result = RunResult.of(machine, stopped)
            return self.result
        except StateRuntimeError as exc:
            self.result = RunResult.of(machine, "error", exc)
            raise
        finally:
            self.wall_time += time.perf_counter() - t0

    def _apply_inputs(self, tick: int) -> None:
        inputs = self._inputs
        while inputs and inputs[0].tick <= tick:
            item = inputs.pop(0).input
            item.apply(self.machine)
            self._applied.append((tick, item))
            if self.recorder is not None:  # the trace's input line: a steered run replays from it
                self.recorder.on_input(tick, round(tick * self.dt, 9), item)

    def _observe(self) -> None:
        now = self.machine.now
        for k, (period, observer) in enumerate(self._observers):
            if now + TIME_EPS >= self._next_observe[k]:
                self._next_observe[k] += period
                observer(self)

    # -- the end ------------------------------------------------------------------------------------------------
    def finish(self, **info: Any) -> None:
        """Write the recorder's last line (``interrupted``, ``error``: what ``info`` adds)."""
        if self.recorder is not None:
            self.recorder.finish(self.machine, **info)

    def summary(self) -> dict[str, Any]:
        """The run summary: the machine's (outcome, ticks, visited states, variables), then the world's metrics."""
        result = summary(self.machine, self.recorder or Recorder())
        if self.driver is not None:
            result.update(self.driver.metrics())
        return result


__all__ = ["DEFAULT_DURATION", "NEVER", "Driver", "Input", "PauseState", "RunResult", "Session", "SetSignal", "SetVars",
           "StopRules", "tick_at", "ticks_for"]
