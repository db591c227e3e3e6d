"""What the texts of UMLet elements say: names, separators, style facets, arrowheads, parameters, UML labels.

Parameters come in two syntaxes, which may be mixed: TRAL's JSON fragment (``"type": "FollowWall", "p": 12``)
and ``key=value`` lines (``distance=0.4``). In a parameter block the JSON lines come first, then the
``key=value`` lines; the type is given in either (``"type": "FollowWall"`` or ``type=FollowWall``). The writer
puts a state's type in the JSON form because UMLet owns ``type=`` lines in a ``UMLState`` (``StateTypeFacet``
accepts only ``state``, ``sender`` and ``receiver`` and draws anything else as an error). A text without a
type is free text: a state's compartments, or a transition's UML label ``event [guard] / action``.

UMLet offers each line of an element's text to the element's facets, and a facet whose key the line starts
with (``key=``, exactly) consumes it (``PropertiesParser.parseFacets``, ``KeyValueFacet.checkStart``); the
key sets below are those facets, per element kind.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from typing import Any

from fsm.model.expr import ExprError, parse, parse_assignments

#: Facets UMLet consumes on every element (style, layout, comments); never names or parameters.
_STYLE_KEYS = {"bg", "fg", "lw", "valign", "halign", "fontsize", "layer", "transparency", "group", "style",
               "symbol", "customelement", "elementstyle", "autoresize"}
#: Boxes (``UMLState``, ``UMLSpecialState``, ``UMLFrame``, ``UMLNote``: ``Settings.MANUALRESIZE`` ->
#: ``BASE_WITH_LINETYPE``) also have ``LineTypeFacet``: ``lt=`` is the border's line type. Not for relations,
#: whose ``lt=`` (the arrow) :func:`parse_relation` reads itself.
BOX_STYLE_KEYS = _STYLE_KEYS | {"lt"}
#: Relation facets: line type, end texts and their positions (``Settings.RELATION``, ``LineDescriptionEnum``,
#: ``LineDescriptionPositionFacet``; ``cbase`` is ``LineDescriptionBasePositionFacet`` of newer UMLets).
_RELATION_KEYS = {"lt", "m1", "m2", "r1", "r2", "m1pos", "m2pos", "r1pos", "r2pos", "cpos", "mpos", "qualifier",
                  "cbase"}
#: Keys of newer UMLets' ``LinkFacet`` and ``PageFacet``: never written as parameter lines either.
_LATER_KEYS = {"link", "page"}
#: Keys a ``key=value`` line of a UMLState may not start with: UMLet would consume (or reject) it.
STATE_FACET_KEYS = BOX_STYLE_KEYS | {"type"} | _LATER_KEYS
#: Keys a ``key=value`` line of a Relation's label may not start with (``type=`` is plain label text there).
RELATION_FACET_KEYS = _STYLE_KEYS | _RELATION_KEYS | _LATER_KEYS
#: ``type=`` values that are UMLet's own shape facets of a UMLState, not state types (any case: UMLet
#: upper-cases the value, ``StateTypeFacet``).
_UMLET_STATE_SHAPES = {"state", "sender", "receiver"}
SEPARATOR = re.compile(r"^\s*(?:--?|-\.\.?)\s*$")
#: A ``key=value`` line (a parameter of a state or transition): the key and the raw value.
KEY_VALUE = re.compile(r"^\s*([A-Za-z_][A-Za-z0-9_]*)\s*=(.*)$")
#: A parameter name the ``key=value`` syntax can carry.
KEY = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
#: The start of a JSON ``"type":`` member: a label written as JSON parameters.
JSON_TYPE = re.compile(r'"type"\s*:')


class TextError(ValueError):
    """A text that cannot be read; the message says why (the caller adds where), ``hint`` what to write."""

    def __init__(self, message: str, hint: str | None = None) -> None:
        super().__init__(message)
        self.hint = hint


#: What a state box's text looks like (the hint of a box that cannot be read).
STATE_BOX_FORM = 'a state box is its name, a line --, then "type": "TypeName", "param": value, ..., one per line'


def numbered(name: str, taken: set[str] | list[str]) -> str:
    """``name``, or the first of ``name (2)``, ``name (3)``, ... not ``taken`` (machines of one diagram, final states
    of one level)."""
    unique, n = name, 2
    while unique in taken:
        unique, n = f"{name} ({n})", n + 1
    return unique


def is_style(line: str, keys: set[str] = _STYLE_KEYS) -> bool:
    return line.lstrip().startswith("//") or key_of(line) in keys


def key_of(line: str) -> str | None:
    """The key of a ``key=value`` line, None for any other line."""
    m = KEY_VALUE.match(line)
    return m.group(1) if m else None


def value_of(line: str, key: str) -> str | None:
    """The value (stripped) of a ``key=value`` line whose key is ``key``, None for any other line."""
    m = KEY_VALUE.match(line)
    return m.group(2).strip() if m and m.group(1) == key else None


def shown_lines(text: str) -> list[str]:
    """The lines of a box's text that UMLet draws: its style facets and ``//`` comments left out."""
    return [ln for ln in text.split("\n") if not is_style(ln, BOX_STYLE_KEYS)]


