"""Writing UMLet diagrams: a machine document as a laid-out ``.uxf`` that converts back to the same document.
The palette of every registered type (:mod:`fsm.tools.umlet.palette`) is drawn with the same helpers.

Texts are written in the syntax the reader (:mod:`fsm.tools.umlet.reader`) reads back exactly, and so that UMLet draws
them as plain text: no line starts with a key one of the element's facets owns (UMLet would consume it, or
draw an error box). A plain name for an ``Idle`` state; for a typed state, under ``--``, the type as TRAL's
JSON fragment ``"type": "FollowWall"`` (UMLet's ``StateTypeFacet`` owns ``type=`` lines in a ``UMLState`` and
accepts only state/sender/receiver), then ``key=value`` lines; an arrow's label ``type=Timeout`` and
``key=value`` lines (a ``Relation`` has no ``type`` facet: the lines are its middle label); UML labels for
``Signal`` transitions that came from one. A parameter whose name is one of the facets' keys (``lw``,
``style``, ``m1``, ...) goes into the JSON fragment line instead, as does every parameter of a state whose
name cannot be its first line. A ``Parallel`` state is a
box holding one ``UMLFrame`` per region (title: the region's name, or ``file=PATH`` for an included region);
each machine's own keys (name, ``$schema``, description, vars) are in a ``machine`` note drawn in it.
"""

from __future__ import annotations

import functools
import json
import textwrap
from collections.abc import Callable
from typing import Any
from xml.sax.saxutils import escape

from ..graph.layout import HEAD, Expansion, LevelLayout, Node, inline_machine, lay_out, sequence_machine
from . import text as T

HEADER = '<?xml version="1.0" encoding="UTF-8" standalone="no"?>\n<diagram program="umlet" version="15.1">\n'


def element(kind: str, x: float, y: float, w: float, h: float, text: str, extra: str = "") -> str:
    return (f"  <element>\n    <id>{kind}</id>\n    <coordinates>\n      <x>{_i(x)}</x>\n      <y>{_i(y)}</y>\n"
            f"      <w>{_i(w)}</w>\n      <h>{_i(h)}</h>\n    </coordinates>\n"
            f"    <panel_attributes>{escape(text)}</panel_attributes>\n"
            + (f"    <additional_attributes>{extra}</additional_attributes>\n" if extra
               else "    <additional_attributes/>\n")
            + "  </element>\n")


def _i(v: float) -> str:
    return str(int(round(v)))


def diagram(elements: list[str], zoom: int = 10) -> str:
    return HEADER + f"  <zoom_level>{zoom}</zoom_level>\n" + "".join(elements) + "</diagram>\n"


def relation(points: list[list[float]], text: str) -> str:
    """A new-style relation: points relative to its origin, at zoom 10, with UMLet's 10 px margin."""
    xs = [p[0] for p in points]
    ys = [p[1] for p in points]
    x0, y0 = int(min(xs)) - 10, int(min(ys)) - 10
    w = int(max(xs) - x0) + 20
    h = int(max(ys) - y0) + 20
    extra = ";".join(f"{_f(p[0] - x0)};{_f(p[1] - y0)}" for p in points)
    return element("Relation", x0, y0, w, h, text, extra)


def _f(v: float) -> str:
    return f"{float(v):.1f}" if float(v).is_integer() else repr(float(v))


# -- texts -----------------------------------------------------------------------------------------------------
_COMMON_STATE = {"id", "type", "layout"}
#: What a composite's box leaves out: it is drawn inside it.
_COMPOSITE_STATE = _COMMON_STATE | {"machine", "regions", "steps", "exceptions"}
_COMMON_TRANSITION = {"type", "from", "to", "layout"}


def value_text(v: Any) -> str:
    if isinstance(v, str):
        if _one_line(v) and T.parse_value(v) == v:
            return v
        return json.dumps(v, ensure_ascii=False)
    return json.dumps(v, ensure_ascii=False, separators=(", ", ": "))


def in_json(key: str, reserved: set[str]) -> bool:
    """Whether a parameter must go into the JSON fragment line: UMLet owns ``key=`` lines (``reserved``), or the
    name is no plain identifier."""
    return key in reserved or not T.KEY.fullmatch(key)


