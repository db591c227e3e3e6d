"""Mutated diagrams never raise anything but DiagramError."""

from __future__ import annotations

import json
from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fsm.model.errors import DiagramError
from fsm.tools.umlet.reader import convert_bytes
from fsm.tools.umlet.writer import export
from helpers import CORPUS

EXAMPLES = Path(__file__).resolve().parents[1] / "diagrams" / "examples"
SEEDS = [p.read_bytes() for p in sorted(EXAMPLES.glob("*.uxf"))]
# a Parallel state drawn as region frames, and machine notes
SEEDS.append(export(json.loads((EXAMPLES / "mission.json").read_text())).encode())
if CORPUS.is_dir():
    SEEDS += [p.read_bytes() for p in sorted(CORPUS.glob("*.uxf"))]

TOKENS = [b"<", b">", b"&", b"-", b";", b"10.0", b"-5", b"nan", b"1e999", b"type=initial", b"type=final",
          b"lt=->", b"lt=<-", b"--", b"\n", b"\r\n", b'"type": ', b"type=Timeout", b"</element>", b"<element>",
          b"<x>", b"</x>", b"", b"\x00", b"\xff", b"{", b"}", b"valign=top", b"<!DOCTYPE x>", b"machine",
          b"type=Parallel", b"file=", b"vars=", b"name=", b"UMLFrame", b"UMLNote"]


@st.composite
def mutated(draw):
    data = bytearray(draw(st.sampled_from(SEEDS)))
    for _ in range(draw(st.integers(1, 6))):
        pos = draw(st.integers(0, len(data)))
        op = draw(st.integers(0, 2))
        if op == 0:  # insert a token
            data[pos:pos] = draw(st.sampled_from(TOKENS))
        elif op == 1:  # delete a slice
            data[pos:pos + draw(st.integers(1, 40))] = b""
        else:  # replace digits (coordinates, points)
            end = min(len(data), pos + 30)
            data[pos:end] = bytes(draw(st.sampled_from(b"0123456789-.;")) if c in b"0123456789" else c
                                  for c in data[pos:end])
    return bytes(data)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mutated())
def test_mutated_diagrams_raise_only_diagram_error(raw):
    try:
        conv = convert_bytes(raw, "m.uxf")
    except DiagramError as exc:
        assert exc.problems and all(p.message for p in exc.problems)
        return
    assert conv.machines


@settings(max_examples=200, deadline=None)
@given(st.binary(max_size=300))
def test_arbitrary_bytes(raw):
    try:
        convert_bytes(raw, "b.uxf")
    except DiagramError:
        pass
