"""The text formats: Mermaid ``stateDiagram-v2`` and Graphviz DOT, with composites and parallel regions nested.

Included machines (``{"file": ...}``) are shown as their composite box; the SVG (:mod:`fsm.tools.graph.drawing`)
expands them.
"""

from __future__ import annotations

import json
from typing import Any

from .labels import edge_label, state_label, sub_machines


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
            subs = sub_machines(st)
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
    out = ["digraph machine {", "  compound=true;", '  rankdir=TB;',
           '  node [shape=box, style=rounded, fontname="Helvetica"];', '  edge [fontname="Helvetica", fontsize=10];']
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
            subs = sub_machines(st)
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
            node, cluster = init
            extra = f" [lhead={cluster}]" if cluster else ""
            out.append(f"{indent}{start} -> {node}{extra};")
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
