"""Parsing, the second load stage: a document (a file by its reader, or a dict) becomes a tree of specs.

Each element is looked up in the registry by its ``type`` and validated against that type's ``Params`` (the
models the JSON Schema is generated from); includes are read relative to the including file, cycles refused;
condition objects are parsed where they are written; a composite's regions are parsed by the layout the table
:data:`REGION_LAYOUTS` names for its type (a Sequence's steps are laid out by :mod:`fsm.sequencer.layout`, any other
composite's sub-machines are parsed as drawn). What cannot be parsed becomes a located problem, and parsing goes on
with the rest of the file.
"""

from __future__ import annotations

import errno
import operator
import os
import stat
from collections.abc import Callable, Mapping
from itertools import chain, repeat
from pathlib import Path
from typing import Any

from pydantic import PydanticUserError, ValidationError
from pydantic_core import SchemaError, SchemaValidator, core_schema

from fsm.loading import plain_params
from fsm.loading.reading import ONLY_DICT, ONLY_STR, parse_json_bytes, read_file_bytes, read_json, reader_for
from fsm.loading.registry import Registry
from fsm.model.document import (
    ConditionSpec,
    Include,
    MachineEnvelope,
    MachineSpec,
    Source,
    StateSpec,
    SubMachine,
    TransitionSpec,
    check_type,
    element_label,
    normalize_legacy,
    problems_from_validation,
)
from fsm.model.errors import DiagramError
from fsm.model.params import ParamsBase
from fsm.model.problems import Problems
from fsm.runtime.composite import Composite
from fsm.sequencer.layout import parse_sequence
from fsm.sequencer.steps import Sequence

#: Machines nested deeper than this are refused (a recursion guard, far beyond any real diagram).
MAX_MACHINE_DEPTH = 48


