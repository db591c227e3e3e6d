""".uxf elements that are no part of a machine (class boxes among state boxes, generic boxes, zero-size boxes) are
named where an arrow ends at them, instead of cascading into "no initial state"; a diagram drawn with UMLClass
boxes and no UMLState at all converts with the class boxes as its states."""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import fsm
from fsm.model.errors import DiagramError
from fsm.tools.umlet.reader import convert_bytes
from fsm.tools.umlet.writer import diagram, element, relation

INIT = element("UMLSpecialState", 100, 20, 20, 20, "type=initial")
START = relation([[110, 40], [110, 80]], "lt=->")
A_TO_B = relation([[110, 120], [110, 200]], "lt=->")


def box(kind: str, y: int, text: str, w: int = 100, h: int = 40) -> str:
    return element(kind, 60, y, w, h, text)


def problems(*elements: str) -> list[fsm.Problem]:
    with pytest.raises(DiagramError) as info:
        convert_bytes(diagram(list(elements), 10).encode(), "t.uxf")
    return info.value.problems


def messages(*elements: str) -> list[str]:
    return [p.message for p in problems(*elements)]


@pytest.mark.parametrize(("kind", "reason"), [("UMLClass", "class boxes are states only in a diagram without"),
                                              ("UMLGeneric", "a UMLGeneric is not part of a state machine"),
                                              ("UMLUseCase", "a UMLUseCase is not part of a state machine")])
def test_an_arrow_to_an_ignored_box_names_it(kind: str, reason: str) -> None:
    [p] = problems(INIT, START, box("UMLState", 80, "A"), box(kind, 200, "B"), A_TO_B)
    assert f"target end at x=110, y=200 ends at {kind} 'B' at x=60, y=200, which is ignored" in p.message
    assert reason in p.message and "UMLState" in (p.hint or "")
    assert p.line is not None and p.element and p.element.startswith("Relation")


@pytest.mark.parametrize("kind", ["UMLClass", "UMLGeneric"])
def test_an_initial_arrow_to_an_ignored_box_does_not_cascade(kind: str) -> None:
    found = messages(INIT, START, box(kind, 80, "A"), box("UMLState", 200, "B"), A_TO_B)
    assert len(found) == 2 and all(f"{kind} 'A'" in m for m in found), found
    assert not any("no initial state" in m or "has no transition" in m for m in found)


def test_a_zero_size_box_is_named_where_it_is_and_where_an_arrow_ends_at_it() -> None:
    arrow = relation([[110, 120], [60, 200]], "lt=->")
    found = problems(INIT, START, box("UMLState", 80, "A"), box("UMLState", 200, "B", 0, 0), arrow)
    assert len(found) == 2
    assert found[0].message.startswith("the box has no size (w=0, h=0)") and "'B'" in (found[0].element or "")
    assert "ends at UMLState 'B' at x=60, y=200, which is ignored: it has no size" in found[1].message


@pytest.mark.parametrize("kind", ["UMLSpecialState", "UMLFrame"])
def test_zero_size_markers_and_frames_are_reported(kind: str) -> None:
    text = "type=initial" if kind == "UMLSpecialState" else "frame"
    found = messages(INIT, START, box("UMLState", 80, "A"), element(kind, 300, 300, 0, 20, text))
    assert found == ["the box has no size (w=0, h=20), so it is ignored"]


def test_a_zero_size_class_box_among_states_is_silently_not_a_state() -> None:
    conv = convert_bytes(diagram([INIT, START, box("UMLState", 80, "A"), element("UMLClass", 300, 300, 0, 0, "X")],
                                 10).encode(), "t.uxf")
    assert [s["id"] for s in conv.machines[0]["states"]] == ["A"]


# -- class boxes as states ------------------------------------------------------------------------------------
CLASS_DIAGRAM = [
    INIT, START,
    box("UMLClass", 80, "Off\n--\nthe lamp is dark"),
    box("UMLClass", 200, "On\n--\n\"type\": \"Idle\""),
    element("UMLSpecialState", 100, 320, 20, 20, "type=final"),
    relation([[110, 120], [110, 200]], "lt=->\npress"),
    relation([[110, 240], [110, 320]], "lt=->\ntype=Timeout\nseconds=0.5"),
]


