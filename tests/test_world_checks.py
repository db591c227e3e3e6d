"""World files: degenerate obstacle polygons, gates that share a marker id, a start outside the hallway and a
heading that is not finite are located errors before any run; every problem of a file at once."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fsm import DiagramError
from fsm.sim.world import load_world, parse_world, polygon_problem

LOOP = [{"points": [[0, 0], [20, 0], [20, 10], [0, 10]], "closed": True},
        {"points": [[2, 2], [18, 2], [18, 8], [2, 8]], "closed": True}]


def world(**changes: Any) -> dict[str, Any]:
    doc: dict[str, Any] = {"walls": json.loads(json.dumps(LOOP)), "start": {"x": 10, "y": 1, "heading": 0}}
    doc.update(changes)
    return doc


def problems_of(doc: dict[str, Any]) -> list[Any]:
    with pytest.raises(DiagramError) as info:
        parse_world(doc, "w.json")
    return info.value.problems


def test_the_loop_is_fine() -> None:
    parse_world(world(), "w.json")


# -- polygons -----------------------------------------------------------------------------------------------
@pytest.mark.parametrize(("points", "words"), [
    ([[5, 1], [5, 1], [6, 1]], "3 different corners"),
    ([[5, 1], [6, 1], [5, 1], [6, 1]], "3 different corners"),
    ([[4, 1], [5, 1], [6, 1]], "no area"),
    ([[4, 0.5], [6, 1.5], [6, 0.5], [4, 1.5]], "intersects itself"),
    ([[4, 0.5], [5, 1], [6, 0.5], [6, 1.5], [5, 1], [4, 1.5]], "corner twice"),
])
def test_degenerate_obstacle_polygons_are_errors(points: list[list[float]], words: str) -> None:
    doc = world(obstacles=[{"type": "box", "center": [5, 9], "size": [0.5, 0.5]},
                           {"type": "polygon", "points": points}])
    [p] = problems_of(doc)
    assert p.pointer == "/obstacles/1/points" and words in p.message and p.hint
    assert p.element == "obstacle 1 (polygon)"


def test_a_proper_polygon_in_either_orientation_is_fine() -> None:
    for pts in ([[4, 0.5], [6, 0.5], [6, 1.5], [4, 1.5]], [[4, 1.5], [6, 1.5], [6, 0.5], [4, 0.5]],
                [[4, 0.5], [6, 0.5], [6, 0.5], [5, 1.5]]):  # a repeated neighbour is just one corner
        parse_world(world(start={"x": 10, "y": 1}, obstacles=[{"type": "polygon", "points": pts}]), "w.json")


@settings(max_examples=300, deadline=None)
@given(st.sets(st.tuples(st.integers(-4, 4), st.integers(-4, 4)), min_size=3, max_size=8))
def test_polygon_check_on_random_corners(corners: set[tuple[int, int]]) -> None:
    """Corners sorted by angle around their centroid form a simple polygon: accepted unless they lie on one line;
    the check never raises."""
    import math

    pts = [(float(x), float(y)) for x, y in corners]
    cx = sum(p[0] for p in pts) / len(pts)
    cy = sum(p[1] for p in pts) / len(pts)
    angles = [math.atan2(p[1] - cy, p[0] - cx) for p in pts]
    if len({round(a, 9) for a in angles}) < len(angles) or any(p == (cx, cy) for p in pts):
        return  # two corners on one ray from the centre: the angular order is not a simple polygon
    ring = [p for _, p in sorted(zip(angles, pts, strict=True))]
    collinear = all(abs((ring[1][0] - ring[0][0]) * (p[1] - ring[0][1]) - (ring[1][1] - ring[0][1])
                        * (p[0] - ring[0][0])) < 1e-12 for p in ring)
    why = polygon_problem(ring)
    if collinear:
        assert why is not None and "one line" in why
    else:
        assert why is None, (ring, why)


# -- gates ----------------------------------------------------------------------------------------------------
def gate(a: int, b: int, x: float = 10, name: str | None = None) -> dict[str, Any]:
    out: dict[str, Any] = {"markers": [a, b], "center": [x, 1]}
    if name:
        out["name"] = name
    return out


def test_two_gates_sharing_a_marker_id() -> None:
    [p] = problems_of(world(gates=[gate(1, 2, 5), gate(3, 2, 15, "exit")]))
    assert p.pointer == "/gates/1/markers/1" and "/gates/0/markers/1" in p.message
    assert p.element == "gate exit"


def test_a_gate_with_one_id_twice() -> None:
    [p] = problems_of(world(gates=[gate(4, 4)]))
    assert p.pointer == "/gates/0/markers/1" and "other marker" in p.message


def test_marker_ids_outside_the_dictionary() -> None:
    [p] = problems_of(world(gates=[gate(1, 50)]))
    assert p.pointer == "/gates/0/markers/1" and "DICT_4X4_50" in p.message


# -- start --------------------------------------------------------------------------------------------------
@pytest.mark.parametrize(("x", "y", "words"), [(-5, 5, "outside every closed wall"), (25, 1, "outside every"),
                                               (10, 5, "walled off by wall 1")])
def test_start_outside_the_hallway(x: float, y: float, words: str) -> None:
    [p] = problems_of(world(start={"x": x, "y": y}))
    assert p.pointer == "/start" and words in p.message


def test_start_inside_an_obstacle() -> None:
    [p] = problems_of(world(obstacles=[{"type": "box", "center": [10, 1], "size": [1.5, 1.5]}]))
    assert p.pointer == "/start" and "obstacle 0" in p.message


def test_open_walls_say_nothing_about_inside() -> None:
    parse_world({"walls": [{"points": [[0, 0], [10, 0]]}], "start": {"x": 5, "y": 3}}, "w.json")


@pytest.mark.parametrize("heading", ["NaN", "Infinity", "-Infinity", "1e400"])
def test_heading_must_be_finite_and_is_located(tmp_path: Path, heading: str) -> None:
    text = '{"walls": [{"points": [[0, 0], [10, 0]]}],\n "start": {"x": 5, "y": 3, "heading": %s}}' % heading
    f = tmp_path / "w.json"
    f.write_text(text)
    with pytest.raises(DiagramError) as info:
        load_world(f)
    [p] = info.value.problems
    assert p.pointer == "/start/heading" and (p.line, p.column) == (2, text.split("\n")[1].index('"heading"') + 1)


def test_all_problems_of_a_world_at_once(tmp_path: Path) -> None:
    doc = world(obstacles=[{"type": "polygon", "points": [[1, 1], [2, 2], [3, 3]]}],
                gates=[gate(7, 7), gate(60, 1, 12)])
    text = json.dumps(doc, indent=2)
    f = tmp_path / "w.json"
    f.write_text(text)
    with pytest.raises(DiagramError) as info:
        load_world(f)
    pointers = sorted(p.pointer for p in info.value.problems)
    assert pointers == ["/gates/0/markers/1", "/gates/1/markers/0", "/obstacles/0/points"]
    assert all(p.line is not None for p in info.value.problems)


def test_null_in_a_world_is_refused() -> None:
    [p] = problems_of(world(name=None))
    assert p.pointer == "/name" and "null" in p.message


def test_shipped_worlds_still_load() -> None:
    root = Path(__file__).resolve().parents[1] / "diagrams" / "worlds"
    for path in sorted(root.glob("*.json")):
        load_world(path)


# -- the camera's field of view (the range calibrations are held to, fsm.vision.camera.FOV_RANGE) -------------
@pytest.mark.parametrize(("camera", "pointers", "words"), [
    ({"fx": 1e-9, "width": 4096, "height": 32}, ["/car/camera/fx", "/car/camera/fx"],
     ["fx = 1e-09 px gives a horizontal field of view of 180 deg at 4096x32; a pinhole camera has 1-179 deg",
      "fx (fy is not set, so also the vertical focal length) = 1e-09 px gives a vertical field of view of 180"]),
    ({"fx": 600, "fy": 100000, "height": 32}, ["/car/camera/fy"], ["fy = 100000 px gives a vertical field of view "
                                                                   "of 0.01833 deg"]),
    ({"fx": 2.7, "width": 640}, ["/car/camera/fx"], ["horizontal field of view of 179 deg"]),
])
def test_a_camera_seeing_180_degrees_or_almost_nothing_is_refused(camera: dict[str, Any], pointers: list[str],
                                                                  words: list[str]) -> None:
    problems = problems_of(world(car={"camera": camera}))
    assert [p.pointer for p in problems] == pointers
    for p, w in zip(problems, words, strict=True):
        assert w in p.message and "use a focal length between" in (p.hint or ""), str(p)


def test_the_edges_of_the_camera_field_of_view_are_fine() -> None:
    for fx in (2.8, 600, 36000):  # 178.997 deg, 56 deg, 1.02 deg horizontally at 640 px
        parse_world(world(car={"camera": {"fx": fx, "fy": 600}}), "w.json")
