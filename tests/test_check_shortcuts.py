"""The cold load's shortcuts in the parse and check stages give what the long way gives: reachability along a chain
equals the breadth-first search, the tree's states, transitions and paths gathered level by level equal the
generators' walk, and the envelope validated with a stand-in for its elements equals (or fails as) the envelope
validated as written."""

from __future__ import annotations

import json
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pydantic import ValidationError

from fsm.loading.loader import analyse
from fsm.loading.outcomes import reachable
from fsm.loading.parsing import envelope_of
from fsm.model.document import MachineEnvelope, MachineSpec, Source

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))
from peers.tral_fsm import nested_doc, ring_doc  # noqa: E402


def _searched(initial: str, edges: list[tuple[str, str]]) -> set[str]:
    """Reachability the plain way: every edge out of every state reached, until nothing new is reached."""
    seen = {initial}
    while True:
        more = {dst for src, dst in edges if src in seen} - seen
        if not more:
            return seen
        seen |= more


_ids = st.sampled_from([f"s{i}" for i in range(8)])


@settings(max_examples=200, deadline=None)
@given(_ids, st.lists(st.tuples(_ids, _ids), max_size=12))
def test_reachable_states_are_those_a_search_finds(initial: str, edges: list[tuple[str, str]]) -> None:
    """With at most one edge out of each state (a chain, a ring) or with more, the same states are reached."""
    spec = MachineSpec(Source(None), "", None, initial, "/initial", [], [], {}, edges=edges)
    assert reachable(spec) == _searched(initial, edges)


def _documents() -> list[Any]:
    files = sorted(p for p in (ROOT / "diagrams").rglob("*.json")
                   if "worlds" not in p.parts and not p.name.endswith(".scenario.json"))
    return [ring_doc(20), nested_doc(), *files]


def _walk(level: MachineSpec, prefix: str = "") -> Iterator[tuple[Any, str]]:
    """Every state with the path of its level, depth first in document order: the plain recursive way."""
    for state in level.states:
        yield state, prefix
        path = f"{prefix}/{state.id}" if prefix else state.id
        for sub in state.subs:
            if sub.machine is not None:
                yield from _walk(sub.machine, f"{path}/{sub.name}" if sub.name else path)


def _walk_transitions(level: MachineSpec, prefix: str = "") -> Iterator[tuple[Any, str]]:
    """Every transition with the path of its level, this level's first: the plain recursive way."""
    yield from ((tr, prefix) for tr in level.transitions)
    for state in level.states:
        path = f"{prefix}/{state.id}" if prefix else state.id
        for sub in state.subs:
            if sub.machine is not None:
                yield from _walk_transitions(sub.machine, f"{path}/{sub.name}" if sub.name else path)


@pytest.mark.parametrize("doc", _documents(), ids=lambda d: d.name if isinstance(d, Path) else str(d.get("name")))
def test_the_tree_gathered_level_by_level_is_the_walk(doc: Any) -> None:
    spec, _analysis, _problems = analyse(doc)
    assert spec is not None
    states, transitions, paths = spec.scoped()
    assert states == list(_walk(spec))
    assert transitions == list(_walk_transitions(spec))
    assert paths == frozenset(f"{prefix}/{s.id}" if prefix else s.id for s, prefix in _walk(spec))


def _outcome(data: dict[str, Any], text_keys: bool = False) -> tuple[str, Any]:
    try:
        if text_keys:
            return "ok", envelope_of(data, text_keys=True).model_dump()
        return "ok", envelope_of(data).model_dump()
    except ValidationError as err:
        return "error", err.errors(include_url=False, include_context=False)


def _written(data: dict[str, Any]) -> tuple[str, Any]:
    try:
        return "ok", MachineEnvelope.model_validate(data).model_dump(exclude={"states", "transitions"})
    except ValidationError as err:
        return "error", err.errors(include_url=False, include_context=False)


_ring = ring_doc(40)
_ENVELOPES: list[dict[str, Any]] = [
    _ring,
    {**_ring, "transitions": []},
    {k: v for k, v in _ring.items() if k != "transitions"},
    {**_ring, "states": []},
    {**_ring, "initial": ""},
    {**_ring, "vars": {"x": float("inf")}, "inputs": [""]},
    {**_ring, "states": [*_ring["states"][:-1], 7]},  # an element that is no object
    {**_ring, "states": [*_ring["states"][:-1], {1: "a", "id": "x"}]},  # a key that is no text (a Python dict)
    {**_ring, "transitions": "none"},
    {**_ring, "bogus": 1, "states": {"a": 1}},
]


@pytest.mark.parametrize("data", _ENVELOPES, ids=range(len(_ENVELOPES)))
def test_the_envelope_with_a_stand_in_is_the_envelope_as_written(data: dict[str, Any]) -> None:
    kind, got = _outcome(data)
    want_kind, want = _written(data)
    assert kind == want_kind
    if kind == "ok":
        got = {k: v for k, v in got.items() if k not in ("states", "transitions")}
    assert got == want
    if all(isinstance(k, str) for el in data.get("states") or () if isinstance(el, dict) for k in el):
        assert _outcome(json.loads(json.dumps(data)) if kind == "ok" else data, text_keys=True)[0] == kind
