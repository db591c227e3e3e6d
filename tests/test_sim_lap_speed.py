"""What the lap's speed-ups must not change: the beam echoes from the wall index, with the cone clipped in place and
the bounding box kept between walls, are those of the plain computation over every wall, to the last bit; the bodies'
state read and written in chipmunk's memory is what chipmunk's own functions read and write."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest

import fsm
from fsm.sim.car import WALL_RADIUS, SimCar
from fsm.sim.loop import Simulation
from fsm.sim.world import load_world

ROOT = Path(__file__).resolve().parents[1]
HALLWAY = ROOT / "diagrams" / "worlds" / "hallway.json"
LAP = ROOT / "diagrams" / "hallway_lap.json"


def every_wall_echo(car: SimCar, ox: float, oy: float, ux: float, uy: float, best: float | None = None) -> float:
    """The beam's echo from the walls, each wall of the world in turn through the cone (no index, no bounding boxes
    kept between walls, the clip written out as intervals): the computation the car's must agree with."""
    assert car._beam is not None
    best = car._max_r if best is None else best
    tan_h = car._tan_half
    for ax, ay, bx, by, *_box in car._beam[0]:
        rx, ry = ax - ox, ay - oy
        x0, y0 = rx * ux + ry * uy, -rx * uy + ry * ux
        rx, ry = bx - ox, by - oy
        x1, y1 = rx * ux + ry * uy, -rx * uy + ry * ux
        if (x0 <= 0.0 and x1 <= 0.0) or (x0 >= best and x1 >= best):
            continue
        t0, t1 = 0.0, 1.0
        ex, ey = x1 - x0, y1 - y0
        for f0, df in ((y0 - x0 * tan_h, ey - ex * tan_h), (-y0 - x0 * tan_h, -ey - ex * tan_h)):
            if df == 0.0:
                if f0 > 0.0:
                    t0, t1 = 1.0, 0.0
            elif df > 0.0:
                t1 = min(t1, -f0 / df)
            else:
                t0 = max(t0, -f0 / df)
        ll = ex * ex + ey * ey
        if t0 > t1 or ll == 0.0:
            continue
        t = min(max(-(x0 * ex + y0 * ey) / ll, t0), t1)
        d = math.hypot(x0 + t * ex, y0 + t * ey) - WALL_RADIUS
        if d <= 0.0:
            return car._min_r
        if d < best and abs(x0 * ey - y0 * ex) / math.sqrt(ll) >= car._cos_inc * (d + WALL_RADIUS):
            best = d
    return best


def every_point_clearance(car: SimCar, x: float, y: float, c: float, s: float, centre: float = 0.0) -> None:
    """The clearance with every point of the outline asked (no bound from the centre's distance)."""
    clear = car.min_clearance
    reach = clear if clear != math.inf else 1e3
    for px, py, _r in car._outline:
        clear = min(clear, car._nearest(car.space, x + c * px - s * py, y + s * px + c * py, reach))
    car.min_clearance = clear


def lap(seed: int, plain: bool, seconds: float, calls: bool = False) -> list[tuple[Any, ...]]:
    """The hallway lap's sensor readings, clearance, pose and state at every tick; ``plain``: the car asks every
    wall for every echo and every point of its outline for the clearance; ``calls``: the car reads and sets its
    bodies through chipmunk's functions."""
    car = SimCar(load_world(HALLWAY), seed=seed)
    if calls:
        assert car._mem is not None  # this pymunk build's layout was found: the test compares the two ways
        car._mem = None
    asked = [0]
    if plain:
        def echo(*a: float) -> float:
            asked[0] += 1
            return every_wall_echo(car, *a)

        car._wall_echo = echo  # type: ignore[method-assign,assignment]
        car._clearance_near = lambda *a: every_point_clearance(car, *a)  # type: ignore[method-assign]
    sim = Simulation(fsm.load(LAP, car=car), car)
    seen: list[tuple[Any, ...]] = []
    sim.add_observer(sim.machine.dt, lambda s: seen.append(
        (car.left, car.right, car.front, car.min_clearance, car.true_pose(), car.pose(), s.machine.active_path)))
    sim.run(duration=seconds)
    assert not plain or asked[0] == 3 * (car.sample - 1)  # the plain echo served every sensor of every sample
    return seen


@pytest.mark.parametrize("seed", [0, 3])
def test_the_lap_reads_what_the_plain_beam_computation_gives(seed: int) -> None:
    fast, plain = lap(seed, False, 45.0), lap(seed, True, 45.0)
    assert len(fast) == len(plain) == 3601
    assert fast == plain
    assert len({row[:3] for row in fast}) > 100  # the readings changed along the way


def test_the_lap_through_chipmunks_memory_is_the_lap_through_its_functions() -> None:
    """The car reads the body's pose and sets the control body's velocities in chipmunk's memory (no call, no GIL
    released); through cpBodyGetAngle, cpBodyGetPosition, cpBodySetVelocity and cpBodySetAngularVelocity the lap
    is the same, bit for bit, bumps into walls (seed 3) included."""
    fast, calls = lap(3, False, 45.0), lap(3, False, 45.0, calls=True)
    assert len(fast) == 3601 and fast == calls


def test_the_bodies_fields_in_chipmunks_memory_are_what_pymunk_reads_and_writes() -> None:
    import pymunk

    from fsm.sim.car import _body_fields

    body, control = pymunk.Body(2.0, 0.5), pymunk.Body(body_type=pymunk.Body.KINEMATIC)
    body.center_of_gravity = (0.1, -0.2)  # the position is the body's origin, not its centre of gravity
    body.angle, body.position = 1.25, (3.5, -2.25)
    fields = _body_fields(body._body, control._body)
    assert fields is not None
    angle, position, velocity, spin = fields
    assert (angle[0], position[0], position[1]) == (body.angle, body.position.x, body.position.y)
    velocity[0], velocity[1], spin[0] = 0.75, -0.5, 0.125
    assert (control.velocity.x, control.velocity.y, control.angular_velocity) == (0.75, -0.5, 0.125)
    space = pymunk.Space()
    space.add(body, control)
    space.step(0.01)
    assert control.position == (0.0075, -0.005) and angle[0] == body.angle


@pytest.mark.parametrize("heading", [0.0, -3.0])
def test_the_clearance_past_posts_and_into_a_wall_is_what_every_point_of_the_outline_gives(heading: float) -> None:
    """The clearance skips the points of the outline that the centre's distance puts beyond the smallest so far; a
    car that drives past posts a few millimetres closer each (each a new smallest clearance, from the corners and the
    middle of the side), then (heading -3) into the wall, measures what asking every point does, at every sample."""
    from fsm.sim.world import parse_world

    posts = [{"type": "circle", "center": [4.0 + 1.5 * k, 0.5 + 0.004 * k], "radius": 0.05} for k in range(12)]
    world = parse_world({"walls": [{"points": [[0, 0], [30, 0], [30, 2], [0, 2]], "closed": True}],
                         "obstacles": posts, "start": {"x": 2.0, "y": 0.8, "heading": heading},
                         "car": {"steering_offset": 0.0}})

    def run(plain: bool) -> list[float]:
        car = SimCar(world, seed=1)
        if plain:
            car._clearance_near = lambda *a: every_point_clearance(car, *a)  # type: ignore[method-assign]
        car.set_speed(1.0)
        seen = []
        for _ in range(2000):
            car.step()
            seen.append(car.min_clearance)
        return seen

    fast = run(False)
    assert fast == run(True) and len(set(fast)) > 12
