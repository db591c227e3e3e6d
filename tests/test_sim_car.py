"""The simulated car: bicycle model, servo and speed limits, hall sensor, ultrasonic cones, noise, collisions, loop."""

from __future__ import annotations

import json
import math
from typing import Any

import pytest

import fsm
from fsm.model.errors import StateRuntimeError
from fsm.sim.car import SimCar
from fsm.sim.io import CarIO
from fsm.sim.loop import Simulation
from fsm.sim.world import parse_world


def corridor(**car: Any) -> Any:
    doc: dict[str, Any] = {"walls": [{"points": [[0, 0], [30, 0], [30, 2], [0, 2]], "closed": True}],
                           "start": {"x": 2.0, "y": 0.5, "heading": 0}}
    if car:
        doc["car"] = car
    return parse_world(doc)


def drive(car: SimCar, seconds: float) -> None:
    for _ in range(int(round(seconds / 0.01))):
        car.step()


def test_sim_car_implements_the_interface() -> None:
    assert isinstance(SimCar(corridor()), CarIO)


def test_steering_zero_does_not_drive_straight_but_the_offset_can_be_zeroed() -> None:
    car = SimCar(corridor())
    car.set_speed(1.0)
    drive(car, 3.0)
    assert car.true_pose()[2] > math.radians(5)  # the default offset pulls left, as on the real car
    straight = SimCar(corridor(steering_offset=0.0))
    straight.set_speed(1.0)
    drive(straight, 3.0)
    x, y, th = straight.true_pose()
    assert th == pytest.approx(0.0, abs=1e-9) and y == pytest.approx(0.5, abs=1e-9)


def test_speed_has_an_acceleration_limit_and_is_clamped() -> None:
    car = SimCar(corridor(acceleration=1.0, max_speed=2.0))
    car.set_speed(5.0)
    drive(car, 0.5)
    assert car.speed == pytest.approx(0.5)
    drive(car, 3.0)
    assert car.speed == pytest.approx(2.0)


def test_servo_has_a_rate_limit() -> None:
    car = SimCar(corridor(steering_rate=2.0, steering_offset=0.0, servo={"latency": 0}))
    car.set_steering(1.0)
    car.step()
    assert car.servo_position == pytest.approx(0.02)
    drive(car, 0.49)
    assert car.servo_position == pytest.approx(1.0)


def test_servo_acts_after_its_latency_and_not_within_its_dead_band() -> None:
    car = SimCar(corridor(steering_offset=0.0, servo={"seconds_per_60": 0.15, "travel": 45, "latency": 0.05,
                                                       "dead_band": 0.02}))
    assert car.params.servo_rate == pytest.approx(60 / (0.15 * 45))
    car.set_steering(0.5)
    drive(car, 0.05)
    assert car.servo_position == 0.0  # the command is still on its way
    car.step()
    assert car.servo_position == pytest.approx(car.params.servo_rate * 0.01)
    drive(car, 0.2)
    assert car.servo_position == pytest.approx(0.5)
    car.set_steering(0.509)  # within half the dead band: the servo stays
    drive(car, 0.2)
    assert car.servo_position == pytest.approx(0.5)
    car.set_steering(0.52)  # outside it: the servo goes all the way to the command
    drive(car, 0.2)
    assert car.servo_position == pytest.approx(0.52)


@pytest.mark.parametrize("servo", [{"seconds_per_60": 0}, {"travel": 100}, {"dead_band": -0.1}, {"latency": 2},
                                   {"speed": 0.1}])
def test_servo_parameters_out_of_range_are_refused_at_their_key(servo: dict[str, Any]) -> None:
    from fsm.model.errors import DiagramError

    with pytest.raises(DiagramError) as err:
        corridor(servo=servo)
    assert "servo" in str(err.value)


