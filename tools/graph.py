"""Drawings of a machine with its nesting: Mermaid ``stateDiagram-v2``, Graphviz DOT, and SVG.

The SVG is drawn here, without Graphviz: boxes where the diagram's ``layout`` put them (a converted UMLet
diagram looks like the diagram), a layered layout (:mod:`fsm.tools.layout`) where there is none.
"""

from __future__ import annotations

import json
import math
import unicodedata
from collections.abc import Callable
from pathlib import Path
from typing import Any
from xml.sax.saxutils import escape, quoteattr

from fsm.document import normalize_legacy
from fsm.errors import DiagramError

from .layout import MARKER, REGION_HEAD, Edge, Expansion, LevelLayout, Node, inline_machine, lay_out

#: Includes nested deeper than this are drawn as a box naming the file (a guard, far beyond real diagrams).
MAX_INCLUDE_DEPTH = 16

_SKIP = {"type", "from", "to", "layout", "label", "description"}


def edge_label(tr: dict[str, Any]) -> str:
    """How a transition is labelled: its UML label, else its type and parameters."""
    if isinstance(tr.get("label"), str) and tr["label"]:
        return tr["label"]
    params = [f"{k}={v if isinstance(v, str) else json.dumps(v)}" for k, v in tr.items() if k not in _SKIP]
    typ = str(tr.get("type", ""))
    return typ + (" " + ", ".join(params) if params else "")


def state_label(st: dict[str, Any]) -> str:
    typ = st.get("type")
    if typ in (None, "Idle", "FSMState") and inline_machine(st) is not None or typ == "Idle":
        return str(st.get("id"))
    return f"{st.get('id')} ({typ})"


def _sub_machines(st: dict[str, Any]) -> list[dict[str, Any]]:
    m = inline_machine(st)
    if m is not None:
        return [m]
    regions = st.get("regions")
    if st.get("type") == "Parallel" and isinstance(regions, list):
        return [r for r in regions if isinstance(r, dict) and isinstance(r.get("states"), list)]
    return []


# -- Mermaid ---------------------------------------------------------------------------------------------------
def mermaid(doc: dict[str, Any]) -> str:
    lines = ["stateDiagram-v2"]
    counter = [0]

    def mtext(text: str) -> str:
        return text.replace("\n", " ").replace(";", ",").replace('"', "'").replace(":", "#58;")

    def level(machine: dict[str, Any], indent: str) -> None:
        ids: dict[str, str] = {}
        for st in machine.get("states", []):
            counter[0] += 1
            ids[str(st.get("id"))] = f"s{counter[0]}"
        if machine.get("initial") in ids:
            lines.append(f"{indent}[*] --> {ids[machine['initial']]}")
        for st in machine.get("states", []):
            sid = ids[str(st.get("id"))]
            subs = _sub_machines(st)
            label = mtext(state_label(st))
            if subs:
                lines.append(f'{indent}state "{label}" as {sid} {{')
                for i, sub in enumerate(subs):
                    if i:
                        lines.append(f"{indent}  --")
                    level(sub, indent + "  ")
                lines.append(f"{indent}}}")
            else:
                lines.append(f'{indent}state "{label}" as {sid}')
            if st.get("type") == "Final":
                lines.append(f"{indent}{sid} --> [*]")
        for tr in machine.get("transitions", []):
            a, b = ids.get(str(tr.get("from"))), ids.get(str(tr.get("to")))
            if a and b:
                lines.append(f"{indent}{a} --> {b} : {mtext(edge_label(tr))}")

    level(doc, "  ")
    return "\n".join(lines) + "\n"