class Parser:
    """One parse: the registry, where problems go, and the include bookkeeping. The region layouts
    (:data:`REGION_LAYOUTS`) call back into it for the elements and machines a composite holds."""

    def __init__(self, registry: Registry, problems: Problems, base_dir: str | os.PathLike[str] | None = None) -> None:
        self.registry = registry
        self.problems = problems
        self.base_dir = Path(base_dir) if base_dir is not None else None
        self._cache: dict[Path, MachineSpec | None] = {}
        self._stack: list[Path] = []
        #: The sources read as JSON text in this parse (their objects' keys are all text), by id.
        self._json_sources: set[int] = set()
        #: Scoped bookkeeping of the types that parse their own children (a Sequence's declared sequences), by name.
        self.scopes: dict[str, Any] = {}
        self._tables: dict[str, dict[str, type[Any]]] = {"state": registry.states, "transition": registry.transitions,
                        "condition": registry.conditions}

    # -- documents ------------------------------------------------------------------------------
    def document(self, src: Any) -> MachineSpec | None:
        """The spec of ``src`` (a path, or a document dict read relative to ``base_dir``), ``None`` when unusable."""
        if isinstance(src, (str, os.PathLike)):
            path = Path(src)
            try:
                data, source = self._read(path)
            except DiagramError as exc:
                self.problems.extend(exc.problems)
                return None
            self._stack.append(Path(os.path.realpath(path)))
            try:
                return self.machine(data, source, "", depth=0)
            finally:
                self._stack.pop()
        source = Source(name=None, directory=self.base_dir or Path.cwd())
        return self.machine(src, source, "", depth=0)

    def _read(self, path: Path) -> tuple[Any, Source]:
        """A file's document by its reader; a JSON file's repeated keys join the other problems of the load."""
        reader = reader_for(path)
        if reader is not read_json:
            return reader(path)
        if not str(path) or str(path) == ".":
            return read_json(path)  # the "no file name" problem
        repeated: list[Any] = []
        data, source = parse_json_bytes(read_file_bytes(path), str(path), path.parent, duplicates=repeated)
        self.problems.extend(repeated)
        self._json_sources.add(id(source))
        return data, source

    def machine(self, data: Any, source: Source, base: str, depth: int) -> MachineSpec | None:
        """One machine level and its sub-machines; ``None`` when its envelope is unusable."""
        if depth > MAX_MACHINE_DEPTH:
            self.problems.add(f"machines nested more than {MAX_MACHINE_DEPTH} levels deep", source, base)
            return None
        if not isinstance(data, dict):
            kind = "array" if isinstance(data, list) else type(data).__name__
            self.problems.add(f"a machine must be a JSON object with 'initial' and 'states', got {kind}", source,
                              base, hint='{"initial": "a", "states": [{"id": "a", "type": "Idle"}]}')
            return None
        if depth == 0 and "expect" in data and not {"states", "initial", "root"} & data.keys():
            self.problems.add("this is a scenario test (it has 'expect' and no 'states'), not a machine document",
                              source, base, hint="run a scenario with `fsmctl test FILE`; `fsmctl run` takes the "
                                                 "machine it names ('machine')")
            return None
        data, legacy = normalize_legacy(data)
        envelope: MachineEnvelope | None
        try:
            envelope = envelope_of(data, text_keys=id(source) in self._json_sources)
        except ValidationError as err:
            self.problems.extend(problems_from_validation(
                err, source=source, base=base, element=None, model=MachineEnvelope, kind="key",
                rename={"initial": "root"} if legacy else None, data=data), source)
            envelope = None
        states_raw = data.get("states") if isinstance(data.get("states"), list) else []
        trans_raw = data.get("transitions") if isinstance(data.get("transitions"), list) else []
        states = self._states(states_raw, source, base, depth)
        transitions = self._transitions(trans_raw, source, base)
        initial = data.get("initial") if isinstance(data.get("initial"), str) else ""
        if len(transitions) == len(trans_raw):  # every element parsed: its ends are its parameters' (strings)
            edges = list(map(_ENDS, map(_PARAMS, transitions)))
        else:
            edges = [(t["from"], t["to"]) for t in trans_raw
                     if isinstance(t, dict) and isinstance(t.get("from"), str) and isinstance(t.get("to"), str)]
        name = data.get("name") if isinstance(data.get("name"), str) else None
        return MachineSpec(
            source=source,
            pointer=base,
            name=envelope.name if envelope else name,
            initial=initial,
            initial_pointer=base + ("/root" if legacy else "/initial"),
            states=states,
            transitions=transitions,
            vars=dict(envelope.vars) if envelope else {},
            edges=edges,
            complete=envelope is not None and len(states) == len(states_raw) and len(transitions) == len(trans_raw),
            inputs=list(envelope.inputs) if envelope and envelope.inputs is not None else None,
            envelope_ok=envelope is not None,
            raw_states=states_raw,
            raw_transitions=trans_raw,
        )

    def submachine(self, data: Any, source: Source, ptr: str, depth: int) -> MachineSpec | None:
        """A sub-machine: inline, or ``{"file": ...}`` relative to the including file."""
        if isinstance(data, dict) and "file" in data:
            try:
                inc = Include.model_validate(data)
            except ValidationError as err:
                self.problems.extend(problems_from_validation(
                    err, source=source, base=ptr, element="include", model=Include, kind="key", data=data), source)
                return None
            return self.include(inc.file, source, ptr, depth)
        return self.machine(data, source, ptr, depth)

    def include(self, file: str, source: Source, ptr: str, depth: int) -> MachineSpec | None:
        """The machine in ``file`` (relative to ``source``'s folder), read once per load; cycles are refused."""
        directory = Path(source.directory) if source.directory is not None else (self.base_dir or Path.cwd())
        add = self.problems.add
        try:
            # realpath, not Path.resolve: on a symlink loop the latter raises RuntimeError (Python 3.11)
            path = Path(os.path.realpath(directory / file))
            mode: int | None = os.stat(path).st_mode
        except FileNotFoundError:
            mode = None
        except (OSError, ValueError) as exc:  # a symlink loop (ELOOP), no permission, a NUL byte, ...
            reason = getattr(exc, "strerror", None) or str(exc)
            hint = ("the path is a symlink that leads back to itself; point it at a machine file"
                    if getattr(exc, "errno", None) == errno.ELOOP else "check the path and its permissions")
            add(f"include file '{file}' cannot be read: {reason}", source, ptr + "/file", element="include",
                hint=hint)
            return None
        if mode is not None and not stat.S_ISREG(mode):
            what = "a directory" if stat.S_ISDIR(mode) else "not a regular file"
            add(f"include file '{file}' is {what} ({path})", source, ptr + "/file", element="include",
                hint="an include names a machine file (.json or .uxf), relative to the including file")
            return None
        if path in self._stack:
            cycle = self._stack[self._stack.index(path):] + [path]
            add("include cycle: " + " -> ".join(p.name for p in cycle), source, ptr + "/file", element="include",
                hint="a machine may not include itself, directly or through others")
            return None
        if path in self._cache:
            return self._cache[path]
        if mode is None:
            add(f"include file '{file}' not found (looked for {path})", source, ptr + "/file", element="include",
                hint="include paths are relative to the including file")
            return None
        try:
            data, inc_source = self._read(path)
        except DiagramError as exc:
            self.problems.extend(exc.problems)
            self._cache[path] = None
            return None
        self._stack.append(path)
        try:
            spec = self.machine(data, inc_source, "", depth)
        finally:
            self._stack.pop()
        self._cache[path] = spec
        return spec

    # -- elements -------------------------------------------------------------------------------
    def _states(self, raws: list[Any], source: Source, base: str, depth: int) -> list[StateSpec]:
        """A level's state elements: validated in one call when they all are (:func:`validated_together`), else one
        by one, each problem at its element."""
        together = validated_together(self._tables["state"], raws)
        if together is None:
            return [st for i, raw in enumerate(raws)
                    if (st := self.state(raw, source, f"{base}/states/{i}", depth)) is not None]
        classes, params = together
        specs = list(map(StateSpec, map(_ID, params), classes, params, _pointers(f"{base}/states/", len(raws)),
                         repeat(source)))
        # the conditions and regions of the elements that have them, in document order (a plain level has none: one
        # set of the level's classes and one of its step keys tell, without a Python step per element)
        if any(cls.condition_fields or cls.is_composite for cls in set(classes)) or \
                list(map(_STEP_KEYS, params)).count(_NO_STEP_KEYS) != len(params):
            for spec in specs:
                self._state_parts(spec, depth)
        return specs

    def _transitions(self, raws: list[Any], source: Source, base: str) -> list[TransitionSpec]:
        """A level's transition elements, as :meth:`_states`."""
        together = validated_together(self._tables["transition"], raws)
        if together is None:
            return [tr for i, raw in enumerate(raws)
                    if (tr := self.transition(raw, source, f"{base}/transitions/{i}")) is not None]
        classes, params = together
        specs = list(map(TransitionSpec, classes, params, _pointers(f"{base}/transitions/", len(raws)),
                         repeat(source)))
        if any(cls.condition_fields for cls in set(classes)) or dict in set(map(type, map(_GUARD, params))):
            for spec in specs:
                self._transition_parts(spec)
        return specs

    def element(self, kind: str, raw: Any, source: Source, ptr: str) -> tuple[type[Any], Any] | None:
        """The class an element's ``type`` names and its validated parameters, or ``None`` (problems added)."""
        if not isinstance(raw, dict):
            return None  # the envelope reported it
        name = raw.get("type")
        cls = None
        if isinstance(name, str):
            try:  # the table's C lookup; a name not imported yet is imported by its __missing__ (as its get does)
                cls = self._tables[kind][name]
            except KeyError:
                cls = None
        if cls is None:
            cls, problems = check_type(kind, raw, self.registry, source, ptr)
            if cls is None:
                self.problems.extend(problems, source)
                return None
        model: type[ParamsBase] = cls.Params
        try:
            # the model's validator itself, as model_validate calls it (pydantic's plugins included): its keyword
            # handling and frame cost about a tenth of the parse stage for a document of plain elements
            return cls, model.__pydantic_validator__.validate_python(raw)
        except ValidationError as err:
            self.problems.extend(problems_from_validation(
                err, source=source, base=ptr, element=element_label(kind, raw), model=model, kind="parameter",
                data=raw), source)
            return None

    def state(self, raw: Any, source: Source, ptr: str, depth: int) -> StateSpec | None:
        """A state element, its condition objects and (through its type) its regions."""
        parsed = self.element("state", raw, source, ptr)
        if parsed is None:
            return None
        return self.state_of(*parsed, source, ptr, depth)

    def state_of(self, cls: type[Any], params: Any, source: Source, ptr: str, depth: int) -> StateSpec:
        """The spec of a state element whose parameters are valid: its condition objects and regions parsed."""
        spec = StateSpec(params.id, cls, params, ptr, source)
        self._state_parts(spec, depth)
        return spec

    def _state_parts(self, spec: StateSpec, depth: int) -> None:
        """A state's condition objects and (a composite's) regions, parsed into its spec."""
        cls, params = spec.cls, spec.params
        if params.precondition is not None or params.until is not None or params.monitors is not None \
                or cls.condition_fields:
            self._step_conditions(spec)
        if cls.is_composite:
            region_layout(cls)(self, spec, depth)

    def _step_conditions(self, spec: StateSpec) -> None:
        """The condition objects of a state's precondition, until, monitors and its type's condition parameters
        (expressions stay text)."""
        p = spec.params
        fields = spec.cls.condition_fields
        if p.precondition is None and p.until is None and p.monitors is None and not fields:
            return
        keys: list[tuple[str, Any]] = [("precondition", p.precondition), ("until", p.until)]
        keys += [(f"monitors/{i}/condition", m.condition) for i, m in enumerate(p.monitors or ())]
        keys += [(key, getattr(p, key, None)) for key in fields]
        conditions = {}
        for key, raw in keys:
            if isinstance(raw, dict):
                cs = self.condition(raw, spec.source, f"{spec.pointer}/{key}", spec.label)
                if cs is not None:
                    conditions[key] = cs
        if conditions:
            spec.conditions = conditions

    def transition(self, raw: Any, source: Source, ptr: str) -> TransitionSpec | None:
        """A transition element and its condition objects (a condition guard, the type's condition parameters)."""
        parsed = self.element("transition", raw, source, ptr)
        if parsed is None:
            return None
        return self.transition_of(*parsed, source, ptr)

    def transition_of(self, cls: type[Any], params: Any, source: Source, ptr: str) -> TransitionSpec:
        """The spec of a transition element whose parameters are valid, its condition objects parsed."""
        spec = TransitionSpec(cls, params, ptr, source)
        self._transition_parts(spec)
        return spec

    def _transition_parts(self, spec: TransitionSpec) -> None:
        """A transition's condition objects (a condition guard, its type's condition parameters), into its spec."""
        fields = spec.cls.condition_fields
        if fields or type(spec.params.guard) is dict:
            conditions = {}
            for key in ("guard", *fields):
                value = getattr(spec.params, key, None)
                if isinstance(value, dict):
                    cs = self.condition(value, spec.source, f"{spec.pointer}/{key}", spec.label)
                    if cs is not None:
                        conditions[key] = cs
            if conditions:
                spec.conditions = conditions

    def condition(self, raw: Any, source: Source, ptr: str, element: str, depth: int = 0) -> ConditionSpec | None:
        """A condition object and the conditions nested in it; ``None`` when it or a nested one does not parse."""
        if depth > MAX_MACHINE_DEPTH:
            self.problems.add("conditions nested too deeply", source, ptr, element=element)
            return None
        parsed = self.element("condition", raw, source, ptr)
        if parsed is None:
            return None
        cls, params = parsed
        spec = ConditionSpec(cls, params, ptr)
        ok = True
        for key in cls.condition_fields:
            value = getattr(params, key)
            items = list(enumerate(value)) if isinstance(value, list) else [(None, value)]
            for i, item in items:
                sub_ptr = f"{ptr}/{key}" + (f"/{i}" if i is not None else "")
                child = self.condition(item, source, sub_ptr, element, depth + 1)
                if child is None:
                    ok = False
                else:
                    spec.children.append(child)
        return spec if ok else None