def test_full_steering_drives_the_bicycle_model_circle() -> None:
    car = SimCar(corridor(steering_offset=0.0, max_steering_angle=20.0, wheelbase=0.26, steering_rate=1e6))
    car.set_steering(1.0)
    car.set_speed(0.5)
    drive(car, 4.0)  # reach speed first
    w = car.body.angular_velocity
    beta = math.atan(0.5 * math.tan(math.radians(20)))
    assert w == pytest.approx(0.5 * math.cos(beta) * math.tan(math.radians(20)) / 0.26, rel=1e-3)


def test_hall_sensor_counts_1500_units_per_1_6_metres() -> None:
    car = SimCar(corridor(steering_offset=0.0))
    car.set_speed(0.8)
    drive(car, 4.0)
    x, _, _ = car.true_pose()
    assert car.distance == pytest.approx(x - 2.0, abs=0.01)  # wheel travel; the body lags it a little
    assert car.hall == int(car._travel * 1500 / 1.60)
    assert car.distance == pytest.approx(car.hall * 1.60 / 1500)


def test_ultrasonic_sensors_read_the_walls_without_noise() -> None:
    car = SimCar(corridor(), noise=False)
    surface = 0.005  # walls are segments of radius 5 mm
    assert car.right == pytest.approx(0.5 - 0.095 - surface, abs=0.001)
    assert car.left == pytest.approx(2 - 0.5 - 0.095 - surface, abs=0.001)
    assert car.front == 3.0  # nothing within range: max range


def test_ultrasonic_range_limits_and_rate() -> None:
    world = corridor(ultrasonic={"max_range": 1.2, "min_range": 0.5, "rate": 10})
    car = SimCar(world, noise=False)
    assert car.left == 1.2  # 1.405 m is beyond the range
    assert car.right == 0.5  # 0.405 m is nearer than the minimum
    before = car.sample
    drive(car, 1.0)
    assert car.sample - before == 10


def test_oblique_echoes_are_lost() -> None:
    # The right sensor looks 10 degrees below +x; its cone (+-7.5) meets the wall y=0 at 72.5-87.5 degrees.
    doc = {"walls": [{"points": [[0, 0], [30, 0]]}], "start": {"x": 2, "y": 0.3, "heading": 80}}
    car = SimCar(parse_world(doc), noise=False)
    assert car.right == 3.0
    doc["start"]["heading"] = 70  # now one ray meets it at 62.5 degrees: an echo
    assert SimCar(parse_world(doc), noise=False).right < 3.0


def test_noise_is_seeded() -> None:
    def readings(seed: int) -> list[float]:
        car = SimCar(corridor(), seed=seed)
        car.set_speed(0.5)
        out = []
        for _ in range(20):
            drive(car, 0.05)
            out.append(car.right)
        return out

    assert readings(1) == readings(1)
    assert readings(1) != readings(2)
    spread = max(readings(3)) - min(readings(3))
    assert 0.002 < spread < 0.05


def test_driving_into_a_wall_counts_one_collision_and_the_wall_holds() -> None:
    car = SimCar(corridor(steering_offset=0.0))
    car.body.angle = math.radians(-30)
    car.set_speed(1.0)
    drive(car, 3.0)
    assert car.collisions == 1
    assert car.contact_steps > 0
    assert car.true_pose()[1] > 0.0  # pushed back, not through the wall
    assert car.min_clearance < 0.01


def test_a_bump_into_a_wall_through_chipmunks_memory_is_the_bump_through_its_functions() -> None:
    """The car sets its control body's velocities and reads its pose in chipmunk's memory; through chipmunk's
    functions (``_mem`` None: other pymunk builds) a run with contacts, steering and a stop is the same to the bit."""

    def bump(direct: bool) -> list[tuple[Any, ...]]:
        car = SimCar(corridor(steering_offset=0.0))
        assert car._mem is not None  # the layout was found on this pymunk build
        if not direct:
            car._mem = None
        car.body.angle = math.radians(-30)
        car.set_speed(1.0)
        seen = []
        for k in range(400):
            if k == 150:
                car.set_steering(0.6)
            if k == 300:
                car.set_speed(-0.5)
            car.step()
            seen.append((car.true_pose(), car.true_position(), car.right, car.min_clearance, car.contact_steps,
                         car.control.velocity, car.control.angular_velocity))
        assert car.collisions >= 1
        return seen

    assert bump(True) == bump(False)


