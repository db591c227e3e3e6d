"""The SVG drawings are legible (issue 24, item 7): counted with :mod:`fsm.tools.graph.quality`."""

from __future__ import annotations

import json
from pathlib import Path
from xml.etree import ElementTree

import pytest

from fsm.tools import graph
from fsm.tools.graph.labels import LABEL_FONT, LABEL_MAX_W, edge_label, short_edge_label, text_width
from fsm.tools.graph.layout import lay_out
from fsm.tools.graph.quality import measure

ROOT = Path(__file__).resolve().parents[1]
NS = "{http://www.w3.org/2000/svg}"
OURS = [p for p in sorted((ROOT / "diagrams").rglob("*.json"))
        if ".scenario" not in p.name and "worlds" not in p.parts]


@pytest.mark.parametrize("path", OURS, ids=lambda p: str(p.relative_to(ROOT / "diagrams")))
def test_our_diagrams_draw_without_overlaps_or_arrows_through_boxes(path):
    q = measure(graph.svg(json.loads(path.read_text()), base=path))
    assert q.boxes > 0
    assert (q.box_overlaps, q.label_box, q.label_label, q.edge_through_box, q.along) == (0, 0, 0, 0, 0), q


def _svg(body: str) -> str:
    return f'<svg xmlns="http://www.w3.org/2000/svg">{body}</svg>'


def test_the_metric_counts_each_kind_of_fault():
    box = '<g class="node" data-path="{p}"><rect x="{x}" y="{y}" width="100" height="40"/></g>'
    body = box.format(p="a", x=0, y=0) + box.format(p="b", x=50, y=20) + box.format(p="c", x=300, y=0) \
        + box.format(p="d", x=600, y=0)
    body += ('<g class="level" data-in=""><polyline class="edge" points="100,10 600,10"/>'  # a -> d through c
             '<polyline class="edge" points="350,-50 350,100"/>'  # crosses it (and runs through c)
             '<polyline class="edge" points="900,0 900,300"/><polyline class="edge" points="900,100 900,200"/></g>')
    label = '<g class="label" data-in=""><rect class="label" x="{x}" y="{y}" width="60" height="15"/></g>'
    body += label.format(x=420, y=100) + label.format(x=440, y=105) + label.format(x=90, y=30)
    q = measure(_svg(body))
    assert (q.box_overlaps, q.edge_through_box, q.label_label, q.label_box, q.crossings, q.along) == (1, 2, 1, 1, 1, 1)


def test_a_composite_and_its_content_are_not_an_overlap_but_its_title_band_is_no_place_for_a_label():
    body = ('<g class="node composite" data-path="c"><rect x="0" y="0" width="300" height="200"/>'
            '<line x1="0" y1="26" x2="300" y2="26"/></g>'
            '<g class="node" data-path="c/a"><rect x="20" y="50" width="100" height="40"/></g>'
            '<g class="label" data-in="c"><rect class="label" x="150" y="120" width="60" height="15"/></g>'
            '<g class="label" data-in="c"><rect class="label" x="150" y="5" width="60" height="15"/></g>')
    q = measure(_svg(body))
    assert (q.box_overlaps, q.label_box) == (0, 1)


def _boxes(doc, base=None):
    root = ElementTree.fromstring(graph.svg(doc, base=base))
    out = {}
    for g in root.iter(NS + "g"):
        r = g.find(NS + "rect")
        if g.get("data-path") and r is not None:
            out[g.get("data-path")] = tuple(float(r.get(k)) for k in ("x", "y", "width", "height"))
    return out, root


def _row(stored_points):
    lay = {"a": (0, 0), "b": (200, 0), "c": (400, 0)}
    states = [{"id": s, "type": "Idle", "layout": {"x": x, "y": y, "w": 120, "h": 40}} for s, (x, y) in lay.items()]
    return {"name": "row", "initial": "a", "states": states,
            "transitions": [{"type": "Timeout", "seconds": 1.0, "from": "a", "to": "c",
                             "layout": {"points": stored_points}},
                            {"type": "Timeout", "seconds": 1.0, "from": "a", "to": "b"}]}


def test_an_arrow_drawn_through_a_box_is_routed_around_it_and_a_clear_one_keeps_its_bends():
    through = [[120, 20], [400, 20]]  # straight through b
    q = measure(graph.svg(_row(through)))
    assert q.edge_through_box == 0 and q.box_overlaps == 0
    around = [[60, 40], [60, 100], [460, 100], [460, 40]]  # below b: valid, kept as drawn
    _, root = _boxes(_row(around))
    lines = [pl.get("points") for pl in root.iter(NS + "polyline") if pl.get("class") == "edge"]
    assert "60,40 60,100 460,100 460,40" in lines