def envelope_of(data: dict[str, Any], text_keys: bool = False) -> MachineEnvelope:
    """``MachineEnvelope.model_validate(data)``, without pydantic copying each state and transition element: a level
    whose elements are all objects with text keys (any JSON document's: ``text_keys`` says ``data`` is one, whose
    keys need no look) is validated with one empty object standing in for them, which validates alike. Raises the
    ``ValidationError`` of ``data`` itself."""
    if sum(len(x) for x in (data.get("states"), data.get("transitions")) if type(x) is list) < _FEW:
        return MachineEnvelope.model_validate(data)  # a few elements: the stand-in's passes cost more than copies
    stand_in = dict(data)
    for key in ("states", "transitions"):
        elements = data.get(key)
        if key in data and not _plain_elements(elements, text_keys):
            return MachineEnvelope.model_validate(data)
        if elements:
            stand_in[key] = _ONE_ELEMENT
    try:
        return MachineEnvelope.model_validate(stand_in)
    except ValidationError:
        return MachineEnvelope.model_validate(data)  # its own errors, in its own words


#: Below this many elements a level's envelope is validated as written (pydantic's copies cost less than the checks).
_FEW = 32
#: What stands in for a list of element objects in :func:`envelope_of` (pydantic copies it, never changes it).
_ONE_ELEMENT: list[dict[str, Any]] = [{}]


