"""Bad input to the loader: each mistake gives one clear, located message (file, line:column, JSON pointer,
element) and nothing else; all mistakes of a file are reported at once; the TRAL legacy form loads; a
20 MB document validates (its speed is in benchmarks/bench_big.py).

Positions are never hard-coded: they are computed from the text each test writes, so a test fails when
the loader points anywhere but at the real place.
"""

from __future__ import annotations

import gc
import json
from dataclasses import dataclass, field
from pathlib import Path

import pytest

import fsm
from fsm import DiagramError, Problem
from fsm.loading.reading import MAX_JSON_DEPTH
from fsm.tools.cli import main as fsmctl


# -- helpers --------------------------------------------------------------------------------------------
def pos_at(text: str, offset: int) -> tuple[int, int]:
    """1-based line and column of ``offset`` in ``text``."""
    line = text.count("\n", 0, offset) + 1
    column = offset - (text.rfind("\n", 0, offset) + 1) + 1
    return line, column


def pos_of(text: str, needle: str, nth: int = 0) -> tuple[int, int]:
    """1-based line and column where the ``nth`` occurrence (0-based) of ``needle`` starts."""
    offset = -1
    for _ in range(nth + 1):
        offset = text.find(needle, offset + 1)
        assert offset >= 0, f"{needle!r} (occurrence {nth}) not in the test document"
    return pos_at(text, offset)


def nth_bracket(text: str, n: int) -> int:
    """Offset of the ``n``-th (1-based) opening bracket or brace of ``text`` (no strings contain any)."""
    count = 0
    for i, ch in enumerate(text):
        if ch in "[{":
            count += 1
            if count == n:
                return i
    raise AssertionError("not enough brackets")


def check_file(path: Path) -> list[Problem]:
    _spec, problems = fsm.check(str(path))
    return problems


def only_problem(problems: list[Problem], severity: str = "error") -> Problem:
    assert len(problems) == 1, "expected exactly one problem, got:\n" + "\n".join(map(str, problems))
    assert problems[0].severity == severity, str(problems[0])
    return problems[0]


def only_error(problems: list[Problem]) -> Problem:
    """The one error among ``problems`` (follow-on warnings are checked by their own tests)."""
    errors = [p for p in problems if p.severity == "error"]
    assert len(errors) == 1, "expected exactly one error, got:\n" + "\n".join(map(str, problems))
    return errors[0]


def doc(states: list[dict], transitions: list[dict] | None = None, initial: str = "a", **extra: object) -> str:
    """A document as pretty JSON text: one element per line, so positions are easy to find."""
    lines = ["{", f'  "initial": {json.dumps(initial)},']
    for key, value in extra.items():
        lines.append(f"  {json.dumps(key)}: {json.dumps(value)},")
    lines.append('  "states": [')
    lines.append(",\n".join("    " + json.dumps(s) for s in states))
    lines.append("  ],")
    lines.append('  "transitions": [')
    lines.append(",\n".join("    " + json.dumps(t) for t in (transitions or [])))
    lines.append("  ]")
    lines.append("}")
    return "\n".join(lines) + "\n"


# -- the table of bad inputs ----------------------------------------------------------------------------
@dataclass
class Case:
    """One bad document. ``needle``/``nth`` say where in the text the message must point."""

    name: str
    text: str | bytes
    message: tuple[str, ...]  # substrings of the message (lower-cased comparison)
    needle: str | None = None
    nth: int = 0
    pointer: str = ""
    element: str | None = None
    extra_files: dict[str, str] = field(default_factory=dict)
    reported_in: str | None = None  # the file the problem belongs to, if not the main one
    expected_pos: tuple[int, int] | None = None  # when no needle can express it


DEEP = 100_000
_deep_array = "[" * DEEP + "]" * DEEP
_deep_inside = (
    '{\n  "initial": "a",\n  "states": [\n    {"id": "a", "type": "Idle", "layout": '
    + "[" * DEEP + "]" * DEEP + "}\n  ]\n}\n"
)
_non_utf8 = b'{\n  "initial": "a",\n  "states": [\n    {"id": "caf\xe9", "type": "Idle"}\n  ]\n}\n'
_sub_no_final = {"initial": "x", "states": [{"id": "x", "type": "Idle"}]}
_sub_final = {"initial": "x", "states": [{"id": "x", "type": "Final"}]}

