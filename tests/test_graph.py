"""``fsmctl graph``: Mermaid, DOT and SVG with nesting."""

from __future__ import annotations

import json
from pathlib import Path
from xml.etree import ElementTree

from fsm.tools import graph
from fsm.tools.cli import main
from helpers import CORPUS

MISSION = Path(__file__).resolve().parents[1] / "diagrams" / "examples" / "drive.json"


def doc():
    return json.loads(MISSION.read_text())


def test_mermaid_nests_the_composite():
    text = graph.mermaid(doc())
    assert text.startswith("stateDiagram-v2")
    assert 'state "drive" as s2 {' in text and "[*] --> s1" in text
    assert "s1 --> s2 : go" in text and "Finished outcome=arrived" in text


def test_dot_has_a_cluster_per_composite():
    text = graph.dot(doc())
    assert "subgraph cluster_" in text and "lhead=cluster_" in text and text.rstrip().endswith("}")


def test_svg_is_wellformed_and_draws_every_state(tmp_path, capsys):
    out = tmp_path / "m.svg"
    assert main(["graph", str(MISSION), "--format", "svg", "-o", str(out)]) == 0
    root = ElementTree.parse(out).getroot()
    texts = " ".join(t.text or "" for t in root.iter("{http://www.w3.org/2000/svg}text"))
    for sid in ("wait", "drive", "accelerate", "cruise", "arrived", "blocked", "succeeded", "failed"):
        assert sid in texts
    assert len(list(root.iter("{http://www.w3.org/2000/svg}polyline"))) >= 7 + 2  # transitions + initial arrows


def test_graph_of_a_uxf_file(capsys):
    assert main(["graph", str(MISSION.with_suffix(".uxf"))]) == 0
    assert "stateDiagram-v2" in capsys.readouterr().out


# -- SVG: nesting, labels, text ----------------------------------------------------------------------------------
import itertools  # noqa: E402
import os  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402

import pytest  # noqa: E402

NS = "{http://www.w3.org/2000/svg}"
ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "diagrams" / "examples"
CORPUS_UXF = CORPUS / "Belinus-code__Garagen-Controller__Zustandsdiagramm.uxf"


def _load(path: Path) -> dict:
    if path.suffix == ".uxf":
        from fsm.tools.umlet.reader import convert_file

        return convert_file(path).machines[0]
    return json.loads(path.read_text())


def _svg_of(path: Path) -> ElementTree.Element:
    return ElementTree.fromstring(graph.svg(_load(path), base=path.parent))


def _rect(el) -> tuple[float, float, float, float]:
    return tuple(float(el.get(k)) for k in ("x", "y", "width", "height"))


def _overlap(a, b) -> bool:
    return min(a[0] + a[2], b[0] + b[2]) - max(a[0], b[0]) > 0.01 and \
        min(a[1] + a[3], b[1] + b[3]) - max(a[1], b[1]) > 0.01


def _inside(a, b) -> bool:
    return a[0] >= b[0] - 0.01 and a[1] >= b[1] - 0.01 and a[0] + a[2] <= b[0] + b[2] + 0.01 \
        and a[1] + a[3] <= b[1] + b[3] + 0.01


def _nodes(root) -> dict[str, tuple[str, tuple[float, float, float, float], list]]:
    """Every drawn state box: data-id -> (class, its rectangle, its texts), the first drawn for an id."""
    out = {}
    for g in root.iter(NS + "g"):
        cls = g.get("class", "")
        if "node" in cls.split():
            out.setdefault(g.get("data-id"), (cls, _rect(g.find(NS + "rect")), g.findall(NS + "text")))
    return out


DRAWN = [EXAMPLES / "mission.json", EXAMPLES / "drive.json", EXAMPLES / "blinker.json",
         ROOT / "diagrams" / "hallway_lap.json", ROOT / "diagrams" / "corner_turn.json"] \
    + ([CORPUS_UXF] if CORPUS_UXF.is_file() else [])