@dataclass
class StateText:
    """A state box's text: its name, its parameters (if any) and its free text compartments."""

    name: str
    params: dict[str, Any] | None  # None: no type given
    description: str | None
    #: the parameters written as ``key=value`` lines (texts: a number there may be meant as text)
    kv_keys: set[str] = field(default_factory=set)
    #: UML internal activities: ``("entry" | "exit", action text)`` from ``entry / x = 1`` lines
    activities: list[tuple[str, str]] = field(default_factory=list)


#: A UML internal activity line of a state: ``entry / count = count + 1`` or ``exit / led = false``.
ACTIVITY = re.compile(r"^\s*(entry|exit)\s*/(.*)$")


def split_state(text: str) -> tuple[list[str], list[list[str]]]:
    """Name lines and compartments (lists of lines) of a UMLState text, style facets removed."""
    name_lines: list[str] = []
    compartments: list[list[str]] = []
    current = name_lines
    for ln in shown_lines(text):
        if SEPARATOR.match(ln):
            current = []
            compartments.append(current)
        elif (value_of(ln, "type") or "").lower() not in _UMLET_STATE_SHAPES:
            current.append(ln)
    return name_lines, compartments


def parse_state(text: str) -> StateText:
    """Name (first lines up to the first separator), type and parameters, and the other compartments."""
    name_lines, compartments = split_state(text)
    name = " ".join(ln.strip() for ln in name_lines if ln.strip())
    params: dict[str, Any] | None = None
    kv_keys: set[str] = set()
    free: list[str] = []
    # A box holding only parameters (no separator): its "name" is the parameters.
    if not compartments and is_param_block(name_lines):
        _check_separator(name_lines)
        compartments = [name_lines]
        name = ""
    activities: list[tuple[str, str]] = []
    for comp in compartments:
        if params is None and is_param_block(comp):
            params, kv_keys = parse_params(comp)
            continue
        block = _block(_take_activities(comp, activities))
        if block.strip():
            free.append(block)
    description = "\n".join(free) if free else None
    return StateText(name, params, description, kv_keys, activities)


def _take_activities(lines: list[str], activities: list[tuple[str, str]]) -> list[str]:
    """The lines of a free text compartment that are no ``entry / ...`` or ``exit / ...`` activity; those are added
    to ``activities``."""
    rest = []
    for ln in lines:
        m = ACTIVITY.match(ln)
        if m:
            activities.append((m.group(1), m.group(2).strip()))
        else:
            rest.append(ln)
    return rest


