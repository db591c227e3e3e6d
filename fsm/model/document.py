"""The machine document: its pydantic models, shape validation with located problems, and the JSON Schema.

Shape validation checks each element against its type's ``Params`` model, the same models the JSON
Schema is generated from, so an editor using ``$schema`` and ``fsmctl validate`` agree.
"""

from __future__ import annotations

import difflib
import math
import operator
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from itertools import repeat
from typing import TYPE_CHECKING, Annotated, Any, NamedTuple, Protocol

from pydantic import BaseModel, Field, ValidationError, WithJsonSchema, field_validator
from pydantic.json_schema import GenerateJsonSchema

from fsm.model.errors import Problem
from fsm.model.jsonpos import escape, pointer
from fsm.model.params import ID_PATTERN, ConditionParams, ParamsBase, StateParams, TransitionParams

if TYPE_CHECKING:
    from pydantic_core import ErrorDetails

#: A parameter that holds a machine: an inline document or ``{"file": ...}``.
MachineSpecField = Annotated[dict[str, Any], WithJsonSchema({"type": "object", "x-machine": True})]
#: What a ``MachineSpecField`` becomes in the generated schema (pydantic cannot reference our own defs).
_MACHINE_REF = {"anyOf": [{"$ref": "#/$defs/Machine"}, {"$ref": "#/$defs/Include"}]}


def _link_machines(node: Any) -> Any:
    """Replace the ``x-machine`` placeholders with references to the Machine and Include definitions."""
    if isinstance(node, dict):
        if node.get("x-machine") is True:
            rest = {k: v for k, v in node.items() if k not in ("x-machine", "type")}
            return {**rest, **_MACHINE_REF}
        if node.get("x-condition") is True:
            rest = {k: v for k, v in node.items() if k not in ("x-condition", "type")}
            return {**rest, "$ref": "#/$defs/Condition"}
        return {k: _link_machines(v) for k, v in node.items()}
    if isinstance(node, list):
        return [_link_machines(v) for v in node]
    return node


class Include(ParamsBase):
    """A machine kept in another file, relative to the including file."""

    file: str = Field(min_length=1, description="Path of the machine file, relative to this file.")


def _no_transitions() -> list[dict[str, Any]]:
    return []


def _no_vars() -> dict[str, Any]:
    return {}


class MachineEnvelope(ParamsBase):
    """The top level of a machine document (elements are checked one by one against their types)."""

    schema_: str | None = Field(default=None, alias="$schema", description="JSON Schema for editors.")
    name: str | None = Field(default=None, description="Name of the machine.")
    description: str | None = Field(default=None, description="Free text for people.")
    initial: str = Field(min_length=1, pattern=ID_PATTERN, description="Id of the initial state.")
    states: list[dict[str, Any]] = Field(min_length=1, description="The states of this level.")
    # the factories are functions of ours, not ``list`` and ``dict``: pydantic reads a factory's signature, and a
    # built-in's is parsed from its text by the tokenizer, whose patterns compiled on first use cost the first load
    # of a process about 5 ms
    transitions: list[dict[str, Any]] = Field(default_factory=_no_transitions,
                                              description="The transitions of this level.")
    vars: dict[str, Any] = Field(default_factory=_no_vars,
                                 description="Initial blackboard variables (top level only).")
    inputs: list[Annotated[str, Field(min_length=1)]] | None = Field(
        default=None, description="The input signals the machine's environment provides (buttons, switches). When "
                                  "given, every signal the machine reads (transitions, conditions, pause buttons) "
                                  "must be one of them: a typo or a pause button nobody can press is a load error.")
    layout: dict[str, Any] | None = Field(default=None, description="Diagram layout; ignored at run time.")

    @field_validator("vars")
    @classmethod
    def _finite_vars(cls, value: dict[str, Any]) -> dict[str, Any]:
        for key, item in value.items():
            if isinstance(item, float) and not math.isfinite(item):
                raise ValueError(f"variable '{key}' must be a finite number, not {item}")
        return value


# -- the parsed form ------------------------------------------------------------------------------
@dataclass
class Source:
    """A document's origin: display name, directory for includes, and a locator for line:column."""

    name: str | None
    directory: Any = None
    text: str | None = None
    #: callable(set[str]) -> dict[pointer, (line, column)] or (line, column, where-in-the-drawing)
    locator: Any = None