# -- DOT -------------------------------------------------------------------------------------------------------
def dot(doc: dict[str, Any]) -> str:
    out = ["digraph machine {", "  compound=true;", '  rankdir=TB;', '  node [shape=box, style=rounded, fontname="Helvetica"];',
           '  edge [fontname="Helvetica", fontsize=10];']
    counter = [0]

    def q(text: str) -> str:
        return json.dumps(text, ensure_ascii=False)

    def level(machine: dict[str, Any], indent: str) -> dict[str, tuple[str, str | None]]:
        nodes: dict[str, tuple[str, str | None]] = {}
        counter[0] += 1
        start = f"init{counter[0]}"
        out.append(f'{indent}{start} [shape=point, width=0.15, label=""];')
        for st in machine.get("states", []):
            counter[0] += 1
            n = f"n{counter[0]}"
            subs = _sub_machines(st)
            if subs:
                out.append(f"{indent}subgraph cluster_{n} {{")
                out.append(f'{indent}  label={q(state_label(st))}; style=rounded;')
                anchor = None
                for sub in subs:
                    inner = level(sub, indent + "  ")
                    anchor = anchor or next(iter(inner.values()))[0] if inner else anchor
                out.append(f"{indent}}}")
                nodes[str(st.get("id"))] = (anchor or n, f"cluster_{n}")
            else:
                shape = ', shape=doublecircle, label=' + q(str(st.get("id"))) if st.get("type") == "Final" else \
                    ", label=" + q(state_label(st))
                out.append(f"{indent}{n} [{shape[2:]}];")
                nodes[str(st.get("id"))] = (n, None)
        init = nodes.get(str(machine.get("initial")))
        if init:
            extra = f" [lhead={init[1]}]" if init[1] else ""
            out.append(f"{indent}{start} -> {init[0]}{extra};")
        for tr in machine.get("transitions", []):
            a, b = nodes.get(str(tr.get("from"))), nodes.get(str(tr.get("to")))
            if not (a and b):
                continue
            attrs = [f"label={q(edge_label(tr))}"]
            if a[1]:
                attrs.append(f"ltail={a[1]}")
            if b[1]:
                attrs.append(f"lhead={b[1]}")
            out.append(f"{indent}{a[0]} -> {b[0]} [{', '.join(attrs)}];")
        return nodes

    level(doc, "  ")
    out.append("}")
    return "\n".join(out) + "\n"


# -- SVG -------------------------------------------------------------------------------------------------------
#: Advance widths (1/100 em) of the printable ASCII characters (space .. ~) in DejaVu Sans, the widest of the
#: fonts the SVG names or falls back to; text measured with it fits when drawn in Helvetica or Arial too.
_WIDTHS = (
    32, 40, 46, 84, 64, 95, 78, 27, 39, 39, 50, 84, 32, 36, 32, 34, 64, 64, 64, 64, 64, 64, 64, 64, 64, 64, 34, 34,
    84, 84, 84, 53, 100, 68, 69, 70, 77, 63, 58, 77, 75, 29, 29, 66, 56, 86, 75, 79, 60, 79, 69, 63, 61, 73, 68, 99,
    69, 61, 69, 39, 34, 39, 84, 50, 50, 61, 63, 55, 63, 62, 35, 63, 63, 28, 28, 58, 28, 97, 63, 61, 63, 63, 41, 52,
    39, 63, 59, 82, 59, 59, 52, 64, 34, 64, 84,
)
FONT, LABEL_FONT, SMALL_FONT, MIN_FONT = 12, 11, 10, 8
BOX_MARGIN = 8  # text keeps this far from a box's left and right border
FINAL_ICON = 30  # a final state's box: room for the bull's eye at its left


def text_width(text: str, size: float, bold: bool = False) -> float:
    """An estimate (on the wide side) of how wide ``text`` is drawn at font size ``size``."""
    total = 0
    for ch in text:
        code = ord(ch)
        if 32 <= code < 127:
            total += _WIDTHS[code - 32]
        elif unicodedata.east_asian_width(ch) in ("W", "F"):
            total += 100
        else:
            base = unicodedata.normalize("NFKD", ch)[:1]
            total += _WIDTHS[ord(base) - 32] if base and 32 <= ord(base) < 127 else 84
    return total / 100 * size * (1.15 if bold else 1.0)


def final_text(st: dict[str, Any]) -> str:
    """A final state's text: ``id → outcome``, or the id alone when it is its outcome."""
    sid = str(st.get("id"))
    outcome = str(st.get("outcome", "succeeded"))
    return sid if outcome == sid else f"{sid} → {outcome}"


def _fit(text: str, avail: float, size: float, bold: bool = False) -> tuple[str, float]:
    """``text`` at the largest size down to ``MIN_FONT`` that fits ``avail``; shortened with … if none does."""
    s = float(size)
    while s > MIN_FONT and text_width(text, s, bold) > avail:
        s -= 0.5
    if text_width(text, s, bold) <= avail:
        return text, s
    k = len(text)
    while k > 0 and text_width(text[:k] + "…", s, bold) > avail:
        k -= 1
    return (text[:k] + "…" if k else ""), s


