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


def _drawn(template: str, kind: str, tmp_path: Path) -> Path:
    """A two-state machine exported as UMLet, with the palette's ``template`` text pasted as a user drops it: into
    state ``a``'s box (its id line kept) or onto the arrow from ``a`` to ``b``."""
    from xml.sax.saxutils import escape

    from fsm.tools.cli import main

    doc = tmp_path / "two.json"
    doc.write_text('{"name": "two", "initial": "a", "states": [{"id": "a", "type": "Idle"}, {"id": "b", "type": '
                   '"Idle"}], "transitions": [{"type": "Always", "from": "a", "to": "b"}]}', encoding="utf-8")
    drawn = tmp_path / f"{kind}.uxf"
    assert main(["export", str(doc), "-o", str(drawn)]) == 0
    text = drawn.read_text(encoding="utf-8")
    if kind == "state":
        old, new = "<panel_attributes>a</panel_attributes>", "a\n" + template.split("\n", 1)[1]
    else:  # the second arrow: the first is the initial marker's
        at = text.index("<panel_attributes>lt=-&gt;</panel_attributes>") + 1
        old = "<panel_attributes>lt=-&gt;</panel_attributes>"
        text, new = text[:at] + text[at:].replace(old, "\0", 1), template
        old = "\0"
    assert old in text
    drawn.write_text(text.replace(old, f"<panel_attributes>{escape(new)}</panel_attributes>", 1), encoding="utf-8")
    return drawn


def test_a_template_dropped_into_a_machine_has_no_problem_with_its_empty_slots(tmp_path: Path) -> None:
    """The palette shows a parameter without a default as ``name=null``, ready for a value; dropped into a machine
    as it is, that line is the parameter left out: no "may not be null", no text value "null" (FollowWall's
    ``clear``, ``snap`` and ``max_angle``; Finished's ``outcome``)."""
    from fsm.loading.loader import check

    raw = parse_raw(PALETTE.read_bytes(), "palette.uxf")
    tried = 0
    for e in raw.elements:
        empty = [line[:-len("=null")] for line in e.text.splitlines() if line.endswith("=null")]
        if not empty or e.kind not in ("UMLState", "Relation"):
            continue
        kind = "state" if e.kind == "UMLState" else "transition"
        (tmp_path / str(tried)).mkdir()
        _spec, problems = check(_drawn(e.text, kind, tmp_path / str(tried)))
        said = [f"{p.pointer} {p.message}" for p in problems]
        for key in empty:
            assert not [s for s in said if f"/{key} " in s or f"'{key}'" in s or "null" in s], (e.text, said)
        tried += 1
    assert tried >= 10  # FollowWall, Finished, SensorLevel, ... (13 today)
