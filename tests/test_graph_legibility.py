"""Issue 33 item 6: the charts of the live page, the report and ``fsmctl graph`` are legible.

Measured on the rendered SVG (:func:`fsm.tools.graph.quality.measure`): label rectangles against each other, against
state boxes and against arrows; arrow polylines against state boxes (through them, or along their border so close
that they seem to go in). On the hallway lap and the gate run as the live page draws them (from the ``.uxf`` the
user runs), and on real UMLet files from the corpus converted by our converter.
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from xml.etree import ElementTree

import pytest

from fsm.tools import graph
from fsm.tools.graph.quality import measure
from fsm.tools.umlet.reader import convert_file, read_uxf
from helpers import CORPUS

ROOT = Path(__file__).resolve().parents[1]
NS = "{http://www.w3.org/2000/svg}"
CORPUS_FILES = ["Belinus-code__Garagen-Controller__Zustandsdiagramm.uxf",
                "ForceGitE__SoftwareDesign-assignment__statechart.uxf",
                "nastygorodi__PROJECT-Short_Text_Generator__State Machine.uxf"]


def _drawn(path: Path) -> str:
    doc, _ = read_uxf(path)
    return graph.svg(doc, base=path)


def _size(svg: str) -> tuple[float, float]:
    m = re.search(r'<svg [^>]*width="([\d.]+)" height="([\d.]+)"', svg)
    assert m is not None
    return float(m.group(1)), float(m.group(2))


def _boxes(svg: str) -> dict[str, tuple[float, float, float, float]]:
    out = {}
    for g in ElementTree.fromstring(svg).iter(NS + "g"):
        rect = g.find(NS + "rect")
        if g.get("data-path") and rect is not None:
            out[g.get("data-path") or ""] = tuple(float(rect.get(k, "0")) for k in ("x", "y", "width", "height"))
    return out


FAULTS = ("box_overlaps", "edge_through_box", "edge_grazes_box", "label_box", "label_label", "label_stacked",
          "label_edge", "label_close", "parallel_close")


@pytest.mark.parametrize("name", ["hallway_lap.uxf", "lap.uxf", "gate_run.uxf", "gate_side.uxf", "gate_home.uxf",
                                  "mission.uxf", "corner_turn.uxf"])
def test_no_label_over_a_label_box_or_arrow_and_no_arrow_in_a_box(name):
    q = measure(_drawn(ROOT / "diagrams" / name))
    assert q.boxes > 0 and q.labels > 0
    assert {f: getattr(q, f) for f in FAULTS} == dict.fromkeys(FAULTS, 0), q


def test_every_machine_of_ours_as_json_too():
    """The JSON documents the loader reads (their drawing expands includes from files, as the report's does)."""
    for path in sorted((ROOT / "diagrams").rglob("*.json")):
        if ".scenario" in path.name or "worlds" in path.parts:
            continue
        q = measure(graph.svg(json.loads(path.read_text()), base=path))
        assert {f: getattr(q, f) for f in FAULTS} == dict.fromkeys(FAULTS, 0), (path.name, q)


@pytest.mark.parametrize("name", CORPUS_FILES)
def test_real_umlet_files_from_the_corpus(name):
    path = CORPUS / name
    if not path.is_file():
        pytest.skip("corpus file not present")
    conv = convert_file(path)
    for doc in conv.machines:
        q = measure(graph.svg(doc, base=path))
        assert q.boxes > 0
        assert {f: getattr(q, f) for f in FAULTS} == dict.fromkeys(FAULTS, 0), q


def test_the_three_laps_are_not_one_column():
    """The hallway lap was a 470 x 4,070 strip: its laps and the lap's four sides now stand side by side, so the
    chart is about as wide as it is tall and "fit" can show it in a window."""
    svg = _drawn(ROOT / "diagrams" / "hallway_lap.uxf")
    w, h = _size(svg)
    assert h <= 1.2 * w, (w, h)
    boxes = _boxes(svg)
    lap1, lap2, lap3 = boxes["lap1"], boxes["lap2"], boxes["lap3"]
    assert lap2[0] >= lap1[0] + lap1[2] and lap3[0] >= lap1[0] + lap1[2]  # beside the first lap, not below it
    inner = [b for p, b in boxes.items() if p.startswith("lap1/") and p.count("/") == 1]
    assert len({b[0] for b in inner}) >= 3  # the lap's own states in several columns


def test_a_long_chain_without_a_layout_is_set_in_columns():
    states = [{"id": f"s{i}", "type": "Wait", "seconds": 1} for i in range(24)]
    transitions = [{"type": "Finished", "from": f"s{i}", "to": f"s{i + 1}"} for i in range(23)]
    svg = graph.svg({"name": "chain", "initial": "s0", "states": states, "transitions": transitions})
    w, h = _size(svg)
    assert h <= 1.5 * w, (w, h)
    q = measure(svg)
    assert {f: getattr(q, f) for f in FAULTS} == dict.fromkeys(FAULTS, 0), q
    boxes = _boxes(svg)
    assert boxes["s1"][1] > boxes["s0"][1]  # still read top to bottom within a column


def test_a_short_or_wide_diagram_keeps_its_geometry():
    """Only a level much taller than wide is reflowed: the user's own layout of the gate side stays as drawn."""
    path = ROOT / "diagrams" / "gate_side.uxf"
    doc, _ = read_uxf(path)
    boxes = _boxes(graph.svg(doc, base=path))
    for st in doc["states"]:
        lay = st.get("layout")
        if lay:
            assert boxes[st["id"]][:2] == (lay["x"], lay["y"])


def test_the_metric_counts_labels_on_arrows_stacked_labels_and_arrows_along_boxes():
    box = '<g class="node" data-path="{p}"><rect x="{x}" y="{y}" width="100" height="40"/></g>'
    label = '<g class="label" data-in=""><rect class="label" x="{x}" y="{y}" width="60" height="15"/></g>'
    body = box.format(p="a", x=0, y=0) + box.format(p="b", x=300, y=0) + box.format(p="c", x=150, y=100)
    body += ('<g class="level" data-in=""><polyline class="edge" points="100,20 300,20"/>'  # a -> b, clear
             '<polyline class="edge" points="50,40 50,98 480,98"/>'  # along c's top border, 2 px above it
             '</g>')
    body += label.format(x=170, y=12)  # across the arrow a -> b
    body += label.format(x=400, y=200) + label.format(x=400, y=217)  # 2 px apart: one stacked pair
    body += label.format(x=400, y=300) + label.format(x=400, y=330)  # apart
    q = measure(f'<svg xmlns="http://www.w3.org/2000/svg">{body}</svg>')
    assert (q.label_edge, q.label_stacked, q.label_label, q.edge_grazes_box, q.edge_through_box) == (1, 1, 0, 1, 0), q


def test_the_metric_counts_close_labels_and_close_parallel_runs():
    """Labels of different arrows closer than ``LABEL_GAP`` (here 6 px apart, and 2 px: stacked too), and parallel
    runs of two arrows closer than ``SPACING`` (12 px apart), not those at the spacing or on top of each other."""
    label = '<g class="label" data-in=""><rect class="label" x="{x}" y="{y}" width="60" height="15"/></g>'
    lines = '<g class="level" data-in="">' + "".join(
        f'<polyline class="edge" points="{pts}"/>' for pts in (
            "0,300 200,300", "20,312 220,312",  # 12 apart along 180: close
            "0,400 200,400", "0,416 200,416",  # 16 apart: at the spacing
            "0,500 200,500", "50,500 250,500",  # on top of each other: "along", not close
            "0,600 200,600", "0,610 10,640",  # not parallel
        )) + "</g>"
    body = lines + label.format(x=400, y=0) + label.format(x=400, y=21)  # 6 apart
    body += label.format(x=400, y=100) + label.format(x=400, y=117)  # 2 apart: stacked, and close
    body += label.format(x=400, y=200) + label.format(x=470, y=200)  # 10 apart: not close
    q = measure(f'<svg xmlns="http://www.w3.org/2000/svg">{body}</svg>')
    assert (q.parallel_close, q.along, q.label_close, q.label_stacked, q.label_label) == (1, 1, 2, 1, 0), q


def test_the_gate_run_keeps_its_arrows_apart_and_fewer_crossings():
    """The gate run of the last round had two arrows into ``approach`` 8 px apart (their long runs 12 px), two
    "Finished" labels 6 px apart beside ``view``, and 9 crossings; the router's lanes are now ``SPACING`` apart."""
    q = measure(_drawn(ROOT / "diagrams" / "gate_run.uxf"))
    assert (q.parallel_close, q.label_close) == (0, 0), q
    assert q.crossings <= 7, q