def param_lines(typ: str, params: dict[str, Any], reserved: set[str], type_as_json: bool) -> list[str]:
    """The type and parameters: a JSON fragment line (``"type": "X"``, with the parameters ``key=value`` cannot
    carry) when ``type_as_json`` or such parameters exist, else ``type=X``; then one ``key=value`` line per
    parameter. ``reserved``: the keys the element's UMLet facets own."""
    extra = {k: v for k, v in params.items() if in_json(k, reserved)}
    lines = [f"{k}={value_text(v)}" for k, v in params.items() if k not in extra]
    if type_as_json or extra:
        return [json.dumps({"type": typ, **extra}, ensure_ascii=False)[1:-1]] + lines
    return [f"type={typ}"] + lines


def _one_line(text: str) -> bool:
    """Whether ``text`` is one line, not empty, without blanks around it."""
    return bool(text) and text == text.strip() and "\n" not in text


def _facet_line(line: str) -> bool:
    """Whether UMLet (in a state or a note) or the reader would take ``line`` for a facet, not text."""
    return T.is_style(line, T.STATE_FACET_KEYS)


def _relation_facet_line(line: str) -> bool:
    """Whether UMLet or the reader would take ``line`` of a relation's text for a facet, not label text."""
    return T.is_style(line, T.RELATION_FACET_KEYS)


def _safe_name(name: str) -> bool:
    return _one_line(name) and "  " not in name and not (
        _facet_line(name) or T.SEPARATOR.match(name) or T.JSON_TYPE.search(name))


def _safe_free_text(text: str) -> bool:
    """Whether ``text`` reads back as a box's free text: no blank line, no line with trailing blanks, none that
    would be read as a facet, a separator or an activity, and no parameters."""
    lines = text.split("\n")
    return not any(not ln.strip() or ln != ln.rstrip() or _facet_line(ln) or T.SEPARATOR.match(ln)
                   or T.ACTIVITY.match(ln) for ln in lines) and not T.is_param_block(lines)


def action_text(assignments: Any) -> str | None:
    """``a = expr; b = 2`` for a ``set`` that reads back exactly (:func:`fsm.tools.umlet.text.parse_actions`),
    else None (then it is written as a parameter)."""
    if not isinstance(assignments, dict) or not assignments:
        return None
    values = [_action_value(value) for value in assignments.values()]
    if None in values:
        return None
    text = "; ".join(f"{name} = {value}" for name, value in zip(assignments, values, strict=True))
    try:
        back = T.parse_actions(text)
    except T.TextError:
        return None
    return text if _same_values(back, assignments) else None


def _same_values(read: dict[str, Any] | None, written: Any) -> bool:
    """Whether what was read back is what was written, each value of the same type (1 is not 1.0 or true)."""
    return read == written and (read is None or all(type(read[k]) is type(v) for k, v in written.items()))


def _action_value(value: Any) -> str | None:
    """The right-hand side of one assignment: an expression as written, a number or a boolean as JSON."""
    if isinstance(value, str):
        return value if _one_line(value) and T.literal(value) == value else None
    return json.dumps(value) if isinstance(value, (bool, int, float)) else None


def activity_lines(sets: Any) -> list[str] | None:
    """The ``entry / ...`` and ``exit / ...`` lines of a state's ``set``, or None when it cannot be written so."""
    if not isinstance(sets, dict) or not sets or set(sets) - {"on_enter", "on_exit"}:
        return None
    lines = []
    for hook, word in (("on_enter", "entry"), ("on_exit", "exit")):
        if hook in sets:
            text = action_text(sets[hook])
            if text is None:
                return None
            lines.append(f"{word} / {text}")
    return lines


def guard_action_text(guard: Any, assignments: Any) -> str | None:
    """``[guard] / action`` for a transition's guard and ``set`` (either may be None), or None when one of them
    cannot be written so (a condition object guard, a guard holding ']')."""
    parts = []
    if guard is not None:
        if not isinstance(guard, str) or not _one_line(guard) or "]" in guard:
            return None
        parts.append(f"[{guard}]")
    if assignments is not None:
        text = action_text(assignments)
        if text is None:
            return None
        parts.append(f"/ {text}")
    return " ".join(parts) if parts else None


def state_text(st: dict[str, Any], composite: bool) -> str:
    """The text of a state box; a composite's (``composite``) leaves out what is drawn inside it."""
    sid = str(st.get("id", ""))
    typ = str(st.get("type", "Idle"))
    params = {k: v for k, v in st.items() if k not in (_COMPOSITE_STATE if composite else _COMMON_STATE)}
    free = _free_text(params, _safe_free_text)
    top = ["valign=top"] if composite else []
    if not _safe_name(sid):
        frag = json.dumps({"id": sid, "type": typ, **params}, ensure_ascii=False)[1:-1]
        return "\n".join(_sections([frag], free) + top)
    activities = activity_lines(params.get("set"))
    if activities is not None:
        params.pop("set")
    implied = "FSMState" if composite and typ != "Sequence" else "Idle"
    shown = param_lines(typ, params, T.STATE_FACET_KEYS, type_as_json=True) if params or typ != implied else None
    return "\n".join(_sections([sid], shown, activities, free) + top)


