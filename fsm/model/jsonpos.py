"""Where JSON pointers are in a JSON text: line and column, found in one linear scan, only when an error needs them."""

from __future__ import annotations

import bisect
import json
import re
from collections.abc import Callable
from typing import Any, cast

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
    trie: dict[Any, Any] = {}
    for ptr in pointers:
        node = trie
        for token in _tokens(ptr):
            node = node.setdefault(token, {})
        node[_HERE] = True
    found: dict[str, int] = {}
    idx = _ws_match(text, 0).end()
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
#: ``_WS.match``, which never gives None (the pattern matches the empty string too).
_ws_match = cast(Callable[[str, int], "re.Match[str]"], _WS.match)
_DECODER = json.JSONDecoder()


def _tokens(ptr: str) -> list[str]:
    if not ptr:
        return []
    return [t.replace("~1", "/").replace("~0", "~") for t in ptr.split("/")[1:]]


def _walk(text: str, idx: int, node: dict[Any, Any], ptr: str, found: dict[str, int]) -> int:
    """Walk the value starting at ``idx``; record wanted positions below ``node``; return the end index."""
    if not any(key is not _HERE for key in node):
        return _DECODER.raw_decode(text, idx)[1]
    members = _members(text, idx)
    if members is None:
        return _DECODER.raw_decode(text, idx)[1]
    try:
        token, at = next(members)
        while True:
            child = node.get(token)
            child_ptr = f"{ptr}/{escape(token)}"
            if child is not None and child.get(_HERE):
                found[child_ptr] = at  # a repeated key: the last one, whose value the parser keeps
            value = members.send(None)
            end = _walk(text, value, child, child_ptr, found) if child is not None else _skip(text, value)
            token, at = members.send(end)
    except StopIteration as stop:
        after: int = stop.value  # where the container ends
        return after


def _members(text: str, idx: int) -> Any:
    """The members of the object or array at ``idx``, or ``None`` for a scalar: a generator that yields
    ``(token, offset)`` per member (the key and its offset; for an array element its index and the value's
    offset), then, sent ``None``, the offset of the member's value, and is sent back where the value ends. It
    returns (``StopIteration.value``) the offset after the container."""
    ch = text[idx]
    if ch not in "{[":
        return None
    return _object_members(text, idx) if ch == "{" else _array_members(text, idx)


def _object_members(text: str, idx: int) -> Any:
    idx = _ws_match(text, idx + 1).end()
    if text[idx] == "}":
        return idx + 1
    while True:
        key, after = _DECODER.raw_decode(text, idx)
        yield key, idx
        idx = yield _ws_match(text, _ws_match(text, after).end() + 1).end()  # past the ':'
        idx = _ws_match(text, idx).end()
        if text[idx] == "}":
            return idx + 1
        idx = _ws_match(text, idx + 1).end()  # after ','


def _array_members(text: str, idx: int) -> Any:
    idx = _ws_match(text, idx + 1).end()
    if text[idx] == "]":
        return idx + 1
    i = 0
    while True:
        yield str(i), idx
        idx = yield idx
        idx = _ws_match(text, idx).end()
        if text[idx] == "]":
            return idx + 1
        idx = _ws_match(text, idx + 1).end()
        i += 1


def _skip(text: str, idx: int) -> int:
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
        _dup_walk(text, _ws_match(text, 0).end(), "", found)
    except (ValueError, IndexError, RecursionError):
        pass  # deeper than Python's stack, or not JSON after all: keep what was found
    index = LineIndex(text)
    return [(ptr, key, index.position(a), index.position(b)) for ptr, key, a, b in found]


def _dup_walk(text: str, idx: int, ptr: str, found: list[tuple[str, str, int, int]]) -> int:
    members = _members(text, idx)
    if members is None:
        return _skip(text, idx)
    is_object = text[idx] == "{"
    seen: dict[str, int] = {}
    try:
        token, at = next(members)
        while True:
            if is_object:
                if token in seen:
                    found.append((ptr, token, seen[token], at))
                else:
                    seen[token] = at
            value = members.send(None)
            token, at = members.send(_dup_walk(text, value, f"{ptr}/{escape(token)}", found))
    except StopIteration as stop:
        after: int = stop.value  # where the container ends
        return after
