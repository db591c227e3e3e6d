"""The parse stage's fast path for plain elements (fsm.loading.plain_params) against pydantic-core, its reference:
whatever the fast path makes, pydantic makes the same (class, instance dict in the same order, set fields, extra and
private values); whatever pydantic refuses, the fast path declines. Elements come from hypothesis, from every
JSON document of the repository and from the converted corpus of UMLet files drawn by other people."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pydantic import AliasChoices, BaseModel, ConfigDict, Field, ValidationError, field_validator

import fsm
from fsm.loading import loader, parsing, plain_params
from fsm.loading.loader import registry_of
from fsm.model.params import StateParams, TransitionParams

REPO = Path(__file__).resolve().parents[1]


def same(fast: list[Any], slow: list[Any]) -> None:
    assert len(fast) == len(slow)
    for a, b in zip(fast, slow, strict=True):
        assert type(a) is type(b)
        assert list(a.__dict__.items()) == list(b.__dict__.items())
        assert a.__pydantic_fields_set__ == b.__pydantic_fields_set__
        assert a.__pydantic_extra__ == b.__pydantic_extra__ and a.__pydantic_private__ == b.__pydantic_private__
        assert a == b
        if isinstance(a.__dict__.get("layout"), dict):
            assert a.__dict__["layout"] is not b.__dict__["layout"]


def reference(classes: list[type[Any]], raws: list[Any]) -> list[Any] | None:
    """What pydantic makes of ``raws`` (the model of each element's class), or None if it refuses one."""
    try:
        return [cls.Params.__pydantic_validator__.validate_python(raw) for cls, raw in zip(classes, raws, strict=True)]
    except ValidationError:
        return None


def compare(classes: list[type[Any]], raws: list[Any]) -> list[Any] | None:
    fast = plain_params.made(classes, raws)
    slow = reference(classes, raws)
    if fast is not None:
        assert slow is not None, f"the fast path took what pydantic refuses: {raws!r}"
        same(fast, slow)
    return fast


@pytest.fixture(scope="module")
def registry() -> Any:
    fsm.load({"initial": "a", "states": [{"id": "a", "type": "Idle"}]})
    reg = registry_of(())
    for model in (StateParams, TransitionParams):
        model.model_rebuild()
    return reg


def test_the_ring_takes_the_fast_path(registry: Any) -> None:
    states = [{"id": f"s{i}", "type": "Idle"} for i in range(50)]
    transitions = [{"type": "Always", "from": f"s{i}", "to": f"s{(i + 1) % 50}"} for i in range(50)]
    idle, always = registry.states["Idle"], registry.transitions["Always"]
    assert compare([idle] * 50, states) is not None
    assert compare([always] * 50, transitions) is not None
    drawn = [dict(t, layout={"points": [[i, 0.5], [i + 1, 2]]}) for i, t in enumerate(transitions)]
    assert compare([always] * 50, drawn) is not None  # as converted from UMLet
    made = plain_params.made([always] * 50, transitions)
    assert made is not None and made[3].from_ == "s3" and made[3].model_fields_set == {"type", "from_", "to"}


TEXTS = st.sampled_from(["a", "s1", "", "a/b", "/", "x\n", "\ud800", "ü", "from", "0"]) | st.text(max_size=4)
VALUES = (TEXTS | st.none() | st.booleans() | st.integers(-3, 3) | st.just(10 ** 400)
          | st.sampled_from([0.5, math.nan, math.inf, -0.0])
          | st.dictionaries(st.sampled_from(["x", "y", "\ud800", "w"]),
                            st.integers(-5, 5) | st.sampled_from([1.5, math.nan, True, "t"])
                            | st.lists(st.integers() | st.lists(st.integers() | st.just(math.inf)
                                                              | st.lists(st.just(1) | st.lists(st.just(2))),
                                                              max_size=2) | st.just({"a": 1}), max_size=2),
                            max_size=3)
          | st.lists(st.integers(), max_size=2))
STATE_KEYS = ["id", "type", "description", "layout", "timeout_exception", "timeout", "endless", "extra", "set"]
TRANSITION_KEYS = ["type", "from", "from_", "to", "description", "layout", "priority", "guard", "extra"]


def elements(keys: list[str], type_name: str, required: dict[str, Any]) -> Any:
    optional = st.dictionaries(st.sampled_from(keys), VALUES, max_size=3)
    return st.builds(lambda base, more: {**base, **more}, st.fixed_dictionaries(required), optional).map(
        lambda raw: {**raw, "type": type_name} if raw.get("type") != "Other" else raw)


@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(elements(STATE_KEYS, "Idle", {"id": TEXTS}), min_size=1, max_size=4), st.data())
def test_states_as_pydantic_makes_them(registry: Any, raws: list[dict[str, Any]], data: Any) -> None:
    if data.draw(st.booleans()):  # all alike, as a generated level is
        raws = [dict(raws[0], id=f"s{i}") for i in range(len(raws))]
    compare([registry.states["Idle"]] * len(raws), raws)


