"""Diagram geometry for a machine document: the stored ``layout`` where there is one, a layered layout elsewhere.

Used by ``fsmctl export`` (UMLet) and ``fsmctl graph --format svg``. Coordinates are UMLet pixels at zoom 10.
Boxes of one level never come closer than ``GAP`` so that arrow ends attach to exactly one box again.

A composite box holds *parts*: the one sub-machine of an ``FSMState``, or one compartment per region of a
``Parallel`` state. By default only inline ``FSMState`` machines are expanded; ``export`` also opens the
regions of a ``Parallel`` state, as frames set in from the box's border (``Expansion.inset``) that keep where
the diagram had them (the state's ``layout.frames``). The drawing passes an ``expand`` hook that also
opens includes (see :class:`Expansion`), and ``drawing=True``, which makes room for such content in a stored
layout by moving what lies right of and below the grown box (only as far as needed: see
:func:`_insert_space`), bends parallel arrows apart, and routes arrows that run through a box around it
(:func:`_reroute`). The UMLet writer never passes ``drawing``: what it writes keeps the diagram's geometry.
With a ``note_size`` hook, a machine level gets a note box (its machine's own keys) right of its content, or
where its ``layout.note`` puts it.
"""

from __future__ import annotations

import functools
import heapq
import math
from collections import Counter, deque
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from itertools import combinations, pairwise
from typing import Any

from .geometry import SPACING, parallel_gap, segment_hits_box, segments_cross

GRID = 10
GAP_X, GAP_Y = 80, 80
PAD, PAD_TOP = 30, 50
MARKER = 20
#: Height of a composite's title band; with a note line (an include's file name) it is ``HEAD_NOTE``.
HEAD, HEAD_NOTE = 26, 40
#: Height of a region's name band at the top of its compartment.
REGION_HEAD = 24
#: Inset regions (export): the space between a Parallel box's border and its frames, and between frames. More
#: than the attachment distance, so an arrow ending at the Parallel box's border is not taken for the frame's.
REGION_GAP = 20
#: Space between a level's content and its note box.
NOTE_GAP = 40


@dataclass(eq=False)
class Part:
    """One compartment of a composite box: its content ``level`` and (for a region) its ``name``."""
    level: LevelLayout
    name: str | None = None
    #: The least width the compartment needs (for its name).
    min_w: float = 0
    x: float = 0
    y: float = 0
    w: float = 0
    h: float = 0


@dataclass
class Expansion:
    """What a composite state shows inside its box.

    ``parts``: ``(region name or None, machine document, expand hook for that machine's states or None for the
    same hook)``; ``note``: a line under the title (an include's file name, or why it could not be read);
    ``foreign``: the parts' coordinates are not this diagram's (an included file, a region), so they are
    moved into the box rather than kept where they are; ``error``: the note says what is wrong;
    ``min_widths``: the least width of each part's compartment (for its name); ``head``: the height of the
    box's own text above its content (default: the title band); ``inset``: regions are frames set in from the
    box's border by ``REGION_GAP`` and kept where the state's ``layout.frames`` puts them.
    """
    parts: list[tuple[str | None, dict[str, Any], Callable[..., Expansion | None] | None]]
    note: str | None = None
    foreign: bool = False
    error: bool = False
    min_widths: list[float] = field(default_factory=list)
    head: float | None = None
    inset: bool = False


@dataclass(eq=False)
class Node:
    doc: dict[str, Any]
    x: float = 0
    y: float = 0
    w: float = 120
    h: float = 40
    parts: list[Part] = field(default_factory=list)
    note: str | None = None
    note_error: bool = False
    foreign: bool = False
    inset: bool = False
    head_override: float | None = None
    placed: bool = False
    #: Moved less than the rest when a composite grew (drawing only, :func:`_insert_space`).
    detached: bool = False
    #: The stored box, before room was made for grown composites (where stored arrow ends are attached).
    stored: tuple[float, float, float, float] | None = None
    #: How far a tall level's reflow into columns moved the node (drawing only, :func:`_reflow`).
    reflowed: tuple[float, float] = (0.0, 0.0)

    @property
    def id(self) -> str:
        return str(self.doc.get("id", ""))

    @property
    def sub(self) -> LevelLayout | None:
        """The content of a plain composite (one unnamed part), else None."""
        if len(self.parts) == 1 and self.parts[0].name is None:
            return self.parts[0].level
        return None

    @property
    def composite(self) -> bool:
        return bool(self.parts) or self.note is not None

    @property
    def regions(self) -> bool:
        return any(p.name is not None for p in self.parts)

    @property
    def head(self) -> float:
        if self.head_override is not None:
            return self.head_override
        return HEAD_NOTE if self.note is not None else HEAD

    def move(self, dx: float, dy: float) -> None:
        self.x += dx
        self.y += dy
        for p in self.parts:
            p.x += dx
            p.y += dy
            p.level.shift(dx, dy)


@dataclass(eq=False)
class Edge:
    doc: dict[str, Any]
    src: Node
    dst: Node
    points: list[list[float]] = field(default_factory=list)


@dataclass(eq=False)
class LevelLayout:
    machine: dict[str, Any]
    nodes: list[Node]
    edges: list[Edge]
    marker: tuple[float, float] | None = None
    marker_points: list[list[float]] = field(default_factory=list)
    initial: Node | None = None
    marker_size: tuple[float, float] = (MARKER, MARKER)
    #: Space inserted for grown composites (drawing only): ``(x line, dx, y line, dy)``, in order.
    inserted: list[tuple[float, float, float, float]] = field(default_factory=list)
    #: Room kept for arrow labels (drawing only): ``[x, y, w, h]`` beside each arrow's middle.
    label_room: list[list[float]] = field(default_factory=list)
    #: The box of the level's note (``note_size`` hook): ``[x, y, w, h]``.
    note: list[float] | None = None

    def bbox(self, labels: bool = True) -> tuple[float, float, float, float]:
        spans = _spans(self) + [(px - 10, py, px + 10, py) for e in self.edges for px, py in e.points]
        if labels:
            spans += [(x, y, x + w, y + h) for x, y, w, h in self.label_room]
        return _extent(spans) if spans else (0, 0, 0, 0)

    def shift(self, dx: float, dy: float) -> None:
        for n in self.nodes:
            n.move(dx, dy)
        for e in self.edges:
            e.points = _moved(e.points, dx, dy)
        if self.marker:
            self.marker = (self.marker[0] + dx, self.marker[1] + dy)
        self.marker_points = _moved(self.marker_points, dx, dy)
        self.label_room = [[x + dx, y + dy, w, h] for x, y, w, h in self.label_room]
        if self.note is not None:
            self.note = [self.note[0] + dx, self.note[1] + dy, self.note[2], self.note[3]]


Span = tuple[float, float, float, float]


def _moved(pts: list[list[float]], dx: float, dy: float) -> list[list[float]]:
    """The points moved by (``dx``, ``dy``)."""
    return [[px + dx, py + dy] for px, py in pts]


def _spans(level: LevelLayout) -> list[Span]:
    """Left, top, right and bottom of each of the level's boxes: states, initial marker, note."""
    spans = [(n.x, n.y, n.x + n.w, n.y + n.h) for n in level.nodes]
    if level.marker:
        mx, my = level.marker
        spans.append((mx, my, mx + MARKER, my + MARKER))
    if level.note is not None:
        x, y, w, h = level.note
        spans.append((x, y, x + w, y + h))
    return spans


def _extent(spans: list[Span]) -> Span:
    """Left, top, right and bottom of the box round ``spans``."""
    return min(s[0] for s in spans), min(s[1] for s in spans), max(s[2] for s in spans), max(s[3] for s in spans)


def _snap(v: float) -> float:
    return math.ceil(v / GRID) * GRID


def text_size(lines: list[str]) -> tuple[float, float]:
    width = max((len(ln) for ln in lines), default=4)
    return max(120.0, _snap(width * 8 + 30)), max(40.0, _snap(len(lines) * 16 + 20))


def inline_machine(state: dict[str, Any]) -> dict[str, Any] | None:
    m = state.get("machine")
    if (state.get("type") == "FSMState" and isinstance(m, dict) and "file" not in m
            and isinstance(m.get("states"), list)):
        return m
    return None