def _free_text(params: dict[str, Any], safe: Callable[[str], bool]) -> list[str] | None:
    """A description that can be a box's free text (``safe``), taken out of ``params``, as the box's lines."""
    desc = params.get("description")
    return [params.pop("description")] if isinstance(desc, str) and safe(desc) else None


def _sections(head: list[str], *sections: list[str] | None) -> list[str]:
    """The lines of a box: ``head``, then each section that has lines after a ``--`` separator."""
    lines = list(head)
    for section in sections:
        if section:
            lines += ["--", *section]
    return lines


def drawn_regions(st: dict[str, Any]) -> list[dict[str, Any]] | None:
    """The regions of a Parallel state when each can be drawn as a frame (an inline machine or an include)."""
    regions = _drawn_list(st, "Parallel", "regions")
    if regions is None or not all(isinstance(r, dict) and (isinstance(r.get("states"), list) or (
            set(r) == {"file"} and isinstance(r["file"], str))) for r in regions):
        return None
    return regions


def _drawn_list(st: dict[str, Any], typ: str, key: str) -> list[Any] | None:
    """``st[key]`` of a ``typ`` state when it is a list that holds something (its regions or steps), else None."""
    items = st.get(key)
    return items if st.get("type") == typ and isinstance(items, list) and items else None


def region_title(region: dict[str, Any]) -> str:
    """A region frame's title: ``file=PATH`` for an include, else the region's name when a title can carry it."""
    if "states" not in region:
        return "file=" + value_text(region["file"])
    name = region.get("name")
    return name if isinstance(name, str) and _safe_title(name) else ""


def _safe_title(name: str) -> bool:
    return _safe_name(name) and T.include_title(name) is None and not T.KEY_VALUE.match(name)


def note_text(machine: dict[str, Any], role: str) -> str | None:
    """The machine note of ``machine`` (``role``: top, region or sub), or None when it needs none.

    The diagram's own machine always has one (without it, the reader names the machine after the file).
    """
    params = {key: machine[key] for key in T.MACHINE_KEYS if key in machine}
    if role == "region" and region_title(machine):
        del params["name"]  # the frame's title is the region's name
    free = _free_text(params, _safe_note_text)
    kv = [f"{key}={json.dumps(value, ensure_ascii=False) if key in ('vars', 'inputs') else value_text(value)}"
          for key, value in params.items()]
    if not kv and free is None and role != "top":
        return None
    return "\n".join(_sections([T.MACHINE_NOTE_TITLE], kv, free) + ["style=wordwrap"])


def _safe_note_text(text: str) -> bool:
    return _safe_free_text(text) and not T.note_key_line(text.split("\n")[0])


#: A note's width; its text wraps (``style=wordwrap``), so its height comes from an estimate of the lines.
NOTE_W, NOTE_CHAR_W, NOTE_LINE_H = 360, 7.5, 18