@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(elements(TRANSITION_KEYS, "Always", {"from": TEXTS, "to": TEXTS}), min_size=1, max_size=4))
def test_transitions_as_pydantic_makes_them(registry: Any, raws: list[dict[str, Any]]) -> None:
    compare([registry.transitions["Always"]] * len(raws), raws)


GOOD_TEXT = st.text(min_size=1).filter(lambda t: "/" not in t)
NUMBER = st.integers(-10 ** 6, 10 ** 6) | st.floats(allow_nan=False, allow_infinity=False)
GOOD_LAYOUT = st.dictionaries(st.text(max_size=3), NUMBER | st.lists(st.lists(NUMBER, max_size=2), max_size=3),
                              max_size=4)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.fixed_dictionaries({"id": GOOD_TEXT, "type": st.just("Idle")},
                                      optional={"description": st.text(), "layout": GOOD_LAYOUT,
                                                "timeout_exception": GOOD_TEXT}), min_size=1, max_size=5))
def test_well_formed_states_take_the_fast_path(registry: Any, raws: list[dict[str, Any]]) -> None:
    """Elements pydantic accepts: the fast path takes them all, and makes what pydantic makes."""
    assert compare([registry.states["Idle"]] * len(raws), raws) is not None


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.fixed_dictionaries({"type": st.just("Always"), "from": GOOD_TEXT, "to": GOOD_TEXT},
                                      optional={"description": st.text(), "layout": GOOD_LAYOUT}),
                min_size=1, max_size=5))
def test_well_formed_transitions_take_the_fast_path(registry: Any, raws: list[dict[str, Any]]) -> None:
    assert compare([registry.transitions["Always"]] * len(raws), raws) is not None


def test_declined_where_it_cannot_decide(registry: Any) -> None:
    idle = registry.states["Idle"]
    for raw in ({"id": "a", "type": "Idle", "timeout": 2},  # a number field: pydantic's
                {"id": "a", "type": "Idle", "layout": {"points": [[[[1]]]]}},  # nested deeper
                {"id": "a", "type": "Idle", "layout": {"points": [{"x": 1}]}},  # objects in it
                {"id": "a", "type": "Idle", "layout": {"points": [[1, math.inf]]}},
                {"id": "a", "type": "Idle", "layout": {"x": math.nan}},  # NaN: pydantic's words
                {"id": "a", "type": "Idle", "description": None},  # null is refused: pydantic's words
                {"id": "a/b", "type": "Idle"}, {"id": "", "type": "Idle"}, {"id": "\ud800", "type": "Idle"}):
        assert plain_params.made([idle], [raw]) is None, raw
    always = registry.transitions["Always"]
    both = {"type": "Always", "from": "a", "from_": "a", "to": "b"}
    assert plain_params.made([always], [both]) is None
    # a type's own fields, validators, hooks or configuration leave its elements to pydantic
    assert plain_params.shape(registry.states["Wait"].Params) is None
    assert plain_params.shape(TransitionParams) is not None

    class Checked(StateParams):
        @field_validator("id")
        @classmethod
        def _upper(cls, value: str) -> str:
            return value.upper()

    class Hooked(StateParams):
        def model_post_init(self, context: Any) -> None:
            pass

    class Private(StateParams):
        _seen: int = 0

    class Loose(StateParams):
        model_config = ConfigDict(extra="allow")

    class Listed(StateParams):
        tags: list[str] = Field(default_factory=list)

    class Plain(BaseModel):
        id: str

    class Chosen(StateParams):
        label: str = Field(default="", validation_alias=AliasChoices("label", "name"))

    for model in (Checked, Hooked, Private, Loose, Listed, Plain, Chosen):
        assert plain_params.shape(model) is None, model.__name__