class SubMachine(NamedTuple):
    """One region of a composite as parsed: its name as a path step (``None``: the composite's states sit
    directly under it, as in ``FSMState``), its machine (``None`` when it failed to parse) and where it is written,
    relative to the composite's element (``"/machine"``, ``"/regions/1"``)."""

    name: str | None
    machine: MachineSpec | None
    pointer: str


class TypeTables(Protocol):
    """What the model needs of a registry (:class:`fsm.loading.registry.Registry` is one): the registered classes
    by name, per kind, and close names for a hint."""

    @property
    def states(self) -> Mapping[str, type[Any]]: ...

    @property
    def transitions(self) -> Mapping[str, type[Any]]: ...

    @property
    def conditions(self) -> Mapping[str, type[Any]]: ...

    def table(self, kind: str) -> Mapping[str, Any]: ...

    def suggest(self, name: str, kind: str) -> list[str]: ...


@dataclass
class ConditionSpec:
    """A parsed condition object: its class, parameters and nested conditions (expressions are checked and
    compiled by the later stages)."""

    cls: type[Any]  #: a registered Condition class (the model names no runtime class)
    params: ConditionParams
    pointer: str
    children: list[ConditionSpec] = field(default_factory=list)

    @property
    def type(self) -> str:
        return self.params.type

    def walk(self) -> Iterator[ConditionSpec]:
        """This condition and every condition nested in it."""
        todo = [self]
        while todo:
            cs = todo.pop()
            yield cs
            todo.extend(cs.children)


@dataclass
class StateSpec:
    """A parsed state element: its type, parameters, sub-machines and condition objects."""

    id: str
    cls: type[Any]  #: a registered State class
    params: StateParams
    pointer: str
    source: Source
    subs: list[SubMachine] = field(default_factory=list)
    #: The condition objects of the step-common keys, by key relative to the element (``"precondition"``,
    #: ``"until"``, ``"monitors/0/condition"``); a key written as an expression (text) is not here.
    conditions: dict[str, ConditionSpec] = field(default_factory=dict)
    #: A Sequence's layout, else None.
    sequence: SequenceLayout | None = None

    @property
    def type(self) -> str:
        """The registered type name the element uses."""
        return self.params.type

    @property
    def label(self) -> str:
        return f"state '{self.id}'"


@dataclass(frozen=True)
class SequenceLayout:
    """Where a Sequence's regions come from: ``subs[0]`` the chain, then one per non-blocking sequence (with the
    index of the blocking step after which it starts, -1: at once), then one per exception sequence."""

    detached_after: tuple[int, ...] = ()
    detached_ids: tuple[str, ...] = ()
    exception_ids: tuple[str, ...] = ()
    #: ids of exception sequences declared here that did not parse (monitors naming them get no second error)
    broken_exception_ids: tuple[str, ...] = ()
    #: every step spec in document order (blocking or not)
    steps: tuple[StateSpec, ...] = ()
    exceptions: tuple[StateSpec, ...] = ()


@dataclass
class TransitionSpec:
    """A parsed transition element: its type, parameters and condition objects (a condition guard is
    ``"guard"``; a type's condition parameters by name)."""

    cls: type[Any]  #: a registered Transition class
    params: TransitionParams
    pointer: str
    source: Source
    conditions: dict[str, ConditionSpec] = field(default_factory=dict)

    @property
    def type(self) -> str:
        return self.params.type

    @property
    def label(self) -> str:
        return f"transition {self.params.from_} -> {self.params.to} ({self.params.type})"


