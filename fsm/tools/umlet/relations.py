"""Relations of a UMLet diagram -> transitions and initial states of the machine levels of a :class:`Scene`.

An arrow's ends attach geometrically (:class:`fsm.tools.umlet.geometry.Attacher`); its direction comes from the
arrowhead. An arrow from an initial pseudostate starts its level. An arrow between levels enters a composite
through the initial states of the levels on the way (else it is an error), and leaves a composite through
generated ``Final`` states (outcome ``exit to TARGET``) and ``Finished`` transitions, one per level. Arrows do
not cross the frame of a ``Parallel`` state's region: a region is left through a Final state.
"""

from __future__ import annotations

from typing import Any, NamedTuple

from . import text as T
from .geometry import LENIENT, Attacher, Attachment, Box
from .scene import Level, Marker, Scene, StateBox
from .source import RawElement, describe, num, where


class Attached(NamedTuple):
    """An arrow with its ends attached: the element, its label, the source and target (a box, ``None`` when
    attached to nothing, ``False`` when ambiguous) and its points."""

    elem: RawElement
    rel: T.RelationText
    src: Any
    dst: Any
    points: list[list[Any]]


class Relations:
    """Resolves the relations of ``scene`` into its levels' transitions and initial markers."""

    def __init__(self, scene: Scene) -> None:
        self.scene = scene
        self.problem = scene.problem
        self.attacher = Attacher([b for b in scene.boxes if b.role != "note"])
        #: Notes (comments and machine notes): UMLet sticks arrows to them like to any box.
        self.notes = Attacher([b for b in scene.boxes if b.role == "note"] + scene.comment_notes)
        self._initial_used: set[int] = set()
        self._pending_enter: dict[int, Any] = {}

    def run(self) -> None:
        self.resolve(self.attach())
        for elem, node, owner in self._pending_enter.values():
            st = self.scene.state_of.get(id(node))
            ow = self.scene.state_of.get(id(owner))
            self.problem(elem, f"the arrow enters '{st.id if st else '?'}' inside composite "
                               f"'{ow.id if ow else '?'}', which is not its initial state",
                         hint="end the arrow at the composite's border and start the composite with an initial "
                              "pseudostate pointing to that state")

    # -- endpoints ------------------------------------------------------------------------------------------
    def attach(self) -> list[Attached]:
        """Each arrow (a relation with one arrowhead) with the boxes its ends stick to, source first."""
        out = []
        for elem in self.scene.relations:
            rel = T.parse_relation(elem.text)
            if rel.start_head == rel.end_head:  # no arrowhead (plain lines, note anchors lt=.), or two
                if rel.start_head:
                    self.problem(elem, f"arrowheads at both ends (lt={rel.lt}): which way does the transition go?",
                                 hint="use lt=-> or lt=<-")
                continue
            found = self._points(elem, rel)
            if found is None:
                continue
            absolute, probes = found
            ends = []
            for probe, point in ((probes[0], absolute[0]), (probes[-1], absolute[-1])):
                ends.append((self.attacher.attach(probe[0], probe[1], elem.old), point))
            if self.at_note(elem, rel, ends, (probes[0], probes[-1])):
                continue
            src_box = self.check_end(elem, ends[0], "source")
            dst_box = self.check_end(elem, ends[1], "target")
            out.append(Attached(elem, rel, src_box, dst_box, [[num(x), num(y)] for x, y in absolute]))
        return out

    def _points(self, elem: RawElement, rel: T.RelationText) -> tuple[list[list[Any]], list[tuple[Any, ...]]] | None:
        """An arrow's points in the scene, source first, and where UMLet probes for the box each point sticks to;
        ``None`` (said) for an arrow of fewer than two points."""
        pts, s = elem.points or [], self.scene.scale
        if len(pts) < 4:
            self.problem(elem, f"a relation needs at least two points, this one has {len(pts) // 2}",
                         hint="draw the arrow again in UMLet")
            return None
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
        return absolute, probes

    def at_note(self, elem: RawElement, rel: T.RelationText, ends: list[Any], probes: Any) -> bool:
        """Whether an end that attaches to no state attaches to a note: a dashed arrow is then the note's anchor
        (ignored); a solid one is an error."""
        for (a, point), probe, role in zip(ends, probes, ("source", "target"), strict=True):
            if a.box is not None or a.rule == "ambiguous":
                continue
            found = self.notes.attach(probe[0], probe[1], elem.old)
            note = found.box or next(iter(found.others), None)
            if note is None:
                continue
            if not rel.dashed:
                label = note.elem.first_line
                what = f"the note '{label if len(label) <= 30 else label[:27] + '...'}'" if label else "a note"
                self.problem(elem, f"{role} end at {self.stored(point)} is attached to {what} at "
                                   f"{where(note.elem)}: a note is no state",
                             hint="draw a note's anchor dashed (lt=. or lt=.>), or end the arrow at a state's "
                                  "border")
            return True
        return False

    def stored(self, point: list[Any]) -> str:
        """A point at zoom 10 in the file's pixels."""
        return f"x={num(point[0] / self.scene.scale)}, y={num(point[1] / self.scene.scale)}"

    def check_end(self, elem: RawElement, end: tuple[Attachment, list[Any]], role: str) -> Box | None | bool:
        a, point = end
        if a.box is not None:
            return a.box
        stored = self.stored(point)
        if a.rule == "ambiguous":
            names = " and ".join(self.scene.box_name(b) for b in a.others)
            self.problem(elem, f"{role} end at {stored} is as close to {names}: ambiguous",
                         hint="move the end onto one of the borders")
            return False
        return None  # unattached: decided later (a TRAL label may name the state)

    def dangling(self, elem: RawElement, point: list[Any], role: str) -> None:
        stored = self.stored(point)
        ignored = self.ignored_at(point)
        if ignored is not None:
            box, reason = ignored
            hint = ("draw the state as a UMLState box (from the palette)" if box.w > 0 and box.h > 0
                    else "give the box a size in UMLet (drag its corner), or delete it")
            self.problem(elem, f"{role} end at {stored} ends at {describe(box.elem)}, which is ignored: {reason}",
                         hint=hint)
            return
        hint = "move the arrow's end onto a state's border (UMLet sticks ends closer than 9 px at 100% zoom)"
        if sum("attached to nothing" in p.message for p in self.scene.problems) < 50:
            near, d = self.attacher.nearest(point[0], point[1])
            if near is not None:
                hint = f"nearest is {self.scene.box_name(near)}, {num(round(d, 1))} px away at zoom 10; " + hint
        self.problem(elem, f"{role} end at {stored} is attached to nothing", hint=hint)

    def ignored_at(self, point: list[Any]) -> tuple[Box, str] | None:
        """The ignored box (class box, zero-size box, ...) an arrow's end lies on or next to, the smallest (the
        innermost) first, with the reason it is ignored."""
        hits = [(box, reason) for box, reason in self.scene.ignored
                if (at := box.border_distance(point[0], point[1]))[1] or at[0] <= LENIENT]
        return min(hits, key=lambda hit: hit[0].w * hit[0].h, default=None)

    # -- relations ------------------------------------------------------------------------------------------
    def resolve(self, attached: list[Attached]) -> None:
        self.mark_machine_frames(attached)
        # initial markers first (a stable sort): entering a composite checks which state each level starts in
        for elem, rel, src, dst, points in sorted(attached, key=lambda r: not _from_initial(r)):
            self.relation(elem, rel, src, dst, points)
        for box in self.scene.boxes:
            if box.role == "initial" and id(box) not in self._initial_used:
                self.problem(box.elem, "initial pseudostate has no transition to a state",
                             hint="draw an arrow from it to the first state of its machine")

    def mark_machine_frames(self, attached: list[Attached]) -> None:
        """A top-level frame no arrow touches is a machine's frame, not a state."""
        touched = {id(box) for r in attached for box in (r.src, r.dst)}  # None, False: no box's id
        self.scene.machine_frames.update(id(box) for box in self.scene.boxes
                                         if box.role == "frame" and box.parent is None and id(box) not in touched)

    def relation(self, elem: RawElement, rel: T.RelationText, src: Any, dst: Any, points: list[Any]) -> None:
        """An arrow with its attached ends: a transition, an initial marker's arrow, or a problem said."""
        if src is False or dst is False:
            return  # ambiguous: reported
        try:
            label = T.parse_label(rel.label_lines)
        except T.TextError as exc:
            self.problem(elem, f"label: {exc}", hint=exc.hint)
            return
        params, explicit = _label_ends(label)
        ends = self.named_ends(elem, src, dst, explicit)
        if ends is None:
            return
        source, target = ends
        if source is None or target is None:
            self.unattached(elem, source, target, points)
            return
        if not self.ends_allowed(elem, source, target):
            return
        if source.role == "initial":
            self.initial(elem, source, target, points)
            return
        states = self._states_of(source, target)
        if states is not None:
            self.transition(elem, *states, params, label, points)

    def _states_of(self, source: Box, target: Box) -> tuple[StateBox, StateBox] | None:
        """The states a transition joins; ``None`` where none is drawn: an unsupported pseudostate (said), a box
        whose text did not parse (said), a machine's frame."""
        scene = self.scene
        if "unsupported" in (source.role, target.role) or \
                id(source) in scene.machine_frames or id(target) in scene.machine_frames:
            return None
        s_state, d_state = scene.state_of.get(id(source)), scene.state_of.get(id(target))
        return None if s_state is None or d_state is None else (s_state, d_state)

    def named_ends(self, elem: RawElement, src: Box | None, dst: Box | None,
                   explicit: dict[str, Any]) -> tuple[Box | None, Box | None] | None:
        """The ends' boxes, as attached or as the label's ``from``/``to`` name them (``None``: a problem said)."""
        ends: list[Box | None] = []
        for box, key, role in ((src, "from", "source"), (dst, "to", "target")):
            if key in explicit:
                named = self.find_state(explicit[key])
                if named is None:
                    self.problem(elem, f"'{key}': {explicit[key]!r} names no state of the diagram")
                    return None
                if box is not None and box is not named.box:
                    self.problem(elem, f"'{key}' in the label names '{named.id}' but the arrow's {role} end is "
                                       f"attached to {self.scene.box_name(box)}",
                                 hint=f"remove '{key}' from the label or move the arrow")
                    return None
                box = named.box
            ends.append(box)
        return ends[0], ends[1]

    def unattached(self, elem: RawElement, source: Box | None, target: Box | None, points: list[Any]) -> None:
        """An arrow with an end attached to nothing: said at that end."""
        for box, i, role in ((source, 0, "source"), (target, -1, "target")):
            if box is None:
                self.dangling(elem, points[i], role)
        if source is not None and source.role == "initial":
            # the marker's arrow is reported where it dangles; its machine does have an initial marker
            self._initial_used.add(id(source))
            self.scene.broken_markers.add(id(source))

    def ends_allowed(self, elem: RawElement, source: Box, target: Box) -> bool:
        """No arrow ends at an initial marker or at a region's frame."""
        scene = self.scene
        if target.role == "initial":
            self.problem(elem, "a transition may not end at an initial pseudostate",
                         hint="an initial pseudostate only starts its machine; end the arrow at a state "
                              "(a final state ends the machine)")
            return False
        for box in (source, target):
            if id(box) in scene.region_frames:
                self.problem(elem, f"the arrow ends at {scene.box_name(box)} of Parallel "
                                   f"'{scene.state_of[id(box.parent)].id}': a region is not a state",
                             hint="arrows go between the states inside one region, or to and from the Parallel "
                                  "state's own border")
                return False
        return True

    def find_state(self, ref: Any) -> StateBox | None:
        if not isinstance(ref, (str, int)) or isinstance(ref, bool):
            return None
        key = str(ref)
        states = self.scene.state_of.values()
        matches = [st for st in states if st.alias == key] or [st for st in states if st.id == key]
        return matches[0] if len(matches) == 1 else None

    def initial(self, elem: RawElement, marker: Box, dst: Box, points: list[Any]) -> None:
        scene = self.scene
        level = scene.level_of(marker)
        if id(marker) in self._initial_used:
            self.problem(elem, "a second transition out of the same initial pseudostate",
                         hint="an initial pseudostate has exactly one outgoing transition")
            return
        self._initial_used.add(id(marker))
        target = scene.state_of.get(id(dst))
        if target is None:  # its text did not read: reported; the machine does have an initial marker
            scene.broken_markers.add(id(marker))
            return
        if dst.parent is not marker.parent:
            self.problem(elem, f"the initial pseudostate and its target '{target.id}' are not in the same machine",
                         hint="put the initial pseudostate inside the same box as the state it starts")
            return
        level.initial_target = target
        scene.markers[id(marker)] = Marker(target, points, elem)

    def transition(self, elem: RawElement, s: StateBox, d: StateBox, params: dict[str, Any] | None,
                   label: T.Label, points: list[Any]) -> None:
        scene = self.scene
        # the composites each end is drawn in, innermost first, up to the level both are drawn in
        s_chain = scene.container_chain(s.box)
        d_chain = scene.container_chain(d.box)
        common = next(c for c in s_chain if c in d_chain)
        s_chain, d_chain = s_chain[:s_chain.index(common)], d_chain[:d_chain.index(common)]
        if self.crosses_region(elem, s_chain, d_chain):
            return
        target = self.entry_target(elem, d, d_chain)
        if target is None:
            return
        # an inner state leaves its composite(s): the drawn arrow's transition to a Final state of the innermost
        # level, then a Finished transition on its outcome in each level above, up to the common one
        outcome = f"exit to {target.id}"
        current = s
        drawn: tuple[dict[str, Any] | None, T.Label, list[Any] | None, RawElement | None]
        drawn = (params, label, points, elem)
        for owner in s_chain:
            lvl = scene.levels[id(owner)]
            self.add_transition(lvl, current, _exit_final(lvl, outcome, elem), *drawn)
            drawn = ({"type": "Finished", "outcome": outcome}, T.Label(None, ""), None, None)
            current = scene.state_of[id(owner)]
        self.add_transition(scene.level_of(current.box), current, target, *drawn)

    def crosses_region(self, elem: RawElement, s_chain: list[Any], d_chain: list[Any]) -> bool:
        """Whether the arrow leaves or enters a region frame of a Parallel state (said as a problem): ``s_chain``
        and ``d_chain`` are the boxes it leaves and enters."""
        scene = self.scene
        for chain, way in ((s_chain, "leaves"), (d_chain, "enters")):
            for c in chain:
                if id(c) in scene.region_frames:
                    self.problem(elem, f"the arrow {way} {scene.box_name(c)} of Parallel "
                                       f"'{scene.state_of[id(c.parent)].id}'",
                                 hint="a region starts at its own initial pseudostate and ends in a Final state; "
                                      "arrows into or out of the Parallel state end at its border, and Finished "
                                      "transitions route on the regions' outcomes")
                    return True
        return False

    def entry_target(self, elem: RawElement, d: StateBox, d_chain: list[Box | None]) -> StateBox | None:
        """The state an arrow to ``d`` enters at the common level, the composites it enters being ``d_chain``:
        ``d`` must be reached through initial states from there, else the arrow waits (``None``) to be said when
        nothing resolves it."""
        scene = self.scene
        target = d
        for owner in d_chain:
            if scene.levels[id(owner)].initial_target is not target:
                self._pending_enter.setdefault(id(elem), (elem, target.box, owner))
                return None
            target = scene.state_of[id(owner)]
        return target

    def add_transition(self, level: Level, s: StateBox, d: StateBox, params: dict[str, Any] | None, label: T.Label,
                       points: list[Any] | None, elem: RawElement | None) -> None:
        try:
            tr = self.transition_doc(params, label)
        except T.TextError as exc:
            self.problem(elem, str(exc), hint=exc.hint)
            return
        tr["_from"], tr["_to"] = s, d
        if points is not None:
            tr["layout"] = {"points": points}
        level.transitions.append(tr)
        level.trans_origin.append(elem)

    def transition_doc(self, params: dict[str, Any] | None, label: T.Label) -> dict[str, Any]:
        """A relation's transition: of the type its parameters name, else a Signal transition on its UML label's
        event, else a completion; with the label's guard and actions. A TextError says what is wrong."""
        uml = label.uml or label.text
        try:
            event, guard, action = T.split_uml(uml)
            if guard is not None:
                T.check_guard(guard)
            actions = T.parse_actions(action) if action is not None else None
        except T.TextError as exc:
            raise T.TextError(f"label: {exc}", hint="a label is 'event [guard] / name = expression; ...' (see "
                                                    "`fsmctl types` and the expression grammar in the "
                                                    "documentation)") from None
        if params is not None:
            tr = self.typed_transition(params, label, event, {"guard": guard, "set": actions})
        elif event:
            tr = _signal_transition(event, label)
        else:
            tr = {"type": "_completion", "from": "", "to": ""}
        if guard is not None:
            tr["guard"] = guard
        if actions is not None:
            tr["set"] = actions
        return tr

    def typed_transition(self, params: dict[str, Any], label: T.Label, event: str, drawn: dict[str, Any]
                         ) -> dict[str, Any]:
        """A transition whose text gives its type and parameters; ``drawn``: the guard and actions of the
        '[guard] / action' line, which the parameters may not give again."""
        typ = params.pop("type", None)
        if not isinstance(typ, str) or not typ:
            raise T.TextError(f"'type' must be a transition type name, got {typ!r}",
                              hint="see `fsmctl types` for the transition types")
        if label.uml and event:
            raise T.TextError(f"label: the line {label.uml[:40]!r} after the parameters may only hold "
                              "'[guard] / action'; the type is given above it")
        for key, value in drawn.items():
            if value is not None and key in params:
                raise T.TextError(f"label: '{key}' is given both as a parameter and in the '[guard] / action' "
                                  "line", hint="keep one of the two")
        params = self.scene.coerce_kv("transition", typ, params, label.kv_keys)
        return {"type": typ, "from": "", "to": "", **params}