def _parallel_note(st: dict[str, Any]) -> str:
    join = st.get("join")
    return "(Parallel" + (f", join={join}" if isinstance(join, str) else "") + ")"


def _expander(directory: Path | None, where: str = "", stack: tuple[Path, ...] = (),
              seen: dict[Path, Any] | None = None) -> Callable[[dict[str, Any]], Expansion | None]:
    """What a composite shows: inline machines, ``{"file": ...}`` includes (read relative to ``directory``, the
    including file's folder) and the regions of a ``Parallel`` state.

    An included file is drawn where it is first included (in document order); a later include of the same file
    is a box naming the file and that first place, so a machine reused many times is drawn once.
    """
    seen = {} if seen is None else seen  # file -> (document, folder) | "problem", and where it is drawn

    def resolve(ref: dict[str, Any], here: str) -> tuple[dict[str, Any] | None, Any, str, bool]:
        """(machine, expand hook for its states, note, whether the note is an error)."""
        file = str(ref.get("file"))
        if directory is None:
            return None, None, f"{file} (not opened)", False
        path = (directory / file).resolve()
        if path in stack:
            return None, None, f"{file}: include cycle", True
        if len(stack) >= MAX_INCLUDE_DEPTH:
            return None, None, f"{file}: nested too deep", True
        if path not in seen:
            seen[path] = (_read_include(path), here)
            got = seen[path][0]
            if isinstance(got, str):
                return None, None, f"{file}: {got}", True
            data, folder = got
            return data, _expander(folder, here, stack + (path,), seen), file, False
        got, first = seen[path]
        if isinstance(got, str):
            return None, None, f"{file}: {got}", True
        return None, None, f"{file}, drawn in {first}", False

    def part(ref: Any, here: str) -> tuple[dict[str, Any] | None, Any, str | None, bool]:
        if isinstance(ref, dict) and "file" in ref:
            return resolve(ref, here)
        if isinstance(ref, dict) and isinstance(ref.get("states"), list):
            return ref, _expander(directory, here, stack, seen), None, False
        return None, None, None, False

    def expand(st: dict[str, Any]) -> Expansion | None:
        here = f"{where}/{st.get('id')}" if where else str(st.get("id"))
        if st.get("type") == "Parallel" and isinstance(st.get("regions"), list):
            parts: list[tuple[str | None, dict[str, Any], Any]] = []
            for i, ref in enumerate(st["regions"]):
                inline = ref.get("name") if isinstance(ref, dict) and isinstance(ref.get("name"), str) else None
                machine, hook, note, error = part(ref, f"{here}/{inline or f'region{i + 1}'}")
                name = machine.get("name") if machine is not None else None
                name = name if isinstance(name, str) and name else f"region{i + 1}"
                if note:
                    name += f" — {note}" if error else f" ({note})"
                parts.append((name, machine if machine is not None else {"states": []}, hook))
            widths = [text_width(name or "", LABEL_FONT) + 2 * BOX_MARGIN + 4 for name, _, _ in parts]
            return Expansion(parts, _parallel_note(st), foreign=True, min_widths=widths) if parts else None
        m = st.get("machine")
        if st.get("type") != "FSMState" or not isinstance(m, dict):
            return None
        machine, hook, note, error = part(m, here)
        if "file" not in m:
            return Expansion([(None, machine, hook)]) if machine is not None else None
        return Expansion([(None, machine, hook)] if machine is not None else [], note, foreign=True, error=error)

    return expand


def _read_include(path: Path) -> tuple[dict[str, Any], Path] | str:
    """An included machine document and its folder, or what is wrong with it."""
    from fsm.loader import reader_for

    try:
        data, source = reader_for(path)(path)
    except DiagramError as exc:
        first = exc.problems[0].message if exc.problems else "cannot be read"
        return "not found" if first == "file not found" else first
    except (OSError, ValueError) as exc:
        return f"cannot be read ({exc})"
    if not isinstance(data, dict) or not isinstance(data.get("states"), list):
        return "not a machine document"
    data = normalize_legacy(data)[0]
    folder = getattr(source, "directory", None)
    return data, Path(folder) if folder is not None else path.parent