def _block(lines: list[str]) -> str:
    """A compartment's lines as one text: each without trailing blanks, without blank lines around it."""
    return "\n".join(ln.rstrip() for ln in lines).strip("\n")


def _check_separator(lines: list[str]) -> None:
    """A box of parameters whose first line is a name (neither JSON nor ``key=value``): its ``--`` line is missing."""
    first, *rest = [stripped for ln in lines if (stripped := ln.strip())]  # a type is given: there are lines
    if first.startswith(('"', "{")) or KEY_VALUE.match(first):
        return
    params = [p for p in rest if p != first]
    shown = " | ".join([first[:40], "--", *(p[:40] for p in params[:3])])
    raise TextError(f"the name {first[:40]!r} and the parameters need a line -- between them",
                    hint=f"write the lines {shown}; " + STATE_BOX_FORM)


def _fragment_problem(body: str) -> TextError | None:
    """What is wrong with a JSON fragment that does not parse, said for the usual hand edits: a parameter line
    without its colon, a parameter name without double quotes, a line without its comma."""
    lines = [stripped for ln in body.strip().strip("{}").split("\n") if (stripped := ln.strip())]
    return _missing_colon(lines) or _unquoted_name(lines) or _missing_comma(lines)


def _missing_colon(lines: list[str]) -> TextError | None:
    for ln in lines:
        if ":" not in ln and "=" not in ln:
            m = re.fullmatch(r'"?([A-Za-z_][A-Za-z0-9_]*)"?\s+(.+?),?', ln)
            return TextError(f"parameter line {ln[:40]!r} has no colon",
                             hint=f'write it as "{m.group(1)}": {m.group(2)}, or as {m.group(1)}={m.group(2)}' if m
                             else 'write each parameter as "name": value')
    return None


def _unquoted_name(lines: list[str]) -> TextError | None:
    for ln in lines:
        m = re.fullmatch(r"([A-Za-z_][A-Za-z0-9_]*)\s*:\s*(.+?),?", ln)
        if m:
            return TextError(f"parameter name '{m.group(1)}' needs double quotes in the JSON parameters",
                             hint=f'write "{m.group(1)}": {m.group(2)}, or {m.group(1)}={m.group(2)}')
    return None


def _missing_comma(lines: list[str]) -> TextError | None:
    for ln, after in zip(lines, lines[1:], strict=False):
        if not ln.endswith((",", "{", "[")) and after.startswith('"'):
            return TextError(f"parameter line {ln[:40]!r} needs a comma at its end (another parameter follows)",
                             hint=f"end it with a comma: {ln[:40]},")
    return None


def _has_kv_type(lines: list[str]) -> bool:
    return any(key_of(ln) == "type" for ln in lines)


def is_param_block(lines: list[str]) -> bool:
    """Whether these lines give a type (``type=X`` or ``"type": "X"``), so they are parameters, not free text."""
    return _has_kv_type(lines) or bool(JSON_TYPE.search("\n".join(lines)))


def parse_params(lines: list[str]) -> tuple[dict[str, Any], set[str]]:
    """A parameter block: JSON fragment lines, then ``key=value`` lines (either part may be empty).

    Returns the parameters (``type`` among them) and the keys given as ``key=value`` lines. A line that starts
    with ``key=`` is never JSON, so where the JSON part ends is unambiguous; after it, every line is
    ``key=value``.
    """
    cut = next((i for i, ln in enumerate(lines) if KEY_VALUE.match(ln)), len(lines))
    json_lines, kv_lines = lines[:cut], lines[cut:]
    shown = [ln for ln in json_lines if ln.strip()]
    out: dict[str, Any] = {}
    if shown:
        fragment = "\n".join(json_lines)
        if not JSON_TYPE.search(fragment) and _has_kv_type(kv_lines):
            raise TextError(f"line {shown[0].strip()[:40]!r} is not key=value (a text with type=... holds only "
                            "key=value lines, after JSON lines if any)")
        out = parse_fragment(fragment)
    kv = parse_key_values(kv_lines)
    for key in kv:
        if key in out:
            raise TextError(f"parameter '{key}' is given twice")
    out.update(kv)
    return out, set(kv)