def test_an_arrow_between_boxes_that_overlap_is_drawn_as_it_is():
    doc = _row([[60, 20], [460, 20]])
    doc["states"][2]["layout"] = {"x": 0, "y": 0, "w": 120, "h": 40}  # c on top of a, b between them
    doc["states"][1]["layout"] = {"x": 40, "y": 10, "w": 30, "h": 20}
    doc["transitions"][0]["layout"]["points"] = [[0, 20], [120, 20]]
    q = measure(graph.svg(doc))
    assert q.boxes == 3 and q.box_overlaps == 3  # drawn as the diagram has it, without a route


def test_the_umlet_placement_keeps_stored_points_even_through_a_box():
    through = [[120, 20], [400, 20]]
    level = lay_out(_row(through), lambda st: [str(st["id"])])  # what the UMLet writer uses (not drawing)
    assert level.edges[0].points == through


def test_an_expanded_include_does_not_push_its_neighbours_far_away():
    path = ROOT / "diagrams" / "gate_run.json"
    boxes, _ = _boxes(json.loads(path.read_text()), base=path)
    side1, look, view = boxes["side1"], boxes["look"], boxes["view"]
    gap = look[0] - (side1[0] + side1[2])
    assert 0 < gap <= 120  # beside the grown side1 (it was 590 px further right and 1,190 px lower)
    assert look[1] < side1[1] + side1[3] and view[1] < side1[1] + side1[3]  # still level with it


def test_a_long_label_is_shortened_with_the_full_text_on_hover():
    tr = {"type": "SensorLevel", "from": "slow", "to": "view", "sensor": "front", "below": 1.2, "samples": 2,
          "guard": {"type": "Sensor", "sensor": "left", "below": 2.5}}
    short = short_edge_label(tr)
    assert short.startswith("SensorLevel sensor=front") and short.endswith("…")
    assert text_width(short, LABEL_FONT) <= LABEL_MAX_W < text_width(edge_label(tr), LABEL_FONT)
    assert short_edge_label({"type": "Finished", "outcome": "wide"}) == "Finished outcome=wide"
    uml = {"type": "Event", "label": "a very long UML label / with an action = " + "x + " * 40 + "1"}
    assert short_edge_label(uml).endswith("…") and text_width(short_edge_label(uml), LABEL_FONT) <= LABEL_MAX_W
    doc = {"initial": "a", "states": [{"id": "a", "type": "Idle"}, {"id": "b", "type": "Idle"}],
           "transitions": [dict(tr, **{"from": "a", "to": "b"})]}
    root = ElementTree.fromstring(graph.svg(doc))
    label = next(g for g in root.iter(NS + "g") if g.get("class") == "label")
    assert label.find(NS + "title").text == edge_label(tr)
    assert "guard" not in " ".join(t.text or "" for t in label.iter(NS + "text"))


def _scatter(seed):
    """A diagram of up to 12 boxes at random places, arrows between random pairs, half of them drawn straight."""
    import random

    r = random.Random(seed)
    n = r.randint(2, 12)
    states = [{"id": f"s{i}", "type": "Idle",
               "layout": {"x": r.randrange(0, 800, 10), "y": r.randrange(0, 800, 10), "w": r.choice([40, 120, 150]),
                          "h": r.choice([20, 40, 90])}} for i in range(n)]
    trs = []
    for _ in range(r.randint(1, 2 * n)):
        a, b = r.randrange(n), r.randrange(n)
        tr = {"type": "Timeout", "seconds": 1.0, "from": f"s{a}", "to": f"s{b}"}
        if r.random() < 0.5:
            la, lb = states[a]["layout"], states[b]["layout"]
            tr["layout"] = {"points": [[la["x"] + la["w"], la["y"] + 5], [lb["x"], lb["y"] + 5]]}
        trs.append(tr)
    return {"initial": "s0", "states": states, "transitions": trs}


def test_random_diagrams_draw_and_where_no_boxes_overlap_no_arrow_runs_through_one():
    routed = 0
    for seed in range(20):
        q = measure(graph.svg(_scatter(seed)))
        if q.box_overlaps == 0:
            assert q.edge_through_box == 0, seed
            routed += 1
    assert routed >= 5  # enough of them have boxes clear of each other for this to say something