def _box_size(node: Node) -> tuple[float, float]:
    """The size of a state box without a stored layout: its text fits."""
    st = node.doc
    if node.composite:
        w = text_width(str(st.get("id")), FONT, bold=True)
        if node.note is not None:
            w = max(w, text_width(node.note, SMALL_FONT))
        return max(120.0, _snap(w + 2 * BOX_MARGIN + 4)), 60.0 if node.parts else 70.0
    if st.get("type") == "Final":
        return max(120.0, _snap(FINAL_ICON + text_width(final_text(st), FONT) + BOX_MARGIN + 4)), 50.0
    name, sub = _state_lines(st)
    w = max(text_width(name, FONT), text_width(sub, SMALL_FONT) if sub else 0)
    return max(120.0, _snap(w + 2 * BOX_MARGIN + 4)), 50.0 if sub else 40.0


def _state_lines(st: dict[str, Any]) -> tuple[str, str]:
    lines = state_label(st).split(" (", 1)
    return lines[0], ("(" + lines[1]) if len(lines) > 1 else ""


def _snap(v: float) -> float:
    return math.ceil(v / 10) * 10


def svg(doc: dict[str, Any], base: str | Path | None = None) -> str:
    """The machine drawn as SVG, with its regions and included machines.

    ``base``: the document's file (or its folder), to open its ``{"file": ...}`` includes; without it an included
    machine is drawn as a box naming its file.
    """
    def lines_of(st: dict[str, Any]) -> list[str]:
        return [state_label(st)]

    folder = None if base is None else Path(base).parent if Path(base).is_file() else Path(base)
    level = lay_out(doc, lines_of, expand=_expander(folder), size=_box_size,
                    label_width=lambda tr: text_width(edge_label(tr), LABEL_FONT) + 4, drawing=True)
    scene = _Scene()
    scene.collect(level, None, ())
    labels = _place_labels(scene)
    x0, y0, x1, y1 = level.bbox(labels=False)
    for rx, ry, rw, rh in [r for _, r, _ in labels] + scene.outside:
        x0, y0, x1, y1 = min(x0, rx), min(y0, ry), max(x1, rx + rw), max(y1, ry + rh)
    m = 20
    width, height = x1 - x0 + 2 * m, y1 - y0 + 2 * m
    body: list[str] = []
    _draw(level, body)
    for _e, (rx, ry, rw, rh), lines in labels:
        body.append(f'<rect class="label" x="{rx:.1f}" y="{ry:.1f}" width="{rw:.1f}" height="{rh:.1f}" fill="white" '
                    'fill-opacity="0.85"/>')
        for i, line in enumerate(lines):
            body.append(f'<text class="label" x="{rx + 2:.1f}" y="{ry + 11 + i * LINE_H:.1f}" font-size="{LABEL_FONT}" '
                        f'fill="#1a4d80">{escape(line)}</text>')
    title = escape(str(doc.get("name") or "machine"))
    return (f'<svg xmlns="http://www.w3.org/2000/svg" width="{width:.0f}" height="{height:.0f}" '
            f'viewBox="{x0 - m:.0f} {y0 - m:.0f} {width:.0f} {height:.0f}" font-family="Helvetica, Arial, sans-serif" '
            f'font-size="{FONT}">\n<title>{title}</title>\n'
            '<defs><marker id="arrow" viewBox="0 0 10 10" refX="10" refY="5" markerWidth="8" markerHeight="8" '
            'orient="auto-start-reverse"><path d="M 0 0 L 10 5 L 0 10 z" fill="#333"/></marker></defs>\n'
            f'<rect x="{x0 - m:.0f}" y="{y0 - m:.0f}" width="{width:.0f}" height="{height:.0f}" fill="white"/>\n'
            + "\n".join(body) + "\n</svg>\n")


# -- edge labels -----------------------------------------------------------------------------------------------
Rect = tuple[float, float, float, float]


def _small_final(n: Node) -> bool:
    """A UMLet final pseudostate: a small circle, its id written beside it."""
    return n.doc.get("type") == "Final" and abs(n.w - n.h) < 1e-6 and n.w <= 40 and not n.composite