def test_mixed_levels_keep_their_order(registry: Any) -> None:
    idle, final = registry.states["Idle"], registry.states["Final"]
    raws = [{"id": "a", "type": "Idle"}, {"type": "Final", "id": "b"}, {"id": "c", "type": "Idle",
                                                                       "layout": {"x": 1, "y": 2.5}},
            {"id": "d", "type": "Idle", "description": "d"}]
    made = compare([idle, final, idle, idle], raws)
    assert made is not None and [m.id for m in made] == ["a", "b", "c", "d"]


def documents() -> list[Path]:
    return sorted(p for p in (REPO / "diagrams").rglob("*.json") if "worlds" not in p.parts
                  and not p.name.endswith(".scenario.json"))


def levels(doc: Any) -> Any:
    """Every list of states and of transitions of a document, at any depth."""
    if isinstance(doc, dict):
        for key in ("states", "transitions"):
            if isinstance(doc.get(key), list):
                yield key, doc[key]
        for value in doc.values():
            yield from levels(value)
    elif isinstance(doc, list):
        for value in doc:
            yield from levels(value)


@pytest.mark.parametrize("path", documents(), ids=lambda p: str(p.relative_to(REPO)))
def test_every_document_of_the_repository(registry: Any, path: Path) -> None:
    checked = 0
    for key, raws in levels(json.loads(path.read_text(encoding="utf-8"))):
        table = registry.states if key == "states" else registry.transitions
        if not all(isinstance(r, dict) and isinstance(r.get("type"), str) and r["type"] in table for r in raws):
            continue
        compare([table[r["type"]] for r in raws], raws)
        checked += 1
    assert checked


def test_the_corpus_drawn_by_others(registry: Any) -> None:
    """UMLet files by other people, converted: elements with layouts, descriptions and parameters."""
    from fsm.model.errors import DiagramError  # noqa: PLC0415
    from fsm.tools.umlet.reader import convert_file  # noqa: PLC0415 - the UMLet reader only here

    corpus = REPO.parent / "shared" / "corpus" / "uxf"
    files = sorted(corpus.glob("*.uxf")) + sorted((REPO / "diagrams").rglob("*.uxf"))
    taken = 0
    for uxf in files:
        try:
            docs = convert_file(uxf).machines
        except DiagramError:  # a drawing that is no machine of ours: nothing to compare
            continue
        for key, raws in levels(docs):
            table = registry.states if key == "states" else registry.transitions
            if raws and all(isinstance(r, dict) and r.get("type") in table for r in raws):
                if compare([table[r["type"]] for r in raws], raws) is not None:
                    taken += 1
    assert taken, "no level of the corpus took the fast path"


def test_a_load_gives_the_spec_the_validator_gives(registry: Any, monkeypatch: pytest.MonkeyPatch,
                                                  tmp_path: Path) -> None:
    doc = {"initial": "s0", "states": [{"id": f"s{i}", "type": "Idle", "layout": {"x": i, "y": 0.5}}
                                       for i in range(40)],
           "transitions": [{"type": "Always", "from": f"s{i}", "to": f"s{(i + 1) % 40}", "description": "next"}
                           for i in range(40)]}
    fast = loader.compile(doc)
    monkeypatch.setattr(plain_params, "made", lambda classes, raws: None)
    slow = loader.compile(json.loads(json.dumps(doc)))
    assert fast.spec.states == slow.spec.states and fast.spec.transitions == slow.spec.transitions
    assert parsing.validated_together(registry.states, doc["states"]) is not None