def note_size(text: str) -> tuple[float, float]:
    per_line = int((NOTE_W - 20) / NOTE_CHAR_W)
    lines = sum(max(1, len(textwrap.wrap(ln, per_line))) for ln in T.shown_lines(text))
    return float(NOTE_W), float(-(-(lines * NOTE_LINE_H + 20) // 10) * 10)


def head_height(text: str) -> float:
    """The height of a composite box's own text above its content."""
    return HEAD + 18 * max(0, len(T.shown_lines(text)) - 1)


def drawn_steps(st: dict[str, Any]) -> dict[str, Any] | None:
    """A Sequence's steps (and exception sequences) as the machine drawn inside its box, or None."""
    steps = _drawn_list(st, "Sequence", "steps")
    if steps is None or not all(isinstance(x, dict) and isinstance(x.get("id"), str)
                                for x in steps + list(st.get("exceptions") or [])):
        return None
    return sequence_machine(st, start="Finished")


def _can_finish(st: dict[str, Any], registry: Any) -> bool:
    if drawn_steps(st) is not None:
        return True
    sub = inline_machine(st)
    if sub is not None:
        return any(isinstance(s, dict) and s.get("type") == "Final" for s in sub.get("states", []))
    cls = registry.states.get(str(st.get("type") or "Idle")) if registry is not None else None
    return bool(cls is not None and cls.can_finish)


def _reads_back(label: str, signal: str, guard: Any, assignments: Any) -> bool:
    """Whether a UML label converts back to exactly this signal, guard and ``set``."""
    try:
        parsed = T.parse_label(label.split("\n"))
        if parsed.text != label or _relation_facet_line(label):  # typed parameters have no text
            return False
        event, g, action = T.split_uml(label)
        actions = T.parse_actions(action) if action is not None else None
    except T.TextError:
        return False
    return event == signal and g == guard and _same_values(actions, assignments)


def transition_text(tr: dict[str, Any], source: dict[str, Any], registry: Any) -> str:
    """The text of a transition's arrow: a UML label that reads back as this Signal transition, else its type (left
    out where the source implies it: Finished from a state that finishes, Always from one that does not) and
    parameters, with its guard and ``set`` as a ``[guard] / action`` line where they read back so."""
    typ = str(tr.get("type"))
    params = {k: v for k, v in tr.items() if k not in _COMMON_TRANSITION}
    label = _signal_label(typ, params)
    if label is not None:
        return "lt=->\n" + label
    tail = _guard_action_line(params)
    implied = not params and _implied_type(typ, source, registry)
    shown = [] if implied else param_lines(typ, params, T.RELATION_FACET_KEYS, type_as_json=False)
    return "\n".join(["lt=->", *shown, *([tail] if tail else [])])


def _signal_label(typ: str, params: dict[str, Any]) -> str | None:
    """A Signal transition's own UML label, when it converts back to exactly its signal, guard and ``set``."""
    if typ != "Signal" or set(params) - {"guard", "set"} != {"signal", "label"} or not isinstance(params["label"], str):
        return None
    label: str = params["label"]
    return label if _reads_back(label, params["signal"], params.get("guard"), params.get("set")) else None


def _guard_action_line(params: dict[str, Any]) -> str | None:
    """``[guard] / action`` for the guard and ``set`` among ``params`` (taken out of them), when they read back."""
    if "guard" not in params and "set" not in params:
        return None
    tail = guard_action_text(params.get("guard"), params.get("set"))
    if tail is not None:
        params.pop("guard", None)
        params.pop("set", None)
    return tail


def _implied_type(typ: str, source: dict[str, Any], registry: Any) -> bool:
    """Whether an arrow without text from ``source`` means ``typ``: Finished when it can finish, else Always."""
    return typ == ("Finished" if _can_finish(source, registry) else "Always")


def final_special(st: dict[str, Any], level_names: set[str], used: set[str]) -> str | None:
    """The text of a ``type=final`` pseudostate that reads back as this Final state, or None."""
    outcome = st.get("outcome")
    if set(st) - {"layout", "id", "type", "outcome"} or (outcome is not None and not _safe_name(outcome)):
        return None
    base = outcome if isinstance(outcome, str) else "final"
    if st.get("id") != base or base in level_names | used:
        return None
    return "\n".join(["type=final", *([] if outcome is None else [outcome])])


# -- export ---------------------------------------------------------------------------------------------------
def export(doc: dict[str, Any], registry: Any = None) -> str:
    """A ``.uxf`` diagram of ``doc`` (stored layout where present) that converts back to ``doc``."""
    roles: dict[int, str] = {id(doc): "top"}  # each machine's note role: top, region (found on expanding), sub
    note_of = functools.partial(_note_of, roles)
    level = lay_out(doc, _lines_of, expand=functools.partial(_expand, roles),
                    note_size=functools.partial(_size_of_note, roles))
    bbox = level.bbox(labels=False)
    stored = any(isinstance(st, dict) and isinstance(st.get("layout"), dict) for st in doc.get("states", []))
    shift = (0.0, 0.0) if stored else (max(0.0, 20 - bbox[0]), max(0.0, 20 - bbox[1]))
    out: list[str] = []
    if shift != (0.0, 0.0):  # drawn anew into view: a stored frame no longer fits
        level.shift(*shift)
    else:
        out += _frame_elements(_mapping(doc, "layout").get("frame"), bbox)
    _emit(level, out, registry, note_of)
    return diagram(out)


def _mapping(doc: dict[str, Any], key: str) -> dict[str, Any]:
    """``doc[key]`` when it is an object, else an empty one."""
    value = doc.get(key)
    return value if isinstance(value, dict) else {}


def _composite(st: dict[str, Any]) -> bool:
    return inline_machine(st) is not None or drawn_regions(st) is not None or drawn_steps(st) is not None


def _lines_of(st: dict[str, Any]) -> list[str]:
    return state_text(st, _composite(st)).split("\n")


def _expand(roles: dict[int, str], st: dict[str, Any]) -> Expansion | None:
    """What a state's box holds: its machine or steps, or its regions' frames (their machines' roles noted)."""
    head = head_height(state_text(st, True))
    sub = inline_machine(st) or drawn_steps(st)
    if sub is not None:
        return Expansion([(None, sub, None)], head=head)
    regions = drawn_regions(st)
    if regions is None:
        return None
    titles = [region_title(r) for r in regions]
    parts: list[tuple[str | None, dict[str, Any], Any]] = [
        (title, r if "states" in r else {"states": []}, None) for title, r in zip(titles, regions, strict=True)]
    roles.update((id(machine), "region") for _, machine, _ in parts)
    return Expansion(parts, head=head, inset=True, min_widths=[len(title) * 8 + 60 for title in titles])


def _note_of(roles: dict[int, str], machine: dict[str, Any]) -> str | None:
    role = roles.get(id(machine), "sub")
    if role != "top" and not machine.get("states"):
        return None  # an included region's empty frame
    return note_text(machine, role)


def _size_of_note(roles: dict[int, str], machine: dict[str, Any]) -> tuple[float, float] | None:
    text = _note_of(roles, machine)
    return note_size(text) if text is not None else None


def _frame_elements(frame: Any, bbox: tuple[float, float, float, float]) -> list[str]:
    """The machine's stored frame (if it has one), grown to hold everything drawn (the note too)."""
    if not isinstance(frame, dict) or not all(isinstance(frame.get(k), (int, float)) for k in "xywh"):
        return []
    x0, y0, x1, y1 = bbox
    fx, fy = min(frame["x"], x0 - 10), min(frame["y"], y0 - 10)
    fw, fh = max(frame["x"] + frame["w"], x1 + 10) - fx, max(frame["y"] + frame["h"], y1 + 10) - fy
    title = frame.get("title")
    title = title if isinstance(title, str) and _safe_name(title) else ""  # the note names the machine
    return [element("UMLFrame", fx, fy, fw, fh, title)]


def _node_element(n: Node, names: set[str], used: set[str]) -> tuple[str, str]:
    """The UMLet element kind and text of a state: a final state as a special state (when its outcome is said by
    its label, see :func:`final_special`), a frame drawn as such, else a state box."""
    st = n.doc
    if st.get("type") == "Final":
        text = final_special(st, names, used)
        if text is not None:
            used.add(str(st.get("id")))
            return "UMLSpecialState", text
    text = state_text(st, n.sub is not None or n.regions)
    if _mapping(st, "layout").get("shape") == "frame" and n.sub is not None and text == f"{st.get('id')}\nvalign=top":
        return "UMLFrame", str(st.get("id"))
    return "UMLState", text


def _emit_inside(n: Node, out: list[str], registry: Any, note_of: Any) -> None:
    """What a state's box holds: its machine, or its regions' frames with their machines."""
    if n.sub is not None:
        _emit(n.sub, out, registry, note_of)
    elif n.regions:
        for p in n.parts:
            out.append(element("UMLFrame", p.x, p.y, p.w, p.h, p.name or ""))
            _emit(p.level, out, registry, note_of)


def _emit(level: LevelLayout, out: list[str], registry: Any, note_of: Any) -> None:
    """The elements of a laid out machine level: its initial marker, states (and what they hold), arrows and
    note."""
    names = {str(n.doc.get("id")) for n in level.nodes if n.doc.get("type") != "Final"}
    used: set[str] = set()
    if level.marker is not None:  # placed for the initial state
        mx, my = level.marker
        out.append(element("UMLSpecialState", mx, my, *level.marker_size, "type=initial"))
        out.append(relation(level.marker_points, "lt=->"))
    for n in level.nodes:
        kind, text = _node_element(n, names, used)
        out.append(element(kind, n.x, n.y, n.w, n.h, text))
        _emit_inside(n, out, registry, note_of)
    for e in level.edges:
        out.append(relation(e.points, transition_text(e.doc, e.src.doc, registry)))
    if level.note is not None:
        text = note_of(level.machine)
        if text is not None:
            x, y, w, h = level.note
            out.append(element("UMLNote", x, y, w, h, text))
