"""Reading the raw elements of a UMLet diagram: ``.uxf`` XML, or the JSON TRAL's ``xml2json`` made of one.

Only the XML structure is handled here (kinds, coordinates, texts, relation points, where each element is
in the file); what the elements mean is :mod:`fsm.tools.umlet.reader`'s business. The XML parser resolves no
entities, loads no DTD and uses no network; a document with a DOCTYPE is refused before it is parsed, so
entity bombs and external entities never reach lxml.
"""

from __future__ import annotations

import bisect
import functools
import io
import math
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from fsm.loading.reading import parse_json_bytes, read_file_bytes
from fsm.model.errors import DiagramError, Problem
from fsm.model.jsonpos import locate

from . import text as T

#: Relation points and coordinates beyond this are refused (far beyond any diagram; keeps arithmetic sane).
MAX_COORDINATE = 1e9
#: More elements than this are refused (a 50 MB diagram holds ~200k; this is a guard, not a design size).
MAX_ELEMENTS = 2_000_000


@dataclass(slots=True)
class RawElement:
    """One ``<element>``: its kind, whether it is an old (``<type>``) element, geometry and texts."""

    index: int
    kind: str  # UMLState, UMLSpecialState, UMLFrame, Relation, ... (old elements: the simple class name)
    old: bool
    x: float
    y: float
    w: float
    h: float
    text: str
    points: list[float] | None  # additional_attributes as numbers (relations), None if absent/empty
    line: int | None = None  # where the element starts in the file (1-based), when known
    column: int | None = None
    pointer: str | None = None  # JSON pointer for the xml2json form

    @property
    def first_line(self) -> str:
        for ln in self.text.split("\n"):
            if ln.strip():
                return ln.strip()
        return ""


@dataclass
class RawDiagram:
    """All elements of a diagram with its zoom level and how to find positions in its text."""

    name: str
    zoom: float
    elements: list[RawElement]
    text: str | None = None  # the file as text (for the loader's locator), None for huge files
    locate_json: Callable[[set[str]], dict[str, tuple[int, int]]] | None = None
    zoom_line: int | None = None
    problems: list[Problem] = field(default_factory=list)


def fail(name: str, message: str, line: int | None = None, column: int | None = None, hint: str | None = None,
         element: str | None = None) -> DiagramError:
    return DiagramError([Problem(message, name, line=line, column=column, hint=hint, element=element)])


def _no_elements(name: str, line: int | None, column: int | None) -> DiagramError:
    return fail(name, "the <diagram> has no elements: draw states and transitions in UMLet", line, column)


# -- entry ------------------------------------------------------------------------------------------------
def read_raw(path: Path) -> RawDiagram:
    """The elements of a ``.uxf`` file (XML) or of its ``xml2json`` JSON form, whichever ``path`` holds."""
    name = str(path)
    raw = read_file_bytes(path, "diagram")
    return parse_raw(raw, name)


def parse_raw(raw: bytes, name: str) -> RawDiagram:
    raw = raw.removeprefix(b"\xef\xbb\xbf")
    head = raw[:64].lstrip()
    if not head:
        raise fail(name, "file is empty; a UMLet diagram is an XML document <diagram>...</diagram>", 1, 1)
    if raw.startswith((b"\xff\xfe", b"\xfe\xff")) or raw[1:2] == b"\x00":
        raise fail(name, "not UTF-8 (looks like UTF-16)", 1, 1, hint="save the diagram as UTF-8, as UMLet does")
    if head[:1] in (b"{", b"["):
        return parse_xml2json(raw, name)
    return parse_xml(raw, name)


# -- XML --------------------------------------------------------------------------------------------------
_PROLOG_ITEM = re.compile(rb"\s*(?:<\?.*?\?>|<!--.*?-->)", re.S)
_ELEMENT_TAG = re.compile(rb"<element[\s>/]")


def _refuse_doctype(raw: bytes, name: str) -> None:
    """A DOCTYPE (and with it every entity declaration) is refused outright, before any parsing."""
    pos = 0
    while m := _PROLOG_ITEM.match(raw, pos):  # each match is not empty
        pos = m.end()
    while raw[pos:pos + 1].isspace():  # b"" at the end is no space
        pos += 1
    if raw.startswith((b"<!DOCTYPE", b"<!doctype"), pos) or b"<!ENTITY" in raw[:pos + 4096]:
        line = raw.count(b"\n", 0, pos) + 1
        col = pos - (raw.rfind(b"\n", 0, pos) + 1) + 1
        raise fail(name, "DOCTYPE declarations are not allowed in a UMLet diagram (entities are never expanded, "
                         "external files never read)", line, col,
                   hint="UMLet never writes a DOCTYPE; remove it")


