"""The UMLet reader: a ``.uxf`` diagram (or TRAL's ``xml2json`` JSON of one) -> machine documents.

``UMLState`` boxes are states, ``UMLSpecialState`` ``type=initial``/``type=final`` the initial marker and
final states, ``Relation`` with an arrowhead the transitions; boxes drawn inside a state box or a
``UMLFrame`` form its sub-machine. Endpoints attach geometrically (:mod:`fsm.tools.uxf_geometry`). Every
element that cannot be placed is reported with its kind, label, file line:column and diagram
coordinates, all at once. Importing this module registers the reader for ``.uxf`` files with the loader.
"""

from __future__ import annotations

import math
from contextvars import ContextVar
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from fsm.document import Source
from fsm.errors import DiagramError, Problem
from fsm.loader import register_reader

from . import uxf_text as T
from .uxf_geometry import Attacher, Box, nest
from .uxf_source import RawDiagram, RawElement, read_raw

_STATE_KINDS_NEW = {"UMLState"}
_STATE_KINDS_OLD = {"State", "StateSubDiagram", "SendSignal", "ReceiveSignal"}
_FRAME_KINDS = {"UMLFrame"}
_SPECIAL_OLD = {"InitialState": "initial", "FinalState": "final", "Decision": "decision",
                "HistoryState": "history", "RegionEndState": "flow_final", "SyncBarHorizontal": "sync",
                "SyncBarVertical": "sync"}
_SUPPORTED_SPECIAL = {"initial", "final"}


# -- results ------------------------------------------------------------------------------------------------
@dataclass
class Converted:
    """What a diagram converts to: one document per machine, with element positions for error messages."""

    diagram: RawDiagram
    machines: list[dict[str, Any]]
    names: list[str]
    #: per machine: JSON pointer -> the raw element it came from
    origins: list[dict[str, RawElement]]

    def locator(self, machine: int) -> Any:
        origins = self.origins[machine]

        def locate(pointers: set[str]) -> dict[str, tuple[int, int, str]]:
            out: dict[str, tuple[int, int, str]] = {}
            for ptr in pointers:
                elem = origins.get(ptr)
                if elem is not None and elem.line is not None:
                    out[ptr] = (elem.line, elem.column or 1, where(elem))
            return out

        return locate

    def coordinates(self, machine: int, pointer: str) -> str | None:
        """Diagram coordinates of the element a pointer falls in (longest known prefix)."""
        origins = self.origins[machine]
        parts = pointer.split("/")
        for k in range(len(parts), 0, -1):
            elem = origins.get("/".join(parts[:k]))
            if elem is not None:
                return where(elem)
        return None


def where(elem: RawElement) -> str:
    return f"x={_num(elem.x)}, y={_num(elem.y)}"


def _num(v: float) -> Any:
    return int(v) if float(v).is_integer() else round(v, 3)


def describe(elem: RawElement) -> str:
    label = elem.first_line
    if elem.kind == "Relation":
        rel = T.parse_relation(elem.text)
        label = " ".join(ln.strip() for ln in rel.label_lines if ln.strip())
        label = (f"lt={rel.lt}" + (f" {label}" if label else "")) if rel.lt else label
    label = label if len(label) <= 40 else label[:37] + "..."
    return f"{elem.kind} '{label}' at {where(elem)}" if label else f"{elem.kind} at {where(elem)}"


# -- the reader hook ------------------------------------------------------------------------------------------
#: ``(resolved path, Converted, machine index)`` set by ``fsmctl convert --machine`` while the loader checks
#: the diagram it already read, so the reader neither reads it twice nor refuses a multi-machine file.
PRESELECTED: ContextVar[tuple[Path, Any, int] | None] = ContextVar("PRESELECTED", default=None)


def read_uxf(path: Path) -> tuple[dict[str, Any], Source]:
    """The loader's reader for ``.uxf``: one machine document, or a DiagramError naming every problem."""
    pre = PRESELECTED.get()
    if pre is not None and pre[0] == path.resolve():
        _, conv, index = pre
        return conv.machines[index], source_for(conv, index, path)
    conv = convert_file(path)
    if len(conv.machines) > 1:
        raise DiagramError([several_machines_problem(conv)])
    return conv.machines[0], source_for(conv, 0, path)