class _Scene:
    """Everything a label must keep clear of, and every arrow with the box it belongs in."""

    def __init__(self) -> None:
        self.boxes: list[Rect] = []  # state boxes, title bands, markers, texts beside small finals
        self.composites: list[tuple[Node, Rect]] = []
        self.edges: list[tuple[Edge, Rect | None, tuple[int, ...]]] = []
        self.segments: list[tuple[tuple[float, float, float, float], int]] = []  # (segment, id of its arrow)
        self.outside: list[Rect] = []  # texts drawn outside any box (for the picture's size)

    def collect(self, level: LevelLayout, container: Rect | None, ancestors: tuple[int, ...]) -> None:
        for n in level.nodes:
            if n.composite:
                self.composites.append((n, (n.x, n.y, n.w, n.h)))
                self.boxes.append((n.x, n.y, n.w, n.head))
                for p in n.parts:
                    if p.name is not None:
                        self.boxes.append((p.x, p.y, p.w, REGION_HEAD))
                    self.collect(p.level, (p.x, p.y, p.w, p.h), ancestors + (id(n),))
            elif _small_final(n):
                self.boxes.append((n.x, n.y, n.w, n.h))
                r = (n.x + n.w + 4, n.y + n.h / 2 - 9, text_width(str(n.doc.get("id")), FONT), 14.0)
                self.boxes.append(r)
                self.outside.append(r)
            else:
                self.boxes.append((n.x, n.y, n.w, n.h))
        if level.marker is not None:
            mw, mh = level.marker_size
            self.boxes.append((level.marker[0], level.marker[1], mw, mh))
            self._polyline(level.marker_points, 0)
        for e in level.edges:
            self.edges.append((e, container, ancestors))
            self._polyline(e.points, id(e))

    def _polyline(self, pts: list[list[float]], owner: int) -> None:
        for (ax, ay), (bx, by) in zip(pts, pts[1:]):
            self.segments.append(((ax, ay, bx, by), owner))


def _area(a: Rect, b: Rect) -> float:
    w = min(a[0] + a[2], b[0] + b[2]) - max(a[0], b[0])
    h = min(a[1] + a[3], b[1] + b[3]) - max(a[1], b[1])
    return w * h if w > 0 and h > 0 else 0.0


def _hits(seg: tuple[float, float, float, float], r: Rect) -> bool:
    """Whether the segment passes through the inside of ``r`` (Liang-Barsky clipping)."""
    x0, y0, x1, y1 = seg
    dx, dy = x1 - x0, y1 - y0
    lo, hi = 0.0, 1.0
    for p, q in ((-dx, x0 - r[0]), (dx, r[0] + r[2] - x0), (-dy, y0 - r[1]), (dy, r[1] + r[3] - y0)):
        if p == 0:
            if q <= 0:
                return False
            continue
        t = q / p
        if p < 0:
            lo = max(lo, t)
        else:
            hi = min(hi, t)
        if lo >= hi:
            return False
    return True


def _crosses(a: tuple[float, float, float, float], b: tuple[float, float, float, float]) -> bool:
    """Whether two segments cross (touching ends do not count)."""
    def orient(px: float, py: float, qx: float, qy: float, rx: float, ry: float) -> float:
        return (qx - px) * (ry - py) - (qy - py) * (rx - px)

    d1 = orient(b[0], b[1], b[2], b[3], a[0], a[1])
    d2 = orient(b[0], b[1], b[2], b[3], a[2], a[3])
    d3 = orient(a[0], a[1], a[2], a[3], b[0], b[1])
    d4 = orient(a[0], a[1], a[2], a[3], b[2], b[3])
    return d1 * d2 < 0 and d3 * d4 < 0


def _point_at(pts: list[list[float]], s: float) -> tuple[float, float, float, float]:
    """The point at arc length ``s`` along ``pts`` and the unit direction there."""
    last = len(pts) - 2
    for i, ((ax, ay), (bx, by)) in enumerate(zip(pts, pts[1:])):
        seg = math.hypot(bx - ax, by - ay)
        if seg > 0 and (s <= seg or i == last):
            f = max(0.0, min(1.0, s / seg))
            return ax + (bx - ax) * f, ay + (by - ay) * f, (bx - ax) / seg, (by - ay) / seg
        s -= seg
    (ax, ay) = pts[0]
    return ax, ay, 1.0, 0.0