def sequence_machine(st: dict[str, Any], start: str = "start") -> dict[str, Any]:
    """A Sequence drawn as the machine the loader compiles it to: its blocking steps chained by ``Finished``
    arrows, an arrow (typed ``start``) to each non-blocking sequence from the step it follows, its exception
    sequences beside, unconnected. The UMLet writer types the start arrows ``Finished`` too (what a diagram can
    say); the reader rebuilds the steps from the arrows."""
    steps = _named(st["steps"])
    blocking = [s for s in steps if not (s.get("type") == "Sequence" and s.get("blocking") is False)]
    exceptions = _named(st.get("exceptions") or ())
    initial = blocking[0]["id"] if blocking else (steps[0]["id"] if steps else "")
    return {"initial": initial, "states": steps + exceptions, "transitions": _chain(steps, blocking, start)}


def _chain(steps: list[dict[str, Any]], blocking: list[dict[str, Any]], start: str) -> list[dict[str, Any]]:
    """The arrows between a Sequence's steps: into each step from the last blocking step before it, typed
    ``Finished`` into a blocking step and ``start`` into a non-blocking one."""
    transitions: list[dict[str, Any]] = []
    last: str | None = None
    for s in steps:
        if last is not None:
            transitions.append({"type": "Finished" if s in blocking else start, "from": last, "to": s["id"]})
        if s in blocking:
            last = s["id"]
    return transitions


def _named(items: Any) -> list[dict[str, Any]]:
    """The steps (or exception sequences) of a Sequence that are dictionaries with a string ``id``."""
    return [s for s in items if isinstance(s, dict) and isinstance(s.get("id"), str)]


def region_name(machine: Any, i: int) -> str:
    """The name of region ``i`` of a Parallel state as the loader names it: its machine's ``name`` (a
    non-empty string), else ``region<i+1>``."""
    name = machine.get("name") if isinstance(machine, dict) else None
    return name if isinstance(name, str) and name else f"region{i + 1}"


def inline_only(state: dict[str, Any]) -> Expansion | None:
    """The default expansion: an inline ``FSMState`` machine, in this diagram's coordinates."""
    m = inline_machine(state)
    return Expansion([(None, m, None)]) if m is not None else None


def lay_out(machine: dict[str, Any], label_lines: Any, *, expand: Callable[..., Expansion | None] | None = None,
            size: Callable[[Node], tuple[float, float]] | None = None,
            label_width: Callable[[dict[str, Any]], float] | None = None, drawing: bool = False,
            note_size: Callable[[dict[str, Any]], tuple[float, float] | None] | None = None) -> LevelLayout:
    """Positions for every state, initial marker and transition of ``machine`` and its sub-machines.

    ``label_lines(state)`` gives the text lines a state box shows (for its size) unless ``size(node)`` is given;
    ``expand(state)`` says what a composite shows (default: inline ``FSMState`` machines only);
    ``label_width(transition)``, how wide an arrow's label is drawn: the layered layout leaves room for it;
    ``note_size(machine)``, the size of the note box a machine level gets (None: no note).
    """
    opts = _Options(label_lines, expand or inline_only, size, label_width, drawing, note_size)
    return _lay_out(machine, opts)


@dataclass(frozen=True)
class _Options:
    """The hooks of :func:`lay_out`, handed down to every sub-machine (with its own ``expand``)."""
    label_lines: Any
    expand: Callable[..., Expansion | None]
    size: Callable[[Node], tuple[float, float]] | None
    label_width: Callable[[dict[str, Any]], float] | None
    drawing: bool
    note_size: Callable[[dict[str, Any]], tuple[float, float] | None] | None


def _lay_out(machine: dict[str, Any], opts: _Options) -> LevelLayout:
    nodes = [_node(st, opts) for st in _dicts(machine, "states")]
    by_id: dict[str, Node] = {}
    for node in nodes:
        by_id.setdefault(node.id, node)
    level = LevelLayout(machine, nodes, [])
    level.initial = by_id.get(str(machine.get("initial")))
    _place(level, by_id, opts.label_width)
    marker = level.marker
    _fit_composites(level, opts.drawing)
    _move_marker_points(level, marker)
    if opts.drawing:
        _reflow(level, opts.label_width)
    level.edges = _edges(machine, by_id)
    _route(level, opts.drawing)
    if opts.note_size is not None:
        _place_note(level, opts.note_size(machine))
    if opts.label_width is not None:
        _keep_label_room(level, opts.label_width)
    return level


def _edges(machine: dict[str, Any], by_id: dict[str, Node]) -> list[Edge]:
    """The machine's transitions between two of its states (by id), as arrows without points yet."""
    edges = []
    for tr in _dicts(machine, "transitions"):
        src, dst = by_id.get(str(tr.get("from"))), by_id.get(str(tr.get("to")))
        if src is not None and dst is not None:
            edges.append(Edge(tr, src, dst))
    return edges


def _node(st: dict[str, Any], opts: _Options) -> Node:
    """The box of state ``st``: its parts laid out, where its stored layout puts it or sized from its text."""
    node = Node(st)
    exp = opts.expand(st)
    if exp is not None:
        node.note, node.note_error, node.foreign = exp.note, exp.error, exp.foreign
        node.inset, node.head_override = exp.inset, exp.head
        widths = exp.min_widths + [0.0] * (len(exp.parts) - len(exp.min_widths))
        for (name, sub, hook), min_w in zip(exp.parts, widths, strict=False):
            node.parts.append(Part(_lay_out(sub, replace(opts, expand=hook or opts.expand)), name, min_w))
    box = _rect(st.get("layout"))
    if box is not None:
        node.x, node.y, node.w, node.h = box
        node.placed = True
        node.stored = box
    else:
        node.w, node.h = opts.size(node) if opts.size is not None else text_size(opts.label_lines(st))
    return node


def _move_marker_points(level: LevelLayout, marker: tuple[float, float] | None) -> None:
    """The stored initial arrow follows its marker and its state when room was made for grown composites."""
    # (a placed marker always has its arrow: _place_marker draws one when none is stored)
    if not level.inserted or marker is None or level.marker is None or level.initial is None:
        return
    pts = level.marker_points
    first = [pts[0][0] + level.marker[0] - marker[0], pts[0][1] + level.marker[1] - marker[1]]
    last = _attach(pts[-1], level.initial) if level.initial.stored is not None else pts[-1]
    middle = _bends(pts, level.inserted, level.initial.detached)
    level.marker_points = [first] + middle + [last]


def _keep_label_room(level: LevelLayout, label_width: Callable[[dict[str, Any]], float]) -> None:
    """Room for each arrow's label beside the middle of its middle segment."""
    for e in level.edges:
        if len(e.points) >= 2:
            i = (len(e.points) - 1) // 2
            (ax, ay), (bx, by) = e.points[i], e.points[i + 1]
            level.label_room.append([(ax + bx) / 2 + 4, (ay + by) / 2 - 8, label_width(e.doc), 16])


def _place_note(level: LevelLayout, size: tuple[float, float] | None) -> None:
    """The note box: where ``layout.note`` puts it (with its size) when every box of the level kept its stored
    place, else right of the level's content, level with its top."""
    if size is None:
        return
    w, h = size
    note = _rect(_dict(level.machine.get("layout")).get("note"))
    if note is not None and all(n.stored is not None for n in level.nodes) and not level.inserted:
        level.note = list(note)
        return
    if not level.nodes:
        level.note = [0.0, 0.0, w, h]
        return
    x0, y0, x1, _ = level.bbox(labels=False)
    level.note = [_snap(x1 + NOTE_GAP), y0, w, h]


# -- composites ------------------------------------------------------------------------------------------------
def _content_top(n: Node) -> float:
    """Offset from a composite's top to its content (room for the title band and the initial marker)."""
    return PAD_TOP + (n.head - HEAD)


def _part_sizes(n: Node) -> list[tuple[float, float]]:
    """The natural (width, height) of each part's compartment."""
    out = []
    for p in n.parts:
        x0, y0, x1, y1 = p.level.bbox()
        if not p.level.nodes:
            x0 = y0 = x1 = y1 = 0
        if p.name is None:
            out.append((_snap(max(x1 - x0 + 2 * PAD, p.min_w)), _snap(y1 - y0 + PAD + _content_top(n))))
        else:
            out.append((_snap(max(x1 - x0 + 2 * PAD, p.min_w)), _snap(y1 - y0 + REGION_HEAD + 16 + PAD)))
    return out


