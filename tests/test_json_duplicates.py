"""Repeated keys in JSON files (machine documents, includes, world files) are errors that name both places,
and includes that cannot be read (symlink loops, directories) give one located message, never a traceback.

Positions are computed from the text each test writes, never hard-coded.
"""

from __future__ import annotations

import json
import os
import string
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import fsm
from fsm import DiagramError
from fsm.model.jsonpos import duplicate_keys
from fsm.sim.world import load_world


def pos_of(text: str, needle: str, nth: int = 0) -> tuple[int, int]:
    offset = -1
    for _ in range(nth + 1):
        offset = text.find(needle, offset + 1)
        assert offset >= 0
    return text.count("\n", 0, offset) + 1, offset - (text.rfind("\n", 0, offset) + 1) + 1


def problems(path: Path) -> list:
    with pytest.raises(DiagramError) as info:
        fsm.load(path)
    return info.value.problems


def test_repeated_key_in_a_state_names_both_places(tmp_path: Path) -> None:
    text = ('{"initial": "a",\n'
            ' "states": [{"id": "a", "type": "Idle",\n'
            '             "type": "Final"}]}\n')
    f = tmp_path / "m.json"
    f.write_text(text)
    [p] = problems(f)
    first, second = pos_of(text, '"type"', 0), pos_of(text, '"type"', 1)
    assert (p.line, p.column) == second
    assert p.pointer == "/states/0/type"
    assert f"line {first[0]}, column {first[1]}" in p.message
    assert "duplicate key 'type'" in p.message and p.hint
    assert p.file == str(f)


def test_every_repeated_key_of_a_file_is_reported(tmp_path: Path) -> None:
    text = ('{"initial": "a", "initial": "b",\n'
            ' "states": [{"id": "a", "type": "Idle"}, {"id": "b", "id": "c", "type": "Idle"}],\n'
            ' "transitions": [], "vars": {"x": 1, "x": 2}}\n')
    f = tmp_path / "m.json"
    f.write_text(text)
    found = {(p.pointer, p.line, p.column) for p in problems(f) if "duplicate key" in p.message}
    assert found == {("/initial", *pos_of(text, '"initial"', 1)),
                     ("/states/1/id", *pos_of(text, '"id": "c"')),
                     ("/vars/x", *pos_of(text, '"x": 2'))}


def test_repeated_keys_are_reported_with_every_other_problem_of_the_file(tmp_path: Path) -> None:
    """The parser keeps the last value: the other checks run on it, and their problems point at it."""
    text = ('{"initial": "a", "initial": "b",\n'
            ' "states": [{"id": "a", "type": "Idel"}],\n'
            ' "transitions": [{"type": "Timeout", "from": "a", "to": "a", "seconds": -1}]}\n')
    f = tmp_path / "m.json"
    f.write_text(text)
    found = sorted((p.pointer, p.line, p.column, p.message.split(" (")[0]) for p in problems(f))
    second = pos_of(text, '"initial"', 1)
    assert found == sorted([
        ("/initial", *second, "duplicate key 'initial'"),
        ("/initial", *second, "initial state 'b' is not a state of this machine"),
        ("/states/0/type", *pos_of(text, '"type": "Idel"'), "unknown state type 'Idel'"),
        ("/transitions/0/seconds", *pos_of(text, '"seconds"'), "'seconds': Input should be greater than 0, got -1"),
    ])


def test_repeated_keys_in_a_world_come_with_its_other_problems(tmp_path: Path) -> None:
    text = ('{"walls": [{"points": [[0, 0], [5, 0]]}], "walls": [],\n'
            ' "gates": [{"markers": [3, 3], "center": [1, 1]}],\n'
            ' "start": {"x": 1, "y": 1}}\n')
    f = tmp_path / "w.json"
    f.write_text(text)
    with pytest.raises(DiagramError) as info:
        load_world(f)
    assert sorted(p.pointer for p in info.value.problems) == ["/gates/0/markers/1", "/walls"]


def test_keys_escaped_differently_are_the_same_key(tmp_path: Path) -> None:
    text = '{"initial": "a", "states": [{"id": "a", "type": "Idle"}], "\\u0069nitial": "a"}'
    f = tmp_path / "m.json"
    f.write_text(text)
    [p] = problems(f)
    assert p.pointer == "/initial" and (p.line, p.column) == pos_of(text, '"\\u0069')


def test_repeated_key_in_an_included_file_is_located_there(tmp_path: Path) -> None:
    (tmp_path / "sub.json").write_text('{"initial": "x",\n "states": [{"id": "x", "type": "Final", "id": "y"}]}')
    main = tmp_path / "main.json"
    main.write_text(json.dumps({"initial": "a", "states": [
        {"id": "a", "type": "FSMState", "machine": {"file": "sub.json"}}]}))
    found = problems(main)
    [p] = [p for p in found if "duplicate key" in p.message]
    assert p.file == str(tmp_path / "sub.json") and p.pointer == "/states/0/id" and p.line == 2
    # the last 'id' counts, so the sub-machine's initial state 'x' is missing: reported in the same run
    assert any("initial state 'x'" in q.message and q.file == p.file for q in found)