def test_emergency_stop_stops_at_once() -> None:
    car = SimCar(corridor())
    car.set_speed(1.0)
    drive(car, 2.0)
    car.emergency_stop()
    x = car.true_pose()[0]
    drive(car, 1.0)
    assert car.true_pose()[0] == pytest.approx(x, abs=1e-6)


def test_nan_command_is_refused() -> None:
    car = SimCar(corridor())
    with pytest.raises(ValueError):
        car.set_steering(float("nan"))


def test_camera_sees_nothing_without_markers_and_is_none_when_switched_off() -> None:
    car = SimCar(corridor())
    drive(car, 0.5)
    view = car.camera()
    assert view is not None and view.frame == 10 and view.detections == () and view.gates == ()
    assert car.rendered_frames == 0  # no marker can be in view: nothing rendered
    assert SimCar(corridor(camera={"enabled": False})).camera() is None


# -- the closed loop -------------------------------------------------------------------------------------
FOLLOW = {"initial": "f", "states": [{"id": "f", "type": "FollowWall", "distance": 0.4, "speed": 1.0},
                                     {"id": "s", "type": "Stop"}, {"id": "end", "type": "Final"}],
          "transitions": [{"type": "Distance", "from": "f", "to": "s", "distance": 20},
                          {"type": "Finished", "from": "s", "to": "end"}]}


def run(doc: Any, seed: int, trace: list[str] | None = None) -> Simulation:
    from fsm.trace.recorder import Recorder

    car = SimCar(corridor(), seed=seed)
    machine = fsm.load(doc, car=car)
    if trace is not None:
        import io

        buf = io.StringIO()
        machine.add_listener(Recorder(buf, extra=lambda: {"x": car.true_pose()[0], "y": car.true_pose()[1],
                                                          "right": car.right}))
    sim = Simulation(machine, car)
    sim.run(duration=60)
    if trace is not None:
        trace.append(buf.getvalue())
    return sim


def test_closed_loop_follows_the_wall() -> None:
    sim = run(FOLLOW, seed=0)
    m = sim.metrics()
    assert sim.machine.outcome == "succeeded"
    assert m["collisions"] == 0
    assert 20.0 <= m["distance_m"] < 20.5
    assert m["wall_error_rms_m"] < 0.03
    assert m["wall_error_samples"] > 100


def test_same_seed_gives_an_identical_trace_and_another_seed_does_not() -> None:
    a: list[str] = []
    b: list[str] = []
    c: list[str] = []
    run(FOLLOW, 7, a)
    run(FOLLOW, 7, b)
    run(FOLLOW, 8, c)
    assert a == b
    assert a != c


def test_the_loop_runs_physics_100hz_sensors_20hz_machine_80hz() -> None:
    car = SimCar(corridor())
    machine = fsm.load({"initial": "i", "states": [{"id": "i", "type": "Idle"}]}, car=car)
    sim = Simulation(machine, car)
    sim.run(duration=2.0)
    assert machine.ticks == 160
    assert car.steps == 200
    assert car.sample == 1 + 40


class Boom(fsm.State):
    def tick(self, ctx: Any) -> None:
        if ctx.now > 1.0:
            raise RuntimeError("boom")


def test_an_exception_in_a_state_stops_the_car() -> None:
    registry = fsm.Registry()
    registry.states.update(fsm.default_registry().states)
    registry.transitions.update(fsm.default_registry().transitions)
    registry.add_state(Boom)
    car = SimCar(corridor())
    doc = {"initial": "go", "states": [
        {"id": "go", "type": "FSMState", "machine": {"initial": "m", "states": [
            {"id": "m", "type": "Motor", "speed": 1.0, "distance": 0.5}, {"id": "b", "type": "Boom"}],
            "transitions": [{"type": "Finished", "from": "m", "to": "b"}]}}]}
    machine = fsm.load(doc, car=car, registry=registry)
    sim = Simulation(machine, car)
    with pytest.raises(StateRuntimeError) as err:
        sim.run(duration=5)
    assert err.value.path == "go/b" and err.value.tick == 81
    assert car.speed == 0.0 and car._cmd_speed == 0.0
    assert json.dumps(sim.metrics())  # metrics still available after the failure