CASES = [
    Case("invalid JSON",
         '{\n  "initial": "a",\n  "states": [\n    {"id": "a" "type": "Idle"}\n  ]\n}\n',
         ("invalid json",), needle='"type"'),
    Case("truncated JSON",
         '{\n  "initial": "a",\n  "states": [\n    {"id": "a", "type": "Idle"}\n',
         ("invalid json",), expected_pos=(5, 1)),
    Case("empty file", "", ("empty",), expected_pos=(1, 1)),
    Case("whitespace only", "  \n\n   \n", ("empty",), expected_pos=(1, 1)),
    Case("top-level array",
         '[\n  {"id": "a", "type": "Idle"}\n]\n',
         ("must be a json object", "array"), needle="["),
    Case("top-level string", '"just text"\n', ("must be a json object",), needle='"just text"'),
    Case("unknown state type",
         doc([{"id": "a", "type": "Idle"}, {"id": "drive", "type": "Idel"}],
             [{"type": "Timeout", "from": "a", "to": "drive", "seconds": 1}]),
         ("unknown state type 'idel'", "did you mean idle"),
         needle='"type": "Idel"', pointer="/states/1/type", element="state 'drive'"),
    Case("unknown transition type",
         doc([{"id": "a", "type": "Idle"}, {"id": "b", "type": "Final"}],
             [{"type": "Timout", "from": "a", "to": "b", "seconds": 1}]),
         ("unknown transition type 'timout'", "did you mean timeout"),
         needle='"type": "Timout"', pointer="/transitions/0/type", element="transition a -> b"),
    Case("parameter of the wrong type",
         doc([{"id": "a", "type": "Idle"}, {"id": "b", "type": "Final"}],
             [{"type": "Timeout", "from": "a", "to": "b", "seconds": "2"}]),
         ("seconds", "number", "'2'"),
         needle='"seconds"', pointer="/transitions/0/seconds", element="transition a -> b"),
    Case("parameter NaN",
         '{\n  "initial": "a",\n  "states": [\n    {"id": "a", "type": "Idle"},\n'
         '    {"id": "b", "type": "Final"}\n  ],\n  "transitions": [\n'
         '    {"type": "Timeout", "from": "a", "to": "b", "seconds": NaN}\n  ]\n}\n',
         ("seconds", "finite"),
         needle='"seconds"', pointer="/transitions/0/seconds", element="transition a -> b"),
    Case("parameter infinite",
         '{\n  "initial": "a",\n  "states": [\n    {"id": "a", "type": "Idle"},\n'
         '    {"id": "b", "type": "Final"}\n  ],\n  "transitions": [\n'
         '    {"type": "Timeout", "from": "a", "to": "b", "seconds": 1e999}\n  ]\n}\n',
         ("seconds", "finite"),
         needle='"seconds"', pointer="/transitions/0/seconds", element="transition a -> b"),
    Case("parameter out of range (Timeout seconds -1)",
         doc([{"id": "a", "type": "Idle"}, {"id": "b", "type": "Final"}],
             [{"type": "Timeout", "from": "a", "to": "b", "seconds": -1}]),
         ("seconds", "greater than 0", "-1"),
         needle='"seconds"', pointer="/transitions/0/seconds", element="transition a -> b"),
    Case("enum parameter out of range",
         doc([{"id": "a", "type": "Idle"}, {"id": "b", "type": "Final"}],
             [{"type": "Signal", "from": "a", "to": "b", "signal": "go", "edge": "sideways"}]),
         ("edge", "sideways"),
         needle='"edge"', pointer="/transitions/0/edge", element="transition a -> b"),
    Case("unknown parameter",
         doc([{"id": "a", "type": "Idle", "speed": 3}]),
         ("unknown parameter 'speed'",),
         needle='"speed"', pointer="/states/0/speed", element="state 'a'"),
    Case("missing initial key",
         '{\n  "states": [\n    {"id": "a", "type": "Idle"}\n  ]\n}\n',
         ("missing", "initial"), needle="{", pointer=""),
    Case("initial state that does not exist",
         doc([{"id": "a", "type": "Idle"}, {"id": "b", "type": "Final"}],
             [{"type": "Always", "from": "a", "to": "b"}], initial="start"),
         ("initial state 'start'", "not a state"),
         needle='"initial"', pointer="/initial"),
    Case("duplicate id",
         doc([{"id": "a", "type": "Idle"}, {"id": "b", "type": "Idle"}, {"id": "a", "type": "Final"}],
             [{"type": "Timeout", "from": "a", "to": "b", "seconds": 1}]),
         ("duplicate id 'a'", "/states/0"),
         needle='"id"', nth=2, pointer="/states/2/id", element="state 'a'"),
    Case("transition from an unknown id",
         doc([{"id": "a", "type": "Idle"}, {"id": "done", "type": "Final"}],
             [{"type": "Timeout", "from": "a", "to": "done", "seconds": 1},
              {"type": "Always", "from": "dne", "to": "done"}]),
         ("'from' names unknown state 'dne'", "did you mean 'done'"),
         needle='"from"', nth=1, pointer="/transitions/1/from", element="transition dne -> done"),
    Case("transition to an unknown id",
         doc([{"id": "a", "type": "Idle"}, {"id": "done", "type": "Final"}],
             [{"type": "Timeout", "from": "a", "to": "done", "seconds": 1},
              {"type": "Always", "from": "a", "to": "dnoe"}]),
         ("'to' names unknown state 'dnoe'", "did you mean 'done'"),
         needle='"to"', nth=1, pointer="/transitions/1/to", element="transition a -> dnoe"),
    Case("missing include file",
         doc([{"id": "a", "type": "FSMState", "machine": {"file": "nowhere.json"}}]),
         ("include", "nowhere.json", "not found"),
         needle='"file"', pointer="/states/0/machine/file", element="include"),
    Case("include cycle (a includes b includes a)",
         doc([{"id": "a", "type": "FSMState", "machine": {"file": "b.json"}}]),
         ("include cycle", "b.json", "a.json"),
         extra_files={"b.json": doc([{"id": "inner", "type": "FSMState", "machine": {"file": "a.json"}}],
                                    initial="inner")},
         reported_in="b.json", needle='"file"', pointer="/states/0/machine/file", element="include"),
    Case("a file that includes itself",
         doc([{"id": "a", "type": "FSMState", "machine": {"file": "./a.json"}}]),
         ("include cycle", "a.json"),
         needle='"file"', pointer="/states/0/machine/file", element="include"),
    Case("Finished out of Idle (never finishes)",
         doc([{"id": "a", "type": "Idle"}, {"id": "b", "type": "Final"}],
             [{"type": "Finished", "from": "a", "to": "b"}]),
         ("'a' (idle) can never finish", "finished"),
         needle='{"type": "Finished"', pointer="/transitions/0", element="transition a -> b"),
    Case("Finished out of an FSMState whose sub-machine has no Final",
         doc([{"id": "a", "type": "FSMState", "machine": _sub_no_final}, {"id": "b", "type": "Final"}],
             [{"type": "Finished", "from": "a", "to": "b"}]),
         ("'a' (fsmstate) can never finish", "final"),
         needle='{"type": "Finished"', pointer="/transitions/0", element="transition a -> b"),
    Case("Finished with an outcome the source never produces",
         doc([{"id": "a", "type": "FSMState", "machine": _sub_final}, {"id": "b", "type": "Final"}],
             [{"type": "Finished", "from": "a", "to": "b", "outcome": "aborted"}]),
         ("never finishes with outcome 'aborted'", "succeeded"),
         needle='"outcome"', pointer="/transitions/0/outcome", element="transition a -> b"),
    Case("JSON nested 100,000 levels deep (top-level array)", _deep_array,
         ("nested",), expected_pos=(1, MAX_JSON_DEPTH + 1)),
    Case("JSON nested 100,000 levels deep (inside a state)", _deep_inside,
         ("nested",), expected_pos=pos_at(_deep_inside, nth_bracket(_deep_inside, MAX_JSON_DEPTH + 1))),
    Case("non-UTF-8 bytes", _non_utf8, ("utf-8", "0xe9"),
         expected_pos=pos_at(_non_utf8.decode("latin-1"), _non_utf8.index(b"\xe9"))),
    Case("transition out of a Final state",
         doc([{"id": "a", "type": "Idle"}, {"id": "b", "type": "Final"}],
             [{"type": "Timeout", "from": "a", "to": "b", "seconds": 1},
              {"type": "Always", "from": "b", "to": "a"}]),
         ("out of final state 'b'",),
         needle='{"type": "Always"', pointer="/transitions/1", element="transition b -> a"),
    Case("InState naming a path that does not exist",
         doc([{"id": "a", "type": "Idle"}, {"id": "b", "type": "Final"}],
             [{"type": "InState", "from": "a", "to": "b", "state": "nowhere/x"}]),
         ("'state' names no state", "nowhere/x"),
         needle='"state"', pointer="/transitions/0/state", element="transition a -> b"),
    Case("state id with a slash",
         doc([{"id": "a", "type": "Idle"}, {"id": "b/c", "type": "Final"}],
             [{"type": "Always", "from": "a", "to": "b/c"}]),
         ("may not contain '/'",),
         needle='"id"', nth=1, pointer="/states/1/id", element="state 'b/c'"),
]


