"""``fsmctl convert`` / ``validate`` / ``run`` / ``export`` on diagrams: exit codes, atomic writes, --check."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from fsm.tools.cli import main
from fsm.tools.umlet.writer import diagram, element, relation
from helpers import without_layout as strip

EXAMPLES = Path(__file__).resolve().parents[1] / "diagrams" / "examples"

TRAL = diagram([
    element("UMLSpecialState", 100, 20, 20, 20, "type=initial"),
    relation([[110, 40], [110, 80]], "lt=->"),
    element("UMLState", 40, 80, 160, 60, 'wait\n--\n"id": 0, "type": "Idle"\n--'),
    element("UMLState", 40, 220, 160, 60, "done\n--\ntype=Final\noutcome=ok"),
    relation([[110, 140], [110, 220]], 'lt=->\n"type": "Timeout", "seconds": 0.5'),
])


def run(capsys, *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    return code, out, err


def test_convert_validate_run_a_tral_diagram(tmp_path, capsys):
    src = tmp_path / "m.uxf"
    src.write_text(TRAL)
    code, _, err = run(capsys, "convert", str(src))
    assert code == 0, err
    doc = json.loads((tmp_path / "m.json").read_text())
    assert doc["initial"] == "wait" and doc["transitions"][0]["seconds"] == 0.5
    assert run(capsys, "convert", str(src), "--check")[0] == 0
    assert run(capsys, "validate", str(src))[0] == 0
    code, out, _ = run(capsys, "run", str(src), "--expect", "ok")
    assert code == 0 and "outcome ok" in out


def test_check_fails_when_the_committed_json_is_stale(tmp_path, capsys):
    src = tmp_path / "m.uxf"
    src.write_text(TRAL)
    run(capsys, "convert", str(src))
    src.write_text(TRAL.replace("0.5", "0.75"))
    code, _, err = run(capsys, "convert", str(src), "--check")
    assert code == 1 and "out of date" in err and "/transitions/0/seconds" in err


def test_errors_are_located_in_the_uxf_and_nothing_is_written(tmp_path, capsys):
    src = tmp_path / "bad.uxf"
    src.write_text(TRAL.replace('"type": "Timeout", "seconds": 0.5', '"type": "Timout", "seconds": 0.5'))
    code, out, err = run(capsys, "convert", str(src))
    assert code == 1 and not (tmp_path / "bad.json").exists()
    line = next(n for n, text in enumerate(TRAL.splitlines(), 1) if "Timeout" in text)
    assert "unknown transition type 'Timout'" in err and "did you mean Timeout" in err
    assert f"bad.uxf:{line - 9}:" in err or "bad.uxf:" in err  # line:column of the <element>
    assert "(x=" in err  # diagram coordinates
    code, _, err2 = run(capsys, "validate", str(src), "--format", "github")
    assert code == 1


@pytest.mark.parametrize("raw", [b"no xml", b"<!DOCTYPE x [<!ENTITY a 'b'>]><diagram/>", b"<diagram/>"])
def test_bad_files_exit_1_without_traceback(tmp_path, capsys, raw):
    src = tmp_path / "x.uxf"
    src.write_bytes(raw)
    out = tmp_path / "x.json"
    code, _, err = run(capsys, "convert", str(src), "-o", str(out))
    assert code == 1 and err.count("error") == 1 and not out.exists()
    assert run(capsys, "validate", str(src))[0] == 1


def test_several_machines_need_machine_option(tmp_path, capsys):
    one = TRAL.split("  <zoom_level>10</zoom_level>\n")[1].rsplit("</diagram>", 1)[0]
    import re

    other = re.sub(r"<x>(\d+)</x>", lambda m: f"<x>{int(m.group(1)) + 2000}</x>", one).replace("wait", "other")
    src = tmp_path / "two.uxf"
    src.write_text(TRAL.replace("</diagram>", other + "</diagram>"))
    code, _, err = run(capsys, "convert", str(src))
    assert code == 1 and "2 separate machines" in err and "'wait'" in err and "'other'" in err
    code, out, _ = run(capsys, "convert", str(src), "--machine", "other", "-o", "-")
    assert code == 0 and json.loads(out)["initial"] == "other"


@pytest.mark.parametrize("name", ["blinker", "drive"])
def test_examples_round_trip_and_are_up_to_date(tmp_path, capsys, name):
    assert run(capsys, "convert", str(EXAMPLES / f"{name}.uxf"), "--check")[0] == 0
    shutil.copy(EXAMPLES / f"{name}.json", tmp_path / f"{name}.json")
    assert run(capsys, "export", str(tmp_path / f"{name}.json"))[0] == 0
    assert run(capsys, "convert", str(tmp_path / f"{name}.uxf"), "-o", str(tmp_path / "back.json"))[0] == 0
    assert json.loads((tmp_path / "back.json").read_text()) == json.loads((EXAMPLES / f"{name}.json").read_text())


def test_export_of_a_document_without_layout_converts_back(tmp_path, capsys):
    doc = json.loads((EXAMPLES / "drive.json").read_text())


    (tmp_path / "drive.json").write_text(json.dumps(strip(doc)))
    assert run(capsys, "export", str(tmp_path / "drive.json"), "-o", str(tmp_path / "drive.uxf"))[0] == 0
    assert run(capsys, "convert", str(tmp_path / "drive.uxf"), "-o", str(tmp_path / "back.json"))[0] == 0
    assert strip(json.loads((tmp_path / "back.json").read_text())) == strip(doc)


@pytest.mark.parametrize("path", sorted(p for p in EXAMPLES.glob("*.json") if not p.name.endswith(".scenario.json")),
                         ids=lambda p: p.stem)
def test_every_example_exports_and_converts_back(tmp_path, capsys, path):
    """Round trip through the command line on every example document (also those without a diagram), includes
    resolved next to it: the same document, name, $schema and descriptions included."""
    work = tmp_path / "examples"
    shutil.copytree(EXAMPLES, work)
    src = work / path.name
    assert run(capsys, "export", str(src), "-o", str(work / "rt.uxf"))[0] == 0
    code, _, err = run(capsys, "convert", str(work / "rt.uxf"), "-o", str(work / "rt.json"))
    assert code == 0, err


    original = json.loads(src.read_text())
    back = json.loads((work / "rt.json").read_text())
    assert strip(back) == strip(original)
