"""UMLet: ``event [guard] / action`` labels, ``[guard] / action`` after typed parameters, ``entry /`` and
``exit /`` lines of state boxes; located errors for what does not parse; export and convert round trip."""

from __future__ import annotations

from typing import Any

import pytest

import fsm
from fsm.loading.registry import default_registry
from fsm.model.errors import DiagramError
from fsm.tools.umlet.reader import convert_bytes
from fsm.tools.umlet.writer import diagram, element, relation, transition_text
from helpers import without_layout as strip

REG = default_registry()
INIT = element("UMLSpecialState", 100, 20, 20, 20, "type=initial")
START = relation([[110, 40], [110, 80]], "lt=->")
A = element("UMLState", 60, 80, 100, 40, "A")
B = element("UMLState", 60, 200, 100, 40, "B")
A_TO_B = [[110, 120], [110, 200]]


def convert(*elements: str) -> dict[str, Any]:
    machines = convert_bytes(diagram(list(elements)).encode(), "t.uxf").machines
    assert len(machines) == 1
    return strip(machines[0])


def errors(*elements: str) -> list[fsm.Problem]:
    with pytest.raises(DiagramError) as info:
        convert_bytes(diagram(list(elements)).encode(), "t.uxf")
    return info.value.problems


@pytest.mark.parametrize("label, expected", [
    ("press [armed] / n = n + 1; led = true",
     {"type": "Signal", "signal": "press", "label": "press [armed] / n = n + 1; led = true", "guard": "armed",
      "set": {"n": "n + 1", "led": True}}),
    ("press / msg = 'a;b'", {"type": "Signal", "signal": "press", "label": "press / msg = 'a;b'",
                             "set": {"msg": "'a;b'"}}),
    ("[n > 3]", {"type": "Always", "guard": "n > 3"}),
    ("[n / 2 > 1] / n = 0", {"type": "Always", "guard": "n / 2 > 1", "set": {"n": 0}}),
    ("/ n = -1.5", {"type": "Always", "set": {"n": -1.5}}),
    ("type=Timeout\nseconds=2\n[n < 3] / n = n + 1",
     {"type": "Timeout", "seconds": 2, "guard": "n < 3", "set": {"n": "n + 1"}}),
])
def test_labels(label: str, expected: dict[str, Any]) -> None:
    doc = convert(INIT, START, A, B, relation(A_TO_B, f"lt=->\n{label}"))
    assert doc["transitions"] == [{"from": "A", "to": "B", **expected}]


def test_guard_only_label_out_of_a_finishing_state_is_finished() -> None:
    inner = element("UMLState", 40, 60, 300, 200, "W\n--\n\"type\": \"FSMState\"\nvalign=top")
    kids = [element("UMLSpecialState", 60, 100, 20, 20, "type=initial"),
            element("UMLState", 100, 90, 80, 40, "x"), relation([[80, 110], [100, 110]], "lt=->"),
            element("UMLSpecialState", 250, 100, 20, 20, "type=final"), relation([[180, 110], [250, 110]], "lt=->")]
    after = element("UMLState", 40, 320, 100, 40, "after")
    doc = convert(element("UMLSpecialState", 20, 20, 20, 20, "type=initial"),
                  relation([[30, 40], [60, 60]], "lt=->"), inner, *kids, after,
                  relation([[100, 260], [100, 320]], "lt=->\n[ok]"))
    assert doc["transitions"] == [{"type": "Finished", "from": "W", "to": "after", "guard": "ok"}]


def test_entry_and_exit_lines() -> None:
    box = element("UMLState", 60, 80, 100, 60, "A\n--\nentry / n = n + 1; led = true\nexit / led = false\n--\nnotes")
    doc = convert(INIT, START, box)
    assert doc["states"] == [{"id": "A", "type": "Idle", "description": "notes",
                              "set": {"on_enter": {"n": "n + 1", "led": True}, "on_exit": {"led": False}}}]


