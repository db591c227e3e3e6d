"""What the writer emits is drawn by UMLet as intended, and the reader reads the forms people type.

UMLet offers each line of an element's text to the element's facets; a facet whose key the line starts with
(``line.startsWith(key + "=")``, no trimming: ``KeyValueFacet.checkStart``) consumes it, and a value it does not
accept draws the whole element as a red error box (``NewGridElement.updateModelFromText`` -> ``drawError``).
The facet keys per element kind below come from umlet/umlet, umlet-elements/src/main/java/com/baselet/element:
``facet/Settings.java`` (BASE: bg, transparency, fg, layer, lw, group, ``//``; BASE_WITH_LINETYPE: lt,
``customelement=``; BASE_EXTENDED: fontsize; MANUALRESIZE: valign, halign, style), ``elementnew/uml/State.java``
(+ separators, ``StateTypeFacet`` type=state|sender|receiver, ``SubStateSymbolFacet`` symbol=substate),
``elementnew/uml/SpecialState.java`` (+ ``SpecialStateTypeFacet`` type=initial|final|...),
``elementnew/uml/Note.java`` and ``elementnew/Text.java`` (``SettingsText``: MANUALRESIZE + separators),
``elementnew/uml/Frame.java``, ``relation/facet/SettingsRelation.java`` (``Settings.RELATION``: BASE, fontsize,
lt, m1pos/m2pos/r1pos/r2pos; ``LineDescriptionFacet``: m1=/m2=/r1=/r2= end texts, every other line the middle
label). Newer UMLets add ``link=`` and ``page=`` (``LinkFacet``, ``PageFacet``) and ``cbase=`` on relations.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from fsm.loading.registry import default_registry
from fsm.model.errors import DiagramError
from fsm.tools.umlet.palette import palette
from fsm.tools.umlet.reader import convert_bytes
from fsm.tools.umlet.source import parse_raw
from fsm.tools.umlet.writer import diagram, element, export, relation
from helpers import without_layout as strip

ROOT = Path(__file__).resolve().parents[1]
DIAGRAMS = sorted((ROOT / "diagrams").glob("*.uxf")) + sorted((ROOT / "diagrams" / "examples").glob("*.uxf"))
EXAMPLES = [p for p in sorted((ROOT / "diagrams").glob("*.json"))
            + sorted((ROOT / "diagrams" / "examples").glob("*.json"))
            if not p.name.endswith(".scenario.json")]  # scenarios are not machines
REGISTRY = default_registry()

_BASE = {"bg", "transparency", "fg", "layer", "lw", "group", "link", "page"}
_BOX = _BASE | {"lt", "fontsize", "valign", "halign", "style"}
FACETS = {
    "UMLState": _BOX | {"type", "symbol"},
    "UMLSpecialState": _BOX | {"type"},
    "UMLFrame": _BOX,
    "UMLNote": _BOX,
    "Text": _BOX,
    "Relation": _BASE | {"fontsize", "lt", "m1pos", "m2pos", "r1pos", "r2pos", "cbase", "m1", "m2", "r1", "r2"},
}
#: The facet lines the writer means as facets, per element kind.
INTENDED = {
    "UMLState": {"valign=top"},
    "UMLSpecialState": {"type=initial", "type=final"},
    "UMLFrame": set(),
    "UMLNote": {"style=wordwrap"},
    "Text": {"fontsize=10"},
    "Relation": {"lt=->"},
}


def facet_lines(kind: str, text: str) -> list[str]:
    """The lines of ``text`` that UMLet's facets of ``kind`` consume (comments and separators aside)."""
    out = []
    for line in text.split("\n"):
        if line.startswith("//") or (kind != "Relation" and line in ("-", "--", "-.", "-..")):
            continue
        if line == "customelement=" or any(line.startswith(k + "=") for k in FACETS[kind]):
            out.append(line)
    return out