def _plain_elements(elements: Any, text_keys: bool) -> bool:
    """Whether ``elements`` is a list of objects whose keys are all text (``text_keys``: known to be, when objects)."""
    return type(elements) is list and set(map(type, elements)) <= ONLY_DICT and \
        (text_keys or set(map(type, chain.from_iterable(elements))) <= ONLY_STR)


def validated_together(table: Mapping[str, type[Any]], raws: list[Any]) -> tuple[list[type[Any]], list[Any]] | None:
    """The class and the validated parameters of each element of ``raws``, all in one pydantic-core call; ``None``
    when one of them is not an object naming a type of ``table`` or does not validate: the caller then takes them
    one by one, so that each problem is found at its element in its own words.

    Validating element by element cost a Python frame and a call into pydantic-core per element, half of the parse
    stage's validation. The list's validator (:func:`_list_validator`) is built from the types' own model schemas,
    once per set of types."""
    if len(raws) < 2 or set(map(type, raws)) != {dict}:
        return None
    try:
        names = list(map(_TYPE_OF, raws))
        classes = {name: table[name] for name in set(names)}  # a name not imported yet: the table imports it
    except (KeyError, TypeError):  # no type, an unhashable one, or one the table does not know
        return None
    validator = _list_validator(tuple(sorted((name, cls.Params) for name, cls in classes.items())))
    if validator is None:
        return None
    types = list(map(classes.__getitem__, names))
    params = plain_params.made(types, raws)  # plain elements without pydantic-core, where the schema allows
    if params is None:
        try:
            params = validator.validate_python(raws)
        except ValidationError:
            return None
    return types, params


