"""Where JSON pointers are in a JSON text: line and column, found in one linear scan, only when an error needs them."""

from __future__ import annotations

import bisect
import re

_TOKEN = re.compile(r'[{}\[\],:]|"(?:[^"\\]|\\.)*"|[^\s{}\[\],:"]+', re.S)
_NEWLINE = re.compile(r"\n")


def escape(token: str | int) -> str:
    """Escape one reference token of a JSON pointer (RFC 6901)."""
    return str(token).replace("~", "~0").replace("/", "~1")


def pointer(*tokens: str | int) -> str:
    return "".join("/" + escape(t) for t in tokens)


class LineIndex:
    """Offsets to 1-based line and column."""

    def __init__(self, text: str) -> None:
        self._starts = [0] + [m.end() for m in _NEWLINE.finditer(text)]

    def position(self, offset: int) -> tuple[int, int]:
        line = bisect.bisect_right(self._starts, offset)
        return line, offset - self._starts[line - 1] + 1


def locate(text: str, pointers: set[str]) -> dict[str, tuple[int, int]]:
    """Line and column of each pointer in ``pointers`` found in ``text``.

    An object member is located at its key (where a person looks for it), an array element at its
    value, the whole document (``""``) at its first token. Unknown pointers are left out.
    """
    found: dict[str, int] = {}
    wanted = set(pointers)
    # Each frame: [is_object, pointer of the container, next index or pending key, expecting_key]
    stack: list[list] = []
    pending_key_ptr: str | None = None
    first = True
    for m in _TOKEN.finditer(text):
        tok = m.group()
        start = m.start()
        if first:
            first = False
            if "" in wanted:
                found[""] = start
        if stack:
            frame = stack[-1]
            if frame[0]:  # object
                if frame[3]:
                    if tok[0] == '"':
                        key = _decode_key(tok)
                        ptr = frame[1] + "/" + escape(key)
                        if ptr in wanted and ptr not in found:
                            found[ptr] = start
                        pending_key_ptr = ptr
                        frame[3] = False
                        continue
                    if tok == "}":
                        stack.pop()
                    continue
                if tok == ":":
                    continue
                if tok == ",":
                    frame[3] = True
                    continue
                if tok == "}":
                    stack.pop()
                    continue
                value_ptr = pending_key_ptr if pending_key_ptr is not None else frame[1]
            else:  # array
                if tok == ",":
                    frame[2] += 1
                    continue
                if tok == "]":
                    stack.pop()
                    continue
                value_ptr = frame[1] + "/" + str(frame[2])
                if value_ptr in wanted and value_ptr not in found:
                    found[value_ptr] = start
        else:
            value_ptr = ""
        if tok == "{":
            stack.append([True, value_ptr, 0, True])
        elif tok == "[":
            stack.append([False, value_ptr, 0, False])
        if len(found) == len(wanted):
            break
    index = LineIndex(text)
    return {p: index.position(off) for p, off in found.items()}


def _decode_key(tok: str) -> str:
    if "\\" not in tok:
        return tok[1:-1]
    import json

    try:
        return json.loads(tok)
    except ValueError:
        return tok[1:-1]


def depth_exceeded_at(text: str, limit: int) -> tuple[int, int] | None:
    """Line and column where nesting first exceeds ``limit`` levels (strings skipped), or ``None``."""
    depth = 0
    for m in re.finditer(r'"(?:[^"\\]|\\.)*"|[\[{]|[\]}]', text, re.S):
        ch = m.group()[0]
        if ch in "[{":
            depth += 1
            if depth > limit:
                return LineIndex(text).position(m.start())
        elif ch in "]}":
            depth -= 1
    return None
