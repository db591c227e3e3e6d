"""Where JSON pointers are in a JSON text: line and column, found in one linear scan, only when an error needs them."""

from __future__ import annotations

import bisect
import json
import re
from typing import Any

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
    """Line and column of each pointer in ``pointers`` found in ``text`` (which must be valid JSON).

    An object member is located at its key (where a person looks for it), an array element at its
    value, the whole document (``""``) at its first token. Unknown pointers are left out. Subtrees
    holding no wanted pointer are skipped by the C decoder, so a 20 MB file takes about one parse.
    """
    trie: dict[str, Any] = {}
    for ptr in pointers:
        node = trie
        for token in _tokens(ptr):
            node = node.setdefault(token, {})
        node[_HERE] = True
    found: dict[str, int] = {}
    idx = _WS.match(text, 0).end()
    if trie.get(_HERE):
        found[""] = idx
    try:
        _walk(text, idx, trie, "", found)
    except (ValueError, IndexError, RecursionError):
        pass  # not valid JSON after all: keep what was found
    index = LineIndex(text)
    return {p: index.position(off) for p, off in found.items()}


_HERE = object()
_WS = re.compile(r"[ \t\n\r]*")
_DECODER = json.JSONDecoder()


def _tokens(ptr: str) -> list[str]:
    if not ptr:
        return []
    return [t.replace("~1", "/").replace("~0", "~") for t in ptr.split("/")[1:]]


def _walk(text: str, idx: int, node: dict[Any, Any], ptr: str, found: dict[str, int]) -> int:
    """Walk the value starting at ``idx``; record wanted positions below ``node``; return the end index."""
    if not any(key is not _HERE for key in node):
        return _DECODER.raw_decode(text, idx)[1]
    ch = text[idx]
    if ch == "{":
        idx = _WS.match(text, idx + 1).end()
        if text[idx] == "}":
            return idx + 1
        while True:
            key, after = _DECODER.raw_decode(text, idx)
            child = node.get(key)
            child_ptr = f"{ptr}/{escape(key)}"
            if child is not None and child.get(_HERE):
                found[child_ptr] = idx  # a repeated key: the last one, whose value the parser keeps
            idx = _WS.match(text, after).end() + 1  # the ':'
            idx = _WS.match(text, idx).end()
            idx = _walk(text, idx, child, child_ptr, found) if child is not None else _DECODER.raw_decode(text, idx)[1]
            idx = _WS.match(text, idx).end()
            if text[idx] == "}":
                return idx + 1
            idx = _WS.match(text, idx + 1).end()  # after ','
    if ch == "[":
        idx = _WS.match(text, idx + 1).end()
        if text[idx] == "]":
            return idx + 1
        i = 0
        while True:
            child = node.get(str(i))
            child_ptr = f"{ptr}/{i}"
            if child is not None:
                if child.get(_HERE):
                    found[child_ptr] = idx
                idx = _walk(text, idx, child, child_ptr, found)
            else:
                idx = _DECODER.raw_decode(text, idx)[1]
            idx = _WS.match(text, idx).end()
            if text[idx] == "]":
                return idx + 1
            idx = _WS.match(text, idx + 1).end()
            i += 1
    return _DECODER.raw_decode(text, idx)[1]


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


def duplicate_keys(text: str) -> list[tuple[str, str, tuple[int, int], tuple[int, int]]]:
    """Every key that occurs twice in one object of ``text`` (valid JSON): ``(pointer of the object, key,
    (line, column) of the first occurrence, (line, column) of the repeat)``, in file order.

    Only called after the fast parse saw a duplicate, so its cost is paid by broken files alone.
    """
    found: list[tuple[str, str, int, int]] = []
    try:
        _dup_walk(text, _WS.match(text, 0).end(), "", found)
    except (ValueError, IndexError, RecursionError):
        pass  # deeper than Python's stack, or not JSON after all: keep what was found
    index = LineIndex(text)
    return [(ptr, key, index.position(a), index.position(b)) for ptr, key, a, b in found]


def _dup_walk(text: str, idx: int, ptr: str, found: list[tuple[str, str, int, int]]) -> int:
    ch = text[idx]
    if ch == "{":
        idx = _WS.match(text, idx + 1).end()
        if text[idx] == "}":
            return idx + 1
        seen: dict[str, int] = {}
        while True:
            key, after = _DECODER.raw_decode(text, idx)
            if key in seen:
                found.append((ptr, key, seen[key], idx))
            else:
                seen[key] = idx
            idx = _WS.match(text, _WS.match(text, after).end() + 1).end()  # past the ':'
            idx = _dup_walk(text, idx, f"{ptr}/{escape(key)}", found)
            idx = _WS.match(text, idx).end()
            if text[idx] == "}":
                return idx + 1
            idx = _WS.match(text, idx + 1).end()
    if ch == "[":
        idx = _WS.match(text, idx + 1).end()
        if text[idx] == "]":
            return idx + 1
        i = 0
        while True:
            idx = _dup_walk(text, idx, f"{ptr}/{i}", found)
            idx = _WS.match(text, idx).end()
            if text[idx] == "]":
                return idx + 1
            idx = _WS.match(text, idx + 1).end()
            i += 1
    return _DECODER.raw_decode(text, idx)[1]