def test_svg_draws_the_regions_of_a_parallel_state_and_its_included_machine():
    root = _svg_of(EXAMPLES / "mission.json")
    nodes = _nodes(root)
    texts = [t.text for t in root.iter(NS + "text")]
    assert "work" in texts and "monitor" in texts  # the region names
    run = nodes["run"][1]
    for sid in ("approach", "grip", "retreat", "done", "failed", "watch", "stopped"):  # the regions' states
        assert _inside(nodes[sid][1], run), sid
    grip = nodes["grip"][1]
    for sid in ("closing", "holding", "gave_up"):  # grip.json, drawn inside the state that includes it
        assert _inside(nodes[sid][1], grip), sid
    assert "grip.json" in texts
    dashed = [ln for ln in root.iter(NS + "line") if ln.get("stroke-dasharray")]
    assert len(dashed) == 1 and run[0] < float(dashed[0].get("x1")) < run[0] + run[2]  # between the two regions
    # each region has its initial marker: three filled circles inside 'run' (work, monitor, grip)
    markers = [c for c in root.iter(NS + "circle") if c.get("fill") == "#333" and float(c.get("r")) > 5
               and _inside((float(c.get("cx")), float(c.get("cy")), 0, 0), run)]
    assert len(markers) == 3


def test_svg_regions_do_not_overlap_and_hold_their_states():
    root = _svg_of(EXAMPLES / "mission.json")
    nodes = _nodes(root)
    work = [nodes[s][1] for s in ("approach", "grip", "retreat", "done", "failed")]
    monitor = [nodes[s][1] for s in ("watch", "stopped")]
    assert max(r[0] + r[2] for r in work) < min(r[0] for r in monitor)


def test_a_missing_include_is_a_box_with_a_note(tmp_path):
    doc = {"name": "m", "initial": "a", "states": [
        {"id": "a", "type": "FSMState", "machine": {"file": "nope.json"}},
        {"id": "p", "type": "Parallel", "regions": [{"file": "gone.json"}, {"file": "grip.json"}]},
        {"id": "b", "type": "Final"}],
        "transitions": [{"type": "Finished", "from": "a", "to": "p"}, {"type": "Finished", "from": "p", "to": "b"}]}
    (tmp_path / "grip.json").write_text((EXAMPLES / "grip.json").read_text())
    root = ElementTree.fromstring(graph.svg(doc, base=tmp_path))
    texts = " ".join(t.text or "" for t in root.iter(NS + "text"))
    assert "nope.json: not found" in texts and "gone.json: not found" in texts
    assert "closing" in texts  # the region that could be read is drawn
    # without the document's folder nothing is opened, and nothing fails
    texts = " ".join(t.text or "" for t in ElementTree.fromstring(graph.svg(doc)).iter(NS + "text"))
    assert "nope.json (not opened)" in texts


def test_an_include_cycle_is_drawn_not_followed(tmp_path):
    (tmp_path / "a.json").write_text(json.dumps({"name": "a", "initial": "x", "states": [
        {"id": "x", "type": "FSMState", "machine": {"file": "a.json"}}, {"id": "y", "type": "Final"}],
        "transitions": [{"type": "Finished", "from": "x", "to": "y"}]}))
    text = graph.svg(json.loads((tmp_path / "a.json").read_text()), base=tmp_path)
    assert "include cycle" in text


def test_a_machine_included_many_times_is_drawn_once():
    root = _svg_of(ROOT / "diagrams" / "hallway_lap.json")
    texts = [t.text for t in root.iter(NS + "text")]
    assert texts.count("lap.json, drawn in lap1") == 2  # lap2, lap3
    assert texts.count("arc") == 1  # turn_left.json: once, in lap1/bottom_turn
    assert texts.count("turn_left.json, drawn in lap1/bottom_turn") == 3


