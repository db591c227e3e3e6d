"""Ids and messages printed to a terminal cannot drive it: control characters (C0, DEL, C1, ESC sequences) are
shown escaped by ``fsm.model.errors.printable``, which every printed problem and the run, validate, test and types lines
go through; files keep the real characters."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from fsm.model.errors import DiagramError, Problem, printable
from helpers import cli

#: Anything a terminal acts on, as it must never reach one.
RAW_CONTROL = re.compile("[\x00-\x08\x0b-\x1f\x7f-\x9f]")

CLEAR, TITLE, CSI = "a\x1b[2J", "t\x1b]0;pwned\x07", "b\x9b31m"


@pytest.mark.parametrize("text, shown", [
    ("plain text, é and ✓", "plain text, é and ✓"),
    (CLEAR, "a\\x1b[2J"),
    (TITLE, "t\\x1b]0;pwned\\x07"),
    (CSI, "b\\x9b31m"),
    ("del\x7f nul\x00 cr\r lf\n tab\t", "del\\x7f nul\\x00 cr\\x0d lf\\x0a tab\\x09"),
    ("lone \ud800", "lone \\ud800"),
    ("admin\u202e\u2066txt.exe\u2069", "admin\\u202e\\u2066txt.exe\\u2069"),
    ("mark\u200f and\u2028line", "mark\\u200f and\\u2028line"),
    ("joiner\u200d kept: it changes no order", "joiner\u200d kept: it changes no order"),
])
def test_printable_escapes_what_a_terminal_acts_on(text: str, shown: str) -> None:
    assert printable(text) == shown


def test_multi_line_output_keeps_line_feeds_and_tabs_only() -> None:
    assert printable("one\n\ttwo\r\x1b[K", multiline=True) == "one\n\ttwo\\x0d\\x1b[K"


def test_a_text_without_controls_is_returned_as_it_is() -> None:
    text = "x" * 100
    assert printable(text) is text


def test_problems_print_escaped_and_keep_the_real_text_for_files() -> None:
    p = Problem(f"unknown state '{TITLE}'", f"m{CLEAR}.json", "/states/0", element=f"state '{CSI}'", hint="h\n")
    assert not RAW_CONTROL.search(str(p))
    assert str(p) == ("ma\\x1b[2J.json at /states/0: error: state 'b\\x9b31m': "
                      "unknown state 't\\x1b]0;pwned\\x07' (h\\x0a)")
    assert p.text == f"m{CLEAR}.json at /states/0: error: state '{CSI}': unknown state '{TITLE}' (h\n)"
    assert p.to_dict()["message"] == f"unknown state '{TITLE}'"
    assert not RAW_CONTROL.search(str(DiagramError([p, p])).replace("\n", ""))


def machine(tmp_path: Path) -> str:
    """Three states whose ids clear the screen, set the window title and start a C1 sequence."""
    doc = {"initial": CLEAR, "states": [{"id": CLEAR, "type": "Idle"}, {"id": CSI, "type": "Idle"},
                                        {"id": TITLE, "type": "Idle"}],
           "transitions": [{"type": "Timeout", "from": CLEAR, "to": CSI, "seconds": 1}]}
    path = tmp_path / "m.json"
    path.write_text(json.dumps(doc), encoding="utf-8")
    return str(path)


def assert_safe(*texts: str) -> None:
    for text in texts:
        assert not RAW_CONTROL.search(text), text


def test_validate_prints_ids_escaped(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    file = machine(tmp_path)
    code, out, err = cli(capsys, "validate", file)
    assert code == 0
    assert_safe(out, err)
    assert "state 't\\x1b]0;pwned\\x07': unreachable from the initial state 'a\\x1b[2J'" in out
    code, out, err = cli(capsys, "validate", "--format", "github", file)
    assert_safe(out, err)
    code, out, _ = cli(capsys, "validate", "--format", "json", file)  # JSON escapes them itself
    assert_safe(out)
    assert json.loads(out)[0]["problems"][0]["element"] == f"state '{TITLE}'"


def test_run_prints_ids_escaped(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    file = machine(tmp_path)
    code, out, err = cli(capsys, "run", file, "--duration", "2", "--summary", str(tmp_path / "s.json"))
    assert code == 0
    assert_safe(out, err)
    assert "visited: a\\x1b[2J -> b\\x9b31m" in out and "active: b\\x9b31m" in out
    assert json.loads((tmp_path / "s.json").read_text(encoding="utf-8"))["visited"] == [CLEAR, CSI]


def test_test_prints_ids_and_names_escaped(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    machine(tmp_path)
    scenario = tmp_path / "s.scenario.json"
    scenario.write_text(json.dumps({"name": f"n{CLEAR}", "machine": "m.json", "duration": 2,
                                    "expect": [{"at": 1.5, "active": CLEAR}, {"never": [TITLE]}]}), encoding="utf-8")
    bad = tmp_path / "bad.scenario.json"
    bad.write_text(json.dumps({"machine": "m.json", "expect": [{"never": [f"zz{TITLE}"]}]}), encoding="utf-8")
    code, out, err = cli(capsys, "test", str(scenario), str(bad))
    assert code == 1
    assert_safe(out, err)
    assert "FAIL na\\x1b[2J: expect[0] at 1.5 s" in out and "enter b\\x9b31m (Timeout from a\\x1b[2J)" in out
    assert "the machine has no state 'zzt\\x1b]0;pwned\\x07'" in err


def test_error_messages_of_the_command_escape_file_names(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    name = str(tmp_path / f"{CLEAR}.json")
    for argv in (["validate", name], ["run", name], ["run", str(tmp_path / "m.json"), "--trace", name + "/x"]):
        machine(tmp_path)
        code, out, err = cli(capsys, *argv)
        assert code in (1, 2)
        assert_safe(out, err)
        assert "\\x1b[2J" in err


def test_types_prints_plugin_docs_escaped(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    plugin = tmp_path / "esc_plugin.py"
    plugin.write_text('from fsm import State, register_state\n\n\n@register_state\nclass EscState(State):\n'
                      '    """Clears \\x1b[2J the screen."""\n', encoding="utf-8")
    code, out, err = cli(capsys, "--plugin", str(plugin), "types", "EscState")
    assert code == 0
    assert_safe(out, err)
    assert "EscState: Clears \\x1b[2J the screen." in out
