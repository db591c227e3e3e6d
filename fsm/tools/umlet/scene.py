"""What the boxes of a UMLet diagram are: states, frames, pseudostates and machine notes, at zoom 10, nested.

A :class:`Scene` holds every box with its text read (a state's name, type and parameters; a frame's title; a
machine note's keys) and the machine level each box is drawn in. Nesting comes from geometry alone
(:func:`fsm.tools.umlet.geometry.nest`): UMLet stores no hierarchy. Problems are collected, located by the
element's kind, label, file line:column and diagram coordinates, never raised one at a time.
"""

from __future__ import annotations

import functools
import json
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from fsm.loading.registry import default_registry
from fsm.model.errors import Problem

from . import text as T
from .geometry import Box, nest
from .source import RawDiagram, RawElement, describe, num, where

#: What the elements of each kind draw. Class boxes are states in a diagram that has no state box at all
#: (students draw state machines with them).
_DRAWS = {"UMLState": "state", "UMLClass": "class", "UMLFrame": "frame", "UMLNote": "note"}
#: The same for old elements (``<type>``), which may have either kind.
_DRAWS_OLD = {"State": "state", "StateSubDiagram": "state", "SendSignal": "state", "ReceiveSignal": "state",
              "Class": "class", "Note": "note"}
_SPECIAL_OLD = {"InitialState": "initial", "FinalState": "final", "Decision": "decision",
                "HistoryState": "history", "RegionEndState": "flow_final", "SyncBarHorizontal": "sync",
                "SyncBarVertical": "sync"}
_SUPPORTED_SPECIAL = {"initial", "final"}
#: Machine note keys whose values are texts (the others: :data:`_NOTE_JSON_KEYS`).
_NOTE_TEXT_KEYS = {"name", "$schema", "description"}


# -- describing elements ---------------------------------------------------------------------------------------
# -- the scene -----------------------------------------------------------------------------------------------
@dataclass(eq=False)
class StateBox:
    """A state drawn as a box (or a frame, or a final pseudostate): its id, type and parameters."""

    box: Box
    id: str = ""
    alias: str | None = None
    type: str | None = None
    params: dict[str, Any] = field(default_factory=dict)
    description: str | None = None
    composite: bool = False


@dataclass(eq=False)
class Marker:
    """An initial pseudostate's arrow: the state it starts, its points and the relation element."""

    target: StateBox
    points: list[Any]
    relation: RawElement


@dataclass(eq=False)
class Level:
    """One machine level: the boxes directly inside a container (or at the top)."""

    owner: Box | None
    states: list[StateBox] = field(default_factory=list)
    initials: list[Box] = field(default_factory=list)
    notes: list[Box] = field(default_factory=list)
    transitions: list[dict[str, Any]] = field(default_factory=list)
    trans_origin: list[RawElement | None] = field(default_factory=list)
    initial_target: StateBox | None = None
    finals_by_outcome: dict[str, StateBox] = field(default_factory=dict)


def _draws(elem: RawElement) -> str | None:
    """What an element draws: a state, class, frame or note box (None: none of them)."""
    return _DRAWS.get(elem.kind) or (_DRAWS_OLD.get(elem.kind) if elem.old else None)


def _pseudostate(elem: RawElement) -> str | None:
    """The pseudostate an element draws (initial, final, decision, ...); ``None`` for any other element."""
    if elem.kind == "UMLSpecialState":
        return T.special_kind(elem.text)[0]
    return _SPECIAL_OLD.get(elem.kind) if elem.old else None