@dataclass
class MachineSpec:
    """One parsed machine level: its states and transitions (those that parsed), and what the checks need of
    the elements as written, including the ones that did not parse (their ids and endpoints)."""

    source: Source
    pointer: str
    name: str | None
    initial: str
    initial_pointer: str
    states: list[StateSpec]
    transitions: list[TransitionSpec]
    vars: dict[str, Any]
    #: (from, to) of every transition drawn, valid or not: reachability follows what the author drew.
    edges: list[tuple[str, str]] = field(default_factory=list)
    #: False when an element of this level failed to parse (then outcomes are not guessed).
    complete: bool = True
    #: The declared input signals (top level), or None when the document does not declare them.
    inputs: list[str] | None = None
    #: Whether the level's envelope (initial, states, ...) was valid.
    envelope_ok: bool = True
    #: False for a level the document does not write as a machine (a Sequence's chain, one of its non-blocking or
    #: exception sequences): the sequencer checks those, not the checks of a written level.
    written: bool = True
    #: The state and transition elements as written (for the checks of ids and endpoints).
    raw_states: list[Any] = field(default_factory=list)
    raw_transitions: list[Any] = field(default_factory=list)

    def levels(self) -> Iterator[MachineSpec]:
        """This level and every sub-machine below it (inline, included, parallel regions), any depth."""
        todo: list[MachineSpec] = [self]
        while todo:
            level = todo.pop()
            yield level
            todo.extend(sub.machine for st in level.states for sub in st.subs if sub.machine is not None)

    def scoped(self) -> tuple[list[tuple[StateSpec, str]], list[tuple[TransitionSpec, str]], frozenset[str]]:
        """Every state below this level with the path of the level it is in (``""`` at the top), depth first in
        document order; every transition with the path of its level; and every state's path. Gathered level by
        level: a level without regions in C-speed steps, not a Python step per element."""
        states: list[tuple[StateSpec, str]] = []
        transitions: list[tuple[TransitionSpec, str]] = []
        paths: list[str] = []
        _scoped_level(self, "", states, transitions, paths)
        return states, transitions, frozenset(paths)


def _scoped_level(spec: MachineSpec, prefix: str, states: list[tuple[StateSpec, str]],
                  transitions: list[tuple[TransitionSpec, str]], paths: list[str]) -> None:
    """One level of :meth:`MachineSpec.scoped`, then the levels below it. (A module function, not a closure that
    calls itself: that closure and its cell are a reference cycle holding the lists, 2,000 pairs for the
    1000-state ring, until the collector's next pass finds them.)"""
    transitions.extend(zip(spec.transitions, repeat(prefix)))
    ids = list(map(_ID, spec.states))
    paths.extend(map(f"{prefix}/".__add__, ids) if prefix else ids)
    if not any(map(_SUBS, spec.states)):
        states.extend(zip(spec.states, repeat(prefix)))
        return
    for st in spec.states:
        states.append((st, prefix))
        path = f"{prefix}/{st.id}" if prefix else st.id
        for sub in st.subs:
            if sub.machine is not None:
                _scoped_level(sub.machine, f"{path}/{sub.name}" if sub.name else path, states, transitions, paths)


_ID = operator.attrgetter("id")
_SUBS = operator.attrgetter("subs")


# -- shape validation -------------------------------------------------------------------------------
def normalize_legacy(data: dict[str, Any]) -> tuple[dict[str, Any], bool]:
    """TRAL's form (``"root": 0``, integer ids) -> the current form. Returns the document and whether it was legacy."""
    if "root" not in data or "initial" in data:
        return data, False
    out = dict(data)
    out["initial"] = _legacy_id(out.pop("root"))
    if isinstance(out.get("states"), list):
        out["states"] = [
            {**s, "id": _legacy_id(s["id"])} if isinstance(s, dict) and "id" in s else s for s in out["states"]
        ]
    if isinstance(out.get("transitions"), list):
        trs = []
        for t in out["transitions"]:
            if isinstance(t, dict):
                t = dict(t)
                for key in ("from", "to"):
                    if key in t:
                        t[key] = _legacy_id(t[key])
            trs.append(t)
        out["transitions"] = trs
    return out, True


def _legacy_id(value: Any) -> Any:
    if isinstance(value, int) and not isinstance(value, bool):
        return str(value)
    return value


