"""Parameter models of plain elements made without pydantic-core, where the schema allows it (the parse stage's
fast path; :func:`fsm.loading.parsing.validated_together` falls back to the validator whenever it does not).

A plain element names its type and sets only fields whose checks are simple: text (``id``, ``type``, ``from``,
``to``, ``description``; a minimum length of one; the id pattern, no ``/``) and a ``layout`` of finite numbers
(lists of them for a transition's points). Every other field keeps its default.

For such elements pydantic-core's validation costs about 13,000 instructions per element: it looks up each of a
model's fields in the input, then builds the model. Here it is replaced by checks over the whole list at once (the
kinds of the values, empty texts, ``/`` in ids, lone surrogates, NaN and infinity), and the models are made as
pydantic makes them: the instance dict in field order, defaults included, the set fields' names, no extra and no
private values.

A list with anything else is answered ``None``, and the validator then decides, in its own words: another key, a
value of another kind, a number field, a layout nested deeper or holding objects, a model with its own validators
or hooks, a plugin watching validations.

The set of given fields' names is shared by the models of one shape (as the plan cache's reader does): parameter
models are frozen, so pydantic never adds to it (a copy, ``model_copy``, copies it first).
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable, Iterable
from itertools import chain, repeat
from operator import itemgetter
from typing import Any, NamedTuple

from annotated_types import MinLen
from pydantic_core import PydanticUndefined, SchemaValidator

from fsm.loading.reading import ONLY_DICT, ONLY_STR
from fsm.model.params import ID_PATTERN, ParamsBase

#: How a given field's values are checked: any text, non-empty text, an id (non-empty, no ``/``), a layout.
TEXT, NONEMPTY, ID, LAYOUT = "text", "nonempty", "id", "layout"
#: A field's default that is kept as it is (pydantic does not copy it): immutable atoms.
_ATOMS = (type(None), bool, int, float, str)
#: The kinds of a layout's numbers (the fast path takes lists of them too, :data:`_NESTED`).
_NUMBERS = frozenset({int, float, bool})


class Shape(NamedTuple):
    """What the fast path knows of a parameters model (made once per class)."""

    #: each field's default in field order; a field that may be given has its place (and its default)
    template: dict[str, Any]
    #: input key (alias, or name) -> (field name, kind)
    fields: dict[str, tuple[str, str]]
    #: the input keys that must be given
    required: frozenset[str]
    #: sets ``__dict__``, ``__pydantic_fields_set__``, ``__pydantic_extra__``, ``__pydantic_private__``
    setters: tuple[Callable[[Any, Any], None], ...]


def shape(model: type[Any]) -> Shape | None:
    """The :class:`Shape` of a parameters model, or None when its validation is more than the fast path checks."""
    if model in _SHAPES:
        return _SHAPES[model]
    found = _shape(model)
    _SHAPES[model] = found
    return found


_SHAPES: dict[type[Any], Shape | None] = {}


def _shape(model: type[Any]) -> Shape | None:
    if not (isinstance(model, type) and issubclass(model, ParamsBase)):
        return None
    if not model.__pydantic_complete__ and not model.model_rebuild(raise_errors=False):
        return None  # a model that cannot be built: its own validator says why
    config = model.model_config
    if (config.get("extra"), config.get("strict"), config.get("frozen"), config.get("populate_by_name"),
            config.get("validate_default")) != ("forbid", True, True, True, False):
        return None
    decorators = model.__pydantic_decorators__
    validators = decorators.field_validators
    if decorators.model_validators or decorators.root_validators or decorators.validators or \
            set(validators) - {"_finite_layout"} or model.__pydantic_post_init__ is not None or \
            model.__private_attributes__ or type(model.__pydantic_validator__) is not SchemaValidator:
        return None
    if "_finite_layout" in validators and _function(validators["_finite_layout"].func) is not \
            _function(ParamsBase.__pydantic_decorators__.field_validators["_finite_layout"].func):
        return None  # a subclass's own validator of that name
    template: dict[str, Any] = {}
    fields: dict[str, tuple[str, str]] = {}
    required = set()
    for name, info in model.model_fields.items():
        kind = _kind(name, info)
        if info.default_factory is not None or info.validate_default or \
                info.validation_alias not in (None, info.alias):
            return None  # a default made or checked per instance, or input keys of its own (AliasChoices, paths)
        if info.default is PydanticUndefined:
            if kind is None:
                return None
            required.add(info.alias or name)
        elif not isinstance(info.default, _ATOMS):
            return None
        template[name] = None if info.default is PydanticUndefined else info.default
        if kind is not None:
            fields[info.alias or name] = (name, kind)
            if info.alias and info.alias != name:
                fields[name] = (name, kind)  # populate_by_name: the field's own name is taken too
    setters = tuple(slot_setter(model, slot) for slot in ("__dict__", "__pydantic_fields_set__", "__pydantic_extra__",
                                                      "__pydantic_private__"))
    return Shape(template, fields, frozenset(required), setters)


def _function(method: Any) -> Any:
    return getattr(method, "__func__", method)


def _kind(name: str, info: Any) -> str | None:
    """How a field's given values are checked, or None when the fast path does not check it (it must not be given)."""
    metadata = list(info.metadata)
    if info.annotation is str or info.annotation == (str | None):
        if not metadata:
            return TEXT
        if len(metadata) == 1 and metadata[0] == MinLen(1):
            return NONEMPTY
        if len(metadata) == 2 and metadata[0] == MinLen(1) and getattr(metadata[1], "pattern", None) == ID_PATTERN \
                and len(vars(metadata[1])) == 1:
            return ID
        return None
    if name == "layout" and info.annotation == (dict[str, Any] | None) and not metadata:
        return LAYOUT
    return None


