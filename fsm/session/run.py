"""``fsm.run``: the one way to run a machine from Python, whatever it starts from.

``source`` is a machine document (a path to a ``.json`` or ``.uxf`` file, the JSON text, or the document as a
dict), a parsed spec, a compiled plan, or a machine already built. It is loaded once (read, parsed, checked,
compiled, built) and run by one :class:`~fsm.session.session.Session`: on the simulated car in ``world`` when a
world is given or when the machine drives a car and no ``car`` is given (the default world, as ``fsmctl run``),
else on ``car`` or on the machine's clock alone::

    import fsm
    result = fsm.run("diagrams/examples/sorter.json", duration=30)
    print(result.outcome, result.stopped, result.ticks)    # succeeded finished 609

The simulator is found through the ``fsm.simulators`` entry-point group (``fsm.sim:simulate``), so that the core
never imports the simulator itself.
"""

from __future__ import annotations

import numbers
import os
from collections.abc import Callable, Iterable, Mapping
from typing import TYPE_CHECKING, Union

from fsm.loading.installed import entry_points
from fsm.loading.loader import compile as compile_plan
from fsm.loading.sources import Source, checked_source
from fsm.model.errors import StateRuntimeError, UsageError
from fsm.model.plan import MachinePlan
from fsm.runtime.clock import DEFAULT_DT
from fsm.runtime.context import shown_value
from fsm.runtime.machine import MAX_RUN_TICKS, Listener, Machine, seconds_argument
from fsm.session.arguments import car_argument, variables_argument
from fsm.session.session import RunResult, Session, StopRules
from fsm.trace.recorder import Recorder

if TYPE_CHECKING:
    from fsm.loading.registry import Registry

#: What :func:`run` and :func:`open_session` start from: what ``fsm.load`` loads (a path, JSON text, a document dict,
#: a spec, a plan: :mod:`fsm.loading.sources`), or a machine already built.
RunSource = Union[Source, Machine]
#: The entry-point group that names the simulator (``sim = "fsm.sim:simulate"``).
SIMULATORS = "fsm.simulators"


def run(source: RunSource, *, world: str | os.PathLike[str] | None = None, car: object | None = None,
        stop: StopRules | None = None, duration: float | None = None, max_ticks: int | None = None,
        until: Callable[[Session], bool] | None = None, outputs: Iterable[Listener] = (),
        registry: Registry | None = None, plugins: tuple[str, ...] = (), variables: Mapping[str, object] | None = None,
        dt: float | None = None, seed: int = 0, base_dir: str | os.PathLike[str] | None = None) -> RunResult:
    """Run the machine in ``source`` to its end and say how it ended (:class:`~fsm.session.session.RunResult`).

    It stops when the machine finishes, ``until(session)`` is true, or at the first of ``duration`` seconds of
    machine time and ``max_ticks`` ticks (``stop``: the same as one :class:`~fsm.session.session.StopRules`);
    without any, after 600 s of machine time, as ``fsmctl run``. ``outputs`` are listeners that see the run (a
    :class:`~fsm.trace.recorder.Recorder` writes its trace, ended by its ``end`` line). ``world`` (a world file)
    runs it on the simulated car, with sensor noise from ``seed``; ``car`` on a car of your own (anything with the
    car interface, ``fsm.sim.io.CarIO``). ``base_dir`` is where the includes of JSON text or a dict are found (else
    the working directory). Raises :class:`~fsm.model.errors.DiagramError` for a document with
    errors, ``TypeError`` or ``ValueError`` for a wrong argument, naming it.
    """
    if until is not None and not callable(until):
        raise TypeError(f"until must be a function of the session returning a bool, or None; got {shown_value(until)}")
    rules = stop_rules(stop, duration, max_ticks, source.dt if isinstance(source, Machine) else dt)
    session = open_session(source, world=world, car=car, stop=rules, registry=registry, plugins=plugins,
                           variables=variables, dt=dt, seed=seed, base_dir=base_dir)
    for output in outputs:
        if isinstance(output, Recorder):
            session.record(output)
        else:
            session.add_listener(output)
    try:
        result = session.run(until=until)
    except StateRuntimeError as error:  # the trace still ends, with the error, as `fsmctl run --trace` ends it
        session.finish(error={"state": error.path, "phase": error.phase, "tick": error.tick, "time": error.time,
                              "message": f"{type(error.cause).__name__}: {error.cause}"})
        raise
    session.finish()
    return result


