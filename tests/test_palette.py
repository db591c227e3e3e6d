"""The committed UMLet palette is what the registry generates now, and every template reads back."""

from __future__ import annotations

from pathlib import Path

from fsm.loading.registry import default_registry
from fsm.tools.umlet.palette import palette
from fsm.tools.umlet.source import parse_raw
from fsm.tools.umlet.text import parse_label, parse_machine_note, parse_relation, parse_state

PALETTE = Path(__file__).resolve().parents[1] / "diagrams" / "TRAL_State-Machine.uxf"


def test_committed_palette_is_not_stale():
    assert PALETTE.read_text(encoding="utf-8") == palette(default_registry()), \
        "regenerate it: fsmctl palette -o diagrams/TRAL_State-Machine.uxf"


def test_every_type_has_a_template_with_every_parameter():
    reg = default_registry()
    raw = parse_raw(palette(reg).encode(), "palette.uxf")
    states, transitions = {}, {}
    for e in raw.elements:
        if e.kind == "UMLState":
            st = parse_state(e.text)
            states[st.params["type"]] = st.params
        elif e.kind == "Relation":
            label = parse_label(parse_relation(e.text).label_lines)
            if label.params:
                transitions[label.params["type"]] = label.params
    assert set(states) == set(reg.states) and set(transitions) == set(reg.transitions)
    from fsm.model.document import param_info

    for name, cls in reg.states.items():
        # drawn inside the box: a Parallel's region frames, a Sequence's step boxes and exception sequences
        drawn = {"regions"} if name == "Parallel" else {"steps", "exceptions"} if name == "Sequence" else set()
        assert {p["name"] for p in param_info(cls.Params)} - drawn <= set(states[name])
    for name, cls in reg.transitions.items():
        for p in param_info(cls.Params):
            assert p["name"] in transitions[name]
            if "default" in p and p["default"] is not None and not isinstance(p["default"], str):
                assert transitions[name][p["name"]] == p["default"]


def test_parallel_template_holds_region_frames_and_the_machine_note_reads():
    raw = parse_raw(palette(default_registry()).encode(), "palette.uxf")
    box = next(e for e in raw.elements if e.kind == "UMLState" and parse_state(e.text).params["type"] == "Parallel")
    frames = [e for e in raw.elements if e.kind == "UMLFrame"]
    assert [f.text for f in frames] == ["region1", "region2"]
    assert all(box.x < f.x and f.x + f.w < box.x + box.w and box.y < f.y and f.y + f.h < box.y + box.h
               for f in frames)
    assert "regions" not in parse_state(box.text).params
    note = next(e for e in raw.elements if e.kind == "UMLNote")
    assert parse_machine_note(note.text).values == {"name": "", "description": ""}
