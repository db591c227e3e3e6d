"""The simulated TRAL car: world files, a pymunk car with ultrasonic and hall sensors, the closed loop, the renderer.

Importing this package is cheap: pymunk and OpenCV load only in the modules that need them
(``car``, ``loop``, ``render``). States and transitions see the car only through the
:class:`fsm.sim.io.CarIO` protocol, so a hardware bridge can implement the same interface.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from fsm.sim.io import SENSORS, CarIO

if TYPE_CHECKING:
    from fsm.loading.registry import Registry
    from fsm.session.session import Session, StopRules
    from fsm.sim.world import World

#: The world a machine that drives runs in when none is given (``fsm.sim.world.default_world`` finds it).
DEFAULT_WORLD = "hallway.json"



def simulate(source: Any, *, world: str | os.PathLike[str] | World | None = None, car_file: str | None = None,
             seed: int = 0, noise: bool = True, registry: Registry | None = None, plugins: tuple[str, ...] = (),
             variables: Mapping[str, Any] | None = None, dt: float | None = None, stop: StopRules | None = None,
             max_collisions: int | None = None) -> Session:
    """A session that runs the machine in ``source`` (a file, a document dict, a parsed spec or a plan) on the
    simulated TRAL car in ``world`` (a world file, default: ``hallway.json`` from the worlds folder next to the
    machine, or the installed worlds; or a checked :class:`~fsm.sim.world.World`, such as a trace's header holds)::

        from fsm.sim import simulate
        session = simulate("diagrams/hallway_lap.uxf")
        print(session.run().outcome, session.summary()["collisions"])

    ``car_file`` replaces the world's car parameters; ``seed`` and ``noise`` drive the sensor noise. The session's
    driver (``session.driver``) is the :class:`~fsm.sim.loop.Simulation`: trajectory, metrics, observers.
    """
    from fsm.loading.building import build
    from fsm.loading.loader import compile as compile_plan
    from fsm.model.plan import MachinePlan
    from fsm.runtime.clock import SimulatedClock
    from fsm.sim.car import SimCar
    from fsm.sim.loop import Simulation
    from fsm.sim.world import World, default_world, load_car, load_world

    plan = source if isinstance(source, MachinePlan) else compile_plan(source, registry=registry, plugins=plugins)
    if world is None:
        world = default_world(str(source) if isinstance(source, (str, os.PathLike))
                              else plan.files[0] if plan.files else ".")
    if isinstance(world, World):
        loaded, world_file = world, None
        if car_file is not None:
            loaded = world.model_copy(update={"car": load_car(car_file)})
    else:
        loaded, world_file = load_world(world, car=car_file), world
    car = SimCar(loaded, seed=seed, noise=noise)
    machine = build(plan, clock=SimulatedClock(dt) if dt is not None else None, car=car)
    if variables:
        machine.ctx.vars.update(variables)
    sim = Simulation(machine, car, world_file=world_file, seed=seed, noise=noise, max_collisions=max_collisions)
    if stop is not None:
        sim.session.stop_rules = stop
    return sim.session


__all__ = ["DEFAULT_WORLD", "SENSORS", "CarIO", "simulate"]
