"""The UMLet reader: the twelve real corpus files, both label syntaxes, attachment, nesting, bad input."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from fsm.loading.loader import check
from fsm.model.errors import DiagramError
from fsm.tools.umlet.reader import convert_bytes, convert_file
from fsm.tools.umlet.writer import diagram, element, relation
from helpers import CORPUS, needs_corpus
from helpers import without_layout as strip

FILES = sorted(CORPUS.glob("*.uxf")) if CORPUS.is_dir() else []


def convert(*elements: str, zoom: int = 10):
    return convert_bytes(diagram(list(elements), zoom).encode(), "t.uxf")


def one(*elements: str, zoom: int = 10) -> dict:
    conv = convert(*elements, zoom=zoom)
    assert len(conv.machines) == 1
    return conv.machines[0]


def errors(*elements: str, zoom: int = 10, raw: bytes | None = None) -> list:
    with pytest.raises(DiagramError) as exc:
        convert_bytes(raw if raw is not None else diagram(list(elements), zoom).encode(), "t.uxf")
    return exc.value.problems


INIT = element("UMLSpecialState", 100, 20, 20, 20, "type=initial")
A = element("UMLState", 60, 80, 100, 40, "A")
B = element("UMLState", 60, 200, 100, 40, "B")
START = relation([[110, 40], [110, 80]], "lt=->")




# -- the corpus -----------------------------------------------------------------------------------------------
EXPECTED = {  # file prefix: (states incl. pseudostates, relations, nested boxes[, validation errors]) or the
    # errors' fragments. Free-text actions after '/' ("admin / automatic replacement") are no assignments: errors.
    "Belinus": (10, 15, 0),
    "ForceGitE": (8, 8, 4, ["unknown variable 'questionsanswered'"]),
    "KIT-MAMID": ["action 'automatic replacement': expected '='"],
    "ikageso1": ["action 'プロフィールを表示'", "action '評価を送信'", "action '研究室一覧を表示'",
                 "action 'ランキングを表示'"],
    "nastygorodi": (8, 7, 0),
    "73jn": ["duplicate state name 'WIFI CONNECT'"],
    "Bleksak": ["has no initial state", "duplicate state name 'TAKE'"],
    "CitrusToffee": ["may not end at an initial pseudostate", "initial pseudostate has no transition"],
    "Itaxo01": ["duplicate state name 'Associa primeiro'"] * 2 + ["action 'Desligar'"] * 2
    + ["states 'Ligado' belong to none of the diagram's machines"],
    "cphjs": ["has no initial state", "source end at x=390, y=430 is attached to nothing"],
    "easoncxz": ["has no initial state", "source end at x=90, y=80 is attached to nothing"],
    "umlet__umlet": ["'termination' pseudostates are not supported", "'flow_final'", "'decision'",
                     "'history_shallow'", "'history_deep'", "attached to nothing", "attached to nothing",
                     "initial pseudostate has no transition", "has no initial state",
                     "duplicate state name 'state'"],
}


def _count(doc: dict) -> tuple[int, int, int]:
    """States (+1 per initial marker), transitions (+1 per initial arrow), boxes nested in another."""
    states = trans = nested = 0

    def walk(m: dict, depth: int) -> None:
        nonlocal states, trans, nested
        states += len(m["states"]) + 1
        trans += len(m["transitions"]) + 1
        if depth:
            nested += len(m["states"]) + 1
        for st in m["states"]:
            if isinstance(st.get("machine"), dict) and "states" in st["machine"]:
                walk(st["machine"], depth + 1)

    walk(doc, 0)
    return states, trans, nested


@needs_corpus
def test_corpus_is_there():
    assert len(FILES) == 12


@needs_corpus
@pytest.mark.parametrize("path", FILES, ids=lambda p: p.name.split("__")[0])
def test_corpus_file_converts_or_fails_located(path: Path):
    key = next(k for k in EXPECTED if path.name.startswith(k))
    want = EXPECTED[key]
    if isinstance(want, tuple):
        conv = convert_file(path)
        assert len(conv.machines) == 1
        assert _count(conv.machines[0]) == want[:3]
        _spec, problems = check(str(path))
        errors = [p for p in problems if p.severity == "error"]
        fragments = want[3] if len(want) > 3 else []
        assert len(errors) == len(fragments), errors
        for p, fragment in zip(errors, fragments, strict=True):
            assert fragment in p.message and p.line and p.where
        return
    with pytest.raises(DiagramError) as exc:
        convert_file(path)
    problems = exc.value.problems
    assert len(problems) == len(want)
    for p in problems:  # located: file, line, column, element with diagram coordinates
        assert p.file == str(path) and p.line and p.column and " at x=" in (p.element or "")
    messages = "\n".join(p.message for p in problems)
    for fragment in want:
        assert fragment in messages


def _itaxo_renamed() -> bytes:
    raw = (CORPUS / "Itaxo01__Projeto-Engenharia-de-Software__Statechart.uxf").read_bytes()
    n = iter(range(1, 10))
    raw = re.sub(rb"<panel_attributes>Associa primeiro</panel_attributes>",
                 lambda m: f"<panel_attributes>Associa {next(n)}</panel_attributes>".encode(), raw)
    # "Ligar/Desligar": in a UML label '/' starts the action, and 'Desligar' is no assignment (a located error)
    return raw.replace("Ligar/Desligar".encode(), "Ligar ou Desligar".encode())


@needs_corpus
def test_several_machines_nested_two_levels_and_exits():
    conv = convert_bytes(_itaxo_renamed(), "itaxo.uxf")
    assert conv.names == ["Aguardando três avaliadores", "Neutro", "Neutro (2)", "Desligado"]
    ligado = conv.machines[3]["states"][0]
    gravacao = ligado["machine"]["states"][1]
    assert gravacao["id"] == "Modo Gravação" and gravacao["machine"]["initial"] == "Waiting"
    assert [s["id"] for s in gravacao["machine"]["states"]] == ["Gravando", "Finaliza a Gravação", "Waiting",
                                                                "Gravação Pausada"]
    first = conv.machines[0]
    exit_final = first["states"][1]["machine"]["states"][-1]
    assert exit_final == {"id": "exit to Aguarda revisões", "type": "Final", "outcome": "exit to Aguarda revisões"}
    assert strip(first["transitions"][0]) == {"type": "Finished", "from": "Aguardando três avaliadores",
                                              "to": "Aguarda revisões", "outcome": "exit to Aguarda revisões"}
    from fsm.tools.umlet.reader import several_machines_problem

    with pytest.raises(DiagramError) as exc:  # the loader hook wants one machine
        raise DiagramError([several_machines_problem(conv)])
    assert "4 separate machines" in str(exc.value) and "--machine" in str(exc.value)


@needs_corpus
def test_zoom_15_points_stored_at_zoom_10():
    doc_text = (CORPUS / "73jn__aws-pycom__statemachine.uxf").read_bytes()
    doc_text = doc_text.replace(b"WIFI\r\nCONNECT\r\n", b"WIFI\r\nCONNECT2\r\n", 1)
    conv = convert_bytes(doc_text, "73jn.uxf")
    doc = conv.machines[0]
    assert doc["initial"] == "INIT"
    assert len(doc["states"]) == 7 and len(doc["transitions"]) == 6
    assert ["lw=3" not in json.dumps(t) for t in doc["transitions"]]


@needs_corpus
def test_old_elements_and_lt_reversed(tmp_path):
    raw = (CORPUS / "easoncxz__two-button-tv-control__states.uxf").read_text()
    # give the entry arrow (which starts in empty space) an initial pseudostate at its start
    raw = raw.replace("</diagram>", "<element><type>com.umlet.element.custom.InitialState</type><coordinates>"
                                    "<x>80</x><y>70</y><w>20</w><h>20</h></coordinates><panel_attributes/>"
                                    "<additional_attributes/></element></diagram>")
    doc = convert_bytes(raw.encode(), "tv.uxf").machines[0]
    assert doc["initial"] == "off"
    assert len(doc["transitions"]) == 10
    assert all(t["type"] == "Signal" for t in doc["transitions"])


# -- syntax -------------------------------------------------------------------------------------------------
def test_key_value_and_json_fragment_states_and_labels():
    doc = one(INIT, START,
              element("UMLState", 60, 80, 160, 80, "follow\n--\ntype=Timeout\n--\nentry / go = 1"),
              element("UMLState", 60, 240, 160, 80, 'B\n--\n"type": "Final", "outcome": "done"\n--\nbg=red'),
              relation([[110, 160], [110, 240]], 'lt=->\n"type": "Timeout", "seconds": 2'),
              )
    assert doc["states"][0]["type"] == "Timeout"  # a transition type used as a state: the loader says so
    assert doc["states"][0]["set"] == {"on_enter": {"go": 1}}  # a UML internal activity
    assert strip(doc["states"][1]) == {"id": "B", "type": "Final", "outcome": "done"}
    assert strip(doc["transitions"][0]) == {"type": "Timeout", "from": "follow", "to": "B", "seconds": 2}


def test_key_values_keep_text_where_the_parameter_is_text():
    doc = one(INIT, START, A, B, relation([[110, 120], [110, 200]], "lt=->\ntype=Signal\nsignal=1\nedge=high"))
    assert strip(doc["transitions"][0]) == {"type": "Signal", "from": "A", "to": "B", "signal": "1", "edge": "high"}


def test_uml_label_becomes_signal_and_no_label_always():
    doc = one(INIT, START, A, B, relation([[110, 120], [110, 200]], "lt=->\nbutton\npressed [armed] / beep = true"),
              relation([[140, 200], [140, 120]], "lt=->\nlw=2"))
    assert strip(doc["transitions"]) == [
        {"type": "Signal", "from": "A", "to": "B", "signal": "button pressed",
         "label": "button pressed [armed] / beep = true", "guard": "armed", "set": {"beep": True}},
        {"type": "Always", "from": "B", "to": "A"}]


def test_direction_from_arrowhead_and_note_anchors_ignored():
    doc = one(INIT, START, A, B, relation([[110, 200], [110, 120]], "lt=<<<-\ngo"),
              relation([[150, 120], [150, 200]], "lt=."), relation([[130, 120], [130, 200]], "lt=-"))
    assert [(t["from"], t["to"]) for t in doc["transitions"]] == [("A", "B")]


def test_multiline_names_styles_and_self_loop_with_bends():
    doc = one(INIT, START, element("UMLState", 60, 80, 100, 60, "AWS\nMQTT\nbg=pink\nlw=3\nfontsize=18"),
              relation([[160, 100], [200, 100], [200, 130], [160, 130]], "lt=->\nagain"))
    assert doc["initial"] == "AWS MQTT"
    assert doc["transitions"][0]["from"] == doc["transitions"][0]["to"] == "AWS MQTT"


def test_umlet_rule_9px_and_lenient_rule():
    # 8 px from the border: UMLet's rule; 10 px: only the lenient rule; 12 px: nothing
    d8 = one(INIT, START, A, B, relation([[110, 128], [110, 200]], "lt=->"))
    assert d8["transitions"][0]["from"] == "A"
    d10 = one(INIT, START, A, B, relation([[110, 130], [110, 200]], "lt=->"))
    assert d10["transitions"][0]["from"] == "A"
    probs = errors(INIT, START, A, B, relation([[110, 132], [110, 200]], "lt=->"))
    assert "source end at x=110, y=132 is attached to nothing" in probs[0].message
    assert "nearest is 'A', 12 px away" in probs[0].hint


def test_zoom_scales_boxes_but_not_new_relation_points():
    # zoom 20: boxes stored at twice their size; relation points stay at zoom 10, relative to the origin
    doc = one(element("UMLSpecialState", 200, 40, 40, 40, "type=initial"),
              element("Relation", 200, 60, 60, 140, "lt=->", "10.0;10.0;10.0;50.0"),
              element("UMLState", 120, 160, 200, 80, "A"), zoom=20)
    assert doc["initial"] == "A"


def test_ambiguous_endpoint_and_duplicate_names():
    probs = errors(INIT, START, A, element("UMLState", 170, 80, 100, 40, "A"),
                   relation([[165, 100], [165, 300]], "lt=->"))
    text = "\n".join(p.message for p in probs)
    assert "duplicate state name 'A'" in text
    assert "ambiguous" in text


def test_tral_from_to_must_agree_with_geometry():
    probs = errors(INIT, START, A, B,
                   relation([[110, 120], [110, 200]], 'lt=->\n"type": "Always", "from": "B", "to": "B"'))
    assert "'from' in the label names 'B' but the arrow's source end is attached to 'A'" in probs[0].message
    # no geometry at one end: the label names it
    doc = one(INIT, START, A, B, relation([[110, 120], [400, 400]], 'lt=->\n"type": "Always", "to": "B"'))
    assert (doc["transitions"][0]["from"], doc["transitions"][0]["to"]) == ("A", "B")


def test_nesting_to_any_depth_in_a_frame_and_crlf():
    els = [element("UMLFrame", 0, 0, 700, 600, "outer"),
           element("UMLSpecialState", 40, 40, 20, 20, "type=initial"),
           relation([[50, 60], [50, 100]], "lt=->")]
    # five levels of composites, each with an initial marker and one inner state
    x, y, w, h = 20, 100, 640, 480
    for depth in range(5):
        els.append(element("UMLState", x, y, w, h, f"level{depth}\r\nvalign=top"))
        els.append(element("UMLSpecialState", x + 20, y + 30, 20, 20, "type=initial"))
        els.append(relation([[x + 30, y + 50], [x + 30, y + 80]], "lt=->"))
        x, y, w, h = x + 10, y + 80, w - 20, h - 90
    els.append(element("UMLState", x, y, 100, 40, "leaf"))
    doc = convert_bytes(diagram(els).encode().replace(b"\n", b"\r\n"), "t.uxf").machines[0]
    assert doc["name"] == "outer"
    m, depth = doc, 0
    while m["states"][0]["type"] == "FSMState":
        m = m["states"][0]["machine"]
        depth += 1
    assert depth == 5 and m["states"][0]["id"] == "leaf"


def test_transition_into_a_composite_that_is_not_its_initial_state():
    probs = errors(INIT, START, A,
                   element("UMLState", 40, 200, 300, 200, "C\nvalign=top"),
                   element("UMLSpecialState", 60, 240, 20, 20, "type=initial"),
                   relation([[70, 260], [70, 290]], "lt=->"),
                   element("UMLState", 60, 290, 80, 40, "x"), element("UMLState", 200, 290, 80, 40, "y"),
                   relation([[150, 120], [240, 290]], "lt=->"))
    assert "enters 'y' inside composite 'C'" in probs[0].message


# -- bad input -------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("raw, fragment", [
    (b"not xml at all", "not well-formed XML"),
    (b"<diagram><zoom_level>10</zoom_level></diagram>", "has no elements"),
    (b"<other/>", "not a UMLet diagram"),
    (b"", "file is empty"),
    (b'<?xml version="1.0"?>\n<!DOCTYPE lolz [<!ENTITY lol "lol"><!ENTITY lol2 "&lol;&lol;&lol;">]>\n'
     b"<diagram><element><id>UMLState</id><coordinates><x>0</x><y>0</y><w>10</w><h>10</h></coordinates>"
     b"<panel_attributes>&lol2;</panel_attributes></element></diagram>", "DOCTYPE declarations are not allowed"),
    (b'<?xml version="1.0"?>\n<!DOCTYPE d [<!ENTITY x SYSTEM "file:///etc/passwd">]><diagram>&x;</diagram>',
     "DOCTYPE"),
    (b"<diagram><element><id>UMLState</id><coordinates><x>ten</x><y>0</y><w>10</w><h>10</h></coordinates>"
     b"<panel_attributes>A</panel_attributes></element></diagram>", "coordinate <x> is not a number: 'ten'"),
    (b"<diagram><element><id>Relation</id><coordinates><x>0</x><y>0</y><w>10</w><h>10</h></coordinates>"
     b"<panel_attributes>lt=-&gt;</panel_attributes><additional_attributes>10;10</additional_attributes>"
     b"</element></diagram>", "needs at least two points, this one has 1"),
    (b"<diagram><zoom_level>abc</zoom_level><element/></diagram>", "element without <id>"),
])
def test_bad_input_is_one_located_message(raw, fragment):
    probs = errors(raw=raw)
    assert any(fragment in p.message for p in probs), [str(p) for p in probs]
    assert all(p.line is not None for p in probs)


def test_external_entity_file_is_never_read(tmp_path, monkeypatch):
    secret = tmp_path / "secret.txt"
    secret.write_text("TOPSECRET")
    raw = (f'<?xml version="1.0"?><!DOCTYPE d [<!ENTITY x SYSTEM "{secret.as_uri()}">]>'
           "<diagram><element><id>UMLState</id><coordinates><x>0</x><y>0</y><w>10</w><h>10</h></coordinates>"
           "<panel_attributes>&x;</panel_attributes></element></diagram>").encode()
    import builtins

    opened = []
    real_open = builtins.open
    monkeypatch.setattr(builtins, "open", lambda f, *a, **k: (opened.append(str(f)), real_open(f, *a, **k))[1])
    probs = errors(raw=raw)
    assert "TOPSECRET" not in str(probs) and str(secret) not in opened


def test_xml2json_legacy_form(tmp_path):
    legacy = {"diagram": {"@program": "umlet", "zoom_level": "10", "element": [
        {"id": "UMLSpecialState", "coordinates": {"x": "100", "y": "20", "w": "20", "h": "20"},
         "panel_attributes": "type=initial", "additional_attributes": None},
        {"id": "Relation", "coordinates": {"x": "100", "y": "30", "w": "30", "h": "70"},
         "panel_attributes": "lt=->", "additional_attributes": "10;10;10;50"},
        {"id": "UMLState", "coordinates": {"x": "60", "y": "80", "w": "100", "h": "40"},
         "panel_attributes": 'follow\n--\n"id": 0, "type": "Idle"\n--', "additional_attributes": None}]}}
    doc = convert_bytes(json.dumps(legacy).encode(), "legacy.json").machines[0]
    assert strip(doc) == {"name": "legacy", "initial": "follow", "states": [{"id": "follow", "type": "Idle"}],
                          "transitions": []}
    single = {"diagram": {"element": legacy["diagram"]["element"][2]}}  # one element: an object, not an array
    assert convert_bytes(json.dumps(single).encode(), "x.json").machines[0]["initial"] == "follow"
    bad = {"diagram": {"element": [{"id": "UMLState", "coordinates": {"x": "a", "y": "0", "w": "1", "h": "1"}}]}}
    probs = errors(raw=json.dumps(bad, indent=1).encode())
    assert probs[0].pointer == "/diagram/element/0" and probs[0].line == 4


def test_huge_file_gives_one_located_error(tmp_path):
    """Its speed is measured by benchmarks/bench_big.py, not asserted here."""
    one_state = element("UMLState", 0, 0, 100, 40, "S")
    raw = diagram([one_state.replace("<x>0</x>", f"<x>{i * 200}</x>").replace(">S<", f">S{i}<")
                   for i in range(70_000)]).encode()
    assert len(raw) > 15_000_000
    probs = errors(raw=raw)  # no initial pseudostate: one located error
    assert len(probs) == 1 and "has no initial state" in probs[0].message


# -- Parallel states and machine notes, drawn by hand ----------------------------------------------------------
def _uxf(*elements: tuple) -> str:
    """A diagram as UMLet writes it: elements as (id, x, y, w, h, text[, relation points])."""
    out = ['<?xml version="1.0" encoding="UTF-8" standalone="no"?>\n<diagram program="umlet" version="15.1">\n'
           "  <zoom_level>10</zoom_level>\n"]
    for kind, x, y, w, h, text, *points in elements:
        extra = f"<additional_attributes>{points[0]}</additional_attributes>" if points else "<additional_attributes/>"
        text = text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
        out.append(f"  <element>\n    <id>{kind}</id>\n    <coordinates>\n      <x>{x}</x>\n      <y>{y}</y>\n"
                   f"      <w>{w}</w>\n      <h>{h}</h>\n    </coordinates>\n    <panel_attributes>{text}"
                   f"</panel_attributes>\n    {extra}\n  </element>\n")
    return "".join(out) + "</diagram>\n"


HAND_PARALLEL = [
    ("UMLSpecialState", 100, 20, 20, 20, "type=initial"),
    ("Relation", 100, 30, 30, 70, "lt=->", "10.0;10.0;10.0;50.0"),
    ("UMLState", 40, 80, 140, 40, "wait"),
    ("Relation", 100, 110, 30, 90, "lt=->\nstart", "10.0;10.0;10.0;70.0"),
    ("UMLState", 20, 180, 800, 300, "run\n--\ntype=Parallel\njoin=any\nvalign=top"),
    # frames drawn right to left in the file: the regions are ordered by their left edges
    ("UMLFrame", 580, 260, 200, 60, "file=grip.json"),
    ("UMLFrame", 310, 260, 250, 200, "monitor\nbg=yellow"),
    ("UMLSpecialState", 330, 290, 20, 20, "type=initial"),
    ("Relation", 330, 300, 30, 60, "lt=->", "10.0;10.0;10.0;40.0"),
    ("UMLState", 330, 340, 100, 40, "watch"),
    ("UMLSpecialState", 500, 350, 20, 20, "type=final\nemergency"),
    ("Relation", 420, 350, 100, 30, "lt=->\nestop", "10.0;10.0;80.0;10.0"),
    ("UMLFrame", 40, 260, 250, 200, "work"),
    ("UMLSpecialState", 60, 290, 20, 20, "type=initial"),
    ("Relation", 60, 300, 30, 60, "lt=->", "10.0;10.0;10.0;40.0"),
    ("UMLState", 60, 340, 120, 40, "step"),
    ("UMLSpecialState", 240, 350, 20, 20, "type=final\nok"),
    ("Relation", 170, 350, 90, 30, "lt=->\ntype=Timeout\nseconds=1", "10.0;10.0;70.0;10.0"),
    ("UMLNote", 60, 400, 200, 50, "machine\n--\ndescription=does the work"),
    ("Relation", 290, 470, 30, 90, "lt=->\ntype=Finished\noutcome=emergency", "10.0;10.0;10.0;70.0"),
    ("UMLSpecialState", 290, 540, 20, 20, "type=final\nstopped"),
    ("Relation", 100, 470, 30, 90, "lt=->", "10.0;10.0;10.0;70.0"),
    ("UMLSpecialState", 100, 540, 20, 20, "type=final\nok"),
    ("UMLNote", 860, 20, 300, 100, "machine\n--\nname=hand\nvars={\"n\": 0}\n--\nA parallel state\ndrawn by hand.\n"
                                   "style=wordwrap"),
    ("UMLNote", 860, 200, 300, 60, "just a comment, not a machine note"),
]


def test_a_hand_drawn_parallel_state_with_region_frames(tmp_path):
    src = tmp_path / "hand.uxf"
    src.write_text(_uxf(*HAND_PARALLEL))
    doc = convert_file(src).machines[0]
    assert strip(doc) == {
        "name": "hand", "description": "A parallel state\ndrawn by hand.", "vars": {"n": 0}, "initial": "wait",
        "states": [
            {"id": "wait", "type": "Idle"},
            {"id": "run", "type": "Parallel", "join": "any", "regions": [
                {"name": "work", "description": "does the work", "initial": "step",
                 "states": [{"id": "step", "type": "Idle"}, {"id": "ok", "type": "Final", "outcome": "ok"}],
                 "transitions": [{"type": "Timeout", "from": "step", "to": "ok", "seconds": 1}]},
                {"name": "monitor", "initial": "watch",
                 "states": [{"id": "watch", "type": "Idle"},
                            {"id": "emergency", "type": "Final", "outcome": "emergency"}],
                 "transitions": [{"type": "Signal", "from": "watch", "to": "emergency", "signal": "estop",
                                  "label": "estop"}]},
                {"file": "grip.json"}]},
            {"id": "stopped", "type": "Final", "outcome": "stopped"},
            {"id": "ok", "type": "Final", "outcome": "ok"}],
        "transitions": [
            {"type": "Signal", "from": "wait", "to": "run", "signal": "start", "label": "start"},
            {"type": "Finished", "from": "run", "to": "stopped", "outcome": "emergency"},
            {"type": "Finished", "from": "run", "to": "ok"}]}  # no label: a Parallel state finishes
    frames = doc["states"][1]["layout"]["frames"]  # the regions' frames, kept in the Parallel state's layout
    assert frames[0] == {"x": 40, "y": 260, "w": 250, "h": 200} and frames[2]["x"] == 580
    # it is a valid machine (the included region next to it), and export draws it back the same way
    (tmp_path / "grip.json").write_text((Path(__file__).resolve().parents[1] / "diagrams" / "examples"
                                         / "grip.json").read_text())
    _spec, problems = check(str(src))
    assert not [p for p in problems if p.severity == "error"], problems
    from fsm.tools.umlet.writer import export

    again = convert_bytes(export(doc).encode(), "again.uxf").machines[0]
    assert strip(again) == strip(doc)
    assert again["states"][1]["layout"] == doc["states"][1]["layout"]  # drawn where it was


def _replace(elements: list, index: int, new: tuple | None) -> list:
    out = list(elements)
    if new is None:
        del out[index]
    else:
        out[index] = new
    return out


def _hand_errors(elements: list) -> list[str]:
    with pytest.raises(DiagramError) as exc:
        convert_bytes(_uxf(*elements).encode(), "hand.uxf")
    for p in exc.value.problems:
        assert p.line and " at x=" in (p.element or ""), p
    return [p.message for p in exc.value.problems]


@pytest.mark.parametrize("change, fragment", [
    # a state inside the Parallel box but in no frame
    (lambda els: els + [("UMLState", 600, 400, 100, 40, "stray")],
     "'stray' is drawn inside Parallel 'run' but in none of its region frames"),
    # an arrow from a region's state to a state outside the Parallel box
    (lambda els: els + [("Relation", 100, 370, 30, 190, "lt=->", "10.0;10.0;10.0;170.0")],
     "the arrow leaves region frame 'work' of Parallel 'run'"),
    # an arrow ending at a region's frame
    (lambda els: els + [("Relation", 160, 110, 30, 160, "lt=->", "10.0;10.0;10.0;150.0")],
     "ends at region frame 'work' of Parallel 'run': a region is not a state"),
    # a frame with nothing in it that includes nothing
    (lambda els: _replace(els, 5, ("UMLFrame", 580, 260, 200, 60, "spare")),
     "region frame 'spare' of Parallel 'run' is empty"),
    # an include frame with a state in it
    (lambda els: els + [("UMLState", 600, 280, 60, 30, "x")],
     "includes a machine from a file, so it may hold nothing else"),
    # frames and regions= at once
    (lambda els: _replace(els, 4, ("UMLState", 20, 180, 800, 300, 'run\n--\ntype=Parallel\nregions=[]')),
     "both holds region frames and gives 'regions'"),
    # the region's note names it differently from its frame
    (lambda els: _replace(els, 18, ("UMLNote", 60, 400, 200, 50, "machine\n--\nname=other")),
     "names the region 'other' but its frame is titled 'work'"),
    # machine notes: unknown key, a key twice, vars not an object, two notes, a note in a simple state
    (lambda els: _replace(els, 23, ("UMLNote", 860, 20, 300, 100, "machine\n--\nname=hand\nnmae=x")),
     "line 'nmae=x' is not one of the machine's key=value lines"),
    (lambda els: _replace(els, 23, ("UMLNote", 860, 20, 300, 100, "machine\n--\nname=a\nname=b")),
     "'name' is given twice"),
    (lambda els: _replace(els, 23, ("UMLNote", 860, 20, 300, 100, "machine\n--\nvars=[1]")),
     "'vars' must be a JSON object"),
    (lambda els: _replace(els, 23, ("UMLNote", 860, 20, 300, 100, "machine\n--\ndescription=a\n--\nb")),
     "the description is given twice"),
    (lambda els: els + [("UMLNote", 860, 300, 300, 60, "machine\n--\nname=again")],
     "a second machine note for one machine"),
    (lambda els: els + [("UMLNote", 45, 85, 40, 30, "machine")],
     "machine note inside 'wait', which holds no machine"),
    (lambda els: els + [("UMLNote", 600, 400, 100, 40, "machine")],
     "machine note inside Parallel 'run' but in none of its region frames"),
])
def test_hand_drawn_parallel_and_note_mistakes_are_located(change, fragment):
    messages = _hand_errors(change(HAND_PARALLEL))
    assert any(fragment in m for m in messages), messages


def test_machine_note_outside_frames_with_several_machines():
    one_machine = [e for e in HAND_PARALLEL if e[0] != "UMLNote"][:4]
    other = [(k, x + 2000, y, w, h, t.replace("wait", "other"), *p) for k, x, y, w, h, t, *p in one_machine]
    elements = one_machine + other + [("UMLNote", 600, 20, 200, 60, "machine\n--\nname=both")]
    messages = _hand_errors([e if e[0] != "Relation" or "start" not in e[5] else (*e[:5], "lt=->") for e in elements])
    assert any("machine note outside every machine frame, but the diagram holds 2 machines" in m for m in messages)


def test_machine_note_names_a_framed_machine_and_a_nested_one():
    doc = one(element("UMLFrame", 0, 0, 600, 500, "framed"),
              element("UMLNote", 300, 20, 200, 80, "machine\n--\n$schema=../s.json\ndescription=outer"),
              INIT, START,
              element("UMLState", 40, 80, 240, 200, "C\nvalign=top"),
              element("UMLSpecialState", 60, 110, 20, 20, "type=initial"),
              relation([[70, 130], [70, 160]], "lt=->"),
              element("UMLState", 60, 160, 80, 40, "x"),
              element("UMLNote", 160, 200, 100, 60, "machine\n--\nname=inner\n--\nthe\ninner one"))
    assert doc["name"] == "framed" and doc["$schema"] == "../s.json" and doc["description"] == "outer"
    assert list(doc)[:3] == ["$schema", "name", "description"]
    assert strip(doc["states"][0]["machine"]) == {"name": "inner", "description": "the\ninner one", "initial": "x",
                                                  "states": [{"id": "x", "type": "Idle"}], "transitions": []}