def _write_case(tmp_path: Path, case: Case) -> Path:
    path = tmp_path / "a.json"
    if isinstance(case.text, bytes):
        path.write_bytes(case.text)
    else:
        path.write_text(case.text, encoding="utf-8")
    for name, text in case.extra_files.items():
        (tmp_path / name).write_text(text, encoding="utf-8")
    return path


def _expected(case: Case, tmp_path: Path) -> tuple[Path, tuple[int, int]]:
    where = tmp_path / (case.reported_in or "a.json")
    if case.expected_pos is not None:
        return where, case.expected_pos
    assert case.needle is not None
    text = case.extra_files[case.reported_in] if case.reported_in else case.text
    assert isinstance(text, str)
    return where, pos_of(text, case.needle, case.nth)


@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_bad_input_gives_one_located_message(tmp_path: Path, case: Case) -> None:
    path = _write_case(tmp_path, case)
    problem = only_error(check_file(path))
    where, (line, column) = _expected(case, tmp_path)
    text = str(problem)
    assert problem.file == str(where), text
    assert (problem.line, problem.column) == (line, column), text
    assert problem.pointer == case.pointer, text
    assert f"{where}:{line}:{column}" in text
    if case.pointer:
        assert f"at {case.pointer}" in text
    if case.element is not None:
        # semantic checks may add the type: "transition a -> b (Finished)"
        assert problem.element is not None and problem.element.startswith(case.element), text
        assert case.element in text
    for part in case.message:
        assert part in text.lower(), f"{part!r} not in {text!r}"
    # fsm.load raises the same single problem, as a DiagramError (never anything else)
    with pytest.raises(DiagramError) as info:
        fsm.load(str(path))
    assert [str(p) for p in info.value.errors] == [text]