def open_session(source: RunSource, *, world: str | os.PathLike[str] | None = None, car: object | None = None,
                 stop: StopRules | None = None, registry: Registry | None = None, plugins: tuple[str, ...] = (),
                 variables: Mapping[str, object] | None = None, dt: float | None = None, seed: int = 0,
                 record: bool = False, base_dir: str | os.PathLike[str] | None = None) -> Session:
    """The session :func:`run` runs, for a caller that steps it, submits inputs or reads its summary: on the
    simulator (:func:`simulator`) or, without one, :meth:`Session.open <fsm.session.session.Session.open>`."""
    variables = variables_argument(variables)
    car_argument(car)
    if isinstance(source, Machine):
        if world is not None or car is not None or dt is not None:
            raise TypeError("a machine already built has its car and clock: give world, car and dt to fsm.load, "
                            "or pass the document to fsm.run instead of the machine")
        if variables:
            source.ctx.vars.update(variables)
        return Session(source, stop=stop, record=record)
    plan = plan_of(source, registry=registry, plugins=plugins, base_dir=base_dir)
    if world is not None or (car is None and plan.needs_car):
        return simulator()(plan, world=world, seed=seed, variables=variables, dt=dt, stop=stop)
    return Session.open(plan, car=car, variables=variables, dt=dt, stop=stop, record=record)


def plan_of(source: Source, *, registry: Registry | None = None, plugins: tuple[str, ...] = (),
            base_dir: str | os.PathLike[str] | None = None) -> MachinePlan:
    """The compiled plan of ``source`` (loaded once: read, parsed, checked, compiled), by the rule ``fsm.load``
    follows (:mod:`fsm.loading.sources`)."""
    checked_source(source, kinds="a path, JSON text, a document dict, a spec, a plan or a machine")
    return compile_plan(source, registry=registry, plugins=plugins, base_dir=base_dir)


def stop_rules(stop: StopRules | None, duration: object = None, max_ticks: object = None,
               dt: float | None = None) -> StopRules | None:
    """``stop``, or the rules ``duration`` and ``max_ticks`` make (checked: numbers, not negative, finite)."""
    if stop is not None:
        if not isinstance(stop, StopRules):
            raise TypeError(f"stop must be an fsm.StopRules or None, got {shown_value(stop)}")
        if duration is not None or max_ticks is not None:
            raise TypeError("give either stop or duration and max_ticks, not both")
        return stop
    ticks: int | None = None
    if max_ticks is not None:
        if isinstance(max_ticks, bool) or not isinstance(max_ticks, numbers.Integral):
            raise TypeError(f"max_ticks must be an int or None, got {shown_value(max_ticks)}")
        if max_ticks < 0:
            raise ValueError(f"max_ticks must be >= 0, got {max_ticks}")
        ticks = int(max_ticks)
    seconds = None if duration is None else seconds_argument("duration", duration)
    if seconds is not None and seconds / (dt or DEFAULT_DT) > MAX_RUN_TICKS:
        raise ValueError(f"duration must be at most {MAX_RUN_TICKS:.0e} ticks, got {duration!r} s; "
                         f"run in steps with Session.step for longer")
    if seconds is None and ticks is None:
        return None
    return StopRules(seconds, ticks)


def simulator() -> Callable[..., Session]:
    """The simulator's session maker (``fsm.sim.simulate``), found by its entry point (the installed
    distributions are read only when a machine needs the simulator)."""
    for point in entry_points(group=SIMULATORS):
        maker: Callable[..., Session] = point.load()
        return maker
    raise UsageError("this machine drives a car, and no simulator is installed (the fsm.simulators entry point): "
                     "pass car=... to fsm.run, or reinstall tral-fsm")


__all__ = ["SIMULATORS", "RunSource", "open_session", "plan_of", "run", "simulator", "stop_rules"]
