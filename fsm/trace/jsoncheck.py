"""A JSON Schema compiled once into plain Python checks, for values checked many times (the lines of a trace).

It covers the part of draft 2020-12 the committed trace schema uses (``type``, ``const``, ``enum``, bounds, ``pattern``,
``required``, ``properties``, ``additionalProperties``, ``items``, ``minItems``, ``maxItems``, ``oneOf``, local
``$ref``) and refuses any other keyword when compiling, so the schema cannot grow a rule that is silently not checked.
It is stricter than JSON Schema in one point: an ``integer`` is a whole number as JSON writes it (``1``, never
``1.0``). A check returns ``None`` or the first :class:`Mismatch`: where it is, what was expected, what was found.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

#: Keywords that only describe (nothing to check).
ANNOTATIONS = frozenset({"$schema", "$id", "$defs", "$comment", "title", "description", "contentEncoding",
                         "contentMediaType", "default", "examples"})
KEYWORDS = frozenset({"type", "const", "enum", "minimum", "maximum", "exclusiveMinimum", "exclusiveMaximum",
                      "pattern", "required", "properties", "additionalProperties", "items", "minItems", "maxItems",
                      "oneOf", "$ref"})
_TYPE_WORDS = {"object": "an object", "array": "a list", "string": "a string", "integer": "a whole number",
               "number": "a number", "boolean": "true or false", "null": "null"}


@dataclass
class Mismatch:
    """The first thing in a value that its schema does not allow; ``path`` runs from the mismatch up to the
    value's root (keys and list indexes, appended on the way back up)."""

    text: str
    path: list[str | int] = field(default_factory=list)

    @property
    def pointer(self) -> str:
        """The JSON pointer of the mismatch in the checked value (``""``: the value itself)."""
        return "".join(f"/{p}" for p in reversed(self.path))

    def __str__(self) -> str:
        return f"at {self.pointer}: {self.text}" if self.path else self.text


Check = Callable[[Any], "Mismatch | None"]


