"""Export then convert gives back exactly the document (``layout`` aside, which export may add or change), for
every example under ``diagrams/`` and every corpus diagram that converts; the committed pairs are fixed points."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fsm.loading.registry import default_registry
from fsm.model.errors import DiagramError
from fsm.tools.umlet.reader import convert_bytes, convert_file
from fsm.tools.umlet.source import parse_raw
from fsm.tools.umlet.writer import export
from helpers import CORPUS, needs_corpus
from helpers import without_layout as strip

ROOT = Path(__file__).resolve().parents[1]
DIAGRAMS = ROOT / "diagrams"
EXAMPLES = [p for p in sorted(DIAGRAMS.glob("*.json")) + sorted((DIAGRAMS / "examples").glob("*.json"))
            if not p.name.endswith(".scenario.json")]  # scenarios are not machines
FILES = sorted(CORPUS.glob("*.uxf")) if CORPUS.is_dir() else []
REGISTRY = default_registry()




def round_trip(doc: dict) -> dict:
    machines = convert_bytes(export(doc, REGISTRY).encode(), "x.uxf").machines
    assert len(machines) == 1
    return machines[0]


def _itaxo_renamed() -> bytes:
    """The Itaxo01 corpus diagram with its duplicate 'Associa primeiro' names made unique (in memory)."""
    raw = (CORPUS / "Itaxo01__Projeto-Engenharia-de-Software__Statechart.uxf").read_bytes()
    n = iter(range(1, 10))
    raw = re.sub(rb"<panel_attributes>Associa primeiro</panel_attributes>",
                 lambda m: f"<panel_attributes>Associa {next(n)}</panel_attributes>".encode(), raw)
    # "Ligar/Desligar": in a UML label '/' starts the action, and 'Desligar' is no assignment (a located error)
    return raw.replace("Ligar/Desligar".encode(), "Ligar ou Desligar".encode())


def _corpus_docs():
    out = []
    for path in FILES:
        try:
            out += [(path.name.split("__")[0], d) for d in convert_file(path).machines]
        except DiagramError:
            pass
    if FILES:
        out += [(f"itaxo-{i}", d) for i, d in enumerate(convert_bytes(_itaxo_renamed(), "itaxo.uxf").machines)]
    return out


def test_every_kind_of_example_is_covered():
    """The examples hold a Parallel state with an include in a region, machine metadata and nesting."""
    texts = {p.stem: p.read_text() for p in EXAMPLES}
    assert '"type": "Parallel"' in texts["mission"] and '"file": "grip.json"' in texts["mission"]
    assert all('"description"' in texts[k] for k in ("mission", "grip", "lane_change", "hallway_lap"))


@needs_corpus
def test_most_corpus_diagrams_convert():
    assert len(_corpus_docs()) >= 7  # KIT-MAMID and ikageso1 write free text after '/': no longer converted


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_example_exports_and_converts_back(path: Path):
    doc = json.loads(path.read_text())
    assert strip(round_trip(doc)) == strip(doc)


@needs_corpus
@pytest.mark.parametrize("name, doc", _corpus_docs(), ids=lambda v: v if isinstance(v, str) else "")
def test_corpus_document_exports_and_converts_back(name, doc):
    assert strip(round_trip(doc)) == strip(doc)


@pytest.mark.parametrize("path", [p for p in EXAMPLES if p.with_suffix(".uxf").exists()], ids=lambda p: p.stem)
def test_committed_pair_is_a_fixed_point(path: Path):
    """The committed diagram is what export writes of the committed document, layout included."""
    assert export(json.loads(path.read_text()), REGISTRY) == path.with_suffix(".uxf").read_text()


def test_parallel_is_drawn_as_frames_not_a_json_parameter():
    doc = json.loads((DIAGRAMS / "examples" / "mission.json").read_text())
    raw = parse_raw(export(doc, REGISTRY).encode(), "m.uxf")
    texts = [e.text for e in raw.elements]
    assert not any("regions=" in t for t in texts)
    run = next(e for e in raw.elements if e.text.startswith("run\n"))
    frames = [e for e in raw.elements if e.kind == "UMLFrame"]
    assert [f.text for f in frames] == ["work", "monitor"]
    for f in frames:  # inside the Parallel box, set in from its border (arrows to the box stay the box's)
        assert run.x + 20 <= f.x and f.x + f.w <= run.x + run.w - 20 and f.y + f.h <= run.y + run.h - 20
    note = next(e for e in raw.elements if e.kind == "UMLNote")
    assert note.text.startswith("machine\n--\nname=mission\n$schema=../../fsm/schema/machine.schema.json\n--\n")


def _machine(**meta) -> dict:
    return {**meta, "initial": "a", "states": [{"id": "a", "type": "Idle"}, {"id": "b", "type": "Final"}],
            "transitions": [{"type": "Timeout", "from": "a", "to": "b", "seconds": 1}]}


@pytest.mark.parametrize("meta", [
    {},  # no name: the note says so (the reader does not name the machine after the file)
    {"name": "x", "description": "line one\nline two", "vars": {"n": 1, "s": "t"}, "$schema": "s.json"},
    {"name": "42", "description": "name=not a key"},
    {"name": "two  spaces", "description": "  padded  "},
    {"name": "null", "description": "--"},
    {"description": "type=Idle\n\"type\": 1"},
])
def test_machine_keys_round_trip(meta):
    doc = _machine(**meta)
    back = round_trip(doc)
    assert strip(back) == doc


def test_nested_and_region_keys_round_trip():
    inner = _machine(name="inner", description="the inner machine", vars={})
    regions = [_machine(name="left", description="d"), _machine(name="file=odd"), _machine(), {"file": "r.json"}]
    doc = {"name": "outer", "initial": "c",
           "states": [{"id": "c", "type": "FSMState", "machine": inner},
                      {"id": "p", "type": "Parallel", "join": "any", "regions": regions}],
           "transitions": [{"type": "Finished", "from": "c", "to": "p"}]}
    assert strip(round_trip(doc)) == doc


TEXT = st.text(st.characters(blacklist_categories=("Cs", "Cc"), blacklist_characters="\r"), max_size=30) | \
    st.sampled_from(["machine", "--", "name=x", "description=y", "bg=red", "// c", "file=a", "null", "1", '"q"'])


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(name=st.none() | TEXT, description=st.none() | TEXT | st.lists(TEXT, max_size=3).map("\n".join),
       region=TEXT)
def test_any_machine_texts_round_trip(name, description, region):
    meta = {k: v for k, v in (("name", name), ("description", description)) if v is not None}
    doc = {**_machine(**meta), "states": [
        {"id": "a", "type": "Parallel", "regions": [_machine(name=region, description=region), _machine()]}],
        "transitions": []}
    assert strip(round_trip(doc)) == doc


def test_a_framed_machine_keeps_its_frame_which_grows_to_hold_the_note():
    from fsm.tools.umlet.writer import diagram, element, relation

    drawn = diagram([element("UMLFrame", 0, 0, 400, 300, "framed"),
                     element("UMLSpecialState", 40, 40, 20, 20, "type=initial"),
                     relation([[50, 60], [50, 100]], "lt=->"),
                     element("UMLState", 20, 100, 120, 40, "only")])
    doc = convert_bytes(drawn.encode(), "t.uxf").machines[0]
    assert doc["name"] == "framed" and "note" not in doc["layout"]
    doc["description"] = "a machine in a frame"
    back = round_trip(doc)
    assert strip(back) == strip(doc)
    frame, note = back["layout"]["frame"], back["layout"]["note"]
    assert frame["title"] == "framed" and frame["x"] == frame["y"] == 0
    assert note["x"] + note["w"] <= frame["w"] and note["y"] + note["h"] <= frame["h"]
    assert round_trip(back) == back  # a fixed point from then on