def source_for(conv: Converted, index: int, path: Path) -> Source:
    return Source(name=str(path), directory=path.parent, text=conv.diagram.text, locator=conv.locator(index))


def several_machines_problem(conv: Converted, hint: str | None = None) -> Problem:
    listing = "; ".join(f"'{n}' ({_machine_where(m)})" for n, m in zip(conv.names, conv.machines))
    return Problem(f"the diagram holds {len(conv.machines)} separate machines: {listing}", conv.diagram.name,
                   line=1, column=1,
                   hint=hint or "convert one with `fsmctl convert FILE.uxf --machine NAME`, "
                                "or draw each machine in its own file")


def _machine_where(doc: dict[str, Any]) -> str:
    lay = (doc.get("layout") or {}).get("initial") or {}
    if "x" in lay:
        return f"initial marker at x={lay['x']}, y={lay['y']} (zoom 10)"
    return "diagram"


def convert_file(path: Path) -> Converted:
    return convert_raw(read_raw(path))


def convert_bytes(data: bytes, name: str = "<diagram>") -> Converted:
    from .uxf_source import parse_raw

    return convert_raw(parse_raw(data, name))


def convert_raw(raw: RawDiagram) -> Converted:
    builder = _Builder(raw)
    builder.run()
    if builder.problems:
        raise DiagramError(sorted(builder.problems, key=lambda p: (p.line or 0, p.column or 0)))
    return Converted(raw, builder.docs, builder.names, builder.origins)


# -- building -------------------------------------------------------------------------------------------------
@dataclass(eq=False)
class _State:
    box: Box
    id: str = ""
    alias: str | None = None
    type: str | None = None
    params: dict[str, Any] = field(default_factory=dict)
    raw_values: dict[str, str] = field(default_factory=dict)
    description: str | None = None
    composite: bool = False


@dataclass(eq=False)
class _Level:
    """One machine level: the boxes directly inside a container (or at the top)."""

    owner: Box | None
    states: list[_State] = field(default_factory=list)
    initials: list[Box] = field(default_factory=list)
    transitions: list[dict[str, Any]] = field(default_factory=list)
    trans_origin: list[RawElement | None] = field(default_factory=list)
    initial_target: _State | None = None
    finals_by_outcome: dict[str, _State] = field(default_factory=dict)
    extra_states: list[dict[str, Any]] = field(default_factory=list)