def _wrapped(text: str) -> list[str] | None:
    """``text`` in two lines of about equal width, broken at a space, or None."""
    spaces = [i for i, ch in enumerate(text) if ch == " "]
    if not spaces:
        return None
    best = min(spaces, key=lambda i: (abs(text_width(text[:i], LABEL_FONT) - text_width(text[i + 1:], LABEL_FONT)), i))
    return [text[:best], text[best + 1:]]


LINE_H = 14.0
_ALONG = (0.5, 0.4, 0.6, 0.3, 0.7, 0.2, 0.8, 0.12, 0.88)


def _label_shapes(text: str) -> list[tuple[list[str], float, float, float]]:
    """The ways to write a label: (lines, width, height, how much less good than one line)."""
    out = [([text], text_width(text, LABEL_FONT) + 4, LINE_H + 1, 0.0)]
    two = _wrapped(text)
    if two is not None:
        out.append((two, max(text_width(t, LABEL_FONT) for t in two) + 4, 2 * LINE_H + 1, 200.0))
    return out


def _place_labels(scene: _Scene) -> list[tuple[Edge, Rect, list[str]]]:
    """A rectangle for every arrow's label, beside its arrow, clear of boxes and other labels where possible.

    Greedy, in document order: each label takes the cheapest of a set of candidate places along its arrow, on
    either side of it and on it, in one line or two (further out only when the near places are all taken).
    """
    placed: list[Rect] = []
    out: list[tuple[Edge, Rect, list[str]]] = []
    for e, container, ancestors in scene.edges:
        text = edge_label(e.doc)
        if not text or len(e.points) < 2:
            continue
        shapes = _label_shapes(text)
        reach = max(w for _, w, _, _ in shapes) + 12 * (2 * LINE_H + 2)
        xs, ys = [p[0] for p in e.points], [p[1] for p in e.points]
        near = (min(xs) - reach, min(ys) - reach, max(xs) - min(xs) + 2 * reach, max(ys) - min(ys) + 2 * reach)
        obstacles = [r for r in scene.boxes if _area(r, near)]
        obstacles += [r for n, r in scene.composites if id(n) not in ancestors and _area(r, near)]
        segments = [(sg, owner == id(e), min(sg[0], sg[2]), min(sg[1], sg[3]), max(sg[0], sg[2]), max(sg[1], sg[3]))
                    for sg, owner in scene.segments]
        segments = [sg for sg in segments if _area((sg[2] - 1, sg[3] - 1, sg[4] - sg[2] + 2, sg[5] - sg[3] + 2), near)]
        labels = [r for r in placed if _area(r, near)]
        length = sum(math.hypot(b[0] - a[0], b[1] - a[1]) for a, b in zip(e.points, e.points[1:]))
        best: tuple[float, Rect, list[str]] | None = None
        for rings in ((-1, 0, 1, 2, 3), tuple(range(4, 12))):
            for ring in rings:
                for t in _ALONG:
                    px, py, dx, dy = _point_at(e.points, t * length)
                    nx, ny = dy, -dx  # right of a downward arrow, above a rightward one
                    if nx < 0 or (nx == 0 and ny > 0):
                        nx, ny = -nx, -ny
                    for lines, w, h, worse in shapes:
                        for side in ((1,) if ring < 0 else (1, -1)):
                            sx, sy = nx * side, ny * side
                            d = 0.0 if ring < 0 else 4 + abs(sx) * w / 2 + abs(sy) * h / 2 + ring * (LINE_H + 2) * 0.75
                            cx, cy = px + sx * d, py + sy * d
                            r = (round(cx - w / 2, 1), round(cy - h / 2, 1), w, h)
                            cost = abs(t - 0.5) * 120 + max(ring, 0) * 250 + (0 if side == 1 else 15) + worse
                            limit = math.inf if best is None else best[0]
                            if cost >= limit:
                                continue
                            cost += _cost(r, (px, py), labels, obstacles, container, segments, limit - cost)
                            if cost < limit:
                                best = (cost, r, lines)
            if best is not None and best[0] < 1e5:
                break
        assert best is not None
        placed.append(best[1])
        out.append((e, best[1], best[2]))
    return out


Segment = tuple[tuple[float, float, float, float], bool, float, float, float, float]  # segment, own, its bbox