def stray_facets(uxf: str) -> list[tuple[str, str]]:
    """Facet lines the writer did not mean as facets: UMLet would not draw them as text (or draw an error)."""
    raw = parse_raw(uxf.encode(), "t.uxf")
    bad = []
    for e in raw.elements:
        assert e.kind in FACETS, e.kind
        lines = facet_lines(e.kind, e.text)
        bad += [(e.kind, ln) for ln in lines if ln not in INTENDED[e.kind]]
        if e.kind == "Relation":
            assert lines.count("lt=->") == 1, e.text  # RelationLineTypeFacet: "Only one lineType allowed"
    return bad


def round_trip(doc: dict) -> tuple[str, dict]:
    text = export(doc, REGISTRY)
    machines = convert_bytes(text.encode(), "x.uxf").machines
    assert len(machines) == 1
    return text, machines[0]




# -- what the writer emits ------------------------------------------------------------------------------------
@pytest.mark.parametrize("path", DIAGRAMS, ids=lambda p: p.stem)
def test_committed_diagrams_have_no_line_umlet_takes_for_a_facet(path: Path):
    assert stray_facets(path.read_text(encoding="utf-8")) == []


def test_palette_has_no_line_umlet_takes_for_a_facet():
    assert stray_facets(palette(REGISTRY)) == []


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_exported_examples_have_no_line_umlet_takes_for_a_facet(path: Path):
    assert stray_facets(export(json.loads(path.read_text()), REGISTRY)) == []


def test_a_typed_state_is_written_with_its_type_as_json_and_key_value_parameters():
    doc = {"initial": "follow", "states": [
        {"id": "follow", "type": "FollowWall", "side": "right", "distance": 0.4},
        {"id": "ok", "type": "Final", "outcome": "ok"}],
        "transitions": [{"type": "Timeout", "from": "follow", "to": "ok", "seconds": 2}]}
    text, back = round_trip(doc)
    assert strip(back) == doc
    texts = [e.text for e in parse_raw(text.encode(), "t.uxf").elements]
    assert 'follow\n--\n"type": "FollowWall"\nside=right\ndistance=0.4' in texts
    assert "lt=->\ntype=Timeout\nseconds=2" in texts
    assert "type=final\nok" in texts


AWKWARD = {"lw": 2, "style": "x", "lt": ".", "type_": 1, "symbol": "substate", "m1": "a", "m2pos": "1,1",
           "cbase": "l", "link": "y.uxf", "page": "p", "group": 3, "customelement": "", "größe": 1, "a-b": [1],
           "plain": "text", "n": 1.5}


def test_parameters_named_like_umlet_facets_go_into_the_json_line():
    doc = {"initial": "a", "states": [{"id": "a", "type": "Custom", **AWKWARD}, {"id": "b", "type": "Idle"}],
           "transitions": [{"type": "Custom", "from": "a", "to": "b", **AWKWARD}]}
    text, back = round_trip(doc)
    assert strip(back) == doc
    assert stray_facets(text) == []
    state = next(e.text for e in parse_raw(text.encode(), "t.uxf").elements if e.text.startswith("a\n"))
    assert state.split("\n")[2].startswith('"type": "Custom", "lw": 2, "style": "x", "lt": "."')
    assert "\nplain=text\nn=1.5" in state and "\ntype_=1\n" in state


@pytest.mark.parametrize("name", ["lt=.", "link=x", "page=p", "symbol=substate", "type=sender", "bg=red",
                                  "customelement=", "m1=x"])
def test_names_labels_and_descriptions_that_look_like_facets_round_trip(name):
    doc = {"initial": "a", "states": [{"id": "a", "type": "Idle", "description": name},
                                      {"id": name, "type": "Final", "outcome": name}],
           "transitions": [{"type": "Signal", "from": "a", "to": name, "signal": name, "label": name}]}
    text, back = round_trip(doc)
    assert strip(back) == doc
    assert stray_facets(text) == []


# -- what the reader accepts --------------------------------------------------------------------------------
INIT = element("UMLSpecialState", 100, 20, 20, 20, "type=initial")
START = relation([[110, 40], [110, 80]], "lt=->")


def one_state(text: str) -> dict:
    machines = convert_bytes(diagram([INIT, START, element("UMLState", 60, 80, 120, 60, text)]).encode(),
                             "t.uxf").machines
    return strip(machines[0]["states"][0])