def test_repeated_key_in_a_world_file(tmp_path: Path) -> None:
    text = ('{"walls": [{"points": [[0, 0], [5, 0]]}],\n'
            ' "start": {"x": 1, "y": 1, "x": 2}}\n')
    f = tmp_path / "w.json"
    f.write_text(text)
    with pytest.raises(DiagramError) as info:
        load_world(f)
    [p] = info.value.problems
    assert p.pointer == "/start/x" and (p.line, p.column) == pos_of(text, '"x": 2')


def test_same_key_in_different_objects_is_fine(tmp_path: Path) -> None:
    f = tmp_path / "m.json"
    f.write_text('{"initial": "a", "states": [{"id": "a", "type": "Idle"}, {"id": "b", "type": "Idle"}],'
                 ' "transitions": [{"type": "Always", "from": "a", "to": "b"}]}')
    assert fsm.load(f).root.initial.id == "a"


# -- hypothesis: any JSON object with one key repeated gives a located duplicate-key problem -------------
_keys = st.text(alphabet=string.ascii_letters + "_ é/~", min_size=1, max_size=6)
_scalars = st.one_of(st.none(), st.booleans(), st.integers(-5, 5), st.text(max_size=4))
_values = st.recursive(_scalars, lambda inner: st.one_of(st.lists(inner, max_size=3),
                                                         st.dictionaries(_keys, inner, max_size=3)), max_leaves=8)


@st.composite
def documents_with_a_repeat(draw: st.DrawFn) -> tuple[str, str, str]:
    """JSON text of a random nested object in which one object repeats one key; the object's pointer and key."""
    base = draw(st.dictionaries(_keys, _values, min_size=1, max_size=4))
    # choose the object that gets the repeat: the top level or a nested object
    path: list[str | int] = []
    node = base
    while True:
        children = [(k, v) for k, v in (node.items() if isinstance(node, dict) else enumerate(node))
                    if isinstance(v, (dict, list)) and v]
        if not children or not draw(st.booleans()):
            break
        k, node = draw(st.sampled_from(children))
        path.append(k)
    if not isinstance(node, dict):  # a list was chosen: wrap it in an object, which takes its place
        node = {"k": node}
        parent = base
        for k in path[:-1]:
            parent = parent[k]
        parent[path[-1]] = node  # type: ignore[index]
    key = draw(st.sampled_from(sorted(node)))
    marker = "\u0000REPEAT\u0000"
    node[marker] = draw(_values)
    indent = draw(st.sampled_from([None, 1, 2]))
    text = json.dumps(base, indent=indent, ensure_ascii=draw(st.booleans()))
    text = text.replace(json.dumps(marker, ensure_ascii=False), json.dumps(key, ensure_ascii=False))
    text = text.replace(json.dumps(marker), json.dumps(key))
    ptr = "".join("/" + str(p).replace("~", "~0").replace("/", "~1") for p in path)
    return text, ptr, key


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(documents_with_a_repeat())
def test_random_documents_with_a_repeated_key_are_refused_with_both_places(case: tuple[str, str, str]) -> None:
    text, ptr, key = case
    from fsm.loading.reading import parse_json_bytes

    with pytest.raises(DiagramError) as info:
        parse_json_bytes(text.encode(), "doc.json")
    escaped = key.replace("~", "~0").replace("/", "~1")
    located = [p for p in info.value.problems if p.pointer == f"{ptr}/{escaped}"]
    assert located, [str(p) for p in info.value.problems]
    p = located[0]
    assert p.line is not None and p.column is not None and "first at line" in p.message
    # the reported position is where the repeated key's text starts
    offset = sum(len(ln) + 1 for ln in text.split("\n")[: p.line - 1]) + p.column - 1
    assert json.JSONDecoder().raw_decode(text, offset)[0] == key
    assert duplicate_keys(text)


def _repeats_by_hook(text: str) -> bool:
    repeated = []

    def pairs(items: list[tuple[str, object]]) -> dict[str, object]:
        obj = dict(items)
        repeated.extend([True] if len(obj) != len(items) else [])
        return obj

    json.loads(text, object_pairs_hook=pairs)
    return bool(repeated)


_tricky = st.text(alphabet=':"\\{}[]ab ', max_size=5)  # what could fool a count of colons, quotes or brackets
_tricky_values = st.recursive(st.one_of(_scalars, _tricky), lambda inner: st.one_of(
    st.lists(inner, max_size=3), st.dictionaries(st.one_of(_keys, _tricky), inner, max_size=3)), max_leaves=10)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.one_of(documents_with_a_repeat().map(lambda case: case[0]),
                 st.builds(json.dumps, _tricky_values, ensure_ascii=st.booleans(), indent=st.sampled_from([None, 1]))))