def parse_key_values(lines: list[str]) -> dict[str, Any]:
    """``key=value`` lines; values are JSON when they parse as JSON (numbers, true, lists, objects), else text."""
    out: dict[str, Any] = {}
    for ln in lines:
        if not ln.strip():
            continue
        m = KEY_VALUE.match(ln)
        if not m:
            raise TextError(f"line {ln.strip()[:40]!r} is not key=value (after the first key=value line of "
                            "the parameters, every line is key=value)")
        key, value = m.group(1), m.group(2).strip()
        if key in out:
            raise TextError(f"parameter '{key}' is given twice")
        out[key] = parse_value(value, strict=True)
    return out


def parse_value(value: str, strict: bool = False) -> Any:
    """A ``key=value`` value: JSON when it parses as JSON, else the text. ``strict``: a JSON object that repeats
    a key is a :class:`TextError` (else it stays text)."""
    if value[:1] in '[{"-0123456789' or value in ("true", "false", "null"):  # "" too: it is no JSON
        try:
            return json.loads(value, object_pairs_hook=_unique_keys)
        except _RepeatedKey as exc:
            if strict:
                raise TextError(f"key '{exc.args[0]}' is given twice in {value[:40]!r}") from None
            return value
        except ValueError:
            return value
    return value


class _RepeatedKey(Exception):
    """A key written twice in one JSON object of a box's text."""


def _unique_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    out = dict(pairs)
    if len(out) != len(pairs):
        seen: set[str] = set()
        for key, _ in pairs:
            if key in seen:
                raise _RepeatedKey(key)
            seen.add(key)
    return out


def parse_fragment(text: str) -> dict[str, Any]:
    """TRAL's fragment ``"type": "FollowWall", "p": 12`` (with or without braces, a trailing comma allowed)."""
    body = text.strip()
    if not body.startswith("{"):
        body = "{" + body.rstrip().rstrip(",") + "}"
    try:
        data: dict[str, Any] = json.loads(body, object_pairs_hook=_unique_keys)
    except _RepeatedKey as exc:
        raise TextError(f"parameter '{exc.args[0]}' is given twice in the JSON parameters") from None
    except json.JSONDecodeError as exc:
        raise _fragment_problem(body) or TextError(
            f"JSON parameters do not parse: {exc.msg} (column {exc.colno} of {body[:60]!r})",
            hint='parameters are "name": value lines, separated by commas') from None
    except RecursionError:
        raise TextError("JSON parameters nested too deeply") from None
    return data  # an object: the text starts with "{"


# -- special states -----------------------------------------------------------------------------------------
def special_kind(text: str) -> tuple[str, str]:
    """``(kind, label)`` of a UMLSpecialState: kind from ``type=`` (default decision, as UMLet draws it)."""
    kind = "decision"
    label: list[str] = []
    for ln in shown_lines(text):
        value = value_of(ln, "type")
        if value is not None:  # SpecialStateTypeFacet: valueOf(value.toUpperCase(ENGLISH))
            kind = value.lower()
        elif ln.strip():
            label.append(ln.strip())
    return kind, " ".join(label)


# -- relations ------------------------------------------------------------------------------------------------
#: A relation's facets other than its line type (which :func:`parse_relation` reads).
_RELATION_STYLE_KEYS = (_STYLE_KEYS | _RELATION_KEYS) - {"lt"}
_LT = re.compile(r"^((?:[<>xo|()+*#^]|\[[^\]]*\])*?)(-|\.\.|\.)((?:[<>xo|()+*#^]|\[[^\]]*\])*)$")


