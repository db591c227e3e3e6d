"""A Sequence's steps laid out as regions, while parsing: the blocking steps become the *chain* (one region, each
step linked to the next by a ``Finished`` transition), each non-blocking sequence and each exception sequence a
region of its own. The chain is expressed in the document's own vocabulary, so the later stages (checks,
compile, build) treat it like any drawn machine.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from itertools import pairwise
from typing import TYPE_CHECKING, Any, Protocol, cast

from fsm.model.document import MachineSpec, SequenceLayout, Source, StateSpec, SubMachine, TransitionSpec
from fsm.sequencer import steps

if TYPE_CHECKING:
    from fsm.model.document import TypeTables
    from fsm.model.problems import Problems


class Parser(Protocol):
    """What laying a sequence out needs of the parse stage (:class:`fsm.loading.parsing.Parser` is one): where
    problems go, the registry, the scoped bookkeeping, and the parsing of an element and of a state."""

    @property
    def registry(self) -> TypeTables: ...

    @property
    def problems(self) -> Problems: ...

    @property
    def scopes(self) -> dict[str, Any]: ...

    def element(self, kind: str, raw: Any, source: Source, ptr: str) -> tuple[type[Any], Any] | None: ...

    def state(self, raw: Any, source: Source, ptr: str, depth: int) -> StateSpec | None: ...

#: The transition type that links the chain's steps: it must be registered for a Sequence to load.
LINK_TYPE = "Finished"


@dataclass
class _Steps:
    """What ``parse_sequence`` collects before it makes the layout."""

    chain: list[StateSpec] = field(default_factory=list)
    detached: list[tuple[int, StateSpec]] = field(default_factory=list)
    steps: list[StateSpec] = field(default_factory=list)
    exceptions: list[StateSpec] = field(default_factory=list)
    broken_exceptions: list[str] = field(default_factory=list)
    complete: bool = True


def is_sequence(cls: type[Any]) -> bool:
    return isinstance(cls, type) and issubclass(cls, steps.Sequence)


def is_detached(st: StateSpec) -> bool:
    """A non-blocking sequence (``"blocking": false``): it runs beside its caller's chain."""
    return is_sequence(st.cls) and getattr(st.params, "blocking", True) is False


def parse_sequence(parser: Parser, spec: StateSpec, depth: int) -> None:
    """Parse a Sequence's steps and exceptions into ``spec.subs`` and ``spec.sequence``."""
    source, ptr = spec.source, spec.pointer
    params = cast(steps.SequenceParams, spec.params)  # a Sequence's parameters are its Params
    add = parser.problems.add
    found = _Steps()
    first_at: dict[str, str] = {}

    def unique(st_id: Any, p: str) -> None:
        if not isinstance(st_id, str):
            return
        if st_id in first_at:
            add(f"duplicate id '{st_id}' (first used at {first_at[st_id]})", source, p + "/id",
                element=f"state '{st_id}'", hint="the steps and exception sequences of one sequence need unique ids")
        else:
            first_at[st_id] = p

    library = {raw["id"]: (raw, f"{ptr}/sequences/{i}") for i, raw in enumerate(params.sequences or ())
               if isinstance(raw, dict) and isinstance(raw.get("id"), str)}
    libraries: list[dict[str, tuple[dict[str, Any], str]]] = parser.scopes.setdefault("sequences", [])
    libraries.append(library)
    try:
        _parse_steps(parser, spec, params, found, unique, depth, libraries)
        for name, (raw, p) in library.items():  # a declared sequence is checked even when no Call uses it
            if not any(st.pointer == p for st in found.steps):
                declared = parser.state(raw, source, p, depth + 1)
                if declared is not None and not is_sequence(declared.cls):
                    add(f"'sequences' holds Sequence elements, not {declared.type}", source, p + "/type",
                        element=f"state '{name}'")
    finally:
        libraries.pop()
    _lay_out(parser, spec, found)


def _parse_steps(parser: Parser, spec: StateSpec, params: steps.SequenceParams, found: _Steps,
                 unique: Callable[[Any, str], None], depth: int,
                 libraries: list[dict[str, tuple[dict[str, Any], str]]]) -> None:
    source, ptr, add = spec.source, spec.pointer, parser.problems.add
    for i, raw in enumerate(params.steps):
        p = f"{ptr}/steps/{i}"
        if not isinstance(raw, dict):
            add("a step is a state element (an object with 'id' and 'type')", source, p,
                element=f"sequence '{spec.id}'", hint='{"id": "wait", "type": "Wait", "seconds": 1}')
            found.complete = False
            continue
        unique(raw.get("id"), p)
        calling: list[str] = parser.scopes.setdefault("calling", [])
        name = None
        if raw.get("type") == CALL_TYPE:
            called = _called(parser, raw, source, p, libraries)
            if called is None:
                found.complete = False
                continue
            raw, p, name = called
            calling.append(name)
        try:
            st = parser.state(raw, source, p, depth + 1)
        finally:
            if name is not None:
                calling.pop()
        if st is None:
            found.complete = False
            continue
        found.steps.append(st)
        if is_detached(st):
            found.detached.append((len(found.chain) - 1, st))
        else:
            found.chain.append(st)
    for i, raw in enumerate(params.exceptions or ()):
        p = f"{ptr}/exceptions/{i}"
        if not isinstance(raw, dict):
            add("an exception sequence is a Sequence element", source, p, element=f"sequence '{spec.id}'")
            continue
        unique(raw.get("id"), p)
        st = parser.state(raw, source, p, depth + 1)
        if st is None:
            if isinstance(raw.get("id"), str):
                found.broken_exceptions.append(raw["id"])
            continue
        if not is_sequence(st.cls):
            add(f"an exception sequence must be a Sequence, not {st.type}", source, p + "/type",
                element=f"state '{st.id}'", hint='{"id": "recover", "type": "Sequence", "steps": [...]}')
            continue
        if getattr(st.params, "blocking", True) is False:
            add("an exception sequence runs while its owner waits: it cannot be non-blocking", source,
                p + "/blocking", element=f"state '{st.id}'", hint="remove \"blocking\": false")
        found.exceptions.append(st)


