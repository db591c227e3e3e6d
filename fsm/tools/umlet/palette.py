"""The UMLet palette ``TRAL_State-Machine.uxf``, generated from the registry so that it is never stale.

One template per registered state and transition type with every parameter and its default, written in the
syntax :mod:`fsm.tools.umlet.reader` reads (see :mod:`fsm.tools.umlet.writer` for why the texts look as they do).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

from fsm.model.document import param_info
from fsm.model.errors import DiagramError, Problem
from fsm.sequencer.layout import is_sequence

from . import text as T
from .source import parse_raw
from .writer import diagram, element, head_height, in_json, param_lines, relation, value_text

#: The palette's machine note: the keys, and where the note goes.
_NOTE_TEMPLATE = "\n".join([
    T.MACHINE_NOTE_TITLE, "--", "name=", "description=",
    "// the keys of the machine this note is drawn in: outside every box, the diagram's machine; in a composite "
    "state or a region frame, that machine",
    "// name, $schema, description: texts; vars: a JSON object, e.g. vars={\"count\": 0}",
    "// free text after another -- line is the description", "style=wordwrap"])


def palette(registry: Any) -> str:
    """The UMLet palette: one template per registered state and transition type, every parameter with its
    default (required ones empty), each explained in a ``//`` comment line UMLet does not draw; a machine note;
    a ``Parallel`` state holds two region frames instead of a ``regions`` parameter."""
    out: list[str] = []
    y = 20
    out.append(element("UMLSpecialState", 20, y, 20, 20, "type=initial"))
    out.append(element("UMLSpecialState", 60, y, 20, 20, "type=final"))
    out.append(element("Text", 100, y, 300, 30, "initial marker / final state (outcome = its label)\nfontsize=10"))
    y += 50
    out.append(element("UMLNote", 20, y, 300, 90, _NOTE_TEMPLATE))
    y += 110
    x_state, x_trans = 20, 360
    ys, yt = y, y
    for kind, name, cls in registry:
        if kind == "state":
            elements, h = _state_template(_template(kind, name, cls), x_state, ys)
            out += elements
            ys += h + 20
        elif kind == "transition":
            template = _template(kind, name, cls)
            text = "\n".join(["lt=->"] + template.head + template.lines + template.comments)
            h = 40 + 20 * len(template.lines)
            out.append(relation([[x_trans + 10, yt + 10], [x_trans + 10, yt + h]], text))
            yt += h + 30
        # conditions are written inside a guard or a Condition transition, not drawn
    y = max(ys, yt) + 10
    out.append(relation([[x_trans + 10, y + 10], [x_trans + 10, y + 60]],
                        "lt=->\nevent [guard] / action\n// a UML label: a Signal transition on 'event'"))
    return diagram(out)


@dataclass
class _Template:
    """The text of one type's template: its type line and the parameters UMLet cannot show as facets (``head``),
    a ``name=default`` line per parameter, and a ``//`` comment for the type and each parameter."""

    name: str
    head: list[str]
    lines: list[str]
    comments: list[str]
    composite: bool
    #: a composite with regions: they are drawn as frames, not written
    drawn: bool


def _template(kind: str, name: str, cls: Any) -> _Template:
    """The template of the registered type ``name`` (``kind``: state or transition)."""
    infos = param_info(cls.Params)
    doc = (cls.__doc__ or "").strip().split("\n")[0]
    comments = [f"// {doc}"] if doc else []
    lines: list[str] = []
    composite = kind == "state" and bool(getattr(cls, "is_composite", False))
    drawn = composite and any(info["name"] == "regions" for info in infos)
    reserved = T.STATE_FACET_KEYS if kind == "state" else T.RELATION_FACET_KEYS
    extra: dict[str, Any] = {}  # parameters UMLet would take for facets: in the JSON line
    drawn_comments = {**(_SEQUENCE_COMMENTS if is_sequence(cls) else {}), **(_REGIONS_COMMENTS if drawn else {})}
    for info in infos:
        drawn_comment = drawn_comments.get(info["name"])
        if drawn_comment is not None:
            comments.append(drawn_comment)
            continue
        if in_json(info["name"], reserved):
            extra[info["name"]] = info.get("default")
        else:
            lines.append(_param_line(info))
        comments.append(_param_comment(info))
    return _Template(name, param_lines(name, extra, reserved, type_as_json=kind == "state"), lines, comments,
                     composite, drawn)