class Scene:
    """The boxes of one diagram, their texts, nesting and levels; relations are kept for later."""

    def __init__(self, raw: RawDiagram) -> None:
        self.raw = raw
        self.name = raw.name
        self.problems: list[Problem] = []
        self.scale = 10.0 / raw.zoom
        self.boxes: list[Box] = []
        self.relations: list[RawElement] = []
        self.state_of: dict[int, StateBox] = {}  # id(box) -> state
        self.note_of: dict[int, dict[str, Any]] = {}  # id(note box) -> the machine's keys
        self.levels: dict[int, Level] = {}  # id(owner box) or 0 -> level
        #: Frames drawn directly inside a Parallel state: its regions.
        self.region_frames: set[int] = set()
        #: Top-level frames that no arrow touches: each holds a machine of its own.
        self.machine_frames: set[int] = set()
        self.markers: dict[int, Marker] = {}  # id(initial pseudostate box) -> its arrow
        #: Initial pseudostates whose arrow ends at a state whose text did not read (reported there).
        self.broken_markers: set[int] = set()
        #: Notes that are no machine notes (comments): not part of a machine, but arrows may anchor at them.
        self.comment_notes: list[Box] = []
        #: Boxes that are no part of a machine (class boxes, generic boxes, zero-size boxes), each with the reason:
        #: an arrow that ends at one is reported naming it.
        self.ignored: list[tuple[Box, str]] = []
        #: Whether ``UMLClass`` boxes are the states (the diagram has no ``UMLState`` at all).
        self.class_states = False
        self._registry: Any = None

    # -- problems -------------------------------------------------------------------------------------------
    def problem(self, elem: RawElement | None, message: str, hint: str | None = None) -> None:
        if elem is None:
            self.problems.append(Problem(message, self.name, hint=hint))
            return
        self.problems.append(Problem(message, self.name, pointer=elem.pointer or "", line=elem.line,
                                     column=elem.column, element=describe(elem), hint=hint))

    def registry(self) -> Any:
        if self._registry is None:
            self._registry = default_registry()
        return self._registry

    # -- queries --------------------------------------------------------------------------------------------
    def box_name(self, box: Box) -> str:
        st = self.state_of.get(id(box))
        name = st.id if st is not None else ""
        if box.role == "initial":
            return f"the initial pseudostate at {where(box.elem)}"
        if id(box) in self.region_frames:
            return f"region frame '{name}'" if name else f"the region frame at {where(box.elem)}"
        return f"'{name}'" if name else f"{box.elem.kind} at {where(box.elem)}"

    def level_of(self, box: Box) -> Level:
        return self.levels[id(box.parent)] if box.parent is not None else self.levels[0]

    def container_chain(self, box: Box) -> list[Box | None]:
        chain: list[Box | None] = []
        node = box.parent
        while node is not None:
            chain.append(node)
            node = node.parent
        chain.append(None)
        return chain

    def is_parallel(self, box: Box | None) -> bool:
        st = self.state_of.get(id(box))  # None: no state's box
        return st is not None and st.type == "Parallel" and st.box.role == "state"

    # -- building -------------------------------------------------------------------------------------------
    def build(self) -> None:
        self.classify()
        nest(self.boxes)
        self.read_states()
        self.make_levels()

    def classify(self) -> None:
        """Sort the elements: state boxes, frames, notes and pseudostates become boxes, relations are kept for
        later, and what is not part of a state machine is ignored (with the reason an arrow ending on it gives)."""
        drawn = {_draws(e) for e in self.raw.elements}
        self.class_states = "class" in drawn and "state" not in drawn
        for elem in self.raw.elements:
            if elem.kind != "Relation" and (elem.w <= 0 or elem.h <= 0):
                self._sizeless(elem)
                continue
            role = self._role(elem)
            if role == "relation":
                self.relations.append(elem)
            elif role == "comment":
                self.comment_notes.append(self.box(elem, "comment"))
            elif role is None:  # texts, class boxes, generic boxes: not part of a state machine
                self.ignored.append((self.box(elem, "ignored"), self._ignored_reason(elem)))
            else:
                self._add_box(elem, role)

    def _sizeless(self, elem: RawElement) -> None:
        """A box of no size is ignored; one that would be part of the machine is said."""
        if self._drawn(elem) in ("state", "frame") or _pseudostate(elem) is not None:
            self.problem(elem, f"the box has no size (w={num(elem.w)}, h={num(elem.h)}), so it is ignored",
                         hint="give it a size in UMLet (drag its corner), or delete it")
        self.ignored.append((self.box(elem, "ignored"), "it has no size"))

    def _role(self, elem: RawElement) -> str | None:
        """state, frame, note, a pseudostate's kind (or unsupported), comment, relation; ``None``: ignored."""
        drawn = self._drawn(elem)
        if drawn in ("state", "frame"):
            return drawn
        if drawn == "note":
            return "note" if T.is_machine_note(elem.text) else "comment"
        special = _pseudostate(elem)
        if special is not None:
            return special if special in _SUPPORTED_SPECIAL else "unsupported"
        return "relation" if elem.kind == "Relation" else None

    def _drawn(self, elem: RawElement) -> str | None:
        """What an element draws (:func:`_draws`), a class box being a state in a diagram that has no state box."""
        drawn = _draws(elem)
        return "state" if drawn == "class" and self.class_states else drawn

    @staticmethod
    def _ignored_reason(elem: RawElement) -> str:
        if _draws(elem) == "class":
            return "class boxes are states only in a diagram without UMLState boxes, and this one has UMLState boxes"
        return f"a {elem.kind} is not part of a state machine"

    def _add_box(self, elem: RawElement, role: str) -> None:
        box = self.box(elem, role)
        box.container = role in ("state", "frame")
        self.boxes.append(box)
        if role == "unsupported":
            self.problem(elem, f"'{_pseudostate(elem)}' pseudostates are not supported",
                         hint="use states and transitions with guards (types) instead; "
                              "only type=initial and type=final are understood")

    def box(self, elem: RawElement, role: str) -> Box:
        """The element's rectangle at zoom 10, as UMLet computes it for sticking."""
        s = self.scale
        if elem.old:
            return Box(elem, role, elem.x * s, elem.y * s, elem.w * s, elem.h * s)
        # NewGridElement.getRealRectangle: val * 10 / gridSize in integer arithmetic
        return Box(elem, role, float(int(elem.x * s)), float(int(elem.y * s)), float(int(elem.w * s)),
                   float(int(elem.h * s)))

    def read_states(self) -> None:
        """The state each frame, state and final box is (a box whose text is wrong has none), the keys of each
        machine note; the frames that are a Parallel state's regions."""
        readers = {"frame": _frame_state, "state": self.read_state, "final": _final_state}
        for box in self.boxes:
            read = readers.get(box.role)
            st = read(box) if read is not None else None
            if st is not None:
                self.state_of[id(box)] = st
            meta = self.read_note(box.elem) if box.role == "note" else None
            if meta is not None:
                self.note_of[id(box)] = meta
        for box in self.boxes:
            if box.role == "frame" and self.is_parallel(box.parent):
                self.region_frames.add(id(box))

    def read_state(self, box: Box) -> StateBox | None:
        elem = box.elem
        try:
            text = T.parse_state(elem.text)
        except T.TextError as exc:
            self.problem(elem, str(exc), hint=exc.hint)
            return None
        st = StateBox(box, id=text.name, description=text.description)
        if text.params is not None and not self._typed(st, text):
            return None
        if text.activities:
            sets = self._activities(elem, text.activities)
            if sets is None:
                return None
            if "set" in st.params:
                self.problem(elem, "the state gives both set= and entry / exit lines", hint="keep one of the two")
                return None
            st.params = {**st.params, "set": sets}
        return st

    def _typed(self, st: StateBox, text: T.StateText) -> bool:
        """A state's ``id`` alias, type and parameters from its parameter lines; ``False``: a problem said."""
        params = dict(text.params or {})
        alias = params.pop("id", None)
        if alias is not None:
            st.alias = str(alias)
            st.id = st.id or str(alias)
        typ = params.pop("type", None)
        if not isinstance(typ, str) or not typ:
            self.problem(st.box.elem, f"'type' must be a type name, got {typ!r}",
                         hint="see `fsmctl types` for the state types")
            return False
        st.type = typ
        st.params = self.coerce_kv("state", typ, params, text.kv_keys)
        return True

    def _activities(self, elem: RawElement, activities: list[tuple[str, str]]) -> dict[str, dict[str, Any]] | None:
        """The ``set`` of a state's ``entry / ...`` and ``exit / ...`` lines; ``None``: a problem said."""
        sets: dict[str, dict[str, Any]] = {}
        for when, action in activities:
            try:
                assigned = T.parse_actions(action)
            except T.TextError as exc:
                self.problem(elem, f"{when} / ...: {exc}",
                             hint="an internal activity is 'entry / name = expression; ...' (or exit)")
                return None
            target = sets.setdefault("on_enter" if when == "entry" else "on_exit", {})
            twice = next((name for name in assigned if name in target), None)
            if twice is not None:
                self.problem(elem, f"{when} / ...: '{twice}' is assigned twice",
                             hint="assign each variable once per entry (or exit)")
                return None
            target.update(assigned)
        return sets

    def read_note(self, elem: RawElement) -> dict[str, Any] | None:
        """A machine note's keys, typed (see :func:`_note_value`); ``None``: a problem said."""
        try:
            note = T.parse_machine_note(elem.text)
            meta = {key: _note_value(key, raw) for key, raw in note.values.items()}
        except T.TextError as exc:
            self.problem(elem, f"machine note: {exc}", hint=exc.hint)
            return None
        if note.description is not None:
            meta["description"] = note.description
        return meta

    def coerce_kv(self, kind: str, typ: str, params: dict[str, Any], kv_keys: set[str]) -> dict[str, Any]:
        """``key=value`` texts (the ``kv_keys``): a value that looks like a number stays text where the parameter
        is text, and ``key=null`` is the parameter left out (the palette's line for a parameter without a default,
        ready to be given a value; a document never holds null). Values from JSON are typed already."""
        if not kv_keys:
            return params
        params = {k: v for k, v in params.items() if v is not None or k not in kv_keys}
        reg = self.registry()
        cls = (reg.states if kind == "state" else reg.transitions).get(typ)
        if cls is None:
            return params
        texts = kv_keys & _text_fields(cls.Params)
        return {k: json.dumps(v) if k in texts and not isinstance(v, (str, dict, list)) else v
                for k, v in params.items()}

    def make_levels(self) -> None:
        """A level (a machine) at the top and in each box that holds more than notes; each note, initial marker
        and state put in the level it is drawn in; final states named."""
        self.levels[0] = Level(None)
        for box in self.boxes:
            if any(c.role != "note" for c in box.children):  # only containers have children
                self.levels[id(box)] = Level(box)
        for box in self.boxes:
            if box.role == "note":
                self._place_note(box)
            elif box.role == "initial":
                self.level_of(box).initials.append(box)
            elif id(box) in self.state_of:  # a frame, state or final box whose text read
                st = self.state_of[id(box)]
                self.level_of(box).states.append(st)
                st.composite = id(box) in self.levels
        for level in self.levels.values():
            _name_finals(level)

    def _place_note(self, box: Box) -> None:
        """A machine note into the level of the box it is drawn in; inside a box that holds no machine it is said."""
        parent = box.parent
        level = self.levels.get(id(parent)) if parent is not None else self.levels[0]
        if level is None:
            assert parent is not None
            self.problem(box.elem, f"machine note inside {self.box_name(parent)}, which holds no machine",
                         hint="move the note into the composite state or region frame whose machine it "
                              "describes, or outside every box for the diagram's own machine")
        elif id(box) in self.note_of:
            level.notes.append(box)