@pytest.mark.parametrize("text", [
    'S\n--\n"type": "Timeout"\nseconds=2',          # what the writer emits
    'S\n--\ntype=Timeout\nseconds=2',              # the key=value form, kept for existing diagrams
    'S\n--\n"type": "Timeout", "seconds": 2',      # TRAL's fragment
    'S\n--\n"type": "Timeout",\n"seconds": 2,',    # over several lines, trailing comma
    'S\n--\n{"type": "Timeout"}\nseconds=2',       # braces
    'S\n--\n"type": "Timeout"\n\nseconds = 2\n',   # blank lines, spaces around =
])
def test_the_type_as_json_or_key_value_with_key_value_parameters(text):
    assert one_state(text) == {"id": "S", "type": "Timeout", "seconds": 2}


def test_json_values_are_typed_key_value_texts_follow_the_parameter_type():
    rel = relation([[110, 140], [110, 200]], 'lt=->\n"type": "Var", "value": "1"\nvar=2')
    doc = convert_bytes(diagram([INIT, START, element("UMLState", 60, 80, 120, 60, "A"),
                                 element("UMLState", 60, 200, 120, 60, "B"), rel]).encode(), "t.uxf").machines[0]
    # var is text: "2" stays text; value is "1" because JSON says so (key=value would have made it 1)
    assert strip(doc["transitions"]) == [{"type": "Var", "from": "A", "to": "B", "value": "1", "var": "2"}]


@pytest.mark.parametrize("shape", ["type=state", "type=State", "type=SENDER", "type=receiver"])
def test_umlets_own_state_shapes_are_not_types_in_any_case(shape):
    assert one_state(f'S\n{shape}\n--\n"type": "Timeout"\nseconds=1') == {"id": "S", "type": "Timeout",
                                                                         "seconds": 1}


@pytest.mark.parametrize("text, message", [
    ('S\n--\n"type": "Timeout", "seconds": 1\nseconds=2', "'seconds' is given twice"),
    ('S\n--\n"type": "Timeout"\nseconds=2\n"x": 1', "is not key=value"),
    ('S\n--\nstray line\ntype=Timeout', "'stray line' is not key=value"),
    ('S\n--\n"type": "Timeout"\n"seconds" 2', "parameter line '\"seconds\" 2' has no colon"),
    ('S\n--\n"type": "Timeout", "seconds": [2', "JSON parameters do not parse"),
])
def test_broken_parameter_blocks_are_located(text, message):
    with pytest.raises(DiagramError) as exc:
        one_state(text)
    (p,) = exc.value.problems
    assert message in p.message and p.line and p.element == "UMLState 'S' at x=60, y=80"


# -- arrows at notes (a UMLNote sticks like any box: default rectangle polygon) ---------------------------------
A_BOX = element("UMLState", 60, 80, 100, 40, "A")
NOTE = element("UMLNote", 300, 80, 120, 40, "calibrate first")


def test_a_solid_arrow_from_a_note_is_a_located_error_not_a_dangling_end():
    with pytest.raises(DiagramError) as exc:
        convert_bytes(diagram([INIT, START, A_BOX, NOTE, relation([[300, 100], [160, 100]], "lt=->")]).encode(),
                      "t.uxf")
    (p,) = exc.value.problems
    assert p.message == ("source end at x=300, y=100 is attached to the note 'calibrate first' at x=300, y=80: "
                         "a note is no state")
    assert "lt=." in p.hint and p.line and p.element.startswith("Relation 'lt=->' at ")


def test_a_dashed_transition_whose_end_is_at_a_state_and_a_note_stays_a_transition():
    B_BOX = element("UMLState", 60, 200, 100, 40, "B")
    near = element("UMLNote", 170, 195, 100, 40, "next to B")  # B's top border is 5 px from the note too
    doc = convert_bytes(diagram([INIT, START, A_BOX, B_BOX, near, relation([[110, 120], [165, 200]], "lt=.>\ngo")])
                        .encode(), "t.uxf").machines[0]
    assert [(t["from"], t["to"]) for t in doc["transitions"]] == [("A", "B")]