@pytest.mark.parametrize("label, fragment", [
    ("stop / switch off", "action 'switch off': expected '='"),
    ("go [n >] / n = 1", "guard [n >]: expected a value"),
    ("go [n > 1 / n = 1", "'[' without ']'"),
    ("go / n = 1; n = 2", "assigns 'n' twice"),
    ("type=Timeout\nseconds=1\ngo [x]", "'go [x]' is not key=value"),
    ("outcome=wide", "'outcome=wide' looks like a parameter, but the relation has no 'type=' line"),
])
def test_bad_labels_are_located_errors(label: str, fragment: str) -> None:
    probs = errors(INIT, START, A, B, relation(A_TO_B, f"lt=->\n{label}"))
    assert len(probs) == 1
    p = probs[0]
    assert fragment in p.message and p.line and p.column and "Relation" in (p.element or "")


def test_bad_entry_line_is_a_located_error() -> None:
    probs = errors(INIT, START, element("UMLState", 60, 80, 100, 40, "A\n--\nentry / beep"))
    assert len(probs) == 1 and "entry / ...: action 'beep'" in probs[0].message and probs[0].line
    assert "UMLState 'A" in (probs[0].element or "")


def test_unknown_variable_in_a_diagram_is_located_at_the_arrow(tmp_path: Any) -> None:
    path = tmp_path / "m.uxf"
    path.write_text(diagram([INIT, START, A, B, relation(A_TO_B, "lt=->\ngo [armed]")]))
    found = [p for p in fsm.check(str(path), registry=REG)[1] if p.severity == "error"]
    assert len(found) == 1 and "unknown variable 'armed'" in found[0].message
    assert found[0].line and found[0].where == "x=100, y=110"


@pytest.mark.parametrize("doc", [
    {"initial": "a", "vars": {"n": 0, "led": False, "msg": ""},
     "states": [{"id": "a", "type": "Idle", "set": {"on_enter": {"n": "n + 1", "led": True},
                                                     "on_exit": {"msg": "'bye'"}}},
                {"id": "b", "type": "Idle", "description": "waits"},
                {"id": "c", "type": "Final"}],
     "transitions": [
         {"type": "Signal", "from": "a", "to": "b", "signal": "go", "label": "go [n > 1] / led = false",
          "guard": "n > 1", "set": {"led": False}},
         {"type": "Timeout", "from": "b", "to": "a", "seconds": 1, "guard": "not led", "set": {"n": 0}},
         {"type": "Always", "from": "a", "to": "c", "guard": "n > 5"},
         {"type": "Signal", "from": "b", "to": "c", "signal": "x", "set": {"msg": "'a]b'"}},
         {"type": "Always", "from": "b", "to": "c", "guard": "msg == ']'"},
         {"type": "Always", "from": "b", "to": "c", "set": {"msg": "1"}},
         {"type": "Condition", "from": "b", "to": "c",
          "condition": {"type": "SignalEdge", "signal": "b", "debounce": 0.02}},
         {"type": "Always", "from": "b", "to": "c", "guard": {"type": "Not", "condition":
                                                             {"type": "Expr", "expr": "led"}}},
     ]},
    {"initial": "a", "vars": {"n": 0},
     "states": [{"id": "a", "type": "Idle", "set": {"on_enter": {"n": "n + 1"}}},
                {"id": "d", "type": "Final"}],
     "transitions": [{"type": "Always", "from": "a", "to": "d", "set": {"n": 2.5}}]},
])
def test_export_and_convert_round_trip(doc: dict[str, Any]) -> None:
    from fsm.tools.umlet.writer import export

    back = convert_bytes(export(doc, REG).encode(), "x.uxf").machines
    assert len(back) == 1
    assert strip(back[0]) == strip({k: v for k, v in doc.items()} | {"name": "x"}) or \
        {k: v for k, v in strip(back[0]).items() if k != "name"} == strip(doc)


def test_export_writes_the_uml_form() -> None:
    source = {"id": "a", "type": "Idle"}
    assert transition_text({"type": "Always", "from": "a", "to": "b", "guard": "n > 1", "set": {"n": 0}},
                           source, REG) == "lt=->\n[n > 1] / n = 0"
    assert transition_text({"type": "Timeout", "from": "a", "to": "b", "seconds": 1, "guard": "ok"},
                           source, REG) == "lt=->\ntype=Timeout\nseconds=1\n[ok]"
    text = transition_text({"type": "Always", "from": "a", "to": "b", "guard": "s == ']'"}, source, REG)
    assert "guard=" in text  # a ']' in the guard cannot be written inside [ ]