def _note_value(key: str, raw: str) -> Any:
    """A machine note's value: a text for name, $schema and description (42, true, [..]: the text as written), a
    JSON list of names for inputs, a JSON object for vars; a :class:`TextError` says what is wrong."""
    value = T.parse_value(raw, strict=True)
    if key in _NOTE_TEXT_KEYS:
        return value if isinstance(value, str) or value is None else raw
    fits, form, hint = _NOTE_JSON_KEYS[key]
    if not fits(value):
        raise T.TextError(f"'{key}' must be {form}, got {raw[:40]!r}", hint=hint)
    return value


def _names(value: Any) -> bool:
    return isinstance(value, list) and all(isinstance(v, str) for v in value)


#: Machine note keys whose values are JSON: whether a value has the form, the form, and how to write it.
_NOTE_JSON_KEYS: dict[str, tuple[Callable[[Any], bool], str, str]] = {
    "inputs": (_names, "a JSON list of signal names", 'write it as inputs=["start", "pause"]'),
    "vars": (lambda value: isinstance(value, dict), "a JSON object", 'write it as vars={"name": value, ...}')}


def _frame_state(box: Box) -> StateBox:
    """A frame's state, named by the title lines above its first separator."""
    title = []
    for ln in T.shown_lines(box.elem.text):
        if T.SEPARATOR.match(ln):
            break
        if ln.strip():
            title.append(ln.strip())
    return StateBox(box, id=" ".join(title))