def _cost(r: Rect, anchor: tuple[float, float], placed: list[Rect], obstacles: list[Rect], container: Rect | None,
          segments: list[Segment], limit: float) -> float:
    """How bad a place ``r`` for a label is; stops counting once it is worse than ``limit``."""
    x0, y0, x1, y1 = r[0] - 2, r[1] - 2, r[0] + r[2] + 2, r[1] + r[3] + 2  # with a little air around it
    cost = 0.0
    for ox, oy, ow, oh in placed:
        w, h = min(x1, ox + ow) - max(x0, ox), min(y1, oy + oh) - max(y0, oy)
        if w > 0 and h > 0:
            cost += 1e6 + w * h * 100
    for ox, oy, ow, oh in obstacles:
        w, h = min(x1, ox + ow) - max(x0, ox), min(y1, oy + oh) - max(y0, oy)
        if w > 0 and h > 0:
            cost += 1e5 + w * h * 10
    if container is not None:
        inner = (container[0] + 2, container[1] + 2, container[2] - 4, container[3] - 4)
        outside = r[2] * r[3] - _area(r, inner)
        if outside > 0.01:
            cost += 1e5 + outside * 10
    if cost >= limit:
        return cost
    cx = max(r[0], min(anchor[0], r[0] + r[2]))  # the label's point nearest to its arrow
    cy = max(r[1], min(anchor[1], r[1] + r[3]))
    leader = (anchor[0], anchor[1], cx, cy)
    lx0, ly0, lx1, ly1 = min(anchor[0], cx), min(anchor[1], cy), max(anchor[0], cx), max(anchor[1], cy)
    rx1, ry1 = r[0] + r[2], r[1] + r[3]
    for seg, own, sx0, sy0, sx1, sy1 in segments:
        if not (sx1 < r[0] or sx0 > rx1 or sy1 < r[1] or sy0 > ry1) and _hits(seg, r):
            cost += 600 if own else 3000
        elif not own and not (sx1 < lx0 or sx0 > lx1 or sy1 < ly0 or sy0 > ly1) and _crosses(leader, seg):
            cost += 3000  # another arrow runs between this label and its arrow
        if cost >= limit:
            break
    return cost


# -- drawing ---------------------------------------------------------------------------------------------------
def _text(x: float, y: float, text: str, size: float, anchor: str = "middle", extra: str = "") -> str:
    size_attr = "" if size == FONT else f' font-size="{size:g}"'
    return (f'<text x="{x:.1f}" y="{y:.1f}" text-anchor="{anchor}"{size_attr}{extra}>{escape(text)}</text>')