@pytest.mark.parametrize("path", DRAWN, ids=lambda p: p.name[:30])
def test_labels_overlap_neither_each_other_nor_boxes(path):
    root = _svg_of(path)
    doc = _load(path)
    labels = [_rect(r) for r in root.iter(NS + "rect") if r.get("class") == "label"]
    assert len(labels) >= len(doc["transitions"])  # one per arrow (nested ones too)
    for a, b in itertools.combinations(labels, 2):
        assert not _overlap(a, b), (a, b)
    for cls, box, _ in _nodes(root).values():
        for lab in labels:
            if "composite" in cls:  # a label is inside a composite (its arrow's box) or outside it, never across
                assert _inside(lab, box) or not _overlap(lab, box), (box, lab)
            else:
                assert not _overlap(lab, box), (box, lab)


def _text_extent(t) -> tuple[float, float]:
    size = float(t.get("font-size", graph.FONT))
    w = graph.text_width(t.text or "", size, bold=t.get("font-weight") == "bold")
    x = float(t.get("x"))
    anchor = t.get("text-anchor", "start")
    return (x - w / 2, x + w / 2) if anchor == "middle" else (x - w, x) if anchor == "end" else (x, x + w)


@pytest.mark.parametrize("path", DRAWN + [ROOT / "diagrams" / "lap.json", ROOT / "diagrams" / "lane_change.json"],
                         ids=lambda p: p.name[:30])
def test_every_text_fits_its_box(path):
    nodes = _nodes(_svg_of(path))
    assert nodes
    for sid, (_cls, (x, _y, w, _h), texts) in nodes.items():
        for t in texts:
            left, right = _text_extent(t)
            assert x <= left and right <= x + w, (sid, t.text, left, right, x, x + w)


def test_a_final_state_named_after_its_outcome_is_not_written_twice():
    texts = [t.text for t in _svg_of(EXAMPLES / "drive.json").iter(NS + "text")]
    assert "succeeded" in texts and "succeeded → succeeded" not in texts
    assert any(t and t.startswith("failed → aborted") for t in texts)


def test_parallel_arrows_are_drawn_apart():
    root = _svg_of(EXAMPLES / "mission.json")
    polylines = [p.get("points") for p in root.iter(NS + "polyline") if p.get("class") == "edge"]
    assert len(polylines) == len(set(polylines))
    doc = _load(EXAMPLES / "mission.json")
    graph_doc = {**doc, "transitions": doc["transitions"] + [
        {"type": "Timeout", "from": "wait_start", "to": "run", "seconds": s} for s in (1, 2, 3)]}
    root = ElementTree.fromstring(graph.svg(graph_doc, base=EXAMPLES))
    polylines = [p.get("points") for p in root.iter(NS + "polyline") if p.get("class") == "edge"]
    assert len(polylines) == len(set(polylines))


def test_stored_layout_is_kept():
    doc = _load(EXAMPLES / "drive.json")
    nodes = _nodes(ElementTree.fromstring(graph.svg(doc, base=EXAMPLES)))
    for st in doc["states"] + doc["states"][1]["machine"]["states"]:
        lay = st["layout"]
        assert nodes[st["id"]][1] == (lay["x"], lay["y"], lay["w"], lay["h"])


def test_stored_layout_makes_room_for_included_content():
    doc = _load(ROOT / "diagrams" / "hallway_lap.json")
    nodes = _nodes(_svg_of(ROOT / "diagrams" / "hallway_lap.json"))
    top = [nodes[st["id"]][1] for st in doc["states"] if st["id"] != "done"]  # ('done' is in lap.json too)
    assert top[0][3] > doc["states"][0]["layout"]["h"]  # lap1 grew to hold lap.json
    for a, b in itertools.combinations(top, 2):
        assert not _overlap(a, b)
    order = [(r[0], r[1]) for r in top]
    assert order == sorted(order)  # the diagram's order, read column by column (issue 33: not one tall column)