def _parser_kwargs() -> dict[str, Any]:
    return dict(resolve_entities=False, no_network=True, load_dtd=False, huge_tree=False, remove_comments=True,
                remove_pis=True, dtd_validation=False)


class _XmlElements:
    """What one pass over a UMLet file's XML events collects: the root's tag, the zoom level and the elements (one
    :class:`RawElement` per ``<element>``, a blank one for an element with problems) with their source lines."""

    def __init__(self, name: str) -> None:
        self.name = name
        self.elements: list[RawElement] = []
        self.zoom_text: str | None = None
        self.zoom_line: int | None = None
        self.root_tag: str | None = None
        self.problems: list[Problem] = []
        self.sourcelines: list[int | None] = []

    def read(self, context: Any) -> None:
        depth = 0
        for event, el in context:
            if event == "start":
                depth += 1
                if depth == 1:
                    self.root(el)
                continue
            depth -= 1
            if depth == 1:
                self.child(el)
                el.clear()
                # drop already processed siblings so memory stays bounded on huge files
                parent = el.getparent()
                if parent is not None:
                    while el.getprevious() is not None:
                        del parent[0]

    def root(self, el: Any) -> None:
        self.root_tag = el.tag
        if el.tag != "diagram":
            raise fail(self.name, f"not a UMLet diagram: the root element is <{el.tag}>, not <diagram>",
                       el.sourceline, 1)

    def child(self, el: Any) -> None:
        """A child of ``<diagram>``: the zoom level, or an element."""
        if el.tag == "zoom_level":
            self.zoom_text = el.text
            self.zoom_line = el.sourceline
        elif el.tag == "element":
            if len(self.elements) >= MAX_ELEMENTS:
                raise fail(self.name, f"more than {MAX_ELEMENTS} elements; refusing to read further", el.sourceline)
            index = len(self.elements)
            self.sourcelines.append(el.sourceline)
            elem = _xml_element(el, index, self.name, self.problems)
            self.elements.append(elem if elem is not None else RawElement(index, "", False, 0, 0, 0, 0, "", None))

    def locate(self, raw: bytes) -> None:
        """Each element's line and column in ``raw``, and its problems' (found by the element's number)."""
        positions = _element_positions(raw, self.sourcelines)
        for elem in self.elements:
            elem.line, elem.column = positions[elem.index]
        for p in self.problems:
            if p.line is None and p.pointer.startswith("#"):
                p.line, p.column = positions[int(p.pointer[1:])]
                p.pointer = ""


def _syntax_failure(exc: Any, name: str) -> DiagramError:
    """lxml's complaint about XML that is not well-formed, located."""
    line, col = exc.position or (None, None)
    msg = re.sub(r",? line \d+, column \d+$", "", str(exc.msg or exc))
    if "huge" in msg.lower():
        msg += " (text nodes are limited to 10 MB)"
    return fail(name, f"not well-formed XML: {msg}", line, col + 1 if col is not None else None,
                hint="is this a UMLet .uxf file?")


def parse_xml(raw: bytes, name: str) -> RawDiagram:
    from lxml import etree  # lazily: `fsmctl validate` on JSON never imports lxml

    _refuse_doctype(raw, name)

    found = _XmlElements(name)
    try:
        found.read(etree.iterparse(io.BytesIO(raw), events=("start", "end"), **_parser_kwargs()))
    except etree.XMLSyntaxError as exc:
        raise _syntax_failure(exc, name) from None
    except (ValueError, MemoryError) as exc:  # lxml raises ValueError for some invalid input
        raise fail(name, f"cannot parse XML: {exc}") from None
    if found.root_tag is None:
        raise fail(name, "not a UMLet diagram: no <diagram> root element", 1, 1)
    found.locate(raw)
    if found.problems:  # else every element read
        raise DiagramError(found.problems)
    zoom = _zoom(found.zoom_text, name, found.zoom_line)
    if not found.elements:
        raise _no_elements(name, 1, 1)
    text = raw.decode("utf-8", "replace") if len(raw) <= 8_000_000 else None
    return RawDiagram(name, zoom, found.elements, text=text, zoom_line=found.zoom_line)


def _element_positions(raw: bytes, sourcelines: list[int | None]) -> list[tuple[int | None, int | None]]:
    """Line and column of each ``<element`` tag; the column only where the tag scan agrees with lxml's line."""
    starts = [0]
    pos = raw.find(b"\n")
    while pos != -1:
        starts.append(pos + 1)
        pos = raw.find(b"\n", pos + 1)
    out: list[tuple[int | None, int | None]] = []
    offsets = [m.start() for m in _ELEMENT_TAG.finditer(raw)]
    for i, line in enumerate(sourcelines):
        if i < len(offsets):
            off = offsets[i]
            ln = bisect.bisect_right(starts, off)
            if line is None or ln == line:
                out.append((ln, off - starts[ln - 1] + 1))
                continue
        out.append((line, None))
    return out