def problems_from_validation(
    err: ValidationError | list[ErrorDetails],
    *,
    source: Source,
    base: str,
    element: str | None,
    model: type[ParamsBase],
    kind: str,
    rename: dict[str, str] | None = None,
    data: Any = None,
) -> list[Problem]:
    """Turn pydantic's errors into problems with JSON pointers, friendly wording and "did you mean" hints.

    ``data`` is the validated input: error locations are cut where they leave it (pydantic appends the
    names of union branches), and the several complaints of one union about one value become one problem.
    ``err`` may also be some of a ValidationError's ``errors()``, their locations made relative to ``base`` (a
    document that validates as a whole and reports each element at its own place, as scenario documents do).
    """
    problems: list[Problem] = []
    at_pointer: dict[str, Problem] = {}
    fields = {f.alias or name for name, f in model.model_fields.items()}
    own = sorted(fields - _COMMON_FIELDS)
    details = err.errors(include_url=False) if isinstance(err, ValidationError) else err
    for e in details:
        loc = list(e["loc"])
        typ = e["type"]
        if data is not None and typ != "missing":
            loc = _existing_prefix(data, loc)
        if rename and loc and loc[0] in rename:
            loc[0] = rename[loc[0]]
        hint = None
        if typ == "missing":
            ptr = base + pointer(*loc[:-1])
            message = f"missing required {kind} '{loc[-1]}'"
            hint = _field_hint(model, str(loc[-1]))
        elif typ == "extra_forbidden" and len(loc) == 1:
            ptr = base + pointer(*loc)
            name = str(loc[-1])
            message = f"unknown {kind} '{name}'"
            close = difflib.get_close_matches(name, sorted(fields), n=2)
            if close:
                hint = "did you mean " + " or ".join(f"'{c}'" for c in close) + "?"
            else:
                hint = "known: " + ", ".join(own) if own else f"this type takes no {kind}s of its own"
        else:
            ptr = base + pointer(*loc)
            where = "/".join(str(x) for x in loc)
            got = _short(e.get("input"))
            if e.get("input", 0) is None and loc:  # every branch of the field refuses null (no field takes it)
                if ptr in at_pointer:
                    continue
                message = f"'{where}' may not be null"
                default = _field_default(model, str(loc[-1]))
                hint = ("leave the key out to get its default" + (f": {default}" if default else "")
                        if default is not None else "give it a value; null is never a parameter's value")
            elif typ == "string_pattern_mismatch" and loc and loc[-1] in ("id", "initial"):
                message = f"'{where}' may not contain '/' (it separates the steps of a state path), got {got}"
            elif not loc:  # a check of the whole element (a type's model validator): its own words say it all
                message = str(e["msg"]).removeprefix("Value error, ").removeprefix("Assertion failed, ")
            elif typ == "value_error":  # a validator's own words; a whole object or list is not worth showing
                shown = "" if isinstance(e.get("input"), (dict, list)) else f", got {got}"
                message = f"'{where}': {str(e['msg']).removeprefix('Value error, ')}{shown}"
            else:
                message = f"'{where}': {e['msg']}, got {got}"
            earlier = at_pointer.get(ptr)
            if earlier is not None:  # another branch of the same union: one problem, all the wishes
                wish = e["msg"].removeprefix("Input should be ")
                head, _, tail = earlier.message.rpartition(", got ")
                earlier.message = f"{head} or {wish}, got {tail}"
                continue
        problem = Problem(message, file=source.name, pointer=ptr, element=element, hint=hint)
        at_pointer.setdefault(ptr, problem)
        problems.append(problem)
    return problems


def _existing_prefix(data: Any, loc: list[Any]) -> list[Any]:
    """The longest prefix of ``loc`` that is a real path into ``data``."""
    out: list[Any] = []
    node = data
    for part in loc:
        if isinstance(node, dict) and part in node:
            node = node[part]
        elif isinstance(node, list) and isinstance(part, int) and 0 <= part < len(node):
            node = node[part]
        else:
            break
        out.append(part)
    return out


_COMMON_FIELDS = {"id", "type", "description", "layout", "from", "to", "priority", "preempt", "guard", "set",
                  "precondition", "until", "monitors", "timeout", "timeout_behavior", "timeout_exception", "endless"}


def _field_hint(model: type[ParamsBase], name: str) -> str | None:
    f = model.model_fields.get(name) or next(
        (f for f in model.model_fields.values() if f.alias == name), None
    )
    if f is not None and f.description:
        return f.description
    return None


def _field_default(model: type[ParamsBase], name: str) -> str | None:
    """How a message names a field's default: ``""`` for an optional field without a shown default,
    ``None`` for a required field."""
    f = model.model_fields.get(name) or next(
        (f for f in model.model_fields.values() if f.alias == name), None)
    if f is None or f.is_required():
        return None
    if f.default is None or f.default_factory is not None:
        return ""
    return f"{f.default!r}"