def _natural_size(n: Node) -> tuple[float, float]:
    sizes = _part_sizes(n)
    if not sizes:
        return 0, 0
    if not n.regions:
        return sizes[0]
    gap = REGION_GAP if n.inset else 0
    return sum(w for w, _ in sizes) + gap * (len(sizes) + 1), n.head + max(h for _, h in sizes) + gap


def _arrange(n: Node) -> None:
    """Put the parts into the box of ``n`` (whose size already holds them): regions side by side."""
    sizes = _part_sizes(n)
    if not sizes:
        return
    if n.regions:
        _arrange_regions(n, sizes)
        return
    p = n.parts[0]
    p.x, p.y, p.w, p.h = n.x, n.y, n.w, n.h
    if p.level.nodes:
        x0, y0, _, _ = p.level.bbox()
        p.level.shift(n.x + PAD - x0, n.y + _content_top(n) - y0)


def _arrange_regions(n: Node, sizes: list[tuple[float, float]]) -> None:
    """The regions of ``n`` side by side below its title band, each at least its natural width (``sizes``) and the
    room left shared out, the last one up to the box's right side; each region's content centred at its top."""
    gap = REGION_GAP if n.inset else 0
    extra = max(0.0, n.w - sum(w for w, _ in sizes) - gap * (len(sizes) + 1)) / len(sizes)
    x = n.x + gap
    for i, (p, (w, _)) in enumerate(zip(n.parts, sizes, strict=True)):
        p.x, p.y = x, n.y + n.head
        p.w = n.x + n.w - gap - x if i == len(sizes) - 1 else math.floor(w + extra)
        p.h = n.y + n.h - gap - p.y
        if p.level.nodes:
            x0, y0, x1, _ = p.level.bbox()
            p.level.shift(p.x + (p.w - (x1 - x0)) / 2 - x0, p.y + REGION_HEAD + 16 - y0)
        x += p.w + gap


def _stored_frames(n: Node) -> list[tuple[float, float, float, float]] | None:
    """The frames an inset composite's regions keep (``layout.frames`` of the state, one per region), when the
    box kept its stored place and every frame lies inside it and holds its region's content; else None."""
    lay = _dict(n.doc.get("layout"))
    stored = lay.get("frames")
    if not n.inset or n.stored is None or not isinstance(stored, list) or len(stored) != len(n.parts):
        return None
    frames = []
    for p, fr in zip(n.parts, stored, strict=True):
        box = _rect(fr)
        if box is None or not _holds((n.x, n.y, n.w, n.h), box[0], box[1], box[0] + box[2], box[1] + box[3]):
            return None
        inner = _spans(p.level)
        if inner and not _holds(box, *_extent(inner)):
            return None
        frames.append(box)
    return frames


def _holds(box: tuple[float, float, float, float], x0: float, y0: float, x1: float, y1: float) -> bool:
    """Whether ``box`` (x, y, w, h) holds the rectangle from (``x0``, ``y0``) to (``x1``, ``y1``)."""
    return not (x0 < box[0] or y0 < box[1] or x1 > box[0] + box[2] or y1 > box[1] + box[3])


def _place(level: LevelLayout, by_id: dict[str, Node], label_width: Callable[[dict[str, Any]], float] | None = None,
           ) -> None:
    """Layered placement (breadth-first from the initial state) of the nodes without a stored layout.

    With ``label_width``, the boxes of a row stand as far apart as the widest label of an arrow into the row,
    and a row is lowered a little for every further labelled arrow coming into it (room to stagger the labels).
    """
    todo = [n for n in level.nodes if not n.placed]
    for n in todo:  # composites without a layout: size from their content
        w, h = _natural_size(n)
        n.w, n.h = max(n.w, w), max(n.h, h)
    if todo:
        _place_rows(level, _rows(level, by_id, todo), by_id, label_width)
    if level.initial is not None:
        _place_marker(level, level.initial, stored=not todo)


def _rows(level: LevelLayout, by_id: dict[str, Node], todo: list[Node]) -> dict[int, list[Node]]:
    """The nodes to place by their distance (in arrows) from the initial state; the unreachable ones last."""
    depth: dict[str, int] = {}
    if level.initial is not None:
        depth[level.initial.id] = 0
        queue = deque([level.initial.id])
        edges: dict[str, list[str]] = {}
        for tr in _dicts(level.machine, "transitions"):
            edges.setdefault(str(tr.get("from")), []).append(str(tr.get("to")))
        while queue:
            cur = queue.popleft()
            for nxt in edges.get(cur, []):
                if nxt not in depth and nxt in by_id:
                    depth[nxt] = depth[cur] + 1
                    queue.append(nxt)
    rows: dict[int, list[Node]] = {}
    last = max(depth.values(), default=0) + 1
    for n in todo:
        rows.setdefault(depth.get(n.id, last), []).append(n)
    return rows


def _place_rows(level: LevelLayout, rows: dict[int, list[Node]], by_id: dict[str, Node],
                label_width: Callable[[dict[str, Any]], float] | None) -> None:
    """The rows one below the other, below what has a stored place, each row's boxes side by side."""
    left, y = _below_placed(level)
    into = _label_widths_into(level, by_id, label_width)
    for i, r in enumerate(sorted(rows)):
        widths = [w for sid in dict.fromkeys(n.id for n in rows[r]) for w in into.get(sid, [])]
        gap_x = max(GAP_X, _snap(max(widths, default=0) + 20))
        if i:
            y += max(0, len(widths) - 1) * 16
        y += _place_row(rows[r], left, y, gap_x) + GAP_Y


def _below_placed(level: LevelLayout) -> tuple[float, float]:
    """Where the first row starts: left-aligned with, and ``GAP_Y`` below, the boxes that have a stored place (below
    the initial marker's room when none has)."""
    placed = [n for n in level.nodes if n.placed]
    y = max(max((n.y + n.h for n in placed), default=-GAP_Y) + GAP_Y, MARKER + 40)
    return min((n.x for n in placed), default=0.0), y


def _place_row(row: list[Node], x: float, y: float, gap_x: float) -> float:
    """The boxes of a row side by side from (``x``, ``y``), ``gap_x`` apart, their parts arranged; the height of the
    tallest."""
    for n in row:
        n.x, n.y = x, y
        _arrange(n)
        n.placed = True
        x += n.w + gap_x
    return max(n.h for n in row)


def _label_widths_into(level: LevelLayout, by_id: dict[str, Node],
                       label_width: Callable[[dict[str, Any]], float] | None) -> dict[str, list[float]]:
    """The widths of the labels of the level's arrows into each state (none without ``label_width``)."""
    into: dict[str, list[float]] = {}
    if label_width is not None:
        for tr in _dicts(level.machine, "transitions"):
            if str(tr.get("from")) in by_id:
                into.setdefault(str(tr.get("to")), []).append(label_width(tr))
    return into


def _place_marker(level: LevelLayout, initial: Node, stored: bool) -> None:
    """The initial marker and its arrow: where ``layout.initial`` keeps them when every box kept its stored
    place, else above the initial state."""
    ini = _dict(_dict(level.machine.get("layout")).get("initial"))
    at = _xy(ini, "x", "y") if stored else None
    if at is None:
        level.marker = (initial.x + initial.w / 2 - MARKER / 2, initial.y - MARKER - 40)
    else:
        level.marker = at
        level.marker_size = _xy(ini, "w", "h") or level.marker_size
        level.marker_points = _points(ini) or []
    if not level.marker_points:
        mx, my = level.marker
        level.marker_points = _connect((mx, my, MARKER, MARKER), (initial.x, initial.y, initial.w, initial.h), 0)


def _fit_composites(level: LevelLayout, drawing: bool) -> None:
    """A composite box must hold its content with a margin; grow it when it does not (never shrink it).

    Content in foreign coordinates (an include, regions) is moved into the box. When ``drawing``, a box that
    grows pushes what lies right of and below it away by as much (see :func:`_insert_space`).
    """
    for n in level.nodes:
        if not n.parts or _keep_frames(n):
            continue
        if n.foreign or n.regions:
            _fit_foreign(level, n, drawing)
        else:
            _fit_own(level, n, drawing)


