"""Export then convert gives back the same document, for every corpus diagram that converts."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from fsm.errors import DiagramError
from fsm.registry import default_registry
from fsm.tools.uxf import convert_bytes, convert_file
from fsm.tools.uxf_writer import export

CORPUS = Path("/work/shared/corpus/uxf")
FILES = sorted(CORPUS.glob("*.uxf")) if CORPUS.is_dir() else []


def strip(d):
    if isinstance(d, dict):
        return {k: strip(v) for k, v in d.items() if k != "layout"}
    return [strip(x) for x in d] if isinstance(d, list) else d


def _itaxo_renamed() -> bytes:
    """The Itaxo01 corpus diagram with its duplicate 'Associa primeiro' names made unique (in memory)."""
    raw = (CORPUS / "Itaxo01__Projeto-Engenharia-de-Software__Statechart.uxf").read_bytes()
    n = iter(range(1, 10))
    return re.sub(rb"<panel_attributes>Associa primeiro</panel_attributes>",
                  lambda m: f"<panel_attributes>Associa {next(n)}</panel_attributes>".encode(), raw)


def _docs():
    out = []
    for path in FILES:
        try:
            out += [(path.name, d) for d in convert_file(path).machines]
        except DiagramError:
            pass
    if FILES:
        out += [("itaxo", d) for d in convert_bytes(_itaxo_renamed(), "itaxo.uxf").machines]
    return out


@pytest.mark.parametrize("name, doc", _docs(), ids=lambda v: v if isinstance(v, str) else "")
def test_export_converts_back(name, doc):
    back = convert_bytes(export(doc, default_registry()).encode(), "x.uxf").machines
    assert len(back) == 1
    assert strip({**back[0], "name": None}) == strip({**doc, "name": None})