def made(classes: list[type[Any]], raws: list[dict[str, Any]]) -> list[Any] | None:
    """The parameter models of ``raws`` (JSON objects, each with its class's ``Params``), as pydantic-core would
    make them, or None when any of them is more than the fast path checks (the caller validates them all)."""
    if not raws:
        return []
    kinds = set(classes)
    if len(kinds) == 1 and len(set(map(len, raws))) == 1:  # one class, and (if every key of the first is in
        cls, = kinds                                           # all) one set of keys: the usual level
        try:
            return _group(cls, list(raws[0]), raws)
        except KeyError:
            pass
    by_group: dict[tuple[type[Any], frozenset[str]], list[int]] = {}
    for i, group in enumerate(zip(classes, map(frozenset, raws), strict=True)):
        by_group.setdefault(group, []).append(i)
    result: list[Any] = [None] * len(raws)
    for (cls, keys), where in by_group.items():
        models = _group(cls, list(keys), list(map(raws.__getitem__, where)))
        if models is None:
            return None
        deque(map(result.__setitem__, where, models), 0)
    return result


def _group(cls: type[Any], keys: list[str], raws: list[dict[str, Any]]) -> list[Any] | None:
    """The models of ``raws``, all of class ``cls`` and each with the input keys ``keys`` (a raw without one raises
    KeyError), or None."""
    params = getattr(cls, "Params", None)
    if not isinstance(params, type):
        return None
    found = shape(params)
    if found is None or not found.required.issubset(keys) or not found.fields.keys() >= set(keys):
        return None
    names = [found.fields[k][0] for k in keys]
    if len(set(names)) != len(names):
        return None  # a field given by its alias and its name
    texts: list[Iterable[str]] = []
    columns: list[list[Any]] = []
    for key in keys:
        values = list(map(itemgetter(key), raws))
        kind = found.fields[key][1]
        if kind == LAYOUT:
            if not _layouts(values):
                return None
            texts.append(chain.from_iterable(values))  # its keys: text, checked for lone surrogates too
            values = list(map(dict, values))  # pydantic copies the dict
        elif set(map(type, values)) != ONLY_STR or (kind != TEXT and not all(values)) or \
                (kind == ID and "/" in "".join(values)):
            return None
        else:
            texts.append(values)
        columns.append(values)
    try:
        "".join(chain.from_iterable(texts)).encode("utf-8")
    except UnicodeEncodeError:  # a lone surrogate (a JSON escape such as "\ud800"): pydantic refuses it
        return None
    n = len(raws)
    dicts = list(map(dict.copy, repeat(found.template, n)))
    placed = list(zip(names, columns, strict=True))
    if names == keys:  # no alias: each raw's values in their places at once (the layout's copy after)
        deque(map(dict.update, dicts, raws), 0)
        placed = [(name, values) for name, values in placed if name == "layout"]
    for name, values in placed:
        deque(map(dict.__setitem__, dicts, repeat(name), values), 0)
    models: list[Any] = list(map(object.__new__, repeat(params, n)))
    set_dict, set_fields, set_extra, set_private = found.setters
    deque(map(set_dict, models, dicts), 0)
    deque(map(set_fields, models, repeat(set(names), n)), 0)
    deque(map(set_extra, models, repeat(None, n)), 0)
    deque(map(set_private, models, repeat(None, n)), 0)
    return models


def _layouts(values: list[Any]) -> bool:
    """Every value a dict of text keys whose values are finite numbers or lists of them, to a depth of three (a
    state's ``x, y, w, h``, a transition's ``points``): what ``_finite_layout`` passes, checked level by level."""
    if set(map(type, values)) != ONLY_DICT or not set(map(type, chain.from_iterable(values))) <= ONLY_STR:
        return False
    items = list(chain.from_iterable(map(dict.values, values)))
    try:
        for _depth in range(_LAYOUT_DEPTH):
            kinds = set(map(type, items))
            if kinds <= _NUMBERS:
                return all(map(math.isfinite, items))
            if not kinds <= _NESTED:
                return False
            if not all(map(math.isfinite, [v for v in items if type(v) is not list])):
                return False
            items = list(chain.from_iterable([v for v in items if type(v) is list]))
    except OverflowError:  # an integer beyond a float's range: finite, but left to the validator
        return False
    return False


#: How deep a layout's lists may nest for the fast path (``points``: a list of pairs).
_LAYOUT_DEPTH = 3
_NESTED = _NUMBERS | {list}


def slot_setter(cls: type, name: str) -> Callable[[Any, Any], None]:
    """What ``object.__setattr__(obj, name, value)`` does for an instance of ``cls``, as a function of ``(obj,
    value)``: the data descriptor it finds (the instance dict's, a slot's) set directly, which skips the lookup per
    object (a third of making a batch of parameter models)."""
    for klass in cls.__mro__:
        found = vars(klass).get(name)
        if found is not None:
            setter = getattr(found, "__set__", None)
            if setter is not None:
                return setter  # type: ignore[no-any-return]
            break
    return lambda obj, value: object.__setattr__(obj, name, value)


__all__ = ["Shape", "made", "shape", "slot_setter"]