def _xml_element(el: Any, index: int, name: str, problems: list[Problem]) -> RawElement | None:
    kind = None
    old = False
    coords = None
    text = ""
    extra = None
    for child in el:
        tag = child.tag
        if tag == "id":
            kind = (child.text or "").strip()
        elif tag == "type":
            kind = (child.text or "").strip().rsplit(".", 1)[-1]
            old = True
        elif tag == "coordinates":
            coords = {c.tag: c.text for c in child if isinstance(c.tag, str)}
        elif tag == "panel_attributes":
            text = child.text or ""
        elif tag == "additional_attributes":
            extra = child.text
    return _make_element(index, kind, old, coords, text, extra, name, problems, lambda: (None, None), None)


def _zoom(text: Any, name: str, line: int | None, pointer: str | None = None) -> float:
    """UMLet reads ``<zoom_level>`` as an integer (``InputHandler``: ``Integer.parseInt``) and zooms only between 1
    and 20 (``DiagramHandler.setGridAndZoom``)."""
    if text is None:
        return 10.0
    try:
        zoom = float(str(text).strip())
    except ValueError:
        zoom = float("nan")
    if not (math.isfinite(zoom) and zoom.is_integer() and 1 <= zoom <= 20):
        raise DiagramError([Problem(f"<zoom_level> must be a whole number between 1 and 20, got "
                                    f"{str(text).strip()[:40]!r}", name, pointer=pointer or "", line=line,
                                    hint="UMLet writes 10 for 100% and zooms between 1 (10%) and 20 (200%)")])
    return zoom


def _number(value: Any) -> float | None:
    """A coordinate: a number, or a text of one (blanks around it allowed), finite and at most
    :data:`MAX_COORDINATE` in size; else None."""
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        return None
    try:
        v = float(value)
    except ValueError:
        return None
    return v if math.isfinite(v) and abs(v) <= MAX_COORDINATE else None


def _make_element(index: int, kind: Any, old: bool, coords: Any, text: Any, extra: Any, name: str,
                  problems: list[Problem], where: Callable[[], tuple[int | None, int | None]],
                  pointer: str | None) -> RawElement | None:
    at: list[float] = []  # x, y once they are read: the element is then named as everywhere else
    try:
        if not isinstance(kind, str) or not kind:
            raise T.TextError("element without <id> (or old <type>): cannot tell what it is")
        values = _coordinates(coords)
        at.extend(values[:2])
        if values[2] < 0 or values[3] < 0:
            raise T.TextError(f"negative size w={values[2]:g}, h={values[3]:g}",
                              "UMLet writes sizes of 0 or more pixels")
        if not isinstance(text, (str, type(None))):
            raise T.TextError("panel_attributes must be text")
        points = _points(kind, extra)
    except T.TextError as bad:
        line, col = where()
        problems.append(Problem(str(bad), name, pointer=pointer if pointer is not None else f"#{index}", line=line,
                                column=col, element=_bad_element(index, kind, old, at, text), hint=bad.hint))
        return None
    text = (text or "").replace("\r\n", "\n").replace("\r", "\n")
    line, col = where()
    return RawElement(index, kind, old, values[0], values[1], values[2], values[3], text, points, line, col, pointer)


def _bad_element(index: int, kind: Any, old: bool, at: list[float], text: Any) -> str:
    """How a message names an element that did not read: as everywhere else once its x and y are read, else by its
    kind, number and first line."""
    text = text if isinstance(text, str) else ""
    if len(at) == 2:
        return describe(RawElement(index, str(kind), old, at[0], at[1], 0, 0, text.replace("\r\n", "\n"), None))
    label = text.strip().split("\n")[0][:40]
    return f"{kind or 'element'} #{index + 1}" + (f" '{label}'" if label else "")


def _coordinates(coords: Any) -> list[float]:
    """x, y, w, h of an element's ``<coordinates>``, each a number."""
    if not isinstance(coords, dict):
        raise T.TextError("element without <coordinates>")
    values = []
    for key in ("x", "y", "w", "h"):
        v = _number(coords.get(key))
        if v is None:
            got = coords.get(key)
            raise T.TextError(f"coordinate <{key}> is not a number: {str(got)[:40]!r}" if got is not None
                       else f"coordinate <{key}> is missing", "UMLet writes whole numbers of pixels")
        values.append(v)
    return values


