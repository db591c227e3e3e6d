"""Fuzzing the scenario reader (``fsm/tools/scenario/model.py``): random bytes, JSON of the right shape with wrong
values (huge, negative, non-numbers, control characters) and truncations of a real scenario file. Only our own
error types may come out; a scenario that loads also expands to its timeline and, when short, runs."""

from __future__ import annotations

import json
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fsm.model.errors import FsmError
from fsm.tools.scenario.model import LoadedScenario, load_scenario
from fsm.tools.scenario.runner import run_scenario
from fsm.tools.scenario.timeline import expand

REPO = Path(__file__).resolve().parents[1]
SORTER = REPO / "diagrams" / "examples" / "sorter.scenario.json"
#: The sorter scenario with its machine named by absolute path, so that a copy anywhere reads the same machine.
SORTER_TEXT = SORTER.read_text(encoding="utf-8").replace('"sorter.json"',
                                                         json.dumps(str(SORTER.parent / "sorter.json")))
MACHINES = [str(SORTER.parent / "sorter.json"), str(SORTER.parent / "mission.json"), "missing.json", "", "."]

FUZZ = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@pytest.fixture(scope="module")
def folder() -> Iterator[Path]:
    with tempfile.TemporaryDirectory(prefix="scenario-fuzz-") as name:
        yield Path(name)


def read(folder: Path, data: bytes) -> LoadedScenario | None:
    """Load ``data`` as a scenario file: a loaded scenario, or ``None`` for our own error; anything else fails."""
    path = folder / "fuzz.scenario.json"
    path.write_bytes(data)
    try:
        loaded = load_scenario(path)
    except FsmError:
        return None
    signals, sets = expand(loaded.scenario, loaded.dt)
    assert all(c.tick >= 0 for c in signals) and all(s.tick >= 0 for s in sets)
    if loaded.end_tick <= 2000 and loaded.world_path is None:
        run_scenario(loaded)
    return loaded


# -- random values where the scenario expects times, counts, names ------------------------------------------
NUMBERS = st.one_of(st.integers(-(2**70), 2**70), st.floats(allow_nan=False, allow_infinity=False),
                    st.sampled_from([0, -0.0, 1e-300, 5e-324, 1e308, 1.7976931348623157e308, 2**63, 10**400]))
TEXT = st.one_of(st.text(max_size=12), st.sampled_from(["cycle", "grip", "cycle/grip", "\x1b[2J", "\ud800", ""]))
SCALARS = st.one_of(st.none(), st.booleans(), NUMBERS, TEXT)
VALUES = st.recursive(SCALARS, lambda inner: st.one_of(st.lists(inner, max_size=3),
                                                       st.dictionaries(TEXT, inner, max_size=3)), max_leaves=8)


def shaped(keys: list[str], value: Any = VALUES) -> st.SearchStrategy[dict[str, Any]]:
    """Objects with some of ``keys``, each with a random value (and now and then a key of no kind)."""
    return st.dictionaries(st.one_of(st.sampled_from(keys), TEXT), value, max_size=len(keys))


TIMES = st.one_of(NUMBERS, SCALARS)
INPUTS = st.one_of(
    st.fixed_dictionaries({"at": TIMES, "signal": TEXT}, optional={"value": SCALARS, "width": TIMES}),
    st.fixed_dictionaries({"at": TIMES, "press": TEXT}, optional={
        "duration": TIMES, "bounce": st.one_of(shaped(["count", "interval"], NUMBERS), SCALARS)}),
    st.fixed_dictionaries({"at": TIMES, "set": st.one_of(st.dictionaries(TEXT, SCALARS, max_size=2), SCALARS)}),
    shaped(["at", "signal", "press", "set", "duration"]),
)
EXPECTATIONS = st.one_of(
    st.fixed_dictionaries({"at": TIMES}, optional={"active": st.one_of(TEXT, st.lists(TEXT, max_size=2), SCALARS),
                                                   "vars": VALUES}),
    st.fixed_dictionaries({"monitors": st.one_of(shaped(["owner", "behavior", "kind", "count", "min", "max"]),
                                                 st.fixed_dictionaries({"owner": TEXT, "at": st.lists(TIMES,
                                                                                                      max_size=3)}))}),
    st.fixed_dictionaries({"transitions": shaped(["count", "min", "max"], NUMBERS)}),
    shaped(["outcome", "finished", "visits", "never", "at", "active", "vars"]),
)
SCENARIOS = st.fixed_dictionaries(
    {"machine": st.one_of(st.sampled_from(MACHINES), SCALARS), "expect": st.lists(EXPECTATIONS, max_size=4)},
    optional={"dt": TIMES, "duration": TIMES, "max_ticks": TIMES, "seed": NUMBERS, "noise": SCALARS,
              "name": SCALARS, "world": st.sampled_from(["missing_world.json", str(REPO / "pyproject.toml"), ""]),
              "plugins": st.lists(st.sampled_from(["no_such_plugin_module_zz", "missing.py", "1 bad"]), max_size=2),
              "plants": st.lists(st.one_of(shaped(["name", "type"]), SCALARS), max_size=2),
              "inputs": st.lists(INPUTS, max_size=4), "extra": SCALARS},
)