class _Builder:
    def __init__(self, raw: RawDiagram) -> None:
        self.raw = raw
        self.name = raw.name
        self.problems: list[Problem] = []
        self.docs: list[dict[str, Any]] = []
        self.names: list[str] = []
        self.origins: list[dict[str, RawElement]] = []
        self.scale = 10.0 / raw.zoom
        self.boxes: list[Box] = []
        self.relations: list[RawElement] = []
        self.state_of: dict[int, _State] = {}  # id(box) -> state
        self.levels: dict[int, _Level] = {}  # id(owner box) or 0 -> level
        self._registry: Any = None
        self._initial_used: set[int] = set()
        self._pending_enter: dict[int, Any] = {}
        self._marker_targets: dict[int, _State] = {}
        self._marker_points: dict[int, Any] = {}
        self._marker_rel: dict[int, RawElement] = {}

    # -- problems -------------------------------------------------------------------------------------------
    def problem(self, elem: RawElement | None, message: str, hint: str | None = None) -> None:
        if elem is None:
            self.problems.append(Problem(message, self.name, hint=hint))
            return
        self.problems.append(Problem(message, self.name, pointer=elem.pointer or "", line=elem.line,
                                     column=elem.column, element=describe(elem), hint=hint))

    # -- steps ----------------------------------------------------------------------------------------------
    def run(self) -> None:
        self.classify()
        nest(self.boxes)
        self.read_states()
        attached = self.attach()
        self.make_levels()
        self.resolve(attached)
        self.emit()

    def classify(self) -> None:
        s = self.scale
        for elem in self.raw.elements:
            kind = elem.kind
            role = None
            if kind in _STATE_KINDS_NEW or (elem.old and kind in _STATE_KINDS_OLD):
                role = "state"
            elif kind in _FRAME_KINDS:
                role = "frame"
            elif kind == "UMLSpecialState":
                special, _ = T.special_kind(elem.text)
                role = special if special in _SUPPORTED_SPECIAL else "unsupported"
            elif elem.old and kind in _SPECIAL_OLD:
                special = _SPECIAL_OLD[kind]
                role = special if special in _SUPPORTED_SPECIAL else "unsupported"
            elif kind == "Relation":
                self.relations.append(elem)
                continue
            if role is None:
                continue  # notes, texts, class boxes: not part of a state machine
            if elem.old:
                box = Box(elem, role, elem.x * s, elem.y * s, elem.w * s, elem.h * s)
            else:  # NewGridElement.getRealRectangle: val * 10 / gridSize in integer arithmetic
                box = Box(elem, role, float(int(elem.x * s)), float(int(elem.y * s)), float(int(elem.w * s)),
                          float(int(elem.h * s)))
            box.container = role in ("state", "frame")
            self.boxes.append(box)
            if role == "unsupported":
                special = T.special_kind(elem.text)[0] if kind == "UMLSpecialState" else _SPECIAL_OLD[kind]
                self.problem(elem, f"'{special}' pseudostates are not supported",
                             hint="use states and transitions with guards (types) instead; "
                                  "only type=initial and type=final are understood")

    def registry(self) -> Any:
        if self._registry is None:
            from fsm.registry import default_registry

            self._registry = default_registry()
        return self._registry

    def read_states(self) -> None:
        for box in self.boxes:
            elem = box.elem
            if box.role in ("state", "frame"):
                st = _State(box)
                if box.role == "frame":
                    title = []
                    for ln in elem.text.split("\n"):
                        if T.SEPARATOR.match(ln):
                            break
                        if not T.is_style(ln) and ln.strip():
                            title.append(ln.strip())
                    st.id = " ".join(title)
                else:
                    try:
                        text = T.parse_state(elem.text)
                    except T.TextError as exc:
                        self.problem(elem, str(exc))
                        continue
                    st.id = text.name
                    st.description = text.description
                    if text.params is not None:
                        params = dict(text.params)
                        alias = params.pop("id", None)
                        if alias is not None:
                            st.alias = str(alias)
                            if not st.id:
                                st.id = str(alias)
                        typ = params.pop("type", None)
                        if not isinstance(typ, str) or not typ:
                            self.problem(elem, f"'type' must be a type name, got {typ!r}",
                                         hint="see `fsmctl types` for the state types")
                            continue
                        st.type = typ
                        st.params = params
                        if text.syntax == "kv":
                            st.params = self.coerce_kv("state", typ, params, elem)
                self.state_of[id(box)] = st
            elif box.role == "final":
                st = _State(box, type="Final")
                if elem.kind == "UMLSpecialState":
                    _, label = T.special_kind(elem.text)
                else:
                    label = " ".join(ln.strip() for ln in elem.text.split("\n")
                                     if ln.strip() and not T.is_style(ln))
                if label:
                    st.params = {"outcome": label}
                self.state_of[id(box)] = st

    def coerce_kv(self, kind: str, typ: str, params: dict[str, Any], elem: RawElement) -> dict[str, Any]:
        """``key=value`` texts: a value that looks like a number stays text where the parameter is text."""
        reg = self.registry()
        cls = (reg.states if kind == "state" else reg.transitions).get(typ)
        if cls is None:
            return params
        text_fields = _text_fields(cls.Params)
        out = {}
        for k, v in params.items():
            if k in text_fields and not isinstance(v, str) and not isinstance(v, (dict, list)):
                v = _json_text(v)
            out[k] = v
        return out

    # -- relations ------------------------------------------------------------------------------------------
    def attach(self) -> list[tuple[RawElement, T.RelationText, Box | None, Box | None, list[list[float]]]]:
        attacher = Attacher(self.boxes)
        out = []
        s = self.scale
        for elem in self.relations:
            rel = T.parse_relation(elem.text)
            if not (rel.start_head or rel.end_head):
                continue  # plain lines and note anchors (lt=.) are not transitions
            if rel.start_head and rel.end_head:
                self.problem(elem, f"arrowheads at both ends (lt={rel.lt}): which way does the transition go?",
                             hint="use lt=-> or lt=<-")
                continue
            pts = elem.points
            if not pts or len(pts) < 4:
                n = 0 if not pts else len(pts) // 2
                self.problem(elem, f"a relation needs at least two points, this one has {n}",
                             hint="draw the arrow again in UMLet")
                continue
            if elem.old:  # integers at the stored zoom, relative to the origin
                absolute = [[(elem.x + pts[i]) * s, (elem.y + pts[i + 1]) * s] for i in range(0, len(pts), 2)]
                probes = [tuple(p) for p in absolute]
            else:  # relative to the origin, stored at zoom 10 whatever zoom_level says
                ox, oy = int(elem.x * s), int(elem.y * s)
                absolute = [[ox + pts[i], oy + pts[i + 1]] for i in range(0, len(pts), 2)]
                # Stickables.getAbsolutePosition: realRectangle.x + (int) px
                probes = [(ox + int(pts[i]), oy + int(pts[i + 1])) for i in range(0, len(pts), 2)]
            if rel.start_head:
                absolute.reverse()
                probes.reverse()
            ends = []
            for probe, point in ((probes[0], absolute[0]), (probes[-1], absolute[-1])):
                ends.append((attacher.attach(probe[0], probe[1], elem.old), point))
            src_box = self.check_end(elem, ends[0], "source", attacher)
            dst_box = self.check_end(elem, ends[1], "target", attacher)
            out.append((elem, rel, src_box, dst_box, [[_num(x), _num(y)] for x, y in absolute]))
        return out

    def check_end(self, elem: RawElement, end: Any, role: str, attacher: Attacher) -> Box | None | bool:
        a, point = end
        if a.box is not None:
            return a.box
        stored = f"x={_num(point[0] / self.scale)}, y={_num(point[1] / self.scale)}"
        if a.rule == "ambiguous":
            names = " and ".join(self.box_name(b) for b in a.others)
            self.problem(elem, f"{role} end at {stored} is as close to {names}: ambiguous",
                         hint="move the end onto one of the borders")
            return False
        return None  # unattached: decided later (a TRAL label may name the state)

    def box_name(self, box: Box) -> str:
        st = self.state_of.get(id(box))
        if box.role == "initial":
            return f"the initial pseudostate at {where(box.elem)}"
        if st is not None and st.id:
            return f"'{st.id}'"
        return f"{box.elem.kind} at {where(box.elem)}"

    # -- levels ---------------------------------------------------------------------------------------------
    def make_levels(self) -> None:
        self.levels[0] = _Level(None)
        for box in self.boxes:
            if box.container and box.children:
                self.levels[id(box)] = _Level(box)
        for box in self.boxes:
            level = self.level_of(box)
            if box.role == "initial":
                level.initials.append(box)
            elif box.role in ("state", "frame", "final"):
                st = self.state_of.get(id(box))
                if st is not None:
                    level.states.append(st)
                    if box.children and box.container:
                        st.composite = True

        for level in self.levels.values():  # final states: id from the outcome label, unique in their level
            taken = {st.id for st in level.states if st.box.role != "final"}
            for st in level.states:
                if st.box.role == "final":
                    base = st.params.get("outcome") or "final"
                    fid, n = base, 2
                    while fid in taken:
                        fid = f"{base} ({n})"
                        n += 1
                    st.id = fid
                    taken.add(fid)

    def level_of(self, box: Box) -> _Level:
        return self.levels[id(box.parent)] if box.parent is not None else self.levels[0]

    def container_chain(self, box: Box) -> list[Box | None]:
        chain: list[Box | None] = []
        node = box.parent
        while node is not None:
            chain.append(node)
            node = node.parent
        chain.append(None)
        return chain

    def resolve(self, attached: list[Any]) -> None:
        self.machine_frames: set[int] = set()
        touched: set[int] = set()
        for _, _, a, b, _ in attached:
            for box in (a, b):
                if isinstance(box, Box):
                    touched.add(id(box))
        for box in self.boxes:
            if box.role == "frame" and box.parent is None and id(box) not in touched:
                self.machine_frames.add(id(box))
        # initial markers first: entering a composite checks which state each level starts in
        first = [r for r in attached if isinstance(r[2], Box) and r[2].role == "initial"]
        rest = [r for r in attached if not (isinstance(r[2], Box) and r[2].role == "initial")]
        for elem, rel, src, dst, points in first + rest:
            self.relation(elem, rel, src, dst, points)
        for box in self.boxes:
            if box.role == "initial" and id(box) not in self._initial_used:
                self.problem(box.elem, "initial pseudostate has no transition to a state",
                             hint="draw an arrow from it to the first state of its machine")

    def relation(self, elem: RawElement, rel: T.RelationText, src: Any, dst: Any, points: list[Any]) -> None:
        if src is False or dst is False:
            return  # ambiguous: reported
        try:
            label = T.parse_label(rel.label_lines)
        except T.TextError as exc:
            self.problem(elem, f"label: {exc}")
            return
        params = dict(label.params) if label.params is not None else None
        explicit: dict[str, Any] = {}
        if params is not None:
            for key in ("from", "to"):
                if key in params:
                    explicit[key] = params.pop(key)
            params.pop("id", None)
        ends = []
        for box, key, role in ((src, "from", "source"), (dst, "to", "target")):
            if key in explicit:
                named = self.find_state(explicit[key])
                if named is None:
                    self.problem(elem, f"'{key}': {explicit[key]!r} names no state of the diagram")
                    return
                if box is not None and box is not named.box:
                    self.problem(elem, f"'{key}' in the label names '{named.id}' but the arrow's {role} end is "
                                       f"attached to {self.box_name(box)}",
                                 hint=f"remove '{key}' from the label or move the arrow")
                    return
                box = named.box
            if box is None:
                ends.append(None)
            else:
                ends.append(box)
        if ends[0] is None or ends[1] is None:
            for box, i, role in ((ends[0], 0, "source"), (ends[1], -1, "target")):
                if box is None:
                    self.dangling(elem, points[i], role)
            return
        src, dst = ends
        if dst.role == "initial":
            self.problem(elem, "a transition may not end at an initial pseudostate",
                         hint="an initial pseudostate only starts its machine; end the arrow at a state "
                              "(a final state ends the machine)")
            return
        if src.role == "initial":
            self.initial(elem, src, dst, points)
            return
        if src.role == "unsupported" or dst.role == "unsupported":
            return  # the pseudostate is reported
        s_state = self.state_of.get(id(src))
        d_state = self.state_of.get(id(dst))
        if s_state is None or d_state is None:
            return  # their text did not parse: reported
        if id(src) in self.machine_frames or id(dst) in self.machine_frames:
            return
        self.transition(elem, s_state, d_state, params, label, points)

    def dangling(self, elem: RawElement, point: list[Any], role: str) -> None:
        stored = f"x={_num(point[0] / self.scale)}, y={_num(point[1] / self.scale)}"
        hint = ("move the arrow's end onto a state's border (UMLet sticks ends closer than 9 px at 100% zoom)")
        if len([p for p in self.problems if "attached to nothing" in p.message]) < 50:
            box, d = Attacher(self.boxes).nearest(point[0], point[1]) if self.boxes else (None, math.inf)
            if box is not None:
                hint = f"nearest is {self.box_name(box)}, {_num(round(d, 1))} px away at zoom 10; " + hint
        self.problem(elem, f"{role} end at {stored} is attached to nothing", hint=hint)

    def find_state(self, ref: Any) -> _State | None:
        if not isinstance(ref, (str, int)) or isinstance(ref, bool):
            return None
        key = str(ref)
        matches = [st for st in self.state_of.values() if st.alias == key] or \
                  [st for st in self.state_of.values() if st.id == key]
        return matches[0] if len(matches) == 1 else None

    def initial(self, elem: RawElement, marker: Box, dst: Box, points: list[Any]) -> None:
        level = self.level_of(marker)
        if id(marker) in self._initial_used:
            self.problem(elem, "a second transition out of the same initial pseudostate",
                         hint="an initial pseudostate has exactly one outgoing transition")
            return
        self._initial_used.add(id(marker))
        target = self.state_of.get(id(dst))
        if target is None:
            return
        if dst.parent is not marker.parent:
            self.problem(elem, f"the initial pseudostate and its target '{target.id}' are not in the same machine",
                         hint="put the initial pseudostate inside the same box as the state it starts")
            return
        level.initial_target = target
        self._marker_targets[id(marker)] = target
        self._marker_points[id(marker)] = points
        self._marker_rel[id(marker)] = elem

    def transition(self, elem: RawElement, s: _State, d: _State, params: dict[str, Any] | None,
                   label: T.Label, points: list[Any]) -> None:
        src, dst = s.box, d.box
        s_chain = self.container_chain(src)
        d_chain = self.container_chain(dst)
        d_set = {id(c) for c in d_chain}
        common = next(c for c in s_chain if id(c) in d_set)
        # enter: the target must be reached through initial states from the common level
        target = d
        node = dst
        while node.parent is not common:
            owner = node.parent
            assert owner is not None
            lvl = self.levels[id(owner)]
            if lvl.initial_target is not None and lvl.initial_target.box is node:
                node = owner
                target = self.state_of[id(owner)]
            else:
                self._pending_enter.setdefault(id(elem), (elem, node, owner))
                return
        if src.parent is common:
            self.add_transition(self.level_of(src), s, target, params, label, points, elem)
            return
        # exit: an inner state leaves its composite(s): Final in each level, Finished one level up
        outcome = f"exit to {target.id}"
        node = src
        first = True
        current = s
        while node.parent is not common:
            owner = node.parent
            assert owner is not None
            lvl = self.levels[id(owner)]
            final = lvl.finals_by_outcome.get(outcome)
            if final is None:
                taken = {st.id for st in lvl.states} | {f.id for f in lvl.finals_by_outcome.values()}
                fid = outcome
                n = 2
                while fid in taken:
                    fid = f"{outcome} ({n})"
                    n += 1
                final = _State(Box(elem, "final", 0, 0, 0, 0), id=fid, type="Final", params={"outcome": outcome})
                lvl.finals_by_outcome[outcome] = final
            if first:
                self.add_transition(lvl, current, final, params, label, points, elem)
                first = False
            else:
                self.add_transition(lvl, current, final, {"type": "Finished", "outcome": outcome},
                                    T.Label(None, ""), None, None)
            current = self.state_of[id(owner)]
            node = owner
        self.add_transition(self.level_of(node), current, target, {"type": "Finished", "outcome": outcome},
                            T.Label(None, ""), None, None)

    def add_transition(self, level: _Level, s: _State, d: _State, params: dict[str, Any] | None, label: T.Label,
                       points: list[Any] | None, elem: RawElement | None) -> None:
        tr: dict[str, Any] = {}
        if params is not None:
            typ = params.pop("type", None) if "type" in params else None
            if not isinstance(typ, str) or not typ:
                self.problem(elem, f"'type' must be a transition type name, got {typ!r}",
                             hint="see `fsmctl types` for the transition types")
                return
            if label.syntax == "kv" and elem is not None:
                params = self.coerce_kv("transition", typ, params, elem)
            tr = {"type": typ, "from": "", "to": "", **params}
        elif label.text:
            tr = {"type": "Signal", "from": "", "to": "", "signal": T.event_name(label.text), "label": label.text}
        else:
            tr = {"type": "_completion", "from": "", "to": ""}
        tr["_from"], tr["_to"] = s, d
        if points is not None:
            tr["layout"] = {"points": points}
        level.transitions.append(tr)
        level.trans_origin.append(elem)

    # -- output ---------------------------------------------------------------------------------------------
    def emit(self) -> None:
        for elem, node, owner in self._pending_enter.values():
            st = self.state_of.get(id(node))
            ow = self.state_of.get(id(owner))
            self.problem(elem, f"the arrow enters '{st.id if st else '?'}' inside composite "
                               f"'{ow.id if ow else '?'}', which is not its initial state",
                         hint="end the arrow at the composite's border and start the composite with an initial "
                              "pseudostate pointing to that state")
        top = self.levels[0]
        machines = self.split_top(top)
        for name, states, initials, frame in machines:
            origins: dict[str, RawElement] = {}
            doc = self.machine_doc(top, states, initials, "", origins, frame)
            if doc is None:
                continue
            base_name, n = name, 2
            while name in self.names:
                name = f"{base_name} ({n})"
                n += 1
            doc_named = {"name": name, **doc}
            self.docs.append(doc_named)
            self.names.append(name)
            self.origins.append(origins)

    def split_top(self, top: _Level) -> list[tuple[str, list[_State], list[Box], Box | None]]:
        """Top-level machines: a frame that nothing attaches to holds one; else connected parts with an initial."""
        stem = Path(self.name).stem
        frames = [st for st in top.states if id(st.box) in self.machine_frames]
        plain = [st for st in top.states if id(st.box) not in self.machine_frames]
        out: list[tuple[str, list[_State], list[Box], Box | None]] = []
        for fr in frames:
            lvl = self.levels.get(id(fr.box))
            if lvl is None:
                continue
            out.append((fr.id or stem, lvl.states, lvl.initials, fr.box))
        if not plain and not top.initials:
            return out
        if len(top.initials) <= 1:
            out.insert(0, (stem, plain, top.initials, None))
            return out
        # several initial markers at the top: connected components
        parent: dict[int, int] = {}

        def find(k: int) -> int:
            while parent.setdefault(k, k) != k:
                parent[k] = parent[parent[k]]
                k = parent[k]
            return k

        for tr in top.transitions:
            a, b = find(id(tr["_from"])), find(id(tr["_to"]))
            if a != b:
                parent[a] = b
        comps: dict[int, list[_State]] = {}
        for st in plain:
            comps.setdefault(find(id(st)), []).append(st)
        marker_of: dict[int, list[Box]] = {}
        for m in top.initials:
            tgt = self._marker_targets.get(id(m))
            if tgt is not None:
                marker_of.setdefault(find(id(tgt)), []).append(m)
        for root, states in comps.items():
            markers = marker_of.get(root, [])
            if not markers:
                names = ", ".join(f"'{st.id}'" for st in states[:5]) + (", ..." if len(states) > 5 else "")
                self.problem(states[0].box.elem, f"states {names} belong to none of the diagram's machines "
                                                 "(no initial pseudostate leads to them)",
                             hint="connect them, or draw them in another file")
                continue
            first = self._marker_targets[id(markers[0])]
            out.append((first.id, states, markers, None))
        return out

    def machine_doc(self, level: _Level, states: list[_State], initials: list[Box], base: str,
                    origins: dict[str, RawElement], frame: Box | None = None) -> dict[str, Any] | None:
        owner_elem = level.owner.elem if level.owner is not None else None
        where_elem = frame.elem if frame is not None else owner_elem
        # initial state
        targets = [(m, self._marker_targets.get(id(m))) for m in initials]
        targets = [(m, t) for m, t in targets if t is not None and t in states]
        initial_id: str | None = None
        layout: dict[str, Any] = {}
        if len(targets) > 1:
            listing = ", ".join(f"at {where(m.elem)}" for m, _ in targets)
            self.problem(targets[1][0].elem, f"{len(targets)} initial pseudostates in one machine ({listing})",
                         hint="keep one initial pseudostate per machine level")
        elif targets:
            marker, tgt = targets[0]
            initial_id = tgt.id
            layout["initial"] = {**self.box_layout(marker), "points": self._marker_points[id(marker)]}
            origins[base + "/initial"] = self._marker_rel[id(marker)]
        elif len(states) == 1:
            initial_id = states[0].id
        else:
            what = f"composite '{self.state_of[id(level.owner)].id}'" if level.owner is not None else "the diagram"
            elem = where_elem or (states[0].box.elem if states else None)
            self.problem(elem, f"{what} has no initial state: no initial pseudostate with an arrow to a state",
                         hint="draw a UMLSpecialState with type=initial and an arrow to the first state")
        if frame is not None:
            layout["frame"] = {**self.box_layout(frame), "title": self.state_of[id(frame)].id}
        # states
        seen: dict[str, _State] = {}
        out_states: list[dict[str, Any]] = []
        all_states = list(states)
        own_level = self.levels.get(id(level.owner)) if level.owner is not None else None
        if frame is not None:
            own_level = self.levels.get(id(frame))
        finals = list((own_level or level).finals_by_outcome.values())
        for st in all_states + finals:
            if not st.id:
                self.problem(st.box.elem, "state box has no name",
                             hint="write the state's name on the first line of the box")
                continue
            if st.id in seen:
                first = seen[st.id]
                self.problem(st.box.elem, f"duplicate state name '{st.id}' in one machine (also at "
                                          f"{where(first.box.elem)})",
                             hint="names are ids: rename one of the boxes")
                continue
            if "/" in st.id:
                self.problem(st.box.elem, f"state name '{st.id}' contains '/', which separates state paths",
                             hint="rename the box")
                continue
            seen[st.id] = st
            ptr = f"{base}/states/{len(out_states)}"
            if st not in finals:
                origins[ptr] = st.box.elem
            out_states.append(self.state_doc(st, ptr, origins))
        # transitions: those whose source is one of these states
        ids = {id(st) for st in all_states + finals}
        lvl = own_level or level
        out_trans: list[dict[str, Any]] = []
        for tr, elem in zip(lvl.transitions, lvl.trans_origin):
            if id(tr["_from"]) not in ids:
                continue
            doc = {k: v for k, v in tr.items() if not k.startswith("_")}
            doc["from"], doc["to"] = tr["_from"].id, tr["_to"].id
            if doc["type"] == "_completion":
                doc["type"] = "Finished" if self.can_finish(tr["_from"]) else "Always"
            ptr = f"{base}/transitions/{len(out_trans)}"
            if elem is not None:
                origins[ptr] = elem
            out_trans.append(_ordered(doc, ("type", "from", "to")))
        doc: dict[str, Any] = {"initial": initial_id or "", "states": out_states, "transitions": out_trans}
        if layout:
            doc["layout"] = layout
        return doc

    def can_finish(self, st: _State) -> bool:
        if st.composite:
            lvl = self.levels.get(id(st.box))
            return bool(lvl and (any(s.box.role == "final" or s.type == "Final" for s in lvl.states)
                                 or lvl.finals_by_outcome))
        cls = self.registry().states.get(st.type or "Idle")
        return bool(cls is not None and cls.can_finish)

    def box_layout(self, box: Box) -> dict[str, Any]:
        return {"x": _num(box.x), "y": _num(box.y), "w": _num(box.w), "h": _num(box.h)}

    def state_doc(self, st: _State, ptr: str, origins: dict[str, RawElement]) -> dict[str, Any]:
        doc: dict[str, Any] = {"id": st.id}
        if st.composite:
            if st.type not in (None, "FSMState"):
                self.problem(st.box.elem, f"a {st.type} state cannot contain other boxes",
                             hint="boxes drawn inside a state form an FSMState's sub-machine; remove type= "
                                  "or move the boxes out")
            if "machine" in st.params:
                self.problem(st.box.elem, "the state both contains boxes and names a 'machine'",
                             hint="draw the sub-machine inside the box or include it with machine=, not both")
            lvl = self.levels[id(st.box)]
            sub = self.machine_doc(lvl, lvl.states, lvl.initials, ptr + "/machine", origins)
            doc["type"] = "FSMState"
            doc.update({k: v for k, v in st.params.items() if k != "machine"})
            doc["machine"] = sub
        else:
            doc["type"] = st.type or "Idle"
            doc.update(st.params)
        if st.description and "description" not in doc:
            doc["description"] = st.description
        if st.box.elem is not None and st.box.w > 0:
            lay = self.box_layout(st.box)
            if st.box.role == "final":
                lay["shape"] = "final"
            elif st.box.role == "frame":
                lay["shape"] = "frame"
            doc["layout"] = lay
        return doc

def _ordered(doc: dict[str, Any], first: tuple[str, ...]) -> dict[str, Any]:
    out = {k: doc[k] for k in first if k in doc}
    out.update((k, v) for k, v in doc.items() if k not in out and k != "layout")
    if "layout" in doc:
        out["layout"] = doc["layout"]
    return out


def _text_fields(model: Any) -> set[str]:
    cache = _TEXT_FIELDS.get(model)
    if cache is None:
        cache = set()
        schema = model.model_json_schema()
        for name, prop in schema.get("properties", {}).items():
            types = {prop.get("type")} if "type" in prop else {p.get("type") for p in prop.get("anyOf", [])}
            if "enum" in prop and all(isinstance(v, str) for v in prop["enum"]):
                types = {"string"}
            types.discard("null")
            if types == {"string"}:
                cache.add(name)
        _TEXT_FIELDS[model] = cache
    return cache


_TEXT_FIELDS: dict[Any, set[str]] = {}


def _json_text(v: Any) -> str:
    import json

    return json.dumps(v) if not isinstance(v, str) else v


register_reader(".uxf", read_uxf)