def _keep_frames(n: Node) -> bool:
    """Whether the regions of ``n`` keep the frames the diagram has for them (see :func:`_stored_frames`): then they
    are put there."""
    frames = _stored_frames(n) if n.regions else None
    if frames is None:
        return False
    for p, (x, y, w, h) in zip(n.parts, frames, strict=True):
        p.x, p.y, p.w, p.h = x, y, w, h
    return True


def _fit_foreign(level: LevelLayout, n: Node, drawing: bool) -> None:
    """Content in foreign coordinates (an include, regions): the box grown to the parts' natural size where it is
    smaller, the parts moved into it."""
    w, h = _natural_size(n)
    if w > n.w or h > n.h:
        _grow(level, n, max(n.w, w), max(n.h, h), drawing)
    _arrange(n)


def _fit_own(level: LevelLayout, n: Node, drawing: bool) -> None:
    """A plain composite's content in this diagram's coordinates: moved in when it sticks out left or above, the
    box grown when it sticks out right or below."""
    sub, p = n.parts[0].level, n.parts[0]
    p.x, p.y, p.w, p.h = n.x, n.y, n.w, n.h
    if not sub.nodes:
        return
    x0, y0, x1, y1 = _node_bbox(sub)
    if x0 < n.x or y0 < n.y:
        sub.shift(max(0, n.x + PAD - x0), max(0, n.y + PAD_TOP - y0))
        x0, y0, x1, y1 = _node_bbox(sub)
    w = _snap(x1 - n.x + PAD) if x1 > n.x + n.w else n.w
    h = _snap(y1 - n.y + PAD) if y1 > n.y + n.h else n.h
    if w != n.w or h != n.h:
        _grow(level, n, w, h, drawing)
    p.x, p.y, p.w, p.h = n.x, n.y, n.w, n.h


def _grow(level: LevelLayout, n: Node, w: float, h: float, drawing: bool) -> None:
    if drawing:
        _insert_space(level, n, w - n.w, h - n.h)
    n.w, n.h = w, h


def _insert_space(level: LevelLayout, n: Node, dw: float, dh: float) -> None:
    """Make room for ``n`` growing by ``dw`` x ``dh`` (drawing only): every node of ``level`` right of ``n`` moves
    right by ``dw`` and every node below it moves down by ``dh``, remembered for the stored arrow points (see
    :func:`_route`); except that a node moves less (only right, only down, or not at all) when it is clear of the
    grown box and of every other node there, so that growing a composite does not push what stands beside it
    far away. A node that moved so is ``detached``: its arrows lose their stored bends."""
    right, bottom = n.x + n.w, n.y + n.h
    others = [m for m in level.nodes if m is not n]
    moves = {id(m): (dw if m.x >= right - 0.5 else 0, dh if m.y >= bottom - 0.5 else 0) for m in others}
    for m in others:
        if moves[id(m)] != (0, 0):
            _move_less(level, n, m, (n.x, n.y, n.w + dw, n.h + dh), moves)
    for m in others:
        m.move(*moves[id(m)])
    level.inserted.append((right, dw, bottom, dh))
    _move_marker(level, n, moves)


def _move_marker(level: LevelLayout, n: Node, moves: dict[int, tuple[float, float]]) -> None:
    """The initial marker moves with its state; when that is the grown node ``n``, as the space inserted last."""
    if level.marker is None:
        return
    if level.initial is not None and level.initial is not n:
        dx, dy = moves[id(level.initial)]
        level.marker = (level.marker[0] + dx, level.marker[1] + dy)
    else:
        mx, my = _spread(list(level.marker), level.inserted[-1:])
        level.marker = (mx, my)


def _move_less(level: LevelLayout, n: Node, m: Node, grown: tuple[float, float, float, float],
               moves: dict[int, tuple[float, float]]) -> None:
    """The least of ``m``'s moves (none, only right, only down) that keeps it clear of the grown box ``n`` and of
    every other node where it is going, if one does: then ``m`` is ``detached``."""
    clear = GAP_X / 2
    mx, my = moves[id(m)]
    options = sorted({(0.0, 0.0), (mx, 0.0), (0.0, my)} - {(mx, my)}, key=lambda o: (abs(o[0]) + abs(o[1]), o))
    for ox, oy in options:
        box = (m.x + ox, m.y + oy, m.w, m.h)
        if _apart(box, grown, clear) and all(
                o is m or o is n or _apart(box, (o.x + moves[id(o)][0], o.y + moves[id(o)][1], o.w, o.h), clear)
                for o in level.nodes):
            moves[id(m)] = (ox, oy)
            m.detached = True
            return


def _apart(a: tuple[float, float, float, float], b: tuple[float, float, float, float], gap: float) -> bool:
    """Whether boxes ``a`` and ``b`` are at least ``gap`` apart (in x or in y)."""
    return (a[0] + a[2] + gap <= b[0] or b[0] + b[2] + gap <= a[0] or a[1] + a[3] + gap <= b[1]
            or b[1] + b[3] + gap <= a[1])


def _spread(p: list[float], ops: list[tuple[float, float, float, float]]) -> list[float]:
    x, y = p
    for right, dw, bottom, dh in ops:
        x += dw if x >= right - 0.5 else 0
        y += dh if y >= bottom - 0.5 else 0
    return [x, y]


def _bends(pts: list[list[float]], inserted: list[tuple[float, float, float, float]], detached: bool,
           shift: tuple[float, float] = (0.0, 0.0)) -> list[list[float]]:
    """A stored arrow's bends (all its points but its ends) where the space ``inserted`` for grown composites, and
    then a reflow's ``shift``, took them; none when an end of the arrow is ``detached``."""
    if detached:
        return []
    dx, dy = shift
    return _moved([_spread(p, inserted) for p in pts[1:-1]], dx, dy)


def _attach(p: list[float], n: Node) -> list[float]:
    """Where a stored arrow end ``p`` on the border of ``n`` is once ``n`` has moved and grown: it keeps its
    distance from the box's left (top) side, or from its right (bottom) side when it was on that one."""
    assert n.stored is not None
    ox, oy, ow, oh = n.stored

    def axis(v: float, o: float, size: float, new_o: float, new_size: float) -> float:
        return v - (o + size) + new_o + new_size if v >= o + size - 0.5 else v - o + new_o

    return [axis(p[0], ox, ow, n.x, n.w), axis(p[1], oy, oh, n.y, n.h)]


def _node_bbox(level: LevelLayout) -> Span:
    return _extent(_spans(level))


def _dict(v: Any) -> dict[str, Any]:
    """``v`` when it is a dictionary (a document's optional ``layout`` block), else an empty one."""
    return v if isinstance(v, dict) else {}


