"""``fsmctl graph``: Mermaid, DOT and SVG with nesting."""

from __future__ import annotations

import json
from pathlib import Path
from xml.etree import ElementTree

from fsm.tools import graph
from fsm.tools.cli import main

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