def test_svg_is_deterministic_across_processes():
    code = ("import json, sys; from pathlib import Path; from fsm.tools import graph; "
            "p = Path(sys.argv[1]); sys.stdout.write(graph.svg(json.loads(p.read_text()), base=p.parent))")
    outs = set()
    for seed in ("1", "2"):
        env = {**os.environ, "PYTHONHASHSEED": seed}
        outs.add(subprocess.run([sys.executable, "-c", code, str(EXAMPLES / "mission.json")], env=env,
                                capture_output=True, check=True, text=True).stdout)
    assert len(outs) == 1
    assert outs.pop() == graph.svg(_load(EXAMPLES / "mission.json"), base=EXAMPLES)


def test_graph_cli_draws_parallel_regions(tmp_path):
    out = tmp_path / "mission.svg"
    assert main(["graph", str(EXAMPLES / "mission.json"), "--format", "svg", "-o", str(out)]) == 0
    root = ElementTree.parse(out).getroot()
    texts = [t.text for t in root.iter(NS + "text")]
    assert "work" in texts and "monitor" in texts
    nodes = _nodes(root)
    for sid in ("approach", "grip", "watch", "stopped"):
        assert _inside(nodes[sid][1], nodes["run"][1])


def test_text_width_estimate_grows_with_text_and_size():
    assert graph.text_width("", 12) == 0
    assert graph.text_width("iii", 12) < graph.text_width("MMM", 12)
    assert graph.text_width("abc", 24) == 2 * graph.text_width("abc", 12)
    assert graph.text_width("abc", 12, bold=True) > graph.text_width("abc", 12)
    assert graph.text_width("Öffnen", 12) > 0 and graph.text_width("状態", 12) == 24


def test_svg_base_may_be_the_document_file_or_its_folder():
    doc = _load(EXAMPLES / "mission.json")
    assert graph.svg(doc, base=EXAMPLES / "mission.json") == graph.svg(doc, base=EXAMPLES)


# -- big machines (issue 8, item 9; timing is in benchmarks/bench_graph.py, never here) ---------------------------
def _overlapping_pairs(rects: list[tuple[float, float, float, float]]) -> list[tuple[int, int]]:
    """Pairs of rectangles that overlap, by a sweep along x (all pairs would take too long here)."""
    order = sorted(range(len(rects)), key=lambda i: rects[i][0])
    out, active = [], []
    for i in order:
        active = [j for j in active if rects[j][0] + rects[j][2] > rects[i][0] + 0.01]
        out += [(j, i) for j in active if _overlap(rects[i], rects[j])]
        active.append(i)
    return out


@pytest.mark.parametrize("stored", [False, True], ids=["layered", "stored-grid"])
def test_a_machine_of_2000_states_is_drawn_with_every_label_clear_of_boxes_and_labels(stored):
    n = 2000
    doc = {"name": "big", "initial": "s0", "states": [{"id": f"s{i}", "type": "Idle"} for i in range(n)],
           "transitions": [{"type": "Timeout", "from": f"s{i}", "to": f"s{(i + 1) % n}", "seconds": 0.5}
                           for i in range(n)]}
    if stored:
        for i, st in enumerate(doc["states"]):
            st["layout"] = {"x": 20 + (i % 45) * 200, "y": 80 + (i // 45) * 120, "w": 120, "h": 40}
    root = ElementTree.fromstring(graph.svg(doc))
    boxes = [box for _cls, box, _ in _nodes(root).values()]
    labels = [_rect(r) for r in root.iter(NS + "rect") if r.get("class") == "label"]
    assert len(boxes) == n and len(labels) == n
    assert _overlapping_pairs(labels) == []
    crossing = [(a, b) for a, b in _overlapping_pairs(boxes + labels) if a < n <= b or b < n <= a]
    assert crossing == []