@dataclass
class RelationText:
    """A relation's line type (arrowheads) and its middle label lines."""

    lt: str
    start_head: bool
    end_head: bool
    dashed: bool
    label_lines: list[str] = field(default_factory=list)


def parse_relation(text: str) -> RelationText:
    lt = "-"
    label: list[str] = []
    for ln in text.split("\n"):
        value = value_of(ln, "lt")
        if value is not None:
            lt = value
        elif not is_style(ln, _RELATION_STYLE_KEYS):
            label.append(ln)
    shown = [i for i, ln in enumerate(label) if ln.strip()]  # without blank lines around the label
    start, end, dashed = arrowheads(lt)
    return RelationText(lt, start, end, dashed, label[shown[0]:shown[-1] + 1] if shown else [])


def arrowheads(lt: str) -> tuple[bool, bool, bool]:
    """Whether ``lt`` draws an arrowhead at the start, at the end, and whether its line is dashed/dotted."""
    m = _LT.match(lt.strip())
    if not m:
        return False, False, False
    start, line, end = m.groups()
    start_head = bool(re.fullmatch(r"<{1,3}", start))
    end_head = bool(re.fullmatch(r">{1,3}", end))
    return start_head, end_head, line != "-"


@dataclass
class Label:
    """A transition label: explicit type and parameters, or a UML ``event [guard] / action`` text.

    With a type, a last line ``[guard] / action`` (starting with ``[`` or ``/``) adds a guard and a ``set``."""

    params: dict[str, Any] | None
    text: str  # the label as one line (UML form), "" if none
    #: the parameters written as ``key=value`` lines
    kv_keys: set[str] = field(default_factory=set)
    #: the ``[guard] / action`` line after typed parameters, "" if none
    uml: str = ""


def _is_uml_line(line: str) -> bool:
    return line.lstrip().startswith(("[", "/"))


def parse_label(lines: list[str]) -> Label:
    body = list(lines)
    while body and not body[-1].strip():
        body.pop()
    tail: list[str] = []
    while body and _is_uml_line(body[-1]):
        tail.insert(0, body.pop())
    if tail and is_param_block(body):
        params, kv_keys = parse_params(body)
        return Label(params, "", kv_keys, _one_line(tail))
    if is_param_block(lines):
        params, kv_keys = parse_params(lines)
        return Label(params, "", kv_keys)
    return Label(None, _one_line(lines))


def _one_line(lines: list[str]) -> str:
    """Lines as one line of text: their words, one blank apart."""
    return " ".join(" ".join(lines).split())


_UML_LABEL = re.compile(r"^(?P<event>[^\[/]*)(?:\[(?P<guard>[^\]]*)\])?\s*(?:/(?P<action>.*))?$", re.S)


def split_uml(label: str) -> tuple[str, str | None, str | None]:
    """``event [guard] / action`` -> ``(event, guard, action)`` (``None`` where the part is not written);
    :class:`TextError` for a text that is not of that form."""
    m = _UML_LABEL.match(label)
    if m is None:
        if "[" in label and "]" not in label.split("[", 1)[1]:
            raise TextError(f"label {label[:40]!r}: '[' without ']' (a guard is written [condition])")
        raise TextError(f"label {label[:40]!r} is not 'event [guard] / action'")
    guard = m.group("guard")
    action = m.group("action")
    return (" ".join(m.group("event").split()), guard.strip() if guard is not None else None,
            action.strip() if action is not None else None)


def literal(text: str) -> Any:
    """A number or true/false written as an action's value is stored as that constant; else the expression."""
    if text in ("true", "false"):
        return text == "true"
    if re.fullmatch(r"-?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][+-]?\d+)?", text):
        try:
            value = json.loads(text)
        except ValueError:
            return text
        return value if json.dumps(value) == text else text
    return text