def _points(kind: str, extra: Any) -> list[float] | None:
    """A relation's points from ``<additional_attributes>`` (``x;y;x;y;...``); ``None`` for other elements."""
    if not isinstance(extra, (str, type(None))):
        raise T.TextError("additional_attributes must be text")
    if kind != "Relation" or not extra or not extra.strip():
        return None
    parts = [p for p in extra.strip().split(";") if p.strip() != ""]
    nums: list[float] = []
    for p in parts:
        n = _number(p)
        if n is None:
            raise T.TextError(f"relation point {p.strip()[:30]!r} is not a number",
                              "additional_attributes holds x;y;x;y;... numbers")
        nums.append(n)
    if len(nums) % 2:
        raise T.TextError(f"relation points come in x;y pairs, got {len(nums)} numbers: {extra.strip()[:60]!r}",
                          "additional_attributes holds x;y;x;y;... numbers; draw the arrow again in UMLet")
    return nums


# -- xml2json ---------------------------------------------------------------------------------------------
def parse_xml2json(raw: bytes, name: str) -> RawDiagram:
    """The legacy form: ``{"diagram": {"zoom_level": "10", "element": [...] or {...}}}``, every value a string."""
    data, source = parse_json_bytes(raw, name, None)
    text = source.text or ""

    def locator(ptrs: set[str]) -> dict[str, tuple[int, int]]:
        return locate(text, ptrs)

    def at(ptr: str) -> tuple[int | None, int | None]:
        pos = locator({ptr}).get(ptr)
        return pos if pos else (None, None)

    diagram = _xml2json_diagram(data, name)
    zoom_ptr = "/diagram/zoom_level"
    zoom = _zoom(diagram.get("zoom_level"), name, at(zoom_ptr)[0] if "zoom_level" in diagram else None, zoom_ptr)
    raw_elements = diagram.get("element")
    if isinstance(raw_elements, dict):  # xml2json makes one element an object, several a list
        items = [(raw_elements, "/diagram/element")]
    elif isinstance(raw_elements, list):
        items = [(e, f"/diagram/element/{i}") for i, e in enumerate(raw_elements)]
    else:
        raise _no_elements(name, *at("/diagram"))
    problems: list[Problem] = []
    elements: list[RawElement] = []
    for index, (item, ptr) in enumerate(items):
        elem = _xml2json_element(index, item, ptr, name, problems, functools.partial(at, ptr))
        if elem is not None:
            elements.append(elem)
    if problems:
        raise DiagramError(problems)
    if not elements:
        raise _no_elements(name, *at("/diagram"))
    return RawDiagram(name, zoom, elements, text=text, locate_json=locator)


def _xml2json_diagram(data: Any, name: str) -> dict[str, Any]:
    """The ``diagram`` object of the xml2json form; a machine document or anything else is refused."""
    diagram = data.get("diagram") if isinstance(data, dict) else None
    if isinstance(diagram, dict):
        return diagram
    if isinstance(data, dict) and {"states", "initial", "root"} & data.keys():
        raise fail(name, "this is already a machine document, not a diagram", 1, 1,
                   hint="validate or run it directly: fsmctl validate FILE")
    raise fail(name, 'not a UMLet diagram in xml2json form: expected {"diagram": {"element": [...]}}', 1, 1)


def _xml2json_element(index: int, item: Any, ptr: str, name: str, problems: list[Problem],
                      at: Callable[[], tuple[int | None, int | None]]) -> RawElement | None:
    """One element of the xml2json form (its kind in ``id``, or an old ``type``; ``#text`` where xml2json met
    mixed content), or ``None`` with its problem added."""
    if not isinstance(item, dict):
        line, col = at()
        problems.append(Problem("element must be an object", name, pointer=ptr, line=line, column=col))
        return None
    kind = item.get("id")
    old = False
    if not isinstance(kind, str) and isinstance(item.get("type"), str):
        kind = item["type"].strip().rsplit(".", 1)[-1]
        old = True
    panel = item.get("panel_attributes")
    if isinstance(panel, dict):
        panel = panel.get("#text", "")
    extra = item.get("additional_attributes")
    if isinstance(extra, dict):
        extra = extra.get("#text")
    return _make_element(index, kind.strip() if isinstance(kind, str) else kind, old, item.get("coordinates"),
                         panel, extra, name, problems, at, ptr)


# -- naming elements in messages ----------------------------------------------------------------------------
def where(elem: RawElement) -> str:
    return f"x={num(elem.x)}, y={num(elem.y)}"


def num(v: float) -> Any:
    return int(v) if float(v).is_integer() else round(v, 3)


def describe(elem: RawElement) -> str:
    label = elem.first_line
    if elem.kind == "Relation":
        rel = T.parse_relation(elem.text)
        label = " ".join(ln.strip() for ln in rel.label_lines if ln.strip())
        label = (f"lt={rel.lt}" + (f" {label}" if label else "")) if rel.lt else label
    label = label if len(label) <= 40 else label[:37] + "..."
    return f"{elem.kind} '{label}' at {where(elem)}" if label else f"{elem.kind} at {where(elem)}"