def _signal_transition(event: str, label: T.Label) -> dict[str, Any]:
    """A Signal transition on a UML label's event (which may not look like a parameter: a signal has no '=')."""
    key, eq, value = event.partition("=")
    if eq and key.strip().isidentifier() and value.strip():
        raise T.TextError(f"label: {event!r} looks like a parameter, but the relation has no 'type=' line "
                          "(a signal's name has no '=')",
                          hint=f"add the transition type above it, e.g. 'type=Finished' then '{event.strip()}' "
                               "(see `fsmctl types`)")
    return {"type": "Signal", "from": "", "to": "", "signal": event, "label": label.text}


def _from_initial(r: Attached) -> bool:
    return isinstance(r.src, Box) and r.src.role == "initial"


def _exit_final(lvl: Level, outcome: str, elem: RawElement) -> StateBox:
    """The Final state of ``lvl`` with ``outcome`` (an exit to a state outside), made the first time it is needed
    with an id no state of the level has."""
    final = lvl.finals_by_outcome.get(outcome)
    if final is None:
        taken = {st.id for st in lvl.states} | {f.id for f in lvl.finals_by_outcome.values()}
        final = StateBox(Box(elem, "final", 0, 0, 0, 0), id=T.numbered(outcome, taken), type="Final",
                         params={"outcome": outcome})
        lvl.finals_by_outcome[outcome] = final
    return final


def _label_ends(label: T.Label) -> tuple[dict[str, Any] | None, dict[str, Any]]:
    """A label's parameters without the ``from`` and ``to`` it names (returned apart) and its ``id``."""
    if label.params is None:
        return None, {}
    params = dict(label.params)
    explicit: dict[str, Any] = {key: params.pop(key) for key in ("from", "to") if key in params}
    params.pop("id", None)
    return params, explicit
