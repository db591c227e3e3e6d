"""The machine documents a resolved :class:`fsm.tools.umlet.scene.Scene` stands for.

The top level holds one machine, or several: each top-level ``UMLFrame`` no arrow touches holds one, and
without frames each connected part with its own initial pseudostate is one. A state box with boxes inside is
an ``FSMState`` whose machine is what it holds; a ``Parallel`` box holds one ``UMLFrame`` per region
(frame title = region name; a frame titled ``file=PATH`` is an included region). A ``UMLNote`` whose first line
is ``machine`` gives the keys of the machine it is drawn in (see :mod:`fsm.tools.umlet.reader`). Every document keeps
the positions of its boxes under ``layout`` and, per JSON pointer, the element it came from (for messages).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

from . import text as T
from .geometry import Box
from .scene import Level, Scene, StateBox
from .source import RawElement, num, where

#: The order of a machine's own keys in a document.
_MACHINE_ORDER = ("$schema", "name", "description", "vars", "inputs", "initial", "states", "transitions", "layout")


class Documents:
    """Emits one document per machine of ``scene`` (its relations already resolved)."""

    def __init__(self, scene: Scene) -> None:
        self.scene = scene
        self.problem = scene.problem
        self.docs: list[dict[str, Any]] = []
        self.names: list[str] = []
        self.origins: list[dict[str, RawElement]] = []

    def run(self) -> None:
        scene = self.scene
        top = scene.levels[0]
        machines = self.split_top(top)
        if len(machines) > 1:
            for note in top.notes:
                self.problem(note.elem, f"machine note outside every machine frame, but the diagram holds "
                                        f"{len(machines)} machines",
                             hint="put the note inside the UMLFrame of the machine it describes")
        for machine in machines:
            self.top_machine(*machine, notes=list(top.notes) if len(machines) == 1 else [])

    def top_machine(self, fallback: str, states: list[StateBox], initials: list[Box], frame: Box | None,
                    notes: list[Any]) -> None:
        """One machine of the diagram: its document, its label among the diagram's machines and its origins."""
        scene = self.scene
        origins: dict[str, RawElement] = {}
        level, title = scene.levels[0], None
        if frame is not None:
            level = scene.levels[id(frame)]
            notes += level.notes
            title = scene.state_of[id(frame)].id or None
        meta = self.metadata(notes)
        # no note: the frame's title (the fallback then), the file's name or the first state's; a note: its name=,
        # else the title
        name: Any = meta.pop("name", title) if notes else fallback
        doc = self.machine_doc(level, states, initials, "", origins, meta=meta, name=name, notes=notes, frame=frame,
                               what="the diagram")
        self.docs.append(doc)
        self.names.append(self._unique_label(name if isinstance(name, str) and name else Path(scene.name).stem, doc))
        self.origins.append(origins)

    def _unique_label(self, label: str, doc: dict[str, Any]) -> str:
        """``label``, numbered (``lap (2)``) when an earlier machine of the diagram has it; a document named so is
        renamed too."""
        unique = T.numbered(label, self.names)
        if unique != label and doc.get("name") == label:
            doc["name"] = unique
        return unique

    def split_top(self, top: Level) -> list[tuple[str, list[StateBox], list[Box], Box | None]]:
        """Top-level machines: a frame that nothing attaches to holds one; else connected parts with an initial."""
        scene = self.scene
        stem = Path(scene.name).stem
        plain = [st for st in top.states if id(st.box) not in scene.machine_frames]
        out: list[tuple[str, list[StateBox], list[Box], Box | None]] = [
            (fr.id or stem, lvl.states, lvl.initials, fr.box) for fr in top.states
            if id(fr.box) in scene.machine_frames and (lvl := scene.levels.get(id(fr.box))) is not None]
        if not plain and not top.initials:
            return out
        if len(top.initials) <= 1:
            out.insert(0, (stem, plain, top.initials, None))
            return out
        return out + self._connected(top, plain)

    def _connected(self, top: Level, plain: list[StateBox]) -> list[tuple[str, list[StateBox], list[Box], None]]:
        """Several initial markers at the top: a machine for each part the transitions connect, named after the
        state its marker leads to; a part that no marker leads to is said."""
        scene = self.scene
        find = _union_find((id(tr["_from"]), id(tr["_to"])) for tr in top.transitions)
        comps: dict[int, list[StateBox]] = {}
        for st in plain:
            comps.setdefault(find(id(st)), []).append(st)
        marker_of: dict[int, list[Box]] = {}
        for m in top.initials:
            marker = scene.markers.get(id(m))
            if marker is not None:
                marker_of.setdefault(find(id(marker.target)), []).append(m)
        out: list[tuple[str, list[StateBox], list[Box], None]] = []
        for root, states in comps.items():
            markers = marker_of.get(root, [])
            if not markers:
                names = ", ".join(f"'{st.id}'" for st in states[:5]) + (", ..." if len(states) > 5 else "")
                self.problem(states[0].box.elem, f"states {names} belong to none of the diagram's machines "
                                                 "(no initial pseudostate leads to them)",
                             hint="connect them, or draw them in another file")
                continue
            first = scene.markers[id(markers[0])].target
            out.append((first.id, states, markers, None))
        return out

    # -- machine keys ---------------------------------------------------------------------------------------
    def metadata(self, notes: list[Box]) -> dict[str, Any]:
        """The keys the machine note among ``notes`` gives (a copy; none without a note)."""
        if not notes:
            return {}
        for extra in notes[1:]:
            self.problem(extra.elem, f"a second machine note for one machine (the first is at "
                                     f"{where(notes[0].elem)})",
                         hint="keep one machine note per machine: merge them")
        return dict(self.scene.note_of[id(notes[0])])

    # -- machines -------------------------------------------------------------------------------------------
    def machine_doc(self, level: Level, states: list[StateBox], initials: list[Box], base: str,
                    origins: dict[str, RawElement], *, meta: dict[str, Any], name: Any = None,
                    notes: list[Box], frame: Box | None = None, what: str) -> dict[str, Any]:
        """The document of one machine level: ``meta`` holds the keys of its machine note (the first of
        ``notes``); ``name`` is the name it has unless the note gives one (None: no name)."""
        scene = self.scene
        layout: dict[str, Any] = {}
        initial_id = self.initial_of(level, states, initials, base, origins, layout, frame, what)
        if frame is not None:
            layout["frame"] = {**box_layout(frame), "title": scene.state_of[id(frame)].id}
        if notes:
            layout["note"] = box_layout(notes[0])
        finals = list(level.finals_by_outcome.values())
        out_states = self.state_docs(states, finals, base, origins)
        out_trans = self.transition_docs(level, {id(st) for st in states + finals}, base, origins)
        doc: dict[str, Any] = dict(meta)
        if name is not None:
            doc.setdefault("name", name)
        doc.update({"initial": initial_id, "states": out_states, "transitions": out_trans})
        if layout:
            doc["layout"] = layout
        return {k: doc[k] for k in _MACHINE_ORDER if k in doc}

    def initial_of(self, level: Level, states: list[StateBox], initials: list[Box], base: str,
                   origins: dict[str, RawElement], layout: dict[str, Any], frame: Box | None, what: str) -> str:
        """The machine's initial state: the target of its one initial marker (its arrow into ``layout``), or its
        only state; several markers, or none for several states, are said ("": none)."""
        scene = self.scene
        markers = [(m, mk) for m in initials if (mk := scene.markers.get(id(m))) is not None and mk.target in states]
        if len(markers) > 1:
            listing = ", ".join(f"at {where(m.elem)}" for m, _ in markers)
            self.problem(markers[1][0].elem, f"{len(markers)} initial pseudostates in one machine ({listing})",
                         hint="keep one initial pseudostate per machine level")
            return ""
        if markers:
            box, mk = markers[0]
            layout["initial"] = {**box_layout(box), "points": mk.points}
            origins[base + "/initial"] = mk.relation
            return mk.target.id
        if any(id(m) in scene.broken_markers for m in initials):
            return ""  # the marker's target state has a text error, reported where it is
        if len(states) == 1:
            return states[0].id
        self.no_initial(level, states, frame, what)
        return ""

    def no_initial(self, level: Level, states: list[StateBox], frame: Box | None, what: str) -> None:
        """Says that a machine of several states has no initial state: at its frame, else its composite's box,
        else its first state."""
        at = next((b.elem for b in (frame, level.owner, *[st.box for st in states[:1]]) if b is not None), None)
        self.problem(at, f"{what} has no initial state: no initial pseudostate with an arrow to a state",
                     hint="draw a UMLSpecialState with type=initial and an arrow to the first state")

    def state_docs(self, states: list[StateBox], finals: list[StateBox], base: str,
                   origins: dict[str, RawElement]) -> list[dict[str, Any]]:
        """The documents of a level's states and final states; a box without a name, with a name used twice or
        with a '/' in it is said and left out."""
        seen: dict[str, StateBox] = {}
        out_states: list[dict[str, Any]] = []
        for st in states + finals:
            wrong = _name_problem(st, seen)
            if wrong is not None:
                self.problem(st.box.elem, wrong[0], hint=wrong[1])
                continue
            seen[st.id] = st
            ptr = f"{base}/states/{len(out_states)}"
            if st not in finals:
                origins[ptr] = st.box.elem
            out_states.append(self.state_doc(st, ptr, origins))
        return out_states

    def transition_docs(self, level: Level, ids: set[int], base: str,
                        origins: dict[str, RawElement]) -> list[dict[str, Any]]:
        """The documents of the level's transitions whose source is one of the states ``ids``."""
        out_trans: list[dict[str, Any]] = []
        for tr, elem in zip(level.transitions, level.trans_origin, strict=True):
            if id(tr["_from"]) not in ids:
                continue
            typ = tr["type"]
            if typ == "_completion":
                typ = "Finished" if self.can_finish(tr["_from"]) else "Always"
            tdoc = {"type": typ, "from": tr["_from"].id, "to": tr["_to"].id}
            tdoc.update((k, v) for k, v in tr.items() if k not in tdoc and not k.startswith("_"))
            if "layout" in tdoc:  # last
                tdoc["layout"] = tdoc.pop("layout")
            ptr = f"{base}/transitions/{len(out_trans)}"
            if elem is not None:
                origins[ptr] = elem
            out_trans.append(tdoc)
        return out_trans

    def sequence_steps(self, st: StateBox, sub: dict[str, Any]) -> tuple[list[Any], list[Any]]:
        """The steps of a Sequence box, in the order its arrows give: from the first step (the initial marker's),
        each step's arrow to the next blocking step, and arrows from a step to the non-blocking sequences that
        start after it. Unconnected non-blocking sequences start first; unconnected Sequences are exception
        sequences. A fork (two arrows to blocking steps), a cycle or an unconnected step is a located problem."""
        chain = _StepChain(self, st, sub)
        order = chain.walk(sub["initial"])
        first, exceptions = chain.unchained(set(order))
        return ([chain.states[sid] for sid in sorted(first, key=chain.y) + order],
                [chain.states[sid] for sid in exceptions])

    def can_finish(self, st: StateBox) -> bool:
        if st.composite and st.type in (None, "FSMState"):
            lvl = self.scene.levels[id(st.box)]
            return any(s.type == "Final" for s in lvl.states) or bool(lvl.finals_by_outcome)
        cls = self.scene.registry().states.get(st.type or "Idle")
        return bool(cls is not None and cls.can_finish)

    # -- states ---------------------------------------------------------------------------------------------
    def state_doc(self, st: StateBox, ptr: str, origins: dict[str, RawElement]) -> dict[str, Any]:
        doc: dict[str, Any] = {"id": st.id}
        frames: list[Box] = []
        if not st.composite:
            doc["type"] = st.type or "Idle"
            doc.update(st.params)
        elif st.type == "Parallel":
            doc.update(self.own_params(st, "Parallel", ("regions",),
                                       f"Parallel '{st.id}' both holds region frames and gives 'regions'",
                                       "draw the regions as frames inside the box, or give regions=, not both"))
            doc["regions"], frames = self.regions(st, ptr, origins)
        elif st.type == "Sequence":
            doc.update(self.sequence_doc(st, ptr, origins))
        else:
            doc.update(self.composite_doc(st, ptr, origins))
        if st.description and "description" not in doc:
            doc["description"] = st.description
        if st.box.w > 0:
            doc["layout"] = _state_layout(st.box, frames)
        return doc

    def sequence_doc(self, st: StateBox, ptr: str, origins: dict[str, RawElement]) -> dict[str, Any]:
        """A Sequence box with step boxes inside: its steps and exception sequences."""
        doc = self.own_params(st, "Sequence", ("steps", "exceptions"),
                              f"Sequence '{st.id}' both contains step boxes and gives 'steps' or 'exceptions' as "
                              "text", "draw the steps inside the box, or write them as text, not both")
        lvl = self.scene.levels[id(st.box)]
        sub = self.machine_doc(lvl, lvl.states, lvl.initials, ptr + "/steps", origins, meta={},
                               notes=[], what=f"sequence '{st.id}'")
        steps, exceptions = self.sequence_steps(st, sub)
        doc["steps"] = steps
        if exceptions:
            doc["exceptions"] = exceptions
        return doc

    def composite_doc(self, st: StateBox, ptr: str, origins: dict[str, RawElement]) -> dict[str, Any]:
        """A box with boxes inside (not a Parallel or Sequence): an FSMState and its sub-machine."""
        if st.type not in (None, "FSMState"):
            self.problem(st.box.elem, f"a {st.type} state cannot contain other boxes",
                         hint="boxes drawn inside a state form an FSMState's sub-machine (or, in a Parallel "
                              "state, its region frames); remove the type or move the boxes out")
        doc = self.own_params(st, "FSMState", ("machine",), "the state both contains boxes and names a 'machine'",
                              "draw the sub-machine inside the box or include it with machine=, not both")
        lvl = self.scene.levels[id(st.box)]
        doc["machine"] = self.machine_doc(lvl, lvl.states, lvl.initials, ptr + "/machine", origins,
                                          meta=self.metadata(lvl.notes), notes=lvl.notes,
                                          what=f"composite '{st.id}'")
        return doc

    def own_params(self, st: StateBox, typ: str, drawn: tuple[str, ...], both: str, hint: str) -> dict[str, Any]:
        """The type and the parameters of a composite's box but those ``drawn`` inside it; a box that gives one
        of them as text too is said (``both``, ``hint``)."""
        if any(key in st.params for key in drawn):
            self.problem(st.box.elem, both, hint=hint)
        return {"type": typ, **{k: v for k, v in st.params.items() if k not in drawn}}

    def regions(self, st: StateBox, ptr: str, origins: dict[str, RawElement]) -> tuple[list[Any], list[Box]]:
        """The regions of a Parallel box, one per frame drawn in it, left to right (then top to bottom), and
        their frames."""
        scene = self.scene
        lvl = scene.levels[id(st.box)]
        frames = sorted((s for s in lvl.states if id(s.box) in scene.region_frames),
                        key=lambda s: (s.box.x, s.box.y))
        hint = ("draw each region as a UMLFrame inside the Parallel state, titled with the region's name, "
                "holding the region's states and its initial pseudostate")
        for other in lvl.states:
            if id(other.box) not in scene.region_frames:
                self.problem(other.box.elem, f"'{other.id}' is drawn inside Parallel '{st.id}' but in none of "
                                             "its region frames", hint=hint)
        for marker in lvl.initials:
            self.problem(marker.elem, f"initial pseudostate inside Parallel '{st.id}' but in none of its "
                                      "region frames", hint=hint)
        for note in lvl.notes:
            self.problem(note.elem, f"machine note inside Parallel '{st.id}' but in none of its region frames",
                         hint="a note in a region frame describes that region's machine")
        out: list[Any] = []
        boxes: list[Box] = []
        for fr in frames:
            region = self.region_doc(st, fr, f"{ptr}/regions/{len(out)}", origins)
            if region is not None:
                out.append(region)
                boxes.append(fr.box)
        return out, boxes

    def region_doc(self, parallel: StateBox, fr: StateBox, ptr: str,
                   origins: dict[str, RawElement]) -> dict[str, Any] | None:
        scene = self.scene
        origins[ptr] = fr.box.elem
        lvl = scene.levels.get(id(fr.box))
        include = T.include_title(fr.id)
        if include is not None:
            if lvl is not None:
                self.problem(fr.box.elem, f"the region frame '{fr.id}' includes a machine from a file, so it "
                                          "may hold nothing else",
                             hint="draw the region's states in a frame titled with its name, or include it")
            return {"file": include}
        if lvl is None:
            self.problem(fr.box.elem, f"region frame '{fr.id}' of Parallel '{parallel.id}' is empty",
                         hint="draw the region's initial pseudostate and states inside it, or title it file=PATH "
                              "to include the region from a file")
            return None
        meta = self.metadata(lvl.notes)
        if fr.id and meta.get("name", fr.id) != fr.id:
            self.problem(lvl.notes[0].elem, f"the machine note names the region '{meta['name']}' but its frame "
                                            f"is titled '{fr.id}'",
                         hint="the frame's title is the region's name: remove name= from the note")
        what = f"region '{fr.id}' of Parallel '{parallel.id}'" if fr.id else f"a region of Parallel '{parallel.id}'"
        return self.machine_doc(lvl, lvl.states, lvl.initials, ptr, origins, meta=meta, name=fr.id or None,
                                notes=lvl.notes, what=what)