def _short(value: Any, limit: int = 60) -> str:
    text = repr(value)
    if isinstance(value, (dict, list)):
        text = type(value).__name__
    return text if len(text) <= limit else text[: limit - 3] + "..."


def element_label(kind: str, data: Any) -> str | None:
    """How messages name an element: ``state 'follow'`` or ``transition follow -> turn``."""
    if not isinstance(data, dict):
        return None
    if kind == "state":
        return f"state '{data['id']}'" if isinstance(data.get("id"), (str, int)) else "state"
    if kind == "condition":
        return f"condition {data['type']}" if isinstance(data.get("type"), str) else "condition"
    src, dst = data.get("from"), data.get("to")
    if isinstance(src, (str, int)) and isinstance(dst, (str, int)):
        return f"transition {src} -> {dst}"
    return "transition"


def check_type(
    kind: str, data: dict[str, Any], registry: TypeTables, source: Source, base: str
) -> tuple[type[Any] | None, list[Problem]]:
    """The registered class an element names by ``type``, or a problem that suggests close names."""
    name = data.get("type")
    table = registry.table(kind)
    cls = table.get(name) if isinstance(name, str) else None
    if cls is not None:
        return cls, []
    label = element_label(kind, data)
    if name is None:
        return None, [Problem("missing required parameter 'type'", source.name, base, element=label,
                              hint=f"one of the registered {kind} types, see `fsmctl types`")]
    if not isinstance(name, str):
        return None, [Problem(f"'type' must be a string, got {_short(name)}", source.name,
                              base + "/type", element=label)]
    close = registry.suggest(name, kind)
    hint = (f'did you mean {" or ".join(close)}? write "type": "{close[0]}"' if close else
            f"see `fsmctl types` for the {kind} types (a plugin's types need it installed, or --plugin)")
    return None, [Problem(f"unknown {kind} type '{name}'", source.name, base + "/type", element=label, hint=hint)]


# -- JSON Schema ------------------------------------------------------------------------------------
SCHEMA_DIALECT = "https://json-schema.org/draft/2020-12/schema"


class NoNullSchema(GenerateJsonSchema):
    """Schemas of our parameter models: an optional field (``str | None = None``) is optional by leaving it
    out, never by writing ``null`` (:class:`fsm.model.params.ParamsBase` refuses null), so no branch allows null."""

    def nullable_schema(self, schema: Any) -> Any:
        return self.generate_inner(schema["schema"])

    def default_schema(self, schema: Any) -> Any:
        out = super().default_schema(schema)
        if isinstance(out, dict) and out.get("default", 0) is None:
            out = {k: v for k, v in out.items() if k != "default"}
        return out


def model_json_schema(model: type[BaseModel], ref_template: str = "#/$defs/{model}") -> dict[str, Any]:
    """A parameter model's JSON Schema as documents must be written (no null anywhere)."""
    return model.model_json_schema(ref_template=ref_template, schema_generator=NoNullSchema)


def file_schema(model: type[Any], file: str, title: str, description: str) -> dict[str, Any]:
    """The committed JSON Schema of a kind of file described by one pydantic model (worlds, scenarios):
    the model's schema under the project's dialect, ``$id``, title and description."""
    schema = model_json_schema(model)
    return {
        "$schema": SCHEMA_DIALECT,
        "$id": f"https://tral-fsm.invalid/{file}",
        "title": title,
        "description": description,
        **{k: v for k, v in schema.items() if k not in ("title", "description")},
    }