@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_bad_input_fsmctl_validate_exits_1_with_one_line(tmp_path: Path, case: Case,
                                                         capsys: pytest.CaptureFixture[str]) -> None:
    path = _write_case(tmp_path, case)
    code = fsmctl(["validate", str(path)])
    out, err = capsys.readouterr()
    assert code == 1
    assert "Traceback" not in err + out
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    where, (line, column) = _expected(case, tmp_path)
    assert lines[0].startswith(f"{where}:{line}:{column}"), lines[0]
    assert "1 error" in out


@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_bad_input_fsmctl_run_writes_nothing(tmp_path: Path, case: Case,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    path = _write_case(tmp_path, case)
    summary, trace = tmp_path / "summary.json", tmp_path / "trace.jsonl"
    code = fsmctl(["run", str(path), "--summary", str(summary), "--trace", str(trace)])
    out, err = capsys.readouterr()
    assert code == 1
    assert "Traceback" not in err + out
    assert len(err.strip().splitlines()) == 1, err
    assert not summary.exists() and not trace.exists()
    assert not list(tmp_path.glob(".*.tmp")), "a temporary file was left behind"


def test_unknown_type_suggests_several_close_names(tmp_path: Path) -> None:
    path = tmp_path / "m.json"
    path.write_text(doc([{"id": "a", "type": "final"}]))  # wrong case: Final; close to nothing else
    problem = only_problem(check_file(path))
    assert "unknown state type 'final'" in problem.message
    assert problem.hint is not None and "Final" in problem.hint


def test_unknown_type_without_close_name_points_to_fsmctl_types(tmp_path: Path) -> None:
    path = tmp_path / "m.json"
    path.write_text(doc([{"id": "a", "type": "Zzzzzzzz"}]))
    problem = only_problem(check_file(path))
    assert "fsmctl types" in (problem.hint or "")


def test_one_mistake_in_a_union_parameter_is_one_problem_at_a_real_pointer(tmp_path: Path) -> None:
    """`Var.value` accepts bool|int|float|str|null; a list there is one mistake, not one per union branch,
    and the pointer must exist in the document (not ``/value/bool``)."""
    text = doc([{"id": "a", "type": "Idle"}, {"id": "b", "type": "Final"}],
               [{"type": "Timeout", "from": "a", "to": "b", "seconds": 1},
                {"type": "Var", "from": "a", "to": "b", "var": "x", "value": [1, 2]}])
    path = tmp_path / "m.json"
    path.write_text(text)
    problem = only_problem(check_file(path))
    assert problem.pointer == "/transitions/1/value"
    assert (problem.line, problem.column) == pos_of(text, '"value"')


def test_unreachable_state_is_a_warning_not_an_error(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    text = doc([{"id": "a", "type": "Idle"}, {"id": "b", "type": "Final"}, {"id": "island", "type": "Idle"}],
               [{"type": "Timeout", "from": "a", "to": "b", "seconds": 0.1}])
    path = tmp_path / "m.json"
    path.write_text(text)
    problem = only_problem(check_file(path), severity="warning")
    assert problem.pointer == "/states/2"
    assert problem.element == "state 'island'"
    assert "unreachable" in problem.message
    assert (problem.line, problem.column) == pos_of(text, '{"id": "island"')
    machine = fsm.load(str(path))  # a warning does not stop the load
    assert fsm.run(machine, max_ticks=100).outcome == "succeeded"
    assert fsmctl(["validate", str(path)]) == 0
    out, err = capsys.readouterr()
    assert "warning" in out and "island" in out
    assert fsmctl(["validate", "--strict", str(path)]) == 1


@pytest.mark.parametrize("broken", [{"to": ""}, {"to": "s7x"}, {"to": 7}])
def test_a_broken_arrow_is_one_error_not_a_cascade_of_unreachable_states(tmp_path: Path, broken: dict) -> None:
    """A ring whose one transition has an empty, unknown or non-text end: its error alone. The states behind it
    would each be "unreachable" only because of that arrow (96 warnings in a 100-state ring before)."""
    n = 30
    transitions = [{"type": "Always", "from": f"s{i}", "to": f"s{(i + 1) % n}"} for i in range(n)]
    transitions[6].update(broken)
    path = tmp_path / "ring.json"
    path.write_text(doc([{"id": f"s{i}", "type": "Idle"} for i in range(n)], transitions, initial="s0"))
    assert only_problem(check_file(path)).pointer.startswith("/transitions/6")
    # a transition missing altogether is no broken arrow: the states behind it are unreachable, as drawn
    del transitions[6]
    path.write_text(doc([{"id": f"s{i}", "type": "Idle"} for i in range(n)], transitions, initial="s0"))
    problems = check_file(path)
    assert [p.element for p in problems] == [f"state 's{i}'" for i in range(7, n)]
    assert {p.severity for p in problems} == {"warning"}


def test_all_errors_of_a_file_are_reported_at_once(tmp_path: Path) -> None:
    """Five different mistakes give exactly five problems, each at its own place."""
    text = doc(
        [{"id": "start", "type": "Idel"},                                     # 1 unknown type
         {"id": "b", "type": "Idle"},
         {"id": "b", "type": "Final"}],                                       # 2 duplicate id
        [{"type": "Timeout", "from": "start", "to": "b", "seconds": -1},      # 3 out of range
         {"type": "Always", "from": "start", "to": "nowhere"},                # 4 unknown target
         {"type": "Finished", "from": "b", "to": "start"}],                   # 5 b (Idle) never finishes
        initial="start",
    )
    path = tmp_path / "five.json"
    path.write_text(text)
    problems = check_file(path)
    assert len(problems) == 5, "\n".join(map(str, problems))
    assert all(p.severity == "error" for p in problems)
    assert all(p.file == str(path) for p in problems)
    expected = {
        "/states/0/type": pos_of(text, '"type": "Idel"'),
        "/states/2/id": pos_of(text, '"id"', 2),
        "/transitions/0/seconds": pos_of(text, '"seconds"'),
        "/transitions/1/to": pos_of(text, '"to": "nowhere"'),
        "/transitions/2": pos_of(text, '{"type": "Finished"'),
    }
    assert {p.pointer: (p.line, p.column) for p in problems} == expected
    with pytest.raises(DiagramError) as info:
        fsm.load(str(path))
    assert len(info.value.errors) == 5
    assert len(str(info.value).splitlines()) == 5


def test_errors_in_an_included_file_and_the_including_file_are_reported_together(tmp_path: Path) -> None:
    inner = doc([{"id": "x", "type": "Final"}, {"id": "z", "type": "Idle", "colour": "red"}], initial="x")
    outer = doc([{"id": "a", "type": "FSMState", "machine": {"file": "sub/inner.json"}}, {"id": "b", "type": "Final"}],
                [{"type": "Finished", "from": "a", "to": "b"}], nmae="typo")
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "inner.json").write_text(inner)
    (tmp_path / "outer.json").write_text(outer)
    problems = check_file(tmp_path / "outer.json")
    got = {(p.file, p.pointer, p.line, p.column) for p in problems}
    assert got == {
        (str(tmp_path / "outer.json"), "/nmae", *pos_of(outer, '"nmae"')),
        (str(tmp_path / "sub" / "inner.json"), "/states/1/colour", *pos_of(inner, '"colour"')),
    }
    assert "did you mean 'name'" in str(next(p for p in problems if p.pointer == "/nmae"))


def test_errors_in_nested_inline_machines_have_full_pointers(tmp_path: Path) -> None:
    sub = {"initial": "x", "states": [{"id": "x", "type": "Idle"}, {"id": "y", "type": "Final"},
                                      {"id": "w", "type": "Idle", "speed": 2}],
           "transitions": [{"type": "Timeout", "from": "x", "to": "y", "seconds": 2}]}
    text = doc([{"id": "a", "type": "FSMState", "machine": sub}, {"id": "b", "type": "Final"}],
               [{"type": "Finished", "from": "a", "to": "b"}])
    path = tmp_path / "m.json"
    path.write_text(text)
    problem = only_problem(check_file(path))
    assert problem.pointer == "/states/0/machine/states/2/speed"
    assert (problem.line, problem.column) == pos_of(text, '"speed"')
    assert problem.element == "state 'w'"


def test_a_broken_transition_causes_no_follow_on_warning(tmp_path: Path) -> None:
    """The only way into 'b' has a bad parameter: that is one mistake; 'b' is not "unreachable" (the user drew
    a transition into it), so no second message tells them to add one."""
    text = doc([{"id": "a", "type": "Idle"}, {"id": "b", "type": "Final"}],
               [{"type": "Timeout", "from": "a", "to": "b", "seconds": -1}])
    path = tmp_path / "m.json"
    path.write_text(text)
    problem = only_problem(check_file(path))
    assert problem.pointer == "/transitions/0/seconds"


def test_a_broken_transition_in_a_sub_machine_causes_no_follow_on_error(tmp_path: Path) -> None:
    """A bad parameter on the sub-machine's way to its Final state must not make the loader claim that the
    composite "can never finish": the Final state is drawn and reachable once the parameter is fixed."""
    sub = {"initial": "x", "states": [{"id": "x", "type": "Idle"}, {"id": "y", "type": "Final"}],
           "transitions": [{"type": "Timeout", "from": "x", "to": "y", "seconds": -2}]}
    text = doc([{"id": "a", "type": "FSMState", "machine": sub}, {"id": "b", "type": "Final"}],
               [{"type": "Finished", "from": "a", "to": "b"}])
    path = tmp_path / "m.json"
    path.write_text(text)
    errors = [p for p in check_file(path) if p.severity == "error"]
    assert [p.pointer for p in errors] == ["/states/0/machine/transitions/0/seconds"], "\n".join(map(str, errors))


def test_missing_file_is_one_diagram_error(tmp_path: Path) -> None:
    path = tmp_path / "absent.json"
    problem = only_problem(check_file(path))
    assert problem.file == str(path)
    assert "not found" in problem.message
    with pytest.raises(DiagramError):
        fsm.load(path)


def test_a_directory_is_one_diagram_error(tmp_path: Path) -> None:
    problem = only_problem(check_file(tmp_path))
    assert "directory" in problem.message


def test_a_path_with_a_nul_byte_is_a_diagram_error() -> None:
    """A path string is user input too (it may come from a config file); it must not escape as ValueError."""
    with pytest.raises(DiagramError):
        fsm.load("machine\x00.json")
    _spec, problems = fsm.check("machine\x00.json")
    assert len(problems) == 1 and problems[0].severity == "error"


def test_dict_document_problems_carry_pointers_and_no_file() -> None:
    spec, problems = fsm.check({"initial": "a", "states": [{"id": "a", "type": "Idle"}],
                                "transitions": [{"type": "Timeout", "from": "a", "to": "a", "seconds": -1}]})
    problem = only_problem(problems)
    assert problem.file is None and problem.line is None
    assert problem.pointer == "/transitions/0/seconds"
    assert str(problem).startswith("<document> at /transitions/0/seconds")


# -- the TRAL legacy form -------------------------------------------------------------------------------
LEGACY = """{"root": 0,
  "states": [
    {"id": 0, "type": "Idle"},
    {"id": 1, "type": "Idle"},
    {"id": 2, "type": "Final", "outcome": "parked"}
  ],
  "transitions": [
    {"type": "Timeout", "from": 0, "to": 1, "seconds": 0.5},
    {"type": "Always", "from": 1, "to": 2}
  ]
}
"""


def test_legacy_form_loads_and_runs(tmp_path: Path) -> None:
    path = tmp_path / "legacy.json"
    path.write_text(LEGACY)
    _spec, problems = fsm.check(str(path))
    assert problems == []
    machine = fsm.load(str(path))
    machine.tick()
    assert machine.active_path == "0"
    assert fsm.run(machine, max_ticks=1000).outcome == "parked"
    assert machine.finished and machine.active_path == "2"
    # 0.5 s in state 0 at 80 Hz, then one tick in state 1
    assert machine.ticks == 41
    assert machine.transition_count == 2


def test_legacy_form_as_a_dict_loads_and_runs() -> None:
    machine = fsm.load(json.loads(LEGACY))
    assert fsm.run(machine, max_ticks=1000).outcome == "parked"


def test_legacy_form_errors_point_at_root_and_integer_ids(tmp_path: Path) -> None:
    text = LEGACY.replace('"root": 0', '"root": 7').replace('"to": 2}', '"to": 9}')
    path = tmp_path / "legacy.json"
    path.write_text(text)
    problems = check_file(path)
    assert [(p.pointer, p.line, p.column) for p in problems] == [
        ("/root", *pos_of(text, '"root"')),
        ("/transitions/1/to", *pos_of(text, '"to": 9')),
    ]
    assert "'7'" in problems[0].message
    assert problems[1].element == "transition 1 -> 9"


# -- size -----------------------------------------------------------------------------------------------
def _big_document(n: int, bad_at: int | None = None) -> str:
    """A ring of ``n`` Idle states left by Timeouts, about 170 bytes per state; one unknown type at ``bad_at``."""
    lines = ["{", '  "name": "ring",', '  "initial": "s0",', '  "states": [']
    for i in range(n):
        t = "Idel" if i == bad_at else "Idle"
        sep = "," if i < n - 1 else ""
        lines.append(f'    {{"id": "s{i}", "type": "{t}", "description": "state {i} of the generated ring"}}{sep}')
    lines += ["  ],", '  "transitions": [']
    for i in range(n):
        sep = "," if i < n - 1 else ""
        lines.append(f'    {{"type": "Timeout", "from": "s{i}", "to": "s{(i + 1) % n}", "seconds": 0.5}}{sep}')
    lines += ["  ]", "}"]
    return "\n".join(lines) + "\n"


def test_20_mb_document_validates_and_locates_a_planted_error(tmp_path: Path) -> None:
    """The speed is measured by benchmarks/bench_big.py, not asserted here (shared, noisy machines)."""
    n = 122_000
    bad = n - 17  # near the end: the locator has to scan almost the whole file
    text = _big_document(n, bad_at=bad)
    assert len(text.encode()) >= 20_000_000
    path = tmp_path / "big.json"
    path.write_text(text)
    problems = check_file(path)
    problem = only_problem(problems)
    assert problem.pointer == f"/states/{bad}/type"
    assert problem.element == f"state 's{bad}'"
    needle = f'{{"id": "s{bad}", "type": "Idel"'
    line, column = pos_of(text, needle)
    assert (problem.line, problem.column) == (line, column + len(f'{{"id": "s{bad}", '))




def test_a_types_own_validator_speaks_for_itself(tmp_path: Path) -> None:
    """A model validator of a type's Params (a check across parameters) is reported in its own words."""
    from pydantic import Field, model_validator

    from fsm import State, StateParams
    from fsm.loading.registry import Registry, using

    registry = Registry()
    with using(registry):
        from fsm.loading.registry import register_state

        @register_state
        class Band(State):
            """A band."""

            class Params(StateParams):
                low: float = Field(20.0)
                high: float = Field(25.0)

                @model_validator(mode="after")
                def _order(self) -> "Band.Params":
                    if self.high < self.low:
                        raise ValueError(f"high ({self.high}) must not be below low ({self.low})")
                    return self

    doc = tmp_path / "band.json"
    doc.write_text('{"initial": "a", "states": [{"id": "a", "type": "Band", "low": 20, "high": 15}]}')
    _spec, problems = fsm.check(str(doc), registry=registry)
    [p] = [p for p in problems if p.severity == "error"]
    assert p.pointer == "/states/0" and p.message == "high (15.0) must not be below low (20.0)", p.message
    assert "state 'a'" in str(p)


# -- the cycle collector, paused while loading ------------------------------------------------------------
def test_load_resumes_the_cycle_collector_after_a_load_and_after_a_refused_one() -> None:
    assert gc.isenabled()
    fsm.load({"initial": "a", "states": [{"id": "a", "type": "Idle"}]})
    assert gc.isenabled()
    with pytest.raises(DiagramError):
        fsm.load({"initial": "a", "states": [{"id": "a", "type": "NoSuchType"}]})
    assert gc.isenabled()


def test_load_leaves_a_cycle_collector_that_was_off_off() -> None:
    gc.disable()
    try:
        fsm.load({"initial": "a", "states": [{"id": "a", "type": "Idle"}]})
        assert not gc.isenabled()
    finally:
        gc.enable()


def test_loads_that_overlap_in_two_threads_leave_the_collector_on() -> None:
    """The collector is one per process: the first of two overlapping loads pauses it, and it stays paused until
    the last of them ends, then it is on again."""
    import threading

    from fsm.loading.loader import collection_paused

    first_in, second_in, first_out = threading.Event(), threading.Event(), threading.Event()
    seen: list[bool] = []

    def first() -> None:
        with collection_paused():
            first_in.set()
            second_in.wait(10)
        first_out.set()

    def second() -> None:
        first_in.wait(10)
        with collection_paused():
            second_in.set()
            first_out.wait(10)
            seen.append(gc.isenabled())  # the first ended, this one still loads

    threads = [threading.Thread(target=first), threading.Thread(target=second)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(10)
    assert seen == [False] and gc.isenabled()