def _draw(level: LevelLayout, body: list[str]) -> None:
    for n in level.nodes:
        st = n.doc
        sid = escape(str(st.get("id")))
        if n.composite:
            body.append(f'<g class="node composite" data-id={quoteattr(str(st.get("id")))}>')
            body.append(f'<rect x="{n.x:.0f}" y="{n.y:.0f}" width="{n.w:.0f}" height="{n.h:.0f}" rx="12" '
                        'fill="#f4f7fb" stroke="#4a6d94" stroke-width="1.5"/>')
            avail = n.w - 2 * BOX_MARGIN
            top = n.y if n.parts else n.y + max(0.0, (n.h - n.head) / 2)  # no content: the text in the middle
            title, size = _fit(str(st.get("id")), avail, FONT, bold=True)
            body.append(_text(n.x + n.w / 2, top + 18, title, size, extra=' font-weight="bold"'))
            if n.note is not None:
                note, nsize = _fit(n.note, avail, SMALL_FONT)
                colour = "#a33" if n.note_error else "#666"
                body.append(_text(n.x + n.w / 2, top + 32, note, nsize, extra=f' font-style="italic" fill="{colour}"'))
            if n.parts:
                body.append(f'<line x1="{n.x:.0f}" y1="{n.y + n.head:.0f}" x2="{n.x + n.w:.0f}" y2="{n.y + n.head:.0f}" '
                            'stroke="#4a6d94"/>')
            for i, p in enumerate(n.parts):
                if i:
                    body.append(f'<line x1="{p.x:.0f}" y1="{p.y:.0f}" x2="{p.x:.0f}" y2="{p.y + p.h:.0f}" '
                                'stroke="#4a6d94" stroke-dasharray="6,4"/>')
                if p.name is not None:
                    name, psize = _fit(p.name, p.w - 2 * BOX_MARGIN, LABEL_FONT)
                    body.append(_text(p.x + p.w / 2, p.y + 16, name, psize,
                                      extra=' font-style="italic" fill="#4a6d94"'))
            body.append("</g>")
            for p in n.parts:
                _draw(p.level, body)
        elif st.get("type") == "Final":
            cx, cy = n.x + n.w / 2, n.y + n.h / 2
            if _small_final(n):  # a UMLet final pseudostate
                r = n.w / 2
                body.append(f'<g class="pseudo" data-id={quoteattr(str(st.get("id")))}>')
                body.append(f'<circle cx="{cx:.0f}" cy="{cy:.0f}" r="{r:.1f}" fill="white" stroke="#333"/>')
                body.append(f'<circle cx="{cx:.0f}" cy="{cy:.0f}" r="{max(r - 4, 2):.1f}" fill="#333"/>')
                body.append(f'<text x="{cx + r + 4:.0f}" y="{cy + 4:.0f}" fill="#555">{sid}</text>')
                body.append("</g>")
            else:
                body.append(f'<g class="node final" data-id={quoteattr(str(st.get("id")))}>')
                body.append(f'<rect x="{n.x:.0f}" y="{n.y:.0f}" width="{n.w:.0f}" height="{n.h:.0f}" rx="10" '
                            'fill="#eef6ee" stroke="#333" stroke-width="3"/>')
                body.append(f'<circle cx="{n.x + 16:.0f}" cy="{cy:.0f}" r="7" fill="white" stroke="#333"/>')
                body.append(f'<circle cx="{n.x + 16:.0f}" cy="{cy:.0f}" r="4" fill="#333"/>')
                left, right = n.x + FINAL_ICON, n.x + n.w - BOX_MARGIN
                text = final_text(st)
                if text_width(text, FONT - 1.5) > right - left and " → " in text and n.h >= 44:
                    first, second = text.split(" → ", 1)
                    a, sa = _fit(first, right - left, FONT)
                    b, sb = _fit("→ " + second, right - left, FONT)
                    size = min(sa, sb)
                    body.append(_text((left + right) / 2, cy - 3, a, size))
                    body.append(_text((left + right) / 2, cy + size, b, size))
                else:
                    t, size = _fit(text, right - left, FONT)
                    body.append(_text((left + right) / 2, cy + size / 3, t, size))
                body.append("</g>")
        else:
            body.append(f'<g class="node" data-id={quoteattr(str(st.get("id")))}>')
            body.append(f'<rect x="{n.x:.0f}" y="{n.y:.0f}" width="{n.w:.0f}" height="{n.h:.0f}" rx="10" fill="#fffbe6" '
                        'stroke="#333" stroke-width="1.2"/>')
            name, sub = _state_lines(st)
            avail = n.w - 2 * BOX_MARGIN
            cx, cy = n.x + n.w / 2, n.y + n.h / 2
            if sub:
                t, size = _fit(name, avail, FONT)
                body.append(_text(cx, cy - 2, t, size))
                t, size = _fit(sub, avail, SMALL_FONT)
                body.append(_text(cx, cy + 12, t, size, extra=' fill="#666"'))
            else:
                t, size = _fit(name, avail, FONT)
                body.append(_text(cx, cy + size / 3, t, size))
            body.append("</g>")
    if level.marker is not None:
        mx, my = level.marker
        w, h = level.marker_size
        body.append(f'<circle cx="{mx + w / 2:.0f}" cy="{my + h / 2:.0f}" r="{min(w, h) / 2 - 2:.1f}" fill="#333"/>')
        pts = " ".join(f"{p[0]:.0f},{p[1]:.0f}" for p in level.marker_points)
        body.append(f'<polyline points="{pts}" fill="none" stroke="#333" marker-end="url(#arrow)"/>')
    for e in level.edges:
        pts = " ".join(f"{p[0]:.0f},{p[1]:.0f}" for p in e.points)
        dash = ' stroke-dasharray="5,3"' if e.doc.get("preempt") else ""
        body.append(f'<polyline class="edge" points="{pts}" fill="none" stroke="#333"{dash} '
                    'stroke-linejoin="round" marker-end="url(#arrow)"/>')


__all__ = ["dot", "mermaid", "svg", "text_width", "final_text", "quoteattr", "MARKER"]