def _pointers(head: str, n: int) -> list[str]:
    """``head + "0"``, ``head + "1"``, ... the pointers of a level's ``n`` elements (C-speed steps)."""
    return list(map(head.__add__, map(str, range(n))))


_TYPE_OF = operator.itemgetter("type")
_ID = operator.attrgetter("id")
_STEP_KEYS = operator.attrgetter("precondition", "until", "monitors")
_GUARD = operator.attrgetter("guard")
_NO_STEP_KEYS = (None, None, None)
_PARAMS = operator.attrgetter("params")
_ENDS = operator.attrgetter("from_", "to")
#: The validators of :func:`_list_validator` by their types (``None``: a set of types validated one by one).
_LIST_VALIDATORS: dict[tuple[tuple[str, type[Any]], ...], SchemaValidator | None] = {}


def _list_validator(types: tuple[tuple[str, type[Any]], ...]) -> SchemaValidator | None:
    """A validator of a list of elements of these ``(name, Params)`` types, chosen by each element's ``type``: the
    types' own model schemas in a list (one type) or a union tagged by ``type``. ``None`` when the models' own
    validators are needed: a model that cannot be built, or pydantic plugins watching the models' validations."""
    if types in _LIST_VALIDATORS:
        return _LIST_VALIDATORS[types]
    if len(_LIST_VALIDATORS) >= 256:  # a process loading documents of ever new type mixes: keep it bounded
        _LIST_VALIDATORS.clear()
    validator: SchemaValidator | None = None
    try:
        schemas = {name: _model_schema(model) for name, model in types}
        item = next(iter(schemas.values())) if len(schemas) == 1 else \
            core_schema.tagged_union_schema(schemas, discriminator="type")
        if all(schema is not None for schema in schemas.values()):
            validator = SchemaValidator(core_schema.list_schema(item))
    except (PydanticUserError, SchemaError):
        validator = None
    _LIST_VALIDATORS[types] = validator
    return validator