def box_layout(box: Box) -> dict[str, Any]:
    return {"x": num(box.x), "y": num(box.y), "w": num(box.w), "h": num(box.h)}


def _state_layout(box: Box, frames: list[Box]) -> dict[str, Any]:
    """A state's ``layout``: its box, its shape when it is a final state or a frame, and its regions' frames."""
    lay = box_layout(box)
    if box.role in ("final", "frame"):
        lay["shape"] = box.role
    if frames:
        lay["frames"] = [box_layout(f) for f in frames]
    return lay

_CYCLE_HINT = "a sequence runs its steps once each, in order (use repeat= to run them again)"


class _StepChain:
    """The steps of one Sequence box and the arrows between them, walked from the first step."""

    def __init__(self, docs: Documents, st: StateBox, sub: dict[str, Any]) -> None:
        self.problem = docs.problem
        self.st = st
        self.states = {x["id"]: x for x in sub["states"]}
        self.boxes = {b.id: b for b in docs.scene.levels[id(st.box)].states}
        self.outs: dict[str, list[str]] = {}
        self.into: dict[str, int] = {}
        for tr in sub.get("transitions", []):
            self.outs.setdefault(tr["from"], []).append(tr["to"])
            self.into[tr["to"]] = self.into.get(tr["to"], 0) + 1

    def detached(self, sid: str) -> bool:
        """A non-blocking sequence: it starts after its step and runs beside the chain."""
        x = self.states[sid]
        return x.get("type") == "Sequence" and x.get("blocking") is False

    def y(self, sid: str) -> float:
        box = self.boxes.get(sid)
        return box.box.y if box is not None else 0.0

    def elem(self, sid: str) -> Any:
        return self.boxes[sid].box.elem if sid in self.boxes else self.st.box.elem

    def walk(self, cur: str) -> list[str]:
        """The chain from ``cur``: each step, then the non-blocking sequences its arrows start; a cycle (an arrow
        back to a step before) or a fork is a problem (the walk does not follow the arrow back, and follows the
        first arrow of a fork)."""
        order: list[str] = []
        seen: set[str] = set()
        while cur in self.states:  # never one seen: the next step is the target of an arrow to a step not seen
            seen.add(cur)
            order.append(cur)
            nxt = self.targets(cur, seen)
            detached = [t for t in nxt if self.detached(t)]
            order += detached
            seen.update(detached)
            cur = self.next_step(cur, [t for t in nxt if not self.detached(t)])
        return order

    def targets(self, cur: str, seen: set[str]) -> list[str]:
        """The steps the arrows from ``cur`` lead to that are not ``seen`` yet, top to bottom; an arrow back to a
        step seen (a cycle) is said."""
        back = [t for t in self.outs.get(cur, []) if t in seen]
        if back:
            self.problem(self.elem(cur), f"the steps of sequence '{self.st.id}' form a cycle: '{cur}' -> "
                                         f"'{back[0]}'", hint=_CYCLE_HINT)
        return sorted((t for t in self.outs.get(cur, []) if t not in seen), key=self.y)

    def next_step(self, cur: str, blocking: list[str]) -> str:
        if len(blocking) > 1:
            self.problem(self.elem(cur), f"step '{cur}' of sequence '{self.st.id}' has arrows to several steps: "
                                         + ", ".join(f"'{b}'" for b in blocking),
                         hint="steps run one after the other: one arrow to the next step (parallel work is a "
                              "non-blocking Sequence, blocking=false)")
        return blocking[0] if blocking else ""  # no step is named ""

    def unchained(self, seen: set[str]) -> tuple[list[str], list[str]]:
        """The steps off the chain: non-blocking sequences nothing points to (they start first) and unconnected
        Sequences (exception sequences); any other is a problem."""
        alone = [sid for sid in self.states if sid not in seen and not self.into.get(sid)]
        first = [sid for sid in alone if self.detached(sid)]
        exceptions = [sid for sid in alone if sid not in first and self.states[sid].get("type") == "Sequence"
                      and not self.outs.get(sid)]
        placed = seen.union(first, exceptions)
        for sid in self.states:
            if sid not in placed:
                self.problem(self.elem(sid), f"step '{sid}' of sequence '{self.st.id}' is not on the chain of steps",
                             hint="connect it with an arrow from the step before it (only Sequence boxes may stand "
                                  "alone: they are exception sequences)")
        return first, exceptions


def _name_problem(st: StateBox, seen: dict[str, StateBox]) -> tuple[str, str] | None:
    """What is wrong with a state box's name (none, one of ``seen`` already, a '/' in it) and how to fix it."""
    if not st.id:
        return "state box has no name", "write the state's name on the first line of the box"
    if st.id in seen:
        return (f"duplicate state name '{st.id}' in one machine (also at {where(seen[st.id].box.elem)})",
                "names are ids: rename one of the boxes")
    if "/" in st.id:
        return f"state name '{st.id}' contains '/', which separates state paths", "rename the box"
    return None


def _union_find(pairs: Iterable[tuple[int, int]]) -> Callable[[int], int]:
    """The root of each element's part, the ``pairs`` joining elements into parts."""
    parent: dict[int, int] = {}

    def find(k: int) -> int:
        while parent.setdefault(k, k) != k:
            parent[k] = parent[parent[k]]
            k = parent[k]
        return k

    for a, b in pairs:
        ra, rb = find(a), find(b)
        if ra != rb:
            parent[ra] = rb
    return find