def describe(value: Any, limit: int = 40) -> str:
    """A short account of a found value for messages: ``'3' (a string)``, ``true (a boolean)``, ``a list of 2``."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return f"{'true' if value else 'false'} (a boolean)"
    if isinstance(value, int):
        return str(value) if abs(value) < 10 ** 24 else f"a whole number of {len(str(abs(value)))} digits"
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, str):
        shown = value if len(value) <= limit else value[:limit] + "…"
        return f"{shown!r} (a string)"
    if isinstance(value, list):
        return f"a list of {len(value)}"
    if isinstance(value, dict):
        return "an object"
    return type(value).__name__


def either(words: Iterable[str]) -> str:
    """``a``, ``a or b``, ``a, b or c``."""
    words = list(words)
    return words[0] if len(words) == 1 else ", ".join(words[:-1]) + " or " + words[-1]


def compile_schema(schema: dict[str, Any], root: dict[str, Any] | None = None) -> Check:
    """The check of ``schema``; ``root`` holds the ``$defs`` that ``#/$defs/...`` references name (default:
    ``schema`` itself). ValueError for a keyword or reference this module does not check."""
    return _Compiler(root if root is not None else schema).compile(schema)


def compile_definition(root: dict[str, Any], name: str) -> Check:
    """The check of ``root["$defs"][name]`` (references resolved in ``root``)."""
    return _Compiler(root).compile({"$ref": f"#/$defs/{name}"})


class _Compiler:
    def __init__(self, root: dict[str, Any]) -> None:
        self.root = root
        self.defs: dict[str, Check] = {}

    def compile(self, schema: Any) -> Check:
        if schema is True or schema == {}:
            return _accept
        if not isinstance(schema, dict):
            raise ValueError(f"a schema is an object, not {describe(schema)}")
        unknown = set(schema) - KEYWORDS - ANNOTATIONS
        if unknown:
            raise ValueError(f"schema keyword(s) not checked by fsm.trace.jsoncheck: {', '.join(sorted(unknown))}")
        checks = [check for check in (self._ref(schema), _type(schema), _const(schema), _bounds(schema),
                                      _pattern(schema), _required(schema), self._properties(schema),
                                      self._additional(schema), self._items(schema), _lengths(schema),
                                      self._one_of(schema)) if check is not None]
        general = checks[0] if len(checks) == 1 else _all(checks) if checks else _accept
        fits = _fast_test(schema) or self._fast_list(schema)
        return general if fits is None else _with_fast_test(fits, general)

    def _fast_list(self, schema: dict[str, Any]) -> Callable[[Any], bool] | None:
        """The predicate of a list whose items have one (rows of sample values), else ``None``."""
        keys = set(schema) - ANNOTATIONS
        if schema.get("type") != "array" or not keys <= {"type", "items", "minItems", "maxItems"}:
            return None
        inner = getattr(self.compile(schema["items"]), "fits", None) if "items" in schema else _anything
        if inner is None:
            return None
        low, high = schema.get("minItems", 0), schema.get("maxItems", math.inf)
        return lambda value: type(value) is list and low <= len(value) <= high and all(map(inner, value))

    def _ref(self, schema: dict[str, Any]) -> Check | None:
        ref = schema.get("$ref")
        if ref is None:
            return None
        prefix = "#/$defs/"
        if not (isinstance(ref, str) and ref.startswith(prefix) and ref[len(prefix):] in self.root.get("$defs", {})):
            raise ValueError(f"unresolvable $ref {ref!r} (only #/$defs/NAME)")
        name = ref[len(prefix):]
        if name not in self.defs:
            cell: list[Check] = []
            self.defs[name] = lambda value: cell[0](value)  # a reference to itself resolves once compiled
            cell.append(self.compile(self.root["$defs"][name]))
            self.defs[name] = cell[0]
        return self.defs[name]

    def _properties(self, schema: dict[str, Any]) -> Check | None:
        if "properties" not in schema:
            return None
        pairs = [(key, self.compile(sub)) for key, sub in schema["properties"].items()]
        pairs = [(key, check) for key, check in pairs if check is not _accept]

        tests = [(key, getattr(check, "fits", _never), check) for key, check in pairs]

        def check(value: Any) -> Mismatch | None:
            if isinstance(value, dict):
                for key, fits, sub in tests:
                    if key in value and not fits(item := value[key]):
                        found = sub(item)
                        if found is not None:
                            found.path.append(key)
                            return found
            return None

        return check if pairs else None

    def _additional(self, schema: dict[str, Any]) -> Check | None:
        extra = schema.get("additionalProperties", True)
        if extra is True:
            return None
        names = list(schema.get("properties", {}))
        known = frozenset(names)
        sub = None if extra is False else self.compile(extra)

        def check(value: Any) -> Mismatch | None:
            if isinstance(value, dict):
                for key in value:
                    if key not in known:
                        if sub is None:
                            return Mismatch(f"unexpected property {describe(key)} (allowed: {', '.join(names)})")
                        found = sub(value[key])
                        if found is not None:
                            found.path.append(key)
                            return found
            return None

        return check

    def _items(self, schema: dict[str, Any]) -> Check | None:
        if "items" not in schema:
            return None
        sub = self.compile(schema["items"])
        if sub is _accept:
            return None
        fits = getattr(sub, "fits", None)

        def check(value: Any) -> Mismatch | None:
            if isinstance(value, list):
                if fits is not None and all(map(fits, value)):
                    return None
                for i, item in enumerate(value):
                    found = sub(item)
                    if found is not None:
                        found.path.append(i)
                        return found
            return None

        return check

    def _one_of(self, schema: dict[str, Any]) -> Check | None:
        if "oneOf" not in schema:
            return None
        branches = [self.compile(sub) for sub in schema["oneOf"]]

        def check(value: Any) -> Mismatch | None:
            misses = [branch(value) for branch in branches]
            fits = misses.count(None)
            if fits == 1:
                return None
            if fits == 0:
                return Mismatch(f"fits none of its {len(branches)} allowed forms: "
                                + "; or ".join(str(m) for m in misses))
            return Mismatch(f"fits {fits} of its allowed forms, but must fit exactly one")

        return check


def _accept(value: Any) -> None:
    return None


def _never(value: Any) -> bool:
    return False


def _anything(value: Any) -> bool:
    return True


#: The Python types json.loads makes for each JSON Schema type.
_PY_TYPES: dict[str, tuple[type, ...]] = {"object": (dict,), "array": (list,), "string": (str,), "integer": (int,),
                                          "number": (int, float), "boolean": (bool,), "null": (type(None),)}
_NUMBER_TYPES = (int, float)
#: How many strings a pattern remembers as matching (a trace repeats its field names in every samples block).
_REMEMBERED = 4096


def _fast_test(schema: dict[str, Any]) -> Callable[[Any], bool] | None:
    """One predicate for a schema of a type and bounds or a pattern (the leaves of a trace line), true when a value
    as json.loads makes it fits; ``None`` for other schemas. A value it refuses is explained by the general checks,
    which also have the last word, so this only saves time."""
    keys = set(schema) - ANNOTATIONS
    if "type" not in keys or not keys <= {"type", "minimum", "maximum", "exclusiveMinimum", "pattern"}:
        return None
    names = schema["type"] if isinstance(schema["type"], list) else [schema["type"]]
    types = frozenset(t for name in names for t in _PY_TYPES[name])
    if "pattern" in keys:
        if types != {str} or len(keys) > 2:
            return None
        search = re.compile(schema["pattern"]).search
        seen: set[str] = set()

        def matches(value: Any) -> bool:
            if type(value) is not str:
                return False
            if value in seen:
                return True
            if search(value) is None:
                return False
            if len(seen) < _REMEMBERED:
                seen.add(value)
            return True

        return matches
    low, high = schema.get("minimum", -math.inf), schema.get("maximum", math.inf)
    above = schema.get("exclusiveMinimum", -math.inf)
    if len(keys) == 1:
        return lambda value: type(value) in types
    return lambda value: type(value) in types and (type(value) not in _NUMBER_TYPES or low <= value <= high
                                                   and value > above)


def _with_fast_test(fits: Callable[[Any], bool], general: Check) -> Check:
    def check(value: Any) -> Mismatch | None:
        return None if fits(value) else general(value)

    check.fits = fits  # type: ignore[attr-defined]  # parents call it directly on each item
    return check


def _all(checks: list[Check]) -> Check:
    def check(value: Any) -> Mismatch | None:
        for one in checks:
            found = one(value)
            if found is not None:
                return found
        return None

    return check


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


_TESTS: dict[str, Callable[[Any], bool]] = {
    "object": lambda v: isinstance(v, dict),
    "array": lambda v: isinstance(v, list),
    "string": lambda v: isinstance(v, str),
    "integer": lambda v: isinstance(v, int) and not isinstance(v, bool),
    "number": _is_number,
    "boolean": lambda v: isinstance(v, bool),
    "null": lambda v: v is None,
}


def _type(schema: dict[str, Any]) -> Check | None:
    if "type" not in schema:
        return None
    names = schema["type"] if isinstance(schema["type"], list) else [schema["type"]]
    if not names or any(name not in _TESTS for name in names):
        raise ValueError(f"unknown type in {schema['type']!r}")
    tests = [_TESTS[name] for name in names]
    expected = either(_TYPE_WORDS[name] for name in names)
    if len(tests) == 1:
        test = tests[0]

        def one(value: Any) -> Mismatch | None:
            return None if test(value) else Mismatch(f"expected {expected}, found {describe(value)}")

        return one

    def check(value: Any) -> Mismatch | None:
        for test in tests:
            if test(value):
                return None
        return Mismatch(f"expected {expected}, found {describe(value)}")

    return check


def _same(a: Any, b: Any) -> bool:
    """JSON equality of two scalars: true is not 1, 1 is 1.0, "1" is neither."""
    if isinstance(a, str) or isinstance(b, str):
        return isinstance(a, str) and isinstance(b, str) and a == b
    if isinstance(a, bool) or isinstance(b, bool):
        return isinstance(a, bool) and isinstance(b, bool) and a == b
    if a is None or b is None:
        return a is b
    return _is_number(a) and _is_number(b) and a == b


def _const(schema: dict[str, Any]) -> Check | None:
    if "const" in schema:
        allowed = [schema["const"]]
    elif "enum" in schema:
        allowed = list(schema["enum"])
    else:
        return None
    if any(isinstance(a, (list, dict)) for a in allowed):
        raise ValueError("const and enum of lists or objects are not checked by fsm.trace.jsoncheck")
    expected = either(describe(a).partition(" (")[0] for a in allowed)  # 'header', 2, true, null

    def check(value: Any) -> Mismatch | None:
        if isinstance(value, (list, dict)) or not any(_same(a, value) for a in allowed):
            return Mismatch(f"expected {expected}, found {describe(value)}")
        return None

    return check


def _bounds(schema: dict[str, Any]) -> Check | None:
    tests: list[tuple[Callable[[Any], bool], str]] = []
    for key, word in (("minimum", "at least"), ("maximum", "at most"), ("exclusiveMinimum", "more than"),
                      ("exclusiveMaximum", "less than")):
        if key in schema:
            limit = schema[key]
            if not _is_number(limit):
                raise ValueError(f"{key} is not a number")
            test = {"minimum": lambda v, b=limit: v >= b, "maximum": lambda v, b=limit: v <= b,
                    "exclusiveMinimum": lambda v, b=limit: v > b, "exclusiveMaximum": lambda v, b=limit: v < b}[key]
            tests.append((test, f"{word} {limit:g}" if isinstance(limit, float) else f"{word} {limit}"))
    if not tests:
        return None

    def check(value: Any) -> Mismatch | None:
        if _is_number(value):
            for test, expected in tests:
                if not test(value):
                    return Mismatch(f"expected a number {expected}, found {describe(value)}")
        return None

    return check


def _pattern(schema: dict[str, Any]) -> Check | None:
    if "pattern" not in schema:
        return None
    search = re.compile(schema["pattern"]).search
    expected = schema.get("title") or f"a string matching {schema['pattern']}"

    def check(value: Any) -> Mismatch | None:
        if isinstance(value, str) and search(value) is None:
            return Mismatch(f"expected {expected}, found {describe(value)}")
        return None

    return check


def _required(schema: dict[str, Any]) -> Check | None:
    keys = list(schema.get("required", ()))
    if not keys:
        return None

    def check(value: Any) -> Mismatch | None:
        if isinstance(value, dict):
            for key in keys:
                if key not in value:
                    return Mismatch(f"{key!r} is missing")
        return None

    return check


def _lengths(schema: dict[str, Any]) -> Check | None:
    low, high = schema.get("minItems"), schema.get("maxItems")
    if low is None and high is None:
        return None

    def check(value: Any) -> Mismatch | None:
        if isinstance(value, list):
            n = len(value)
            if (low is not None and n < low) or (high is not None and n > high):
                wanted = f"{low}" if low == high else f"at least {low}" if high is None else \
                    f"at most {high}" if low is None else f"{low} to {high}"
                return Mismatch(f"expected {wanted} items, found {n}")
        return None

    return check