def json_schema(registry: TypeTables) -> dict[str, Any]:
    """The JSON Schema of machine documents for the registered types (discriminated on ``type``)."""
    defs: dict[str, Any] = {}

    def model_schema(model: type[Any]) -> dict[str, Any]:
        schema = model_json_schema(model)
        for name, sub in schema.pop("$defs", {}).items():
            if name in defs and defs[name] != sub:
                raise ValueError(f"two parameter models are both called {name}; rename one")
            defs[name] = sub
        return schema

    def dispatch(kind: str, table: Mapping[str, type[Any]]) -> dict[str, Any]:
        names = sorted(table)
        branches = []
        for name in names:
            cls = table[name]
            schema = model_schema(cls.Params)
            schema["title"] = name
            doc = (cls.__doc__ or "").strip().splitlines()
            if doc:
                schema["description"] = doc[0]
            schema["properties"]["type"] = {"const": name,
                                            "description": schema["properties"]["type"].get("description", "")}
            defs[f"{kind}.{name}"] = schema
            branches.append(
                {"if": {"properties": {"type": {"const": name}}, "required": ["type"]},
                 "then": {"$ref": f"#/$defs/{kind}.{name}"}}
            )
        return {
            "type": "object",
            "required": ["type"],
            "properties": {"type": {"enum": names}},
            "allOf": branches,
        }

    machine = model_schema(MachineEnvelope)
    machine["title"] = "Machine"
    machine["properties"]["states"]["items"] = {"$ref": "#/$defs/State"}
    machine["properties"]["transitions"]["items"] = {"$ref": "#/$defs/Transition"}
    defs["State"] = dispatch("state", registry.states)
    defs["Transition"] = dispatch("transition", registry.transitions)
    defs["Condition"] = dispatch("condition", registry.conditions)
    defs["Include"] = model_schema(Include)
    defs["Machine"] = machine
    return {
        "$schema": SCHEMA_DIALECT,
        "$id": "https://tral-fsm.invalid/machine.schema.json",
        "title": "tral-fsm machine document",
        "description": "A state machine for tral-fsm; generated from the registered types by `fsmctl schema`.",
        "$ref": "#/$defs/Machine",
        "$defs": _link_machines(dict(sorted(defs.items()))),
    }


__all__ = [
    "ConditionSpec",
    "Include",
    "MachineEnvelope",
    "MachineSpec",
    "MachineSpecField",
    "Source",
    "StateSpec",
    "SubMachine",
    "TransitionSpec",
    "check_type",
    "element_label",
    "escape",
    "json_schema",
    "normalize_legacy",
    "problems_from_validation",
]


# -- introspection --------------------------------------------------------------------------------
def param_info(model: type[ParamsBase], own_only: bool = True) -> list[dict[str, Any]]:
    """Each parameter of a Params model: name, type (readable), required, default, description.

    Used by ``fsmctl types`` and the UMLet palette, so both always show what the models accept.
    """
    schema = model_json_schema(model)
    props = schema.get("properties", {})
    required = set(schema.get("required", []))
    out = []
    for name, prop in props.items():
        if own_only and name in _COMMON_FIELDS:
            continue
        info: dict[str, Any] = {
            "name": name,
            "type": _type_text(prop),
            "required": name in required,
            "description": prop.get("description", ""),
        }
        if "default" in prop:
            info["default"] = prop["default"]
        elif name not in required:  # optional without a default to show (null in the model): left out
            info["default"] = None
        out.append(info)
    return out


def _type_text(prop: dict[str, Any]) -> str:
    if prop.get("x-machine"):
        return 'machine document or {"file": ...}'
    if prop.get("x-condition"):
        return "condition"
    if "const" in prop:
        return repr(prop["const"])
    if "enum" in prop:
        return "|".join(str(v) for v in prop["enum"])
    if "anyOf" in prop:
        parts = [_type_text(p) for p in prop["anyOf"]]
        parts = [p for p in parts if p != "null"] or ["null"]
        return " or ".join(dict.fromkeys(parts))
    if "$ref" in prop:
        ref: str = prop["$ref"]
        return ref.rsplit("/", 1)[-1].lower()
    typ = prop.get("type", "any")
    text = {"number": "number", "integer": "integer", "string": "text", "boolean": "true|false",
            "object": "object", "array": "list", "null": "null"}.get(typ, str(typ))
    if typ == "array" and "items" in prop:
        text = f"list of {_type_text(prop['items'])}"
    bounds = []
    for key, sym in (("exclusiveMinimum", ">"), ("minimum", ">="), ("exclusiveMaximum", "<"), ("maximum", "<=")):
        if key in prop:
            bounds.append(f"{sym} {prop[key]}")
    if bounds:
        text += " " + ", ".join(bounds)
    return text