def test_repeats_found_by_counting_are_the_parsers_own(text: str) -> None:
    """The reader finds a repeated key by counting (keys against colons, strings against quotes, fsm.loading.reading
    .json_count) instead of a hook per object: it says what a hook would, or that it cannot tell (then the hook
    decides), for texts with colons, quotes, brackets and backslashes inside their strings."""
    from fsm.loading.reading import _repeats_key, parse_json_bytes

    found = _repeats_key(text, json.loads(text))
    assert found in (None, _repeats_by_hook(text))
    if not _repeats_by_hook(text):
        assert parse_json_bytes(text.encode(), "doc.json")[0] == json.loads(text)


# -- includes that cannot be read ---------------------------------------------------------------------------
def _including(tmp_path: Path, target: str) -> tuple[Path, str]:
    text = json.dumps({"initial": "a", "states": [
        {"id": "a", "type": "FSMState", "machine": {"file": target}}]})
    main = tmp_path / "main.json"
    main.write_text(text)
    return main, text


@pytest.mark.parametrize("layout", ["self", "pair"])
def test_symlink_loop_include_is_a_located_error(tmp_path: Path, layout: str) -> None:
    if layout == "self":
        os.symlink("a.json", tmp_path / "a.json")
    else:
        os.symlink("b.json", tmp_path / "a.json")
        os.symlink("a.json", tmp_path / "b.json")
    main, text = _including(tmp_path, "a.json")
    [p] = problems(main)
    assert p.pointer == "/states/0/machine/file" and (p.line, p.column) == pos_of(text, '"file"')
    assert "symbolic links" in p.message.lower() and "symlink" in p.hint


def test_symlink_loop_as_the_machine_itself_is_a_clean_error(tmp_path: Path) -> None:
    os.symlink("m.json", tmp_path / "m.json")
    [p] = problems(tmp_path / "m.json")
    assert "symbolic links" in p.message.lower()


def test_include_of_a_directory_is_a_located_error(tmp_path: Path) -> None:
    (tmp_path / "d.json").mkdir()
    main, text = _including(tmp_path, "d.json")
    [p] = problems(main)
    assert "directory" in p.message and p.pointer == "/states/0/machine/file"


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
def test_include_of_a_fifo_is_refused_without_reading_it(tmp_path: Path) -> None:
    os.mkfifo(tmp_path / "f.json")
    main, _ = _including(tmp_path, "f.json")
    [p] = problems(main)  # would hang if the loader opened the FIFO
    assert "not a regular file" in p.message


def test_include_through_a_good_symlink_still_works(tmp_path: Path) -> None:
    (tmp_path / "real.json").write_text(json.dumps({"initial": "x", "states": [{"id": "x", "type": "Final"}]}))
    os.symlink("real.json", tmp_path / "link.json")
    main, _ = _including(tmp_path, "link.json")
    m = fsm.load(main)
    fsm.run(m, max_ticks=5)
    assert m.active_path == "a/x" and m.state("a").finished


# -- JSON inside .uxf boxes -----------------------------------------------------------------------------------
@pytest.mark.parametrize(("text", "words"), [
    ('A\n--\n"type": "Idle", "type": "Final"', "parameter 'type' is given twice"),
    ('A\n--\ntype=Final\nlayout={"x": 1, "x": 2}', "key 'x' is given twice"),
])
def test_repeated_keys_in_a_state_box_are_errors(text: str, words: str) -> None:
    from fsm.tools.umlet.reader import convert_bytes
    from fsm.tools.umlet.writer import diagram, element, relation

    elements = [element("UMLSpecialState", 100, 20, 20, 20, "type=initial"),
                relation([[110, 40], [110, 80]], "lt=->"), element("UMLState", 60, 80, 100, 40, text)]
    with pytest.raises(DiagramError) as info:
        convert_bytes(diagram(elements, 10).encode(), "t.uxf")
    [p] = info.value.problems
    assert words in p.message and p.line is not None and "UMLState 'A'" in (p.element or "")


def test_repeated_keys_in_a_machine_note_are_errors() -> None:
    from fsm.tools.umlet.reader import convert_bytes
    from fsm.tools.umlet.writer import diagram, element, relation

    elements = [element("UMLSpecialState", 100, 20, 20, 20, "type=initial"),
                relation([[110, 40], [110, 80]], "lt=->"), element("UMLState", 60, 80, 100, 40, "A"),
                element("UMLNote", 300, 80, 100, 40, 'machine\n--\nvars={"x": 1, "x": 2}')]
    with pytest.raises(DiagramError) as info:
        convert_bytes(diagram(elements, 10).encode(), "t.uxf")
    [p] = info.value.problems
    assert "key 'x' is given twice" in p.message and "UMLNote" in (p.element or "")