def _lay_out(parser: Parser, spec: StateSpec, found: _Steps) -> None:
    """The chain, the non-blocking sequences and the exception sequences as the Sequence's regions."""
    source, ptr, add = spec.source, spec.pointer, parser.problems.add
    if not found.chain:
        if found.complete:
            add("a sequence needs at least one blocking step", source, ptr + "/steps", element=f"sequence '{spec.id}'",
                hint='end it with {"id": "join", "type": "Join", "sequences": [...]} to wait for its '
                     "non-blocking sequences")
        spec.subs = []
        return
    chain = MachineSpec(source=source, pointer=ptr, name=None, initial=found.chain[0].id,
                        initial_pointer=ptr + "/steps", states=found.chain,
                        transitions=_links(parser, spec, found.chain), vars={},
                        edges=[(a.id, b.id) for a, b in pairwise(found.chain)], complete=found.complete,
                        written=False)
    subs = [SubMachine(None, chain, ptr)]
    subs += [SubMachine(None, _single(st, source), st.pointer) for _after, st in found.detached]
    subs += [SubMachine(None, _single(st, source), st.pointer) for st in found.exceptions]
    spec.subs = subs
    spec.sequence = SequenceLayout(
        detached_after=tuple(after for after, _ in found.detached),
        detached_ids=tuple(st.id for _, st in found.detached),
        exception_ids=tuple(st.id for st in found.exceptions),
        broken_exception_ids=tuple(found.broken_exceptions),
        steps=tuple(found.steps),
        exceptions=tuple(found.exceptions),
    )


#: A step that runs a sequence declared in ``sequences`` (of its Sequence or an enclosing one) under its own id.
CALL_TYPE = "Call"
#: A Call's keys that apply to the called instance (besides its id): the step-common keys and the drawing's.
_CALL_KEYS = ("description", "layout", "set", "precondition", "until", "monitors", "timeout", "timeout_behavior",
              "timeout_exception", "endless", "blocking")


def _called(parser: Parser, raw: dict[str, Any], source: Source, ptr: str,
            libraries: list[dict[str, tuple[dict[str, Any], str]]]) -> tuple[dict[str, Any], str, str] | None:
    """The element a Call step stands for: the declared sequence it names, under the Call's id (with the Call's
    own step keys on top), parsed at the declaration's place so that its problems point there."""
    parsed = parser.element("state", raw, source, ptr)
    if parsed is None:
        return None
    name = parsed[1].sequence
    expanding: list[str] = parser.scopes.setdefault("calling", [])
    for library in reversed(libraries):
        if name in library:
            if name in expanding:
                parser.problems.add(f"sequence '{name}' calls itself (through {' -> '.join(expanding + [name])})",
                                    source, ptr + "/sequence", element=f"state '{raw.get('id')}'",
                                    hint="a sequence may call others, not itself")
                return None
            definition, where = library[name]
            return {**definition, "id": raw["id"], **{k: raw[k] for k in _CALL_KEYS if k in raw}}, where, name
    known = sorted({n for library in libraries for n in library})
    parser.problems.add(f"no sequence '{name}' is declared for Call", source, ptr + "/sequence",
                        element=f"state '{raw.get('id')}'",
                        hint=("declared here: " + ", ".join(known)) if known else
                        'declare it in "sequences" of this Sequence or an enclosing one')
    return None


def _links(parser: Parser, spec: StateSpec, chain: list[StateSpec]) -> list[TransitionSpec]:
    """The chain's ``Finished`` transitions (any outcome goes on to the next step); a registry without that type
    cannot run a sequence of more than one step, which is a located error."""
    if len(chain) < 2:
        return []
    link = parser.registry.transitions.get(LINK_TYPE)
    if link is None:
        parser.problems.add(f"a sequence of several steps needs the transition type '{LINK_TYPE}', which this "
                            "registry lacks", spec.source, spec.pointer + "/steps", element=f"sequence '{spec.id}'",
                            hint="load the built-in types (fsm.Registry.with_builtins()) or register a "
                                 f"'{LINK_TYPE}' transition")
        return []
    return [TransitionSpec(link, link.Params.model_validate({"type": LINK_TYPE, "from": a.id, "to": b.id}),
                           b.pointer, spec.source) for a, b in pairwise(chain)]


def _single(st: StateSpec, source: Source) -> MachineSpec:
    """A region holding one state (a non-blocking or exception sequence)."""
    return MachineSpec(source=source, pointer=st.pointer, name=None, initial=st.id, initial_pointer=st.pointer,
                       states=[st], transitions=[], vars={}, edges=[], complete=True, written=False)


__all__ = ["LINK_TYPE", "Parser", "is_detached", "is_sequence", "parse_sequence"]