def _num(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _dicts(machine: dict[str, Any], key: str) -> list[dict[str, Any]]:
    """The dictionaries in the list ``machine[key]`` (its states or transitions); the rest is skipped."""
    items = machine.get(key)
    return [v for v in items if isinstance(v, dict)] if isinstance(items, list) else []


def _xy(lay: dict[str, Any], x: str, y: str) -> tuple[float, float] | None:
    """The stored numbers ``lay[x]`` and ``lay[y]`` (a position or a size) when both are finite, else None."""
    if _num(lay.get(x)) and _num(lay.get(y)):
        return float(lay[x]), float(lay[y])
    return None


def _rect(v: Any) -> tuple[float, float, float, float] | None:
    """``(x, y, w, h)`` of a stored box (a ``layout`` block) when all four are finite numbers, else None."""
    lay = _dict(v)
    if not all(_num(lay.get(k)) for k in "xywh"):
        return None
    return float(lay["x"]), float(lay["y"]), float(lay["w"]), float(lay["h"])


def _points(lay: dict[str, Any]) -> list[list[float]] | None:
    """The stored ``points`` of an arrow (at least two ``[x, y]`` of finite numbers), else None."""
    pts = lay.get("points")
    if not (isinstance(pts, list) and len(pts) >= 2 and all(_is_point(p) for p in pts)):
        return None
    return [[float(p[0]), float(p[1])] for p in pts]


def _is_point(p: Any) -> bool:
    return isinstance(p, list) and len(p) == 2 and all(_num(v) for v in p)


# -- tall levels ---------------------------------------------------------------------------------------------
#: A level taller than ``REFLOW_ASPECT`` times its width (and than ``REFLOW_MIN_H``) is reflowed into columns
#: (drawing only); the number of columns is the one whose height over width comes nearest to ``REFLOW_TARGET``.
REFLOW_ASPECT, REFLOW_MIN_H, REFLOW_TARGET = 2.0, 900.0, 0.75
#: The most columns tried (more for a very long chain: about the square root of its length).
MAX_COLUMNS = 12
#: A level that is one column of states (two bands in three hold one state) is reflowed from this height over width.
COLUMN_ASPECT = 1.0


def _bands(level: LevelLayout) -> list[list[tuple[float, float, float, float, Node | None]]]:
    """The level's boxes (states, and the initial marker as ``None``) cut into horizontal bands: a band ends where
    a horizontal line meets no box. Top to bottom."""
    items: list[tuple[float, float, float, float, Node | None]] = [(n.x, n.y, n.w, n.h, n) for n in level.nodes]
    if level.marker is not None:  # it reaches down to its state, so that the two stay in one band
        mx, my = level.marker
        reach = level.initial.y + 1 - my if level.initial is not None else level.marker_size[1]
        items.append((mx, my, level.marker_size[0], max(level.marker_size[1], reach), None))
    items.sort(key=lambda b: (b[1], b[0]))
    bands: list[list[tuple[float, float, float, float, Node | None]]] = []
    bottom = -math.inf
    for b in items:
        if not bands or b[1] >= bottom:
            bands.append([])
        bands[-1].append(b)
        bottom = max(bottom, b[1] + b[3])
    return bands


def _columns(sizes: list[tuple[float, float]], gap_x: float) -> list[list[int]]:
    """Consecutive bands (``(width, height)`` each) split into columns: for each number of columns, the lowest
    column height that holds them all in that many (cut greedily); of those, the split whose height over width is
    nearest ``REFLOW_TARGET`` (of two alike, the one with fewer columns)."""
    best: tuple[float, list[list[int]]] = (math.inf, [list(range(len(sizes)))])
    total = sum(h for _, h in sizes) + GAP_Y * (len(sizes) - 1)
    tallest = max(h for _, h in sizes)
    for k in range(2, min(len(sizes), max(MAX_COLUMNS, math.isqrt(len(sizes)) + 1)) + 1):
        cols = _split_in(sizes, k, max(tallest, total / k))
        score = _score(sizes, cols, gap_x)
        if score < best[0]:
            best = (score, cols)
    return best[1]


def _split_in(sizes: list[tuple[float, float]], k: int, limit: float) -> list[list[int]]:
    """The bands cut into at most ``k`` columns, as low as that takes: from ``limit`` (an even share of the height,
    at least the tallest band), a little more a time."""
    cols = _cut_columns(sizes, limit)
    while len(cols) > k:  # a band did not fit where the even share ended: a little more height a column
        limit *= 1.05
        cols = _cut_columns(sizes, limit)
    return cols


def _score(sizes: list[tuple[float, float]], cols: list[list[int]], gap_x: float) -> float:
    """How far the columns' height over width is from ``REFLOW_TARGET`` (by its logarithm), and a little for each
    column."""
    width = sum(max(sizes[i][0] for i in c) for c in cols) + gap_x * (len(cols) - 1)
    tall = max(sum(sizes[i][1] for i in c) + GAP_Y * (len(c) - 1) for c in cols)
    return abs(math.log(tall / width / REFLOW_TARGET)) + 0.05 * len(cols)


def _cut_columns(sizes: list[tuple[float, float]], limit: float) -> list[list[int]]:
    """The bands in order, a new column wherever the next one would make the column taller than ``limit``."""
    cols: list[list[int]] = [[]]
    height = 0.0
    for i, (_, h) in enumerate(sizes):
        if cols[-1] and height + GAP_Y + h > limit + 1:
            cols.append([])
            height = 0.0
        height += (GAP_Y if cols[-1] else 0) + h
        cols[-1].append(i)
    return cols


def _reflow(level: LevelLayout, label_width: Callable[[dict[str, Any]], float] | None) -> None:
    """A level much taller than wide (a long chain of states, as a diagram drawn as one column) is cut into its
    horizontal bands and the bands set into columns side by side, in order, so that the drawing reads in a
    page rather than as a strip. Each band keeps its own arrangement; every node remembers how far it moved
    (``reflowed``), so arrows within a band keep their stored bends and arrows between bands are drawn anew."""
    bands = _tall_bands(level)
    if bands is None:
        return
    x0, y0, _, _ = _node_bbox(level)
    boxes = [_extent([(x, y, x + w, y + h) for x, y, w, h, _ in band]) for band in bands]
    widths = [label_width(tr) for tr in _dicts(level.machine, "transitions")] if label_width is not None else []
    gap_x = GAP_X + min(max(widths, default=0.0), 240.0)
    sizes = [(bx1 - x0, by1 - by0) for _, by0, bx1, by1 in boxes]
    columns = _columns(sizes, gap_x)
    if len(columns) >= 2:
        _set_columns(level, [(bands[i], boxes[i][1], sizes[i]) for i in range(len(bands))], columns, gap_x)


def _set_columns(level: LevelLayout, bands: list[tuple[list[tuple[float, float, float, float, Node | None]], float,
                                                        tuple[float, float]]],
                 columns: list[list[int]], gap_x: float) -> None:
    """Move the bands (each with its top and its size from the level's left) into ``columns`` side by side, from
    the level's top left corner, each column ``gap_x`` right of the one before."""
    x0, y0, _, _ = _node_bbox(level)
    left = x0
    for col in columns:
        top = y0
        for i in col:
            band, band_top, (_, height) = bands[i]
            dy = _snap(top - band_top)
            _move_band(level, band, left - x0, dy)
            top = band_top + dy + height + GAP_Y
        left += _snap(max(bands[i][2][0] for i in col) + gap_x)


def _tall_bands(level: LevelLayout) -> list[list[tuple[float, float, float, float, Node | None]]] | None:
    """The level's bands when it is to be reflowed into columns: at least four states and three bands, no note,
    taller than ``REFLOW_MIN_H`` and than ``COLUMN_ASPECT`` times its width, and either taller than
    ``REFLOW_ASPECT`` times its width or one column of states (two bands in three hold one state); else None."""
    if len(level.nodes) < 4 or level.note is not None:
        return None
    x0, y0, x1, y1 = _node_bbox(level)
    if y1 - y0 <= max(REFLOW_MIN_H, COLUMN_ASPECT * (x1 - x0)):
        return None
    bands = _bands(level)
    if len(bands) < 3 or (y1 - y0 <= REFLOW_ASPECT * (x1 - x0) and 3 * _singles(bands) < 2 * len(bands)):
        return None
    return bands


def _singles(bands: list[list[tuple[float, float, float, float, Node | None]]]) -> int:
    """How many of the bands hold one state."""
    return sum(1 for band in bands if sum(1 for b in band if b[4] is not None) == 1)


def _move_band(level: LevelLayout, band: list[tuple[float, float, float, float, Node | None]], dx: float,
               dy: float) -> None:
    """Move a band's states (each remembering it, ``reflowed``) and the initial marker with its arrow."""
    for *_, n in band:
        if n is None:
            assert level.marker is not None
            level.marker = (level.marker[0] + dx, level.marker[1] + dy)
            level.marker_points = _moved(level.marker_points, dx, dy)
        else:
            n.move(dx, dy)
            n.reflowed = (dx, dy)


# -- arrows ----------------------------------------------------------------------------------------------------
def _route(level: LevelLayout, drawing: bool = False) -> None:
    """Each arrow's points: its stored ones (following its boxes when they moved) where it has them, else a
    loop, a bowed arrow of several between two boxes (drawing), or a straight one. When ``drawing``, arrows
    are then set apart and routed around the boxes in their way."""
    pair_count: dict[tuple[int, int], int] = {}
    pair_total = Counter(_pair(e) for e in level.edges)
    index = {id(n): i for i, n in enumerate(level.nodes)}
    for e in level.edges:
        if _keep_stored_points(level, e):
            continue
        key = _pair(e)
        k = pair_count.get(key, 0)
        pair_count[key] = k + 1
        e.points = _drawn_anew(e, k, pair_total[key] if drawing else 1, index[id(e.src)] < index[id(e.dst)])
    if drawing:
        _separate_duplicates(level)
        _reroute(level)
        _spread_pairs(level)


def _drawn_anew(e: Edge, k: int, total: int, forward: bool) -> list[list[float]]:
    """The points of the ``k``-th of ``total`` arrows between the same two boxes, drawn anew: a loop, one of several
    bowed apart (``forward``: from the earlier box of the level to the later), or a straight one."""
    a, b = (e.src.x, e.src.y, e.src.w, e.src.h), (e.dst.x, e.dst.y, e.dst.w, e.dst.h)
    if e.src is e.dst:
        return _loop(a, k)
    if total > 1:
        return _bowed(a, b, k, total, forward)
    return _connect(a, b, k)


def _pair(e: Edge) -> tuple[int, int]:
    """The two boxes an arrow joins, in either direction."""
    return min(id(e.src), id(e.dst)), max(id(e.src), id(e.dst))


def _keep_stored_points(level: LevelLayout, e: Edge) -> bool:
    """Give ``e`` its stored points when it has them and its two boxes kept theirs (or moved together); when the
    boxes moved, its ends stay on them and its bends follow the inserted space. Whether it had them."""
    pts = _points(_dict(e.doc.get("layout")))
    # a stored box (``stored``) is placed where it was stored
    if pts is None or e.src.stored is None or e.dst.stored is None or e.src.reflowed != e.dst.reflowed:
        return False
    e.points = pts
    if level.inserted or e.src.reflowed != (0.0, 0.0):  # boxes moved: the ends stay on their boxes
        middle = _bends(e.points, level.inserted, e.src.detached or e.dst.detached, e.src.reflowed)
        e.points = [_attach(e.points[0], e.src)] + middle + [_attach(e.points[-1], e.dst)]
    return True


def _loop(box: tuple[float, float, float, float], k: int) -> list[list[float]]:
    """The ``k``-th arrow from a box to itself: a loop out of its right side, wider for each further one."""
    x, y, w, h = box
    off = 12 * k
    cy = y + h / 2
    return [[x + w, cy - 8 - off / 2], [x + w + 40 + off, cy - 8 - off / 2],
            [x + w + 40 + off, cy + 8 + off / 2], [x + w, cy + 8 + off / 2]]


def _separate_duplicates(level: LevelLayout) -> None:
    """Stored arrows that lie exactly on top of one another get a bend each, so every one can be seen."""
    groups: dict[tuple[tuple[int, int], ...], int] = {}
    for e in level.edges:
        if e.src is e.dst or len(e.points) < 2:
            continue
        key = tuple((round(p[0]), round(p[1])) for p in e.points)
        canon = min(key, key[::-1])
        k = groups.get(canon, 0)
        groups[canon] = k + 1
        if k:
            _bend_apart(e, canon, k)


def _bend_apart(e: Edge, canon: tuple[tuple[int, int], ...], k: int) -> None:
    """The ``k``-th arrow on the line ``canon`` (its rounded points) gets a bend in its middle segment, on
    alternate sides of the line, further out for each further pair."""
    (ax, ay), (bx, by) = canon[0], canon[-1]
    nx, ny = _normal(ax, ay, bx, by)
    off = 18 * ((k + 1) // 2) * (1 if k % 2 else -1)
    i = (len(e.points) - 1) // 2
    p, q = e.points[i], e.points[i + 1]
    bend = [float(round((p[0] + q[0]) / 2 + nx * off)), float(round((p[1] + q[1]) / 2 + ny * off))]
    e.points = e.points[:i + 1] + [bend] + e.points[i + 1:]


def _spread_pairs(level: LevelLayout) -> None:
    """Two straight arrows between the same two boxes (a stored diagram's pair, drawn a little apart) that run side
    by side closer than ``SPACING`` are moved apart to ``SPACING``, each by half, their ends kept on the boxes; two
    that cross swap their ends on one box."""
    straight: dict[tuple[int, int], list[Edge]] = {}
    for e in level.edges:
        if e.src is not e.dst and len(e.points) == 2:
            straight.setdefault(_pair(e), []).append(e)
    for pair in straight.values():
        for e, f in combinations(pair, 2):
            _part_two(e, f)


def _part_two(e: Edge, f: Edge) -> None:
    """Two straight arrows between the same boxes: swap an end when they cross, else move them apart to
    ``SPACING`` when they run side by side closer than that."""
    (a0, a1), (a2, a3) = e.points
    (b0, b1), (b2, b3) = f.points
    a, b = (a0, a1, a2, a3), (b0, b1, b2, b3)
    if segments_cross(a, b):  # the two cross: each takes the other's end on one of the boxes
        j = 0 if f.src is e.src else 1
        e.points[0], f.points[j] = f.points[j], e.points[0]
        return
    gap = parallel_gap(a, b, 0.0)
    if not 0.5 < gap < SPACING:
        return
    dx, dy = a[2] - a[0], a[3] - a[1]
    length = math.hypot(dx, dy)
    nx, ny = -dy / length, dx / length
    if (b[0] - a[0]) * nx + (b[1] - a[1]) * ny < 0:  # the normal points from e towards f
        nx, ny = -nx, -ny
    half = (SPACING - gap) / 2 + 1  # whole units: the SVG rounds the points
    _shift_straight(e, -nx * half, -ny * half)
    _shift_straight(f, nx * half, ny * half)


def _shift_straight(e: Edge, sx: float, sy: float) -> None:
    """The straight arrow ``e`` moved by (``sx``, ``sy``), its ends where the moved line leaves and enters its boxes."""
    (ax, ay), (bx, by) = e.points
    length = math.hypot(bx - ax, by - ay) or 1.0
    ux, uy = (bx - ax) / length * 6, (by - ay) / length * 6  # a few units back into each box
    s_in = (ax + sx - ux, ay + sy - uy)
    t_in = (bx + sx + ux, by + sy + uy)
    p = _exit_point((e.src.x, e.src.y, e.src.w, e.src.h), *s_in, *t_in)
    q = _exit_point((e.dst.x, e.dst.y, e.dst.w, e.dst.h), *t_in, *s_in)
    e.points = [[round(p[0], 1), round(p[1], 1)], [round(q[0], 1), round(q[1], 1)]]


#: Routing around boxes (drawing only): how far a detour keeps from a box, what a bend costs (in drawing
#: units of length), and the most boxes a level may have for its arrows to be routed (the grid grows with the
#: square of it).
CLEARANCE, BEND, ROUTE_MAX = 12, 60.0, 80
#: How close an arrow may run along a box that is not one of its ends (closer, it looks as if it went in).
GRAZE = 4.0
Seg = tuple[float, float, float, float]
#: Routing passes: after the first, each routed arrow is routed again with all the others in place.
ROUTE_PASSES = 2
#: What crossing another arrow costs a routed arrow, in drawing units of length.
CROSS = 600.0
#: What running beside an arrow routed before, closer than ``SPACING``, costs, as a share of ``CROSS`` (running on it
#: costs all of ``CROSS``): less than a crossing, so that keeping apart never costs a crossing more.
BESIDE = 0.2


def _reroute(level: LevelLayout) -> None:
    """Arrows that run through a box of their level other than their ends get a new path: horizontal and vertical
    runs along the free channels between the boxes (a shortest path with few bends on the grid of lines
    ``CLEARANCE`` off every box's sides and through the ends' middles), from the side of the source that faces
    the way to go to the side of the target it comes from. Stored bends are kept for every arrow that is clear.
    A machine included several times is routed once (:func:`_routes` remembers the answer)."""
    if len(level.nodes) > ROUTE_MAX:
        return
    index = {id(n): i for i, n in enumerate(level.nodes)}
    arrows = tuple((index[id(e.src)], index[id(e.dst)], _frozen(e.points)) for e in level.edges)
    boxes = tuple((n.x, n.y, n.w, n.h) for n in level.nodes)
    for e, path in zip(level.edges, _routes(boxes, arrows, _frozen(level.marker_points)), strict=True):
        if path is not None:
            e.points = [list(p) for p in path]


Point = tuple[float, float]


def _frozen(pts: list[list[float]]) -> tuple[Point, ...]:
    """Points as tuples: a key of :func:`_routes`' memory."""
    return tuple((p[0], p[1]) for p in pts)


@functools.lru_cache(maxsize=64)
def _routes(boxes: tuple[Seg, ...], arrows: tuple[tuple[int, int, tuple[Point, ...]], ...],
            marker: tuple[Point, ...]) -> tuple[tuple[Point, ...] | None, ...]:
    """For each arrow ``(source, target, points)`` among ``boxes``, its new path, or None to keep its own."""
    bad = _through_boxes(boxes, arrows)
    kept = _kept_segments(arrows, bad, marker)
    crossings: dict[Seg, int] = {}
    hits: dict[Seg, tuple[int, ...]] = {}
    paths: dict[int, list[list[float]]] = {}
    for _ in range(ROUTE_PASSES):  # the first pass sees the arrows routed before; the next ones all the others
        for n, k in enumerate(bad):
            used, routed = _others(paths, k)
            found = _grid_path(list(boxes), arrows[k][0], arrows[k][1], used, n, (kept, routed, crossings, hits))
            if found is not None:
                paths[k] = found
    return tuple(tuple((p[0], p[1]) for p in paths[k]) if k in paths else None for k in range(len(arrows)))


def _kept_segments(arrows: tuple[tuple[int, int, tuple[Point, ...]], ...], bad: list[int],
                   marker: tuple[Point, ...]) -> list[Seg]:
    """The segments of the arrows that keep their path (all but ``bad``) and of the initial marker's arrow."""
    kept = [(a[0], a[1], b[0], b[1]) for k, (_, _, pts) in enumerate(arrows) if k not in bad
            for a, b in pairwise(pts)]
    return kept + [(a[0], a[1], b[0], b[1]) for a, b in pairwise(marker)]


def _through_boxes(boxes: tuple[Seg, ...], arrows: tuple[tuple[int, int, tuple[Point, ...]], ...]) -> list[int]:
    """The arrows (not loops) that run through, or closer than ``GRAZE`` along, a box other than their ends."""
    return [k for k, (si, ti, pts) in enumerate(arrows) if si != ti and len(pts) >= 2 and any(
        i not in (si, ti) and segment_hits_box(a[0], a[1], b[0], b[1], boxes[i], -GRAZE)
        for a, b in pairwise(pts) for i in range(len(boxes)))]


def _others(paths: dict[int, list[list[float]]], k: int,
            ) -> tuple[dict[tuple[int, float], list[tuple[float, float]]], list[Seg]]:
    """The paths routed so far but arrow ``k``'s: their horizontal and vertical runs (``(0, y)`` or ``(1, x)``
    to their spans), and all their segments."""
    used: dict[tuple[int, float], list[tuple[float, float]]] = {}
    routed: list[Seg] = []
    for o, path in paths.items():
        if o == k:
            continue
        for a, b in pairwise(path):
            if a[1] == b[1]:
                used.setdefault((0, a[1]), []).append((min(a[0], b[0]), max(a[0], b[0])))
            elif a[0] == b[0]:
                used.setdefault((1, a[0]), []).append((min(a[1], b[1]), max(a[1], b[1])))
            routed.append((a[0], a[1], b[0], b[1]))
    return used, routed


def _grid_path(boxes: list[tuple[float, float, float, float]], si: int, ti: int,
               used: dict[tuple[int, float], list[tuple[float, float]]], k: int,
               seen: tuple[list[Seg], list[Seg], dict[Seg, int], dict[Seg, tuple[int, ...]]],
               ) -> list[list[float]] | None:
    """The orthogonal path (Dijkstra over (grid point, direction)) from the middle of box ``si`` to the middle of
    box ``ti`` that passes through no other box, cut at the two boxes' borders; None when there is none. Each
    crossing of an arrow (``seen``: the level's arrows that keep their path, the arrows routed before, and
    what is known of each grid run: how many of the first it crosses, which boxes it touches) and each
    stretch along an arrow routed before (``used``) costs ``CROSS``; the ends are set off by ``k`` (mod 3) so
    that arrows sharing a box do not share their last run. A* with the Manhattan distance to the goal."""
    kept, routed, crossings, hits = seen
    across_h, across_v = _runs(routed)
    c = CLEARANCE
    s, t = boxes[si], boxes[ti]
    off = (k % 3 - 1) * SPACING
    start = (s[0] + s[2] / 2 + _within(off, s[2]), s[1] + s[3] / 2 + _within(off, s[3]))
    goal = (t[0] + t[2] / 2 + _within(off, t[2]), t[1] + t[3] / 2 + _within(off, t[3]))
    xs, ys = _grid_lines(boxes, start, goal)

    def free(a: tuple[float, float], b: tuple[float, float], key: Seg) -> bool:
        """No box in the way; the ends' own boxes only left (entered) straight from (to) their middle."""
        lo_x, lo_y, hi_x, hi_y = key
        inside = hits.get(key)
        if inside is None:
            inside = hits[key] = tuple(i for i, r in enumerate(boxes) if lo_x < r[0] + r[2] + GRAZE
                                       and hi_x > r[0] - GRAZE and lo_y < r[1] + r[3] + GRAZE and hi_y > r[1] - GRAZE)
        if any(i != si and i != ti for i in inside):
            return False
        for r, (px, py) in ((s, start), (t, goal)):
            if lo_x < r[0] + r[2] + c - 1 and hi_x > r[0] - c + 1 and lo_y < r[1] + r[3] + c - 1 \
                    and hi_y > r[1] - c + 1 and not (lo_x == hi_x == px or lo_y == hi_y == py):
                return False
        return True

    # A run's cost but for the bend is the same both ways and each time the search reaches it: worked out once per
    # run (as ``(length and shared runs, crossings)``, None when it is not free) and summed in the same order.
    runs: dict[Seg, tuple[float, float] | None] = {}

    def step_cost(a: tuple[float, float], b: tuple[float, float], turned: bool) -> float | None:
        """What the grid run from ``a`` to ``b`` costs (None: it is not free)."""
        key = a + b if a <= b else b + a  # (grid neighbours differ in one coordinate: its lower end first)
        if key in runs:
            parts = runs[key]
        else:
            parts = runs[key] = None if not free(a, b, key) else (
                abs(b[0] - a[0]) + abs(b[1] - a[1]) + CROSS * _shared(used, a, b),
                CROSS * _crossed(key, kept, crossings, across_h, across_v))
        if parts is None:
            return None
        return parts[0] + (BEND if turned else 0) + parts[1]

    xi, yi = {v: i for i, v in enumerate(xs)}, {v: i for i, v in enumerate(ys)}
    end = _cheapest(xs, ys, (xi[start[0]], yi[start[1]]), (xi[goal[0]], yi[goal[1]]), step_cost)
    if end is None:
        return None
    return _cut(_corners(*end, xs, ys), s, t)


def _runs(routed: list[Seg]) -> tuple[list[tuple[float, float, float]], list[tuple[float, float, float]]]:
    """The horizontal runs of the arrows routed before as ``(y, x0, x1)``, and their vertical runs as
    ``(x, y0, y1)``."""
    across_h = [(a[1], min(a[0], a[2]), max(a[0], a[2])) for a in routed if a[1] == a[3] and a[0] != a[2]]
    across_v = [(a[0], min(a[1], a[3]), max(a[1], a[3])) for a in routed if a[0] == a[2] and a[1] != a[3]]
    return across_h, across_v


def _grid_lines(boxes: list[tuple[float, float, float, float]], start: Point, goal: Point,
                ) -> tuple[list[float], list[float]]:
    """The grid's vertical and horizontal lines: two lanes beside every side of every box, ``SPACING`` apart (so
    that a second arrow along a box need not run on, or right beside, the first), and through the two ends."""
    c = CLEARANCE
    far = c + SPACING
    xs = sorted({v for x, _, w, _ in boxes for v in (x - c, x - far, x + w + c, x + w + far)}
                | {start[0], goal[0]})
    ys = sorted({v for _, y, _, h in boxes for v in (y - c, y - far, y + h + c, y + h + far)}
                | {start[1], goal[1]})
    return xs, ys


def _cheapest(xs: list[float], ys: list[float], origin: tuple[int, int], target: tuple[int, int],
              step_cost: Callable[[Point, Point, bool], float | None],
              ) -> tuple[tuple[int, int], dict[tuple[int, int], tuple[int, int] | None]] | None:
    """A* over the grid points from ``origin`` to ``target`` (indices into ``xs`` and ``ys``), each run costing
    ``step_cost(a, b, turned)``, with the Manhattan distance to the target: the target and the way each point
    was reached, or None when it cannot be reached."""
    steps = ((1, 0), (-1, 0), (0, 1), (0, -1))
    # one state per grid point (the direction it is reached in rides along): a bend is charged against the
    # cheapest way in, which is not always the cheapest path with bends counted, but four times less to search
    best: dict[tuple[int, int], float] = {origin: 0.0}
    came: dict[tuple[int, int], tuple[int, int] | None] = {origin: None}
    heap: list[tuple[float, float, int, int, int]] = [(0.0, 0.0, origin[0], origin[1], -1)]
    gx, gy = xs[target[0]], ys[target[1]]
    while heap:
        _, cost, i, j, d = heapq.heappop(heap)
        if cost > best.get((i, j), math.inf):
            continue
        if (i, j) == target:
            return (i, j), came
        a = (xs[i], ys[j])
        for nd, (di, dj) in enumerate(steps):
            ni, nj = i + di, j + dj
            if not (0 <= ni < len(xs) and 0 <= nj < len(ys)):
                continue
            b = (xs[ni], ys[nj])
            step = step_cost(a, b, nd != d and d >= 0)
            if step is None:
                continue
            new = cost + step
            if new < best.get((ni, nj), math.inf):
                best[(ni, nj)] = new
                came[(ni, nj)] = (i, j)
                heapq.heappush(heap, (new + abs(b[0] - gx) + abs(b[1] - gy), new, ni, nj, nd))
    return None


def _crossed(key: Seg, kept: list[Seg], crossings: dict[Seg, int], across_h: list[tuple[float, float, float]],
             across_v: list[tuple[float, float, float]]) -> int:
    """How many arrows the grid run ``key`` crosses: those that keep their path (counted once a run, in
    ``crossings``) and the ones routed before (horizontal and vertical runs: only the crosswise ones cross)."""
    crossed = crossings.get(key)
    if crossed is None:
        crossed = crossings[key] = sum(segments_cross(key, seg) for seg in kept)
    if key[1] == key[3]:
        y = key[1]
        return crossed + sum(1 for x, y0, y1 in across_v if key[0] < x < key[2] and y0 < y < y1)
    x = key[0]
    return crossed + sum(1 for y, x0, x1 in across_h if key[1] < y < key[3] and x0 < x < x1)


def _corners(end: tuple[int, int], came: dict[tuple[int, int], tuple[int, int] | None], xs: list[float],
             ys: list[float]) -> list[tuple[float, float]]:
    """The path the search found, back from its end, as its corners only."""
    cells: list[tuple[int, int]] = []
    cur: tuple[int, int] | None = end
    while cur is not None:
        cells.append(cur)
        cur = came[cur]
    pts = [(xs[i], ys[j]) for i, j in reversed(cells)]
    corners = [pts[0]]
    for p, q in pairwise(pts[1:]):
        before = corners[-1]
        if not ((before[0] == p[0] == q[0]) or (before[1] == p[1] == q[1])):
            corners.append(p)
    corners.append(pts[-1])
    return corners


def _cut(corners: list[tuple[float, float]], s: Seg, t: Seg) -> list[list[float]] | None:
    """The path cut at the borders: it leaves the source where it first leaves it and enters the target where it
    last enters it; None when the two boxes overlap (no path between their borders)."""
    first = next((i for i in range(1, len(corners)) if not _inside_box(corners[i], s)), None)
    last = max((i for i in range(len(corners) - 1) if not _inside_box(corners[i], t)), default=None)
    if first is None or last is None or first > last + 1:
        return None
    p0 = _exit_point(s, *corners[first - 1], *corners[first])
    p1 = _exit_point(t, *corners[last + 1], *corners[last])
    path = [p0] + corners[first:last + 1] + [p1]
    return [[round(x), round(y)] for x, y in path]


def _shared(used: dict[tuple[int, float], list[tuple[float, float]]], a: tuple[float, float],
            b: tuple[float, float]) -> float:
    """How many routed runs the run ``a``-``b`` would lie on (for some length), plus ``BESIDE`` for each it would
    run beside closer than ``SPACING``."""
    (axis, at), lo, hi = ((0, a[1]), a[0], b[0]) if a[1] == b[1] else ((1, a[0]), a[1], b[1])
    lo, hi = min(lo, hi), max(lo, hi)
    return sum(1 if line == at else BESIDE for (other, line), spans in used.items()
               if other == axis and abs(line - at) < SPACING for s0, s1 in spans if min(hi, s1) - max(lo, s0) > 1)


def _within(off: float, size: float) -> float:
    """An arrow end's offset from the middle of a box side ``size`` long, kept a little inside the box."""
    lim = max(0.0, size / 2 - 6)
    return max(-lim, min(lim, off))


def _inside_box(p: tuple[float, float], r: tuple[float, float, float, float]) -> bool:
    return r[0] < p[0] < r[0] + r[2] and r[1] < p[1] < r[1] + r[3]


def _bowed(a: tuple[float, float, float, float], b: tuple[float, float, float, float], k: int, total: int,
           forward: bool) -> list[list[float]]:
    """The ``k``-th of ``total`` arrows between the same two boxes: its ends spread along the borders and its
    middle bent away from the others, so none is drawn over another."""
    ax, ay = a[0] + a[2] / 2, a[1] + a[3] / 2
    bx, by = b[0] + b[2] / 2, b[1] + b[3] / 2
    nx, ny = _normal(ax, ay, bx, by)
    if not forward:  # the same side for both directions: offsets measured from one of the two boxes
        nx, ny = -nx, -ny
    slot = k - (total - 1) / 2
    end_off = slot * 16
    lim = min(a[2], a[3], b[2], b[3]) / 2 - 6
    end_off = max(-lim, min(lim, end_off))
    sx, sy = ax + nx * end_off, ay + ny * end_off
    tx, ty = bx + nx * end_off, by + ny * end_off
    p = _exit_point(a, sx, sy, tx, ty)
    q = _exit_point(b, tx, ty, sx, sy)
    mid_off = slot * 36
    mx, my = (p[0] + q[0]) / 2 + nx * (mid_off - end_off), (p[1] + q[1]) / 2 + ny * (mid_off - end_off)
    if abs(slot) < 1e-9:
        return [[round(p[0]), round(p[1])], [round(q[0]), round(q[1])]]
    return [[round(p[0]), round(p[1])], [round(mx), round(my)], [round(q[0]), round(q[1])]]


def _normal(ax: float, ay: float, bx: float, by: float) -> tuple[float, float]:
    """The unit normal of the line from (``ax``, ``ay``) to (``bx``, ``by``), left of it in drawing coordinates
    (an arbitrary one when the two points are one)."""
    dx, dy = bx - ax, by - ay
    length = math.hypot(dx, dy) or 1.0
    return -dy / length, dx / length


def _connect(a: tuple[float, float, float, float], b: tuple[float, float, float, float],
             k: int) -> list[list[float]]:
    """A straight arrow from box ``a``'s border to box ``b``'s border; the ``k``-th parallel one is offset."""
    ax, ay = a[0] + a[2] / 2, a[1] + a[3] / 2
    bx, by = b[0] + b[2] / 2, b[1] + b[3] / 2
    nx, ny = _normal(ax, ay, bx, by)
    off: float = (k + 1) // 2 * 14 * (1 if k % 2 else -1) if k else 0
    lim = min(a[2], a[3], b[2], b[3]) / 2 - 4
    off = max(-lim, min(lim, off))
    sx, sy = ax + nx * off, ay + ny * off
    tx, ty = bx + nx * off, by + ny * off
    p = _exit_point(a, sx, sy, tx, ty)
    q = _exit_point(b, tx, ty, sx, sy)
    return [[round(p[0]), round(p[1])], [round(q[0]), round(q[1])]]


def _exit_point(box: tuple[float, float, float, float], x: float, y: float, tx: float,
                ty: float) -> tuple[float, float]:
    """Where the segment from (x, y) inside ``box`` towards (tx, ty) leaves the box."""
    bx, by, bw, bh = box
    dx, dy = tx - x, ty - y
    t = 1.0
    if dx > 0:
        t = min(t, (bx + bw - x) / dx)
    elif dx < 0:
        t = min(t, (bx - x) / dx)
    if dy > 0:
        t = min(t, (by + bh - y) / dy)
    elif dy < 0:
        t = min(t, (by - y) / dy)
    return x + dx * t, y + dy * t