def _final_state(box: Box) -> StateBox:
    """A final state; its label (a special state's, or the box's text) is its outcome."""
    elem = box.elem
    st = StateBox(box, type="Final")
    if elem.kind == "UMLSpecialState":
        _, label = T.special_kind(elem.text)
    else:
        label = " ".join(ln.strip() for ln in T.shown_lines(elem.text) if ln.strip())
    if label:
        st.params = {"outcome": label}
    return st


def _name_finals(level: Level) -> None:
    """Final states take their outcome label as id (else ``final``), numbered to be unique in their level."""
    taken = {st.id for st in level.states if st.box.role != "final"}
    for st in level.states:
        if st.box.role == "final":
            st.id = T.numbered(st.params.get("outcome") or "final", taken)
            taken.add(st.id)


@functools.cache
def _text_fields(model: Any) -> set[str]:
    """The fields of a Params model whose values are texts (a string, or an enum of strings; null aside)."""
    out = set()
    for name, prop in model.model_json_schema().get("properties", {}).items():
        types = {prop.get("type")} if "type" in prop else {p.get("type") for p in prop.get("anyOf", [])}
        if "enum" in prop and all(isinstance(v, str) for v in prop["enum"]):
            types = {"string"}
        if types - {"null"} == {"string"}:
            out.add(name)
    return out