def test_wall_follower_far_from_its_wall_turns_into_it_unless_its_angle_is_limited() -> None:
    """Started 1.4 m from the right wall with 0.45 m to keep, the plain PD saturates and turns the car round (facing
    the wall, the side sensor reads farther, not nearer); with ``max_angle`` it approaches at that angle, settles
    at the distance and drives on along the corridor."""
    world = parse_world({"walls": [{"points": [[0, 0], [30, 0], [30, 2.6], [0, 2.6]], "closed": True}],
                         "start": {"x": 2.0, "y": 1.4, "heading": 0}})

    def follow(**limit: Any) -> tuple[SimCar, list[float]]:
        doc = {"initial": "f", "states": [{"id": "f", "type": "FollowWall", "side": "right", "distance": 0.45,
                                           "speed": 0.6, **limit}]}
        car = SimCar(world, seed=0)
        sim = Simulation(fsm.load(doc, car=car), car)
        headings: list[float] = []
        for _ in range(120):
            sim.run(max_ticks=8)  # 0.1 s
            headings.append(math.degrees(car.true_pose()[2]))
        return car, headings

    car, headings = follow()
    assert min(headings) < -80 or car.collisions > 0, "the plain PD was expected to turn the car into the wall"
    car, headings = follow(max_angle=25)
    assert min(headings) > -25 - 8 and car.collisions == 0
    x, y, th = car.true_pose()
    assert x > 8.0 and abs(car.true_distance("right") - 0.45) < 0.05 and abs(math.degrees(th)) < 5


def beam_world(model: str, **extra: Any) -> Any:
    """A corridor with a 2 cm post 1.5 m ahead of the front sensor, slightly off the beam's axis."""
    doc: dict[str, Any] = {"walls": [{"points": [[0, 0], [30, 0], [30, 2], [0, 2]], "closed": True}],
                           "obstacles": [{"type": "circle", "center": [3.72, 1.03], "radius": 0.02}],
                           "start": {"x": 2.0, "y": 1.0, "heading": 0},
                           "car": {"ultrasonic": {"model": model, **extra}}}
    return parse_world(doc)


def test_the_beam_echoes_from_a_thin_post_that_the_rays_miss() -> None:
    assert SimCar(beam_world("rays"), noise=False).front == 3.0  # between two rays
    car = SimCar(beam_world("beam"), noise=False)
    assert car.front == pytest.approx(3.72 - 2.20 - 0.02, abs=0.002)
    assert car.left == pytest.approx(0.9) and car.right == pytest.approx(0.9)  # the walls beside, as the rays see


def test_the_beam_sees_a_flat_wall_only_within_max_incidence() -> None:
    doc: dict[str, Any] = {"walls": [{"points": [[0, 0], [30, 0], [30, 2], [0, 2]], "closed": True}],
                           "start": {"x": 28.0, "y": 1.0, "heading": 0},
                           "car": {"ultrasonic": {"model": "beam", "max_incidence": 70}}}
    car = SimCar(parse_world(doc), noise=False)
    assert car.front == pytest.approx(30 - 28.2 - 0.005, abs=1e-3)  # the end wall, square ahead
    doc["start"] = {"x": 10.0, "y": 1.0, "heading": 30}  # the top wall 1.16 m off at 30 degrees: 60 from its normal
    assert SimCar(parse_world(doc), noise=False).front < 3.0
    doc["start"]["heading"] = 12  # 78 degrees from the normal even at the cone's edge (12 + 7.5): no echo
    assert SimCar(parse_world(doc), noise=False).front == 3.0


def test_dropouts_read_max_range() -> None:
    car = SimCar(beam_world("beam", dropouts=1.0))
    assert car.front == 3.0 and car.left == 3.0
