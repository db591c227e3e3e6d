"""Sequences drawn in UMLet: steps are boxes inside the Sequence box, in the order of the arrows from its initial
marker; non-blocking sequences hang off the step they follow; unconnected Sequence boxes are exception sequences.
Export and convert round-trip; forks, cycles and loose steps are located errors."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from fsm.tools.umlet.writer import diagram, element, relation
from helpers import cli, plain_document

REPO = Path(__file__).resolve().parents[1]



@pytest.mark.parametrize("machine", ["diagrams/examples/sorter.json", "diagrams/mission.json"])
def test_export_draws_the_steps_and_convert_reads_them_back(machine: str, tmp_path: Path,
                                                            capsys: pytest.CaptureFixture[str]) -> None:
    uxf, back = tmp_path / "m.uxf", tmp_path / "m.json"
    assert cli(capsys, "export", str(REPO / machine), "-o", str(uxf))[0] == 0
    text = uxf.read_text()
    doc = json.loads((REPO / machine).read_text())
    first = doc["states"][0]
    for step in first["steps"]:
        assert f"<panel_attributes>{step['id']}\n" in text  # a box per step, not a JSON list in one box
    assert "steps=" not in text
    code, _out, err = cli(capsys, "convert", str(uxf), "-o", str(back))
    assert code == 0, err
    assert plain_document(json.loads(back.read_text())) == plain_document(doc)


def _sequence_diagram(extra: list[str]) -> str:
    """A Sequence box 'seq' holding an initial marker and steps a -> b (Wait), plus ``extra`` elements."""
    return diagram([
        element("UMLSpecialState", 100, 10, 20, 20, "type=initial"),
        relation([[110, 30], [110, 60]], "lt=->"),
        element("UMLState", 20, 60, 420, 420, 'seq\n--\n"type": "Sequence"\nvalign=top'),
        element("UMLSpecialState", 60, 110, 20, 20, "type=initial"),
        relation([[70, 130], [70, 160]], "lt=->"),
        element("UMLState", 40, 160, 120, 40, 'a\n--\n"type": "Wait"\nseconds=1'),
        relation([[70, 200], [70, 260]], "lt=->"),
        element("UMLState", 40, 260, 120, 40, 'b\n--\n"type": "Wait"\nseconds=1'),
        *extra,
    ])


def _convert(tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str) -> tuple[int, str, Any]:
    uxf = tmp_path / "s.uxf"
    uxf.write_text(text)
    out = tmp_path / "s.json"
    code, _o, err = cli(capsys, "convert", str(uxf), "-o", str(out))
    return code, err, json.loads(out.read_text()) if code == 0 else None


def test_a_hand_drawn_sequence_converts(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, err, doc = _convert(tmp_path, capsys, _sequence_diagram([
        element("UMLState", 240, 160, 160, 80, 'oops\n--\n"type": "Sequence"\nvalign=top'),
        element("UMLSpecialState", 260, 190, 20, 20, "type=initial"),
        relation([[270, 210], [270, 225]], "lt=->"),
        element("UMLState", 250, 225, 100, 10, 'o1\n--\n"type": "Step"'),
    ]))
    assert code == 0, err
    seq = doc["states"][0]
    assert [s["id"] for s in seq["steps"]] == ["a", "b"]
    assert [e["id"] for e in seq["exceptions"]] == ["oops"]


def test_a_fork_between_steps_is_a_located_error(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, err, _ = _convert(tmp_path, capsys, _sequence_diagram([
        relation([[160, 180], [260, 180], [260, 360]], "lt=->"),
        element("UMLState", 200, 360, 120, 40, 'c\n--\n"type": "Wait"\nseconds=1'),
    ]))
    assert code == 1
    assert "step 'a' of sequence 'seq' has arrows to several steps: 'b', 'c'" in err
    assert "s.uxf:" in err and "x=40, y=160" in err


def test_a_cycle_and_a_loose_step_are_located_errors(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, err, _ = _convert(tmp_path, capsys, _sequence_diagram([
        relation([[160, 280], [200, 280], [200, 180], [160, 180]], "lt=->"),
        element("UMLState", 240, 360, 120, 40, 'loose\n--\n"type": "Wait"\nseconds=1'),
    ]))
    assert code == 1
    assert "the steps of sequence 'seq' form a cycle: 'b' -> 'a'" in err
    assert "step 'loose' of sequence 'seq' is not on the chain of steps" in err
