"""Drawings of a machine with its nesting: Mermaid ``stateDiagram-v2``, Graphviz DOT, and SVG.

The SVG is drawn here, without Graphviz: boxes where the diagram's ``layout`` put them (a converted UMLet
diagram looks like the diagram), a layered layout (:mod:`fsm.tools.layout`) where there is none.
"""

from __future__ import annotations

import json
from typing import Any
from xml.sax.saxutils import escape, quoteattr

from .layout import MARKER, LevelLayout, inline_machine, lay_out

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
def svg(doc: dict[str, Any]) -> str:
    def lines_of(st: dict[str, Any]) -> list[str]:
        return [state_label(st)]

    level = lay_out(doc, lines_of)
    x0, y0, x1, y1 = level.bbox()
    for lab_x, lab_y, text in _labels(level):
        x1 = max(x1, lab_x + len(text) * 6.5)
    m = 20
    width, height = x1 - x0 + 2 * m, y1 - y0 + 2 * m
    body: list[str] = []
    _draw(level, body)
    title = escape(str(doc.get("name") or "machine"))
    return (f'<svg xmlns="http://www.w3.org/2000/svg" width="{width:.0f}" height="{height:.0f}" '
            f'viewBox="{x0 - m:.0f} {y0 - m:.0f} {width:.0f} {height:.0f}" font-family="Helvetica, Arial, sans-serif" '
            f'font-size="12">\n<title>{title}</title>\n'
            '<defs><marker id="arrow" viewBox="0 0 10 10" refX="10" refY="5" markerWidth="8" markerHeight="8" '
            'orient="auto-start-reverse"><path d="M 0 0 L 10 5 L 0 10 z" fill="#333"/></marker></defs>\n'
            '<rect x="{:.0f}" y="{:.0f}" width="{:.0f}" height="{:.0f}" fill="white"/>\n'.format(x0 - m, y0 - m, width, height)
            + "\n".join(body) + "\n</svg>\n")


def _labels(level: LevelLayout) -> list[tuple[float, float, str]]:
    out = []
    for e in level.edges:
        (ax, ay), (bx, by) = _mid_segment(e.points)
        out.append(((ax + bx) / 2 + 4, (ay + by) / 2 - 4, edge_label(e.doc)))
    for n in level.nodes:
        if n.sub is not None:
            out.extend(_labels(n.sub))
    return out


def _mid_segment(points: list[list[float]]) -> tuple[list[float], list[float]]:
    i = max(0, (len(points) - 1) // 2)
    return points[i], points[min(i + 1, len(points) - 1)]


def _draw(level: LevelLayout, body: list[str]) -> None:
    for n in level.nodes:
        st = n.doc
        if n.sub is not None:
            body.append(f'<rect x="{n.x:.0f}" y="{n.y:.0f}" width="{n.w:.0f}" height="{n.h:.0f}" rx="12" '
                        'fill="#f4f7fb" stroke="#4a6d94" stroke-width="1.5"/>')
            body.append(f'<text x="{n.x + n.w / 2:.0f}" y="{n.y + 18:.0f}" text-anchor="middle" font-weight="bold">'
                        f'{escape(state_label(st))}</text>')
            body.append(f'<line x1="{n.x:.0f}" y1="{n.y + 26:.0f}" x2="{n.x + n.w:.0f}" y2="{n.y + 26:.0f}" '
                        'stroke="#4a6d94"/>')
            _draw(n.sub, body)
        elif st.get("type") == "Final":
            cx, cy = n.x + n.w / 2, n.y + n.h / 2
            if abs(n.w - n.h) < 1e-6 and n.w <= 40:  # a UMLet final pseudostate
                r = n.w / 2
                body.append(f'<circle cx="{cx:.0f}" cy="{cy:.0f}" r="{r:.1f}" fill="white" stroke="#333"/>')
                body.append(f'<circle cx="{cx:.0f}" cy="{cy:.0f}" r="{max(r - 4, 2):.1f}" fill="#333"/>')
                body.append(f'<text x="{cx + r + 4:.0f}" y="{cy + 4:.0f}" fill="#555">{escape(str(st.get("id")))}</text>')
            else:
                body.append(f'<rect x="{n.x:.0f}" y="{n.y:.0f}" width="{n.w:.0f}" height="{n.h:.0f}" rx="10" '
                            'fill="#eef6ee" stroke="#333" stroke-width="3"/>')
                body.append(f'<circle cx="{n.x + 16:.0f}" cy="{cy:.0f}" r="7" fill="white" stroke="#333"/>')
                body.append(f'<circle cx="{n.x + 16:.0f}" cy="{cy:.0f}" r="4" fill="#333"/>')
                outcome = st.get("outcome", "succeeded")
                body.append(f'<text x="{cx + 8:.0f}" y="{cy + 4:.0f}" text-anchor="middle">'
                            f'{escape(str(st.get("id")))} → {escape(str(outcome))}</text>')
        else:
            body.append(f'<rect x="{n.x:.0f}" y="{n.y:.0f}" width="{n.w:.0f}" height="{n.h:.0f}" rx="10" fill="#fffbe6" '
                        'stroke="#333" stroke-width="1.2"/>')
            lines = state_label(st).split(" (")
            text = lines[0]
            sub = ("(" + lines[1]) if len(lines) > 1 else ""
            cy = n.y + n.h / 2 + (0 if sub else 4)
            body.append(f'<text x="{n.x + n.w / 2:.0f}" y="{cy:.0f}" text-anchor="middle">{escape(text)}</text>')
            if sub:
                body.append(f'<text x="{n.x + n.w / 2:.0f}" y="{cy + 14:.0f}" text-anchor="middle" fill="#666" '
                            f'font-size="10">{escape(sub)}</text>')
    if level.marker is not None:
        mx, my = level.marker
        w, h = level.marker_size
        body.append(f'<circle cx="{mx + w / 2:.0f}" cy="{my + h / 2:.0f}" r="{min(w, h) / 2 - 2:.1f}" fill="#333"/>')
        pts = " ".join(f"{p[0]:.0f},{p[1]:.0f}" for p in level.marker_points)
        body.append(f'<polyline points="{pts}" fill="none" stroke="#333" marker-end="url(#arrow)"/>')
    for e in level.edges:
        pts = " ".join(f"{p[0]:.0f},{p[1]:.0f}" for p in e.points)
        dash = ' stroke-dasharray="5,3"' if e.doc.get("preempt") else ""
        body.append(f'<polyline points="{pts}" fill="none" stroke="#333"{dash} marker-end="url(#arrow)"/>')
        (ax, ay), (bx, by) = _mid_segment(e.points)
        body.append(f'<text x="{(ax + bx) / 2 + 4:.0f}" y="{(ay + by) / 2 - 4:.0f}" font-size="11" fill="#1a4d80">'
                    f'{escape(edge_label(e.doc))}</text>')


__all__ = ["dot", "mermaid", "svg", "quoteattr", "MARKER"]
