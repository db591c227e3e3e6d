"""World files: the shipped worlds load, the committed schema is current, bad worlds get located errors."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pytest

from fsm.model.errors import DiagramError
from fsm.sim.world import WORLD_SCHEMA_PATH, load_world, parse_world, wall_segments, world_schema_text

ROOT = Path(__file__).resolve().parent.parent
WORLDS = sorted((ROOT / "diagrams" / "worlds").glob("*.json"))


def base() -> dict[str, Any]:
    return {"walls": [{"points": [[0, 0], [10, 0], [10, 2], [0, 2]], "closed": True}],
            "start": {"x": 1.0, "y": 0.5, "heading": 0}}


def write(tmp_path: Path, doc: Any) -> tuple[Path, str]:
    text = json.dumps(doc, indent=2)
    path = tmp_path / "w.json"
    path.write_text(text)
    return path, text


def problems(tmp_path: Path, doc: Any) -> tuple[list[Any], str]:
    path, text = write(tmp_path, doc)
    with pytest.raises(DiagramError) as err:
        load_world(path)
    return err.value.problems, text


def line_of(text: str, needle: str, nth: int = 0) -> int:
    idx = -1
    for _ in range(nth + 1):
        idx = text.index(needle, idx + 1)
    return text.count("\n", 0, idx) + 1


@pytest.mark.parametrize("path", WORLDS, ids=lambda p: p.name)
def test_shipped_worlds_load(path: Path) -> None:
    world = load_world(path)
    assert world.segments()
    assert world.obstacles or world.gates or world.markers or path.name == "hallway.json"


def test_hallway_is_a_two_metre_loop_of_20_by_10_with_door_frames() -> None:
    world = load_world(ROOT / "diagrams" / "worlds" / "hallway.json")
    outer, inner = world.walls
    xs, ys = [p[0] for p in outer.points], [p[1] for p in outer.points]
    assert (max(xs) - min(xs), max(ys) - min(ys)) == (20, 10)
    assert min(p[0] for p in inner.points) - min(p[0] for p in outer.points) == pytest.approx(2.0)
    assert len(outer.doors) >= 6 and all(0.02 <= d.depth <= 0.1 for d in outer.doors)


def test_committed_world_schema_is_current() -> None:
    assert WORLD_SCHEMA_PATH.read_text(encoding="utf-8") == world_schema_text(), \
        "regenerate it: python -m fsm.sim.world --schema fsm/schema/world.schema.json"


def test_world_schema_accepts_the_shipped_worlds() -> None:
    jsonschema = pytest.importorskip("jsonschema")
    schema = json.loads(WORLD_SCHEMA_PATH.read_text())
    for path in WORLDS:
        jsonschema.validate(json.loads(path.read_text()), schema)


def test_door_is_a_recess_into_the_chosen_side() -> None:
    doc = base()
    doc["walls"] = [{"points": [[0, 0], [10, 0]], "doors": [{"segment": 0, "at": 5, "width": 1, "depth": 0.05}]}]
    segs = wall_segments(parse_world(doc).walls[0])
    assert len(segs) == 5
    assert segs[2] == ((4.5, -0.05), (5.5, -0.05))  # right of the direction of travel: -y
    doc["walls"][0]["doors"][0]["side"] = "left"
    assert wall_segments(parse_world(doc).walls[0])[2] == ((4.5, 0.05), (5.5, 0.05))
    assert parse_world(doc).segments(doors=False) == [((0.0, 0.0), (10.0, 0.0))]


def test_open_and_self_intersecting_walls_are_fine() -> None:
    doc = base()
    doc["walls"].append({"points": [[3, 1.5], [5, 1.9], [5, 1.5], [3, 1.9]]})  # crosses itself, open
    parse_world(doc)


# -- bad worlds -------------------------------------------------------------------------------------------
def test_car_inside_a_wall_is_a_located_error(tmp_path: Path) -> None:
    doc = base()
    doc["start"] = {"x": 5.0, "y": 0.05, "heading": 0}
    (p,), text = problems(tmp_path, doc)
    assert p.pointer == "/start" and "inside or touching wall 0" in p.message
    assert p.line == line_of(text, '"start"')


def test_car_inside_an_obstacle_is_a_located_error(tmp_path: Path) -> None:
    doc = base()
    doc["obstacles"] = [{"type": "circle", "center": [1.1, 0.5], "radius": 0.1}]
    (p,), _ = problems(tmp_path, doc)
    assert p.pointer == "/start" and "obstacle 0" in p.message


def test_nan_coordinate_is_a_located_error(tmp_path: Path) -> None:
    text = json.dumps(base(), indent=2).replace("10,", "NaN,", 1)
    path = tmp_path / "w.json"
    path.write_text(text)
    with pytest.raises(DiagramError) as err:
        load_world(path)
    (p,) = err.value.problems
    assert p.pointer == "/walls/0/points/1/0"
    assert "finite number" in p.message
    assert p.line == line_of(text, "NaN")


def test_negative_sensor_range_is_a_located_error(tmp_path: Path) -> None:
    doc = base()
    doc["car"] = {"ultrasonic": {"max_range": -3}}
    (p,), text = problems(tmp_path, doc)
    assert p.pointer == "/car/ultrasonic/max_range"
    assert "greater than 0" in p.message
    assert p.line == line_of(text, '"max_range"')


def test_min_range_above_max_range_is_an_error(tmp_path: Path) -> None:
    doc = base()
    doc["car"] = {"ultrasonic": {"min_range": 2, "max_range": 1}}
    (p,), _ = problems(tmp_path, doc)
    assert p.pointer == "/car/ultrasonic" and "below max_range" in p.message


def test_missing_world_file_is_an_error(tmp_path: Path) -> None:
    with pytest.raises(DiagramError, match="world file not found"):
        load_world(tmp_path / "absent.json")


@pytest.mark.parametrize("text, words", [("", "empty"), ("{", "invalid JSON"), ("[1, 2]", "JSON object"),
                                         ("\xff", "not UTF-8")])
def test_corrupt_world_file_is_a_located_error(tmp_path: Path, text: str, words: str) -> None:
    path = tmp_path / "w.json"
    path.write_bytes(text.encode("latin-1"))
    with pytest.raises(DiagramError, match=words):
        load_world(path)


def test_every_problem_of_a_world_is_reported_at_once(tmp_path: Path) -> None:
    doc = base()
    doc["walls"][0]["points"][0] = [0, "x"]
    doc["start"]["heading"] = "north"
    doc["gates"] = [{"markers": [1], "center": [1, 1]}]
    doc["speed"] = 3
    found, _ = problems(tmp_path, doc)
    pointers = {p.pointer for p in found}
    assert {"/walls/0/points/0/1", "/start/heading", "/gates/0/markers", "/speed"} <= pointers
    assert all(p.line is not None for p in found)


def test_door_that_does_not_fit_its_segment(tmp_path: Path) -> None:
    doc = base()
    doc["walls"][0]["doors"] = [{"segment": 1, "at": 1.9, "width": 0.9}, {"segment": 7, "at": 1}]
    found, _ = problems(tmp_path, doc)
    assert [p.pointer for p in found] == ["/walls/0/doors/0/at", "/walls/0/doors/1/segment"]


def test_obstacle_needs_the_fields_of_its_shape(tmp_path: Path) -> None:
    doc = base()
    doc["obstacles"] = [{"type": "box", "center": [5, 1]}]
    (p,), _ = problems(tmp_path, doc)
    assert p.pointer == "/obstacles/0" and "'size'" in p.message


def test_box_obstacle_corners() -> None:
    doc = base()
    doc["obstacles"] = [{"type": "box", "center": [5, 1], "size": [2, 1], "angle": 90}]
    poly = parse_world(doc).obstacles[0].polygon()
    assert poly is not None
    xs, ys = [p[0] for p in poly], [p[1] for p in poly]
    assert (min(xs), max(xs), min(ys), max(ys)) == pytest.approx((4.5, 5.5, 0, 2))
    assert math.isclose(abs(poly[0][0] - 5.5), 0, abs_tol=1e-9) or math.isclose(poly[0][0], 4.5)


def test_car_file_replaces_the_worlds_car(tmp_path: Path) -> None:
    from fsm.sim.world import load_car

    car_path = tmp_path / "car.json"
    car_path.write_text(json.dumps({"wheelbase": 0.3, "ultrasonic": {"noise": 0.0, "rate": 10}}))
    path, _ = write(tmp_path, base())
    world = load_world(path, car=car_path)
    assert world.car.wheelbase == 0.3 and world.car.ultrasonic.rate == 10 and world.car.length == 0.40
    car_path.write_text(json.dumps({"wheelbase": 0.5, "length": 0.4}, indent=1))
    with pytest.raises(DiagramError) as err:
        load_car(car_path)
    (p,) = err.value.problems
    assert "shorter than the body" in p.message and p.file == str(car_path)