#: The comments of the parameters drawn rather than written: a Sequence's steps and exceptions, ...
_SEQUENCE_COMMENTS = {
    "steps": ("// steps: boxes drawn inside this box, chained by arrows from an initial marker; a non-blocking "
              "Sequence hangs off the step it follows"),
    "exceptions": "// exceptions: Sequence boxes drawn inside this box with no arrow to or from them"}
#: ... and a composite's regions.
_REGIONS_COMMENTS = {
    "regions": ("// regions: one UMLFrame per region inside this box, titled with the region's name (or file=PATH "
                "to include the region), holding its initial marker, states and arrows")}


def _param_comment(info: dict[str, Any]) -> str:
    """``// name (type, required): description``."""
    req = "required" if info["required"] else "optional"
    desc = f": {info['description']}" if info.get("description") else ""
    return f"// {info['name']} ({info['type']}, {req}){desc}"


def _param_line(info: dict[str, Any]) -> str:
    """``name=default``, ``name=null`` for a parameter without a default (the converter reads it as left out), or
    ``name=`` for a required parameter."""
    if "default" not in info:
        return f"{info['name']}="
    return f"{info['name']}={value_text(info['default']) if info['default'] is not None else 'null'}"


def _state_template(t: _Template, x: int, y: int) -> tuple[list[str], int]:
    """A state type's box (with two region frames for a composite with regions) at (x, y), and its height."""
    text = "\n".join([t.name, "--"] + t.head + t.lines + t.comments + (["valign=top"] if t.composite else []))
    h = 40 + 20 * len(t.lines) + (80 if t.composite else 0)
    w = 300 if t.composite else 220
    frames: list[str] = []
    if t.drawn:
        top = y + head_height(text)
        h = int(top - y) + 70 + 20
        frames = [element("UMLFrame", x + 20 + 140 * i, top, 120, 70, f"region{i + 1}") for i in range(2)]
    return [element("UMLState", x, y, w, h, text), *frames], h


_TYPE_NAME = re.compile(r'(?:"type"\s*:\s*"|^type=)([A-Za-z_][A-Za-z0-9_]*)', re.M)


#: The UMLet element that draws each kind of type.
_KIND_OF_ELEMENT = {"UMLState": "state", "Relation": "transition"}


def _types_drawn(raw: bytes, name: str) -> set[tuple[str, str]] | None:
    """(kind, type) of every state box and arrow in the diagram that names its type; ``None`` when the diagram does
    not read (the machine check says why)."""
    try:
        diagram = parse_raw(raw, name)
    except DiagramError:
        return None
    return {(kind, m.group(1)) for el in diagram.elements if (kind := _KIND_OF_ELEMENT.get(el.kind)) is not None
            for m in _TYPE_NAME.finditer(el.text)}


def palette_problems(raw: bytes, name: str, registry: Any) -> list[Problem] | None:
    """``None`` unless the diagram is a palette: it holds a template of every built-in state and transition
    type (no machine uses them all). A palette is valid when it is exactly what ``fsmctl palette`` generates."""
    builtin = {(kind, n) for kind, n, cls in registry if cls.__module__.startswith("fsm.")}
    if not builtin:
        return None
    found = _types_drawn(raw, name)
    if found is None or not builtin <= found:
        return None
    text = raw.decode("utf-8", errors="replace")
    if text == palette(registry):
        return []
    installed = sorted({dist for (kind, n), dist in getattr(registry, "installed_by", {}).items()
                        if kind in ("state", "transition") and (kind, n) not in found})
    if installed:
        return [_without_plugins(text, name, registry, ", ".join(installed))]
    return [Problem("this is a UMLet palette (a template of every type), not a machine, and it differs from what "
                    "`fsmctl palette` generates", name, line=1, column=1,
                    hint=f"regenerate it: fsmctl palette -o {name} (with the same --plugin options)")]


def _without_plugins(text: str, name: str, registry: Any, plugins: str) -> Problem:
    """What is wrong with a palette that lacks the types of the installed ``plugins``: only that (a warning), or
    that and more."""
    if text == palette(registry.without_installed()):
        return Problem(f"this UMLet palette holds every type but those of the installed plugin(s) {plugins}",
                       name, line=1, column=1, severity="warning",
                       hint=f"to draw with them too: fsmctl palette -o {name}; to check without installed "
                            f"plugins: FSM_NO_ENTRY_POINTS=1 fsmctl validate {name}")
    return Problem("this is a UMLet palette (a template of every type), not a machine, and it differs from "
                   "what `fsmctl palette` generates; it also lacks the types of the installed plugin(s) "
                   + plugins, name, line=1, column=1,
                   hint=f"regenerate it: fsmctl palette -o {name} (with the same --plugin options)")
