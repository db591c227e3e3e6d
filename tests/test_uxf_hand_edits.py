"""Hand edits of a real UMLet diagram (a corpus file, edited here as a person would in UMLet's text panel): a state
box without its ``--`` line, a parameter line without a colon or a comma, a parameter name without quotes, a
misspelt type name. Each is one located message with the box's canvas position and what to write instead."""

from __future__ import annotations

from pathlib import Path

import pytest

from helpers import CORPUS, cli, needs_corpus

#: A German garage-door controller drawn in UMLet 14.3 (valid as it is: plain UML states and transitions).
GARAGE = "Belinus-code__Garagen-Controller__Zustandsdiagramm.uxf"
#: The box edited: the state GESCHLOSSEN at x=1710, y=660, line 42 of the file.
BOX = "<panel_attributes>GESCHLOSSEN\n--\n\nvalign=top\n</panel_attributes>"
WHERE = "UMLState 'GESCHLOSSEN' at x=1710, y=660"


def edited(tmp_path: Path, text: str) -> Path:
    source = (CORPUS / GARAGE).read_text(encoding="utf-8")
    assert source.count(BOX) == 1
    out = tmp_path / "garage.uxf"
    out.write_text(source.replace(BOX, f"<panel_attributes>{text}\nvalign=top\n</panel_attributes>"),
                   encoding="utf-8")
    return out


@needs_corpus
@pytest.mark.parametrize("text, message", [
    ('GESCHLOSSEN\n"type": "Idle"',
     "the name 'GESCHLOSSEN' and the parameters need a line -- between them (write the lines GESCHLOSSEN | -- | "
     '"type": "Idle"; a state box is its name, a line --, then "type": "TypeName", "param": value, ..., one per '
     "line)"),
    ('GESCHLOSSEN\n--\n"type": "Wait",\n"seconds" 2',
     "parameter line '\"seconds\" 2' has no colon (write it as \"seconds\": 2, or as seconds=2)"),
    ('GESCHLOSSEN\n--\n"type": "Wait",\nseconds: 2',
     "parameter name 'seconds' needs double quotes in the JSON parameters (write \"seconds\": 2, or seconds=2)"),
    ('GESCHLOSSEN\n--\n"type": "Wait"\n"seconds": 2',
     "parameter line '\"type\": \"Wait\"' needs a comma at its end (another parameter follows) (end it with a "
     "comma: \"type\": \"Wait\",)"),
])
def test_a_hand_edited_box_says_what_it_should_look_like(text: str, message: str, tmp_path: Path,
                                                         capsys: pytest.CaptureFixture[str]) -> None:
    file = edited(tmp_path, text)
    code, _, err = cli(capsys, "validate", str(file))
    assert code == 1
    assert err == f"{file}:42:3: error: {WHERE}: {message}\n"


@needs_corpus
def test_a_misspelt_type_is_located_on_the_canvas_with_the_name_meant(tmp_path: Path,
                                                                    capsys: pytest.CaptureFixture[str]) -> None:
    file = edited(tmp_path, 'GESCHLOSSEN\n--\n"type": "Idel"')
    code, _, err = cli(capsys, "validate", str(file))
    assert code == 1
    assert err == (f"{file}:42:3 (x=1710, y=660) at /states/1/type: error: state 'GESCHLOSSEN': unknown state type "
                   "'Idel' (did you mean Idle? write \"type\": \"Idle\")\n")


@needs_corpus
def test_the_box_written_as_the_hint_says_is_valid(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    file = edited(tmp_path, 'GESCHLOSSEN\n--\n"type": "Wait",\n"seconds": 2')
    code, out, err = cli(capsys, "validate", str(file))
    assert (code, err) == (0, "") and out.endswith(": ok\n")