def test_a_diagram_of_class_boxes_converts_with_them_as_states() -> None:
    [doc] = convert_bytes(diagram(CLASS_DIAGRAM, 10).encode(), "lamp.uxf").machines
    assert doc["initial"] == "Off"
    assert [(s["id"], s["type"]) for s in doc["states"]] == [("Off", "Idle"), ("On", "Idle"),
                                                             ("final", "Final")]
    assert doc["states"][0]["description"] == "the lamp is dark"
    assert [(t["type"], t["from"], t["to"]) for t in doc["transitions"]] == [
        ("Signal", "Off", "On"), ("Timeout", "On", "final")]


def test_a_class_box_diagram_runs(tmp_path: Path) -> None:
    f = tmp_path / "lamp.uxf"
    f.write_text(diagram(CLASS_DIAGRAM, 10), encoding="utf-8")
    m = fsm.load(f)
    m.schedule_signal("press", 0.1)
    assert fsm.run(m, duration=2).outcome == "succeeded"


def test_class_boxes_nest_like_state_boxes() -> None:
    outer = element("UMLClass", 40, 60, 300, 200, "Outer")
    inner_init = element("UMLSpecialState", 60, 100, 20, 20, "type=initial")
    inner = element("UMLClass", 60, 140, 100, 40, "Inner")
    arrow = relation([[70, 120], [70, 140]], "lt=->")
    top_init = element("UMLSpecialState", 10, 10, 20, 20, "type=initial")
    top_arrow = relation([[20, 30], [40, 70]], "lt=->")
    [doc] = convert_bytes(diagram([top_init, top_arrow, outer, inner_init, inner, arrow], 10).encode(),
                          "t.uxf").machines
    assert doc["states"][0]["type"] == "FSMState"
    assert doc["states"][0]["machine"]["initial"] == "Inner"


def test_with_one_state_box_the_class_boxes_are_ignored_again() -> None:
    found = messages(*CLASS_DIAGRAM, box("UMLState", 500, "Lonely"))
    assert found and all("UMLClass" in m for m in found)
    assert not any("no initial state" in m for m in found)


# -- hypothesis: a chain of states with one box made ignorable -----------------------------------------------
@settings(max_examples=60, deadline=None)
@given(n=st.integers(2, 6), data=st.data())
def test_one_ignored_box_in_a_chain_is_named_and_nothing_cascades(n: int, data: st.DataObject) -> None:
    bad = data.draw(st.integers(0, n - 1), label="which box")
    kind = data.draw(st.sampled_from(["UMLClass", "UMLGeneric", "zero"]), label="how")
    elements = [INIT, START]
    for i in range(n):
        y = 80 + 120 * i
        if i == bad and kind == "zero":
            elements.append(element("UMLState", 60, y, 0, 0, f"S{i}"))
        elif i == bad:
            elements.append(box(kind, y, f"S{i}"))
        else:
            elements.append(box("UMLState", y, f"S{i}"))
        if i + 1 < n:  # arrows to and from a zero-size box end where it is
            x0 = 60 if (kind == "zero" and i == bad) else 110
            x1 = 60 if (kind == "zero" and i + 1 == bad) else 110
            y0 = y if (kind == "zero" and i == bad) else y + 40
            elements.append(relation([[x0, y0], [x1, y + 120]], "lt=->"))
    if kind == "zero" and bad == 0:
        elements[1] = relation([[110, 40], [60, 80]], "lt=->")
    found = problems(*elements)
    text = "\n".join(str(p) for p in found)
    assert "no initial state" not in text and "has no transition" not in text
    assert f"'S{bad}'" in text
    named = [p for p in found if p.element and p.element.startswith("Relation")]
    assert named and all(f"'S{bad}'" in p.message and "ignored" in p.message for p in named), text
    for p in found:
        assert p.line is not None, str(p)