def parse_actions(text: str) -> dict[str, Any]:
    """An action ``a = expr; b = 2`` -> ``{"a": "expr", "b": 2}``; :class:`TextError` (with the column) if it
    does not parse."""
    try:
        pairs = parse_assignments(text)
    except ExprError as exc:
        raise TextError(f"action {text[:60]!r}: {exc}") from None
    out: dict[str, Any] = {}
    for name, expr_text, _ in pairs:
        if name in out:
            raise TextError(f"action {text[:60]!r} assigns '{name}' twice")
        out[name] = literal(expr_text)
    return out


def check_guard(text: str) -> str:
    """A guard's syntax (its variables are checked with the machine); :class:`TextError` if it does not parse."""
    try:
        parse(text)
    except ExprError as exc:
        raise TextError(f"guard [{text[:60]}]: {exc}") from None
    return text


# -- machine notes and region frames --------------------------------------------------------------------------
#: The first line of a ``UMLNote`` that carries a machine's own keys.
MACHINE_NOTE_TITLE = "machine"
#: The keys a machine note may give, in the order the writer puts them.
MACHINE_KEYS = ("name", "$schema", "description", "vars", "inputs")
_NOTE_KEY_VALUE = re.compile(r"^\s*(\$?[A-Za-z_][A-Za-z0-9_]*)\s*=(.*)$")
_INCLUDE = re.compile(r"^\s*file\s*=(.*)$")


def is_machine_note(text: str) -> bool:
    """Whether a note's first line (style lines aside) is ``machine``."""
    return next((ln.strip() for ln in shown_lines(text) if ln.strip()), "") == MACHINE_NOTE_TITLE


@dataclass
class MachineNote:
    """A machine note: its ``key=value`` texts (unparsed) and its free text (the description), if any."""

    values: dict[str, str]
    description: str | None


def parse_machine_note(text: str) -> MachineNote:
    """The compartments after the ``machine`` line: one starting with a machine key holds only ``key=value``
    lines (keys from :data:`MACHINE_KEYS`); any other is free text, the machine's description."""
    name_lines, compartments = split_state(text)
    title = next(i for i, ln in enumerate(name_lines) if ln.strip())  # the "machine" line
    values: dict[str, str] = {}
    free: list[str] = []
    for comp in [name_lines[title + 1:]] + compartments:
        lines = [ln for ln in comp if ln.strip()]
        if not lines:
            continue
        if note_key_line(lines[0]):
            _add_key_values(lines, values)
        else:
            free.append(_block(comp))
    if free and "description" in values:
        raise TextError("the description is given twice: as description= and as free text")
    return MachineNote(values, "\n".join(free) if free else None)


def _add_key_values(lines: list[str], values: dict[str, str]) -> None:
    """A compartment of a machine note's ``key=value`` lines into ``values``: each a machine key, given once."""
    for ln in lines:
        kv = _note_key_value(ln)
        if kv is None:
            raise TextError(f"line {ln.strip()[:40]!r} is not one of the machine's key=value lines "
                            f"({', '.join(MACHINE_KEYS)}); free text goes after another -- line")
        if kv[0] in values:
            raise TextError(f"'{kv[0]}' is given twice")
        values[kv[0]] = kv[1]


def _note_key_value(line: str) -> tuple[str, str] | None:
    """The key (one of :data:`MACHINE_KEYS`) and the value text of a machine note's ``key=value`` line."""
    m = _NOTE_KEY_VALUE.match(line)
    return (m.group(1), m.group(2).strip()) if m and m.group(1) in MACHINE_KEYS else None


def note_key_line(line: str) -> bool:
    """Whether ``line`` would be read as one of a machine note's ``key=value`` lines."""
    return _note_key_value(line) is not None


def include_title(title: str) -> str | None:
    """The file of a region frame titled ``file=PATH`` (an included region), else None."""
    m = _INCLUDE.match(title)
    if not m:
        return None
    value = parse_value(m.group(1).strip())
    return value if isinstance(value, str) else m.group(1).strip()