def places(node: Any, path: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    """Every place in a JSON document: the path of each value below the top."""
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    return [p for key, value in items for p in [path + (key,), *places(value, path + (key,))]]


SORTER_DOC = json.loads(SORTER_TEXT)
SORTER_PLACES = places(SORTER_DOC) + [("dt",), ("max_ticks",), ("inputs", 0, "width"),
                                     ("expect", 0, "monitors", "at", 1)]


def mutated(changes: list[tuple[tuple[Any, ...], Any]]) -> dict[str, Any]:
    """The real scenario with a few values replaced (where their place still exists after earlier changes)."""
    doc = json.loads(json.dumps(SORTER_DOC))
    for path, value in changes:
        node = doc
        for key in path[:-1]:
            ok = (isinstance(node, dict) and key in node) or (isinstance(node, list) and isinstance(key, int)
                                                                and key < len(node))
            if not ok:
                break
            node = node[key]
        else:
            if isinstance(node, dict) or (isinstance(node, list) and isinstance(path[-1], int)
                                          and path[-1] < len(node)):
                node[path[-1]] = value
    return doc


#: The places of times and counts, where a huge or tiny number has the most to break.
TIME_KEYS = {"at", "duration", "dt", "max_ticks", "width", "interval", "count"}
TIME_PLACES = [p for p in SORTER_PLACES if TIME_KEYS & set(p)]
CHANGES = st.one_of(st.tuples(st.sampled_from(TIME_PLACES), NUMBERS),
                    st.tuples(st.sampled_from(SORTER_PLACES), st.one_of(NUMBERS, VALUES)))


@FUZZ
@given(changes=st.lists(CHANGES, min_size=1, max_size=3))
def test_a_real_scenario_with_wrong_values_gives_our_errors_only(folder: Path,
                                                                 changes: list[tuple[tuple[Any, ...], Any]]) -> None:
    read(folder, json.dumps(mutated(changes)).encode("utf-8", "surrogatepass"))


@FUZZ
@given(doc=SCENARIOS)
def test_scenarios_with_wrong_values_give_our_errors_only(folder: Path, doc: dict[str, Any]) -> None:
    read(folder, json.dumps(doc).encode("utf-8", "surrogatepass"))


@FUZZ
@given(data=st.binary(max_size=300))
def test_random_bytes_give_our_errors_only(folder: Path, data: bytes) -> None:
    assert read(folder, data) is None or data.strip().startswith(b"{")


@FUZZ
@given(cut=st.integers(0, len(SORTER_TEXT.encode("utf-8"))), flip=st.integers(0, 255))
def test_truncated_or_damaged_real_scenarios_give_our_errors_only(folder: Path, cut: int, flip: int) -> None:
    text = SORTER_TEXT.encode("utf-8")
    read(folder, text[:cut])
    read(folder, text[:cut] + bytes([flip]) + text[cut + 1:])


def test_the_real_scenario_reads_and_passes(folder: Path) -> None:
    """The fuzzed file is the real one: whole, it loads and passes (so the truncations start from a good file)."""
    loaded = read(folder, SORTER_TEXT.encode("utf-8"))
    assert loaded is not None and run_scenario(loaded).passed