def _model_schema(model: type[Any]) -> Any:
    """The core schema of a parameters model (built now if it was deferred), or ``None`` when pydantic validates
    the model through plugins (then only the model's own validator calls them)."""
    if not model.__pydantic_complete__ and not model.model_rebuild(raise_errors=False):
        return None  # a model that cannot be built: its own validator says why, element by element
    if type(model.__pydantic_validator__) is not SchemaValidator:
        return None
    return model.__pydantic_core_schema__


#: Whether pydantic's plugins were looked up in this process (a list: set once, no ``global``).
_PLUGINS_LOOKED_UP: list[bool] = []


def parse(src: Any, registry: Registry, problems: Problems,
          base_dir: str | os.PathLike[str] | None = None) -> MachineSpec | None:
    """The spec of ``src`` (a path or a document dict); every problem found goes to ``problems``."""
    if not _PLUGINS_LOOKED_UP:  # before the first parameter model is built (fsm.loading.pydantic_plugins says why)
        from fsm.loading.pydantic_plugins import spare_pydantic_plugin_scan

        spare_pydantic_plugin_scan()
        _PLUGINS_LOOKED_UP.append(True)
    parser = Parser(registry, problems, base_dir)
    try:
        return parser.document(src)
    except RecursionError:
        name = str(src) if isinstance(src, (str, os.PathLike)) else None
        problems.add("document nested too deeply to check", Source(name), "")
        return None


def parse_submachines(parser: Parser, spec: StateSpec, depth: int) -> None:
    """A composite's regions as drawn: each sub-machine its type names (``Composite.submachines``) into
    ``spec.subs``, a region's own ``name`` checked to be usable as a path step."""
    for default_name, doc, rel in spec.cls.submachines(spec.params):
        sub = parser.submachine(doc, spec.source, spec.pointer + rel, depth + 1)
        name = default_name
        if default_name is not None and sub is not None and sub.name:
            name = sub.name
            if "/" in name or any(name == other.name for other in spec.subs):
                parser.problems.add(f"region name '{name}' is not usable as a path step (it contains '/' or is "
                                    f"used twice in '{spec.id}')", sub.source, sub.pointer + "/name",
                                    element=spec.label, hint="give each region a unique name")
        spec.subs.append(SubMachine(name, sub, spec.pointer + rel))


#: How a composite's regions are parsed, by the base class of its type, the most specific first: a Sequence's steps
#: are laid out as regions, any other composite's sub-machines are parsed as drawn.
REGION_LAYOUTS: tuple[tuple[type[Any], Callable[[Parser, StateSpec, int], None]], ...] = (
    (Sequence, parse_sequence),
    (Composite, parse_submachines),
)


def region_layout(cls: type[Any]) -> Callable[[Parser, StateSpec, int], None]:
    """The layout of :data:`REGION_LAYOUTS` for a composite type."""
    for base, layout in REGION_LAYOUTS:
        if issubclass(cls, base):
            return layout
    return parse_submachines


__all__ = ["MAX_MACHINE_DEPTH", "REGION_LAYOUTS", "Parser", "parse", "parse_submachines", "region_layout"]
