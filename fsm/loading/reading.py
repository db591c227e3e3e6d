"""Reading input files for the loader and the tools: a reader per file suffix (JSON by default, ``.uxf``
registered by ``fsm.tools``), files the caller has already read (``preloaded``), regular files only and capped
in size, standard input, and strict JSON (UTF-8, limited nesting, no repeated keys) whose problems carry
line:column.
"""

from __future__ import annotations

import array
import errno
import itertools
import json
import os
import re
import stat
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from pathlib import Path
from typing import Any

from fsm.model.document import Source
from fsm.model.errors import DiagramError, Problem
from fsm.model.jsonpos import LineIndex, depth_exceeded_at, duplicate_keys, escape, locate
from fsm.model.problems import place as place  # re-exported: the adapters and tools locate through it

#: Where a too-deep JSON text is reported (Python's parser gives up somewhat deeper than this).
MAX_JSON_DEPTH = 400

Reader = Callable[[Path], tuple[Any, Source]]
_READERS: dict[str, Reader] = {}


#: What besides a file's text decides what a reader makes of it (the plan cache's key holds it), by reader.
CacheKey = Callable[[Path], "tuple[str, str | None]"]
_CACHE_KEYS: dict[Reader, CacheKey] = {}


def register_reader(suffix: str, reader: Reader, cache_key: CacheKey | None = None) -> None:
    """Let ``load`` read files ending in ``suffix`` (``".uxf"``) with ``reader(path) -> (document, Source)``.

    The reader raises :class:`DiagramError` for a file it cannot read. This keeps the core free of
    UMLet: ``fsm.tools`` registers its reader. ``cache_key(path)`` gives what besides the file's text decides what
    the reader makes of it (a diagram's chosen machine) and the file's text if the caller has read it already
    (else None); without it, the reader's files are not cached (fsm.loading.cache).
    """
    _READERS[suffix.lower()] = reader
    if cache_key is not None:
        _CACHE_KEYS[reader] = cache_key


def cache_key(path: Path) -> tuple[str, str | None] | None:
    """What besides its text decides what the file's reader (by suffix) makes of ``path``, with its text when the
    caller read it already; None when its reader says nothing of it (its documents are not cached)."""
    reader = _reader_by_suffix(path)
    if reader is read_json:
        return "json", None
    key = _CACHE_KEYS.get(reader)
    return key(path) if key is not None else None


#: Entry-point group of file readers: the entry point's name is the suffix without its dot (``uxf``).
READER_GROUP = "fsm.readers"


def reader_for(path: Path) -> Reader:
    """The reader of a file by its suffix: registered, or found in the ``fsm.readers`` entry points
    (how ``fsm.tools`` provides ``.uxf`` without the core knowing UMLet), else JSON."""
    pre = _PRELOADED.get()
    if pre is not None and str(path) in pre:
        item = pre[str(path)]
        if isinstance(item, tuple):  # already read and parsed by the caller
            return lambda _path: item
        if str(path) == STDIN_NAME and item.lstrip(b"\xef\xbb\xbf \t\r\n").startswith(b"<"):
            return reader_for(Path(STDIN_NAME + ".uxf"))  # a diagram on standard input
    return _reader_by_suffix(path)


def _reader_by_suffix(path: Path) -> Reader:
    suffix = path.suffix.lower()
    reader = _READERS.get(suffix)
    if reader is None and suffix and suffix not in _NO_READER:
        from fsm.loading.installed import entry_points

        for ep in entry_points(group=READER_GROUP, name=suffix[1:]):
            reader = ep.load()
            _READERS[suffix] = reader
            break
        else:
            _NO_READER.add(suffix)  # looking the entry points up costs more than parsing a small file
    return reader or read_json


#: Suffixes no entry point provides a reader for (read as JSON), so the lookup is made once per process. ``.json`` is
#: the core's own format: a JSON document is read without looking at the installed distributions at all.
_NO_READER: set[str] = {".json"}


def read_json(path: Path) -> tuple[Any, Source]:
    """Read a JSON file strictly: UTF-8, one JSON value, limited nesting; problems carry line:column."""
    if not str(path) or str(path) == ".":
        raise DiagramError([Problem("no file name given", None, hint="name a machine file (.json or .uxf)")])
    return parse_json_bytes(read_file_bytes(path), str(path), path.parent)


#: Input files larger than this are refused (a guard against /dev/zero-like inputs and exhausted memory, far
#: above any real diagram: benchmarks/bench_big.py reads 52 MB). ``FSM_MAX_INPUT_BYTES`` overrides it.
MAX_INPUT_BYTES = 64 * 1024 * 1024
#: How standard input (``-`` on the command line) is named in messages.
STDIN_NAME = "<stdin>"

#: Files the caller has already read (``fsmctl`` reads each named file, and standard input, once):
#: ``str(path)`` -> the bytes, or the ``(document, Source)`` a reader made of them.
_PRELOADED: ContextVar[dict[str, Any] | None] = ContextVar("_PRELOADED", default=None)


@contextmanager
def preloaded(files: dict[str, Any]) -> Iterator[None]:
    """While active, ``read_file_bytes`` and the readers take these files' bytes (or parsed documents) from
    ``files`` instead of reading them again."""
    token = _PRELOADED.set({**(_PRELOADED.get() or {}), **files})
    try:
        yield
    finally:
        _PRELOADED.reset(token)


def preloaded_copy(name: str) -> Any:
    """What the caller preloaded for the file ``name`` (its bytes, or the ``(document, Source)`` a reader made of
    them), or None."""
    pre = _PRELOADED.get()
    return pre.get(name) if pre is not None else None


def max_input_bytes() -> int:
    try:
        return max(1, int(os.environ.get("FSM_MAX_INPUT_BYTES", "")))
    except ValueError:
        return MAX_INPUT_BYTES


def _too_big(name: str, size: int | None, limit: int) -> DiagramError:
    shown = f"{size / 1048576:.1f} MiB" if size is not None else "more than that"
    return DiagramError([Problem(f"file is too big ({shown}; the limit is {limit / 1048576:g} MiB)", name,
                                 hint="set FSM_MAX_INPUT_BYTES to a larger number of bytes to read it")])


def read_stdin_bytes() -> bytes:
    """Standard input, read once and capped (``-`` as a file name); named ``<stdin>`` in messages."""
    import sys

    limit = max_input_bytes()
    stream = getattr(sys.stdin, "buffer", None)
    if stream is None:
        raise DiagramError([Problem("standard input is not open", STDIN_NAME)])
    try:
        data: bytes = stream.read(limit + 1)
    except (OSError, ValueError) as exc:
        raise DiagramError([Problem(f"cannot read standard input: {exc}", STDIN_NAME)]) from None
    if len(data) > limit:
        raise _too_big(STDIN_NAME, None, limit)
    return data


def read_file_bytes(path: Path, what: str | None = None) -> bytes:
    """The bytes of ``path``, or a DiagramError saying why it cannot be read (``what``: "world", ...).

    Only regular files are read (checked before opening, so a FIFO or ``/dev/zero`` never hangs or fills
    memory), and at most :func:`max_input_bytes` of them.
    """
    name = str(path)
    pre = _PRELOADED.get()
    cached = pre.get(name) if pre is not None else None
    if isinstance(cached, bytes):
        return cached
    kind = what or "machine"
    a_kind = ("an " if kind[:1].lower() in "aeiou" else "a ") + kind  # "an image"
    try:
        st = os.stat(path)
        if stat.S_ISDIR(st.st_mode):
            raise DiagramError([Problem(f"is a directory, not {a_kind} file", name)])
        if not stat.S_ISREG(st.st_mode):
            sort = ("a FIFO" if stat.S_ISFIFO(st.st_mode) else "a device" if stat.S_ISCHR(st.st_mode)
                    or stat.S_ISBLK(st.st_mode) else "a socket" if stat.S_ISSOCK(st.st_mode) else "special")
            raise DiagramError([Problem(f"not a regular file ({sort}); {a_kind} file must be a regular file", name,
                                        hint="pass '-' to read standard input")])
        limit = max_input_bytes()
        if st.st_size > limit:
            raise _too_big(name, st.st_size, limit)
        # O_NONBLOCK: should the file have become a FIFO since the stat, opening it does not hang
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0))
        with os.fdopen(fd, "rb") as fh:
            if not stat.S_ISREG(os.fstat(fh.fileno()).st_mode):
                raise DiagramError([Problem(f"not a regular file; {a_kind} file must be a regular file", name)])
            data = fh.read(limit + 1)
        if len(data) > limit:
            raise _too_big(name, None, limit)
        return data
    except FileNotFoundError:
        dangling = os.path.islink(path)
        raise DiagramError([Problem(
            ("symlink to a missing file" if dangling else f"{what} file not found" if what else "file not found"),
            name, hint="check the path")]) from None
    except NotADirectoryError:
        raise DiagramError([Problem("file not found (a folder on its path is a file)", name,
                                    hint="check the path")]) from None
    except OSError as exc:
        reason = {errno.ELOOP: "too many levels of symbolic links (a symlink loop)",
                  errno.ENAMETOOLONG: "the file name is too long"}.get(exc.errno or 0, exc.strerror or str(exc))
        raise DiagramError([Problem(f"cannot read: {reason}", name)]) from None
    except ValueError as exc:  # e.g. a NUL byte in the path
        raise DiagramError([Problem(f"not a usable file name: {exc}", repr(name))]) from None


def parse_json_bytes(raw: bytes, name: str | None, directory: Any = None,
                     duplicates: list[Problem] | None = None) -> tuple[Any, Source]:
    """One JSON value from ``raw``, strictly (UTF-8, limited nesting, no repeated keys), with a locator.

    A repeated key raises :class:`DiagramError`, unless ``duplicates`` is given: then its problems are added
    there and the data (the last of the repeated values) is returned, so the caller reports them together
    with everything else it finds.
    """
    if raw.startswith(b"\xef\xbb\xbf"):
        raw = raw[3:]
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        col = exc.start - (raw.rfind(b"\n", 0, exc.start) + 1) + 1
        raise DiagramError([Problem(
            f"not UTF-8: byte 0x{raw[exc.start]:02x} at offset {exc.start} cannot be decoded",
            name, line=line, column=col, hint="save the file as UTF-8")]) from None
    if not text.strip():
        raise DiagramError([Problem("file is empty; a machine document is a JSON object", name, line=1, column=1,
                                    hint='start from {"initial": ..., "states": [...], "transitions": [...]}')])
    repeated: list[bool] = []

    def pairs_to_dict(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
        obj = dict(pairs)
        if len(obj) != len(pairs):
            repeated.append(True)
        return obj

    try:
        data = json.loads(text)
        found = _repeats_key(text, data)
        if found is None:  # the hook tells, object by object
            data = json.loads(text, object_pairs_hook=pairs_to_dict)
        elif found:
            repeated.append(True)
    except json.JSONDecodeError as exc:
        if exc.msg == "Extra data" and _is_trace(text):
            raise DiagramError([Problem(
                "this is a run's trace (fsmctl run --trace: JSON Lines, a record per line), not a JSON document",
                name, line=1, column=1, hint="traces are read by fsmctl report, explain, watch and export --mcap")]) \
                from None
        raise DiagramError([Problem(f"invalid JSON: {exc.msg}", name, line=exc.lineno, column=exc.colno)]) from None
    except ValueError:  # an integer of more digits than Python converts (sys.get_int_max_str_digits)
        limit = sys.get_int_max_str_digits()
        raise DiagramError([_at_first(text, name, r"-?\d{%d,}" % (limit + 1),
                                      f"a number of more than {limit} digits is too long to read",
                                      "no document needs a number of this many digits")]) from None
    except RecursionError:
        deep = depth_exceeded_at(text, MAX_JSON_DEPTH)
        at_line, at_column = deep if deep is not None else (None, None)
        raise DiagramError([Problem(f"JSON nested more than {MAX_JSON_DEPTH} levels deep", name,
                                    line=at_line, column=at_column,
                                    hint="no machine document needs this depth")]) from None
    if repeated:
        if duplicates is None:
            raise DiagramError(duplicate_key_problems(text, name))
        duplicates.extend(duplicate_key_problems(text, name))
    source = Source(name=name, directory=directory, text=text, locator=lambda ptrs: locate(text, ptrs))
    return data, source


def _is_trace(text: str) -> bool:
    """Whether ``text`` starts with a trace's header line (``{"type": "header", "format": "tral-fsm-trace", ...}``)."""
    try:
        head = json.loads(text.partition("\n")[0])
    except ValueError:
        return False
    return isinstance(head, dict) and head.get("format") == "tral-fsm-trace"


#: The set of the kinds of a list of JSON objects, of texts, of arrays: ``set(map(type, values)) <= ONLY_STR`` checks
#: a whole list in one C-speed pass (the loader's bulk checks use these).
ONLY_DICT = frozenset({dict})
ONLY_STR = frozenset({str})
ONLY_LIST = frozenset({list})


def json_count(data: Any, keys: int | None = None, strings: bool = False) -> int:
    """How many keys (``strings``: strings, keys and values) the parsed JSON value ``data`` holds, counted level by
    level in C-speed passes: no Python step per object or value. ``keys``: the count stops there (the text writes
    no more keys than that), so the values below the last object with a key are not looked at.

    A parse that dropped a repeated key holds fewer keys than the text writes colons outside its strings, and fewer
    strings than the text writes quotes, halved, when it has no backslash (then every quote opens or closes a
    string). So a repeated key is found without a Python hook called for each of the text's objects (about a tenth
    of a document's parse)."""
    count = 0
    level = [data]
    while level:
        types = list(map(type, level))
        kinds = set(types)  # (a list's count of a type would compare the other types with it the slow way)
        if strings and str in kinds:
            count += sum(map(ONLY_STR.__contains__, types))
        if dict not in kinds and list not in kinds:
            break
        dicts = level if kinds == ONLY_DICT else list(itertools.compress(level, map(ONLY_DICT.__contains__, types)))
        count += sum(map(len, dicts))
        if count == keys and not strings:
            break
        lists = itertools.compress(level, map(ONLY_LIST.__contains__, types)) if list in kinds else ()
        level = list(itertools.chain(itertools.chain.from_iterable(map(dict.values, dicts)),
                                     itertools.chain.from_iterable(lists)))
    return count


def _repeats_key(text: str, data: Any) -> bool | None:
    """Whether the parse ``data`` of ``text`` dropped a repeated key (:func:`json_count`); None when the counts
    cannot tell (a colon inside a string of a text with a backslash)."""
    colons = text.count(":")
    if json_count(data, colons) == colons:  # every colon separates a key, and no key was dropped
        return False
    if "\\" in text:
        return None
    return json_count(data, strings=True) != text.count('"') // 2


def _at_first(text: str, name: str | None, pattern: str, message: str, hint: str) -> Problem:
    """A problem at the first place ``pattern`` matches outside a string of ``text`` (else without a place)."""
    for match in re.finditer(r'"(?:[^"\\]|\\.)*"|(' + pattern + ")", text):
        if match.group(1) is not None:
            line, column = LineIndex(text).position(match.start(1))
            return Problem(message, name, line=line, column=column, hint=hint)
    return Problem(message, name, hint=hint)


def duplicate_key_problems(text: str, name: str | None) -> list[Problem]:
    """One problem per repeated key of ``text``, at the repeat, naming where the key was first written.

    JSON parsers disagree about repeated keys (most keep the last silently), so a document that repeats
    one means two different machines to two tools: it is refused.
    """
    problems = []
    for ptr, key, (line1, col1), (line2, col2) in duplicate_keys(text):
        problems.append(Problem(
            f"duplicate key '{key}' (first at line {line1}, column {col1})", name, f"{ptr}/{escape(key)}",
            line=line2, column=col2, element=f"object at {ptr}" if ptr else "top-level object",
            hint="a key may appear once per object; delete one of the two or rename it"))
    if not problems:  # the scan could not follow the text (far too deep): still refuse, without a place
        problems.append(Problem("duplicate key in a JSON object", name,
                                hint="a key may appear once per object; delete one of the two"))
    return problems


class _Strict(ValueError):
    """A JSON text that parses but is not strict JSON (raised from inside the parser's hooks)."""


def _unique_pairs(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    obj = dict(pairs)
    if len(obj) != len(pairs):
        seen: set[str] = set()
        key = next(k for k, _ in pairs if k in seen or seen.add(k))  # type: ignore[func-returns-value]
        raise _Strict(f"key {key[:40]!r} appears twice in one object")
    return obj


def _no_constant(name: str) -> Any:
    raise _Strict(f"{name} is not JSON (write null, or the value as a string)")


def _finite_float(text: str) -> float:
    value = float(text)
    if value - value != 0:  # inf: the number is beyond what a double holds
        raise _Strict(f"number {text[:24]} is out of range (beyond ±1.8e308)")
    return value


_FLOAT_MAX = 1.7976931348623157e308


def _bounded_int(text: str) -> int:
    digits = len(text.lstrip("-"))
    # more digits than ±1.8e308 has cannot become a float (and Python refuses 4300 and more)
    if digits > 309 or abs(value := int(text)) > _FLOAT_MAX:
        raise _Strict(f"number {text[:24]}… of {digits} digits is out of range (beyond ±1.8e308)")
    return value


_JSON_STRING = re.compile(rb'"(?:[^"\\]|\\.)*"', re.S)
_NOT_BRACKETS = bytes(b for b in range(256) if b not in b"[]{}")
_BRACKET_STEPS = bytes.maketrans(b"[{]}", b"\x01\x01\xff\xff")  # +1 and -1 as signed bytes


def _nesting(raw: bytes) -> int:
    """How deep the brackets of a JSON text nest (strings skipped), counted in C-speed steps: a line of a million
    brackets takes milliseconds, not seconds."""
    steps = _JSON_STRING.sub(b"", raw).translate(_BRACKET_STEPS, _NOT_BRACKETS)
    return max(itertools.accumulate(array.array("b", steps)), default=0)


_LINE_DECODER = json.JSONDecoder(object_pairs_hook=_unique_pairs, parse_constant=_no_constant,
                                 parse_float=_finite_float, parse_int=_bounded_int)


def parse_json_line(raw: bytes) -> Any:
    """One line of a JSON Lines file (a trace), strictly: UTF-8, no NaN or Infinity, numbers a double holds,
    no repeated keys, at most :data:`MAX_JSON_DEPTH` levels; ``ValueError`` says what is wrong (with the column
    when the parser knows it). Lines are read by the thousand, so the nesting is measured only when the line
    has enough brackets to be too deep."""
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ValueError(f"not UTF-8: byte 0x{raw[exc.start]:02x} at column {exc.start + 1}") from None
    if raw.count(b"[") + raw.count(b"{") > MAX_JSON_DEPTH and _nesting(raw) > MAX_JSON_DEPTH:
        deep = depth_exceeded_at(text, MAX_JSON_DEPTH)  # where (slower, so only for a line that is too deep)
        if deep is not None:
            raise ValueError(f"JSON nested more than {MAX_JSON_DEPTH} levels deep (column {deep[1]})")
    try:
        return _LINE_DECODER.decode(text)
    except json.JSONDecodeError as exc:
        raise ValueError(f"invalid JSON: {exc.msg} (column {exc.colno})") from None
    except _Strict as exc:
        raise ValueError(str(exc)) from None
    except RecursionError:
        raise ValueError("JSON nested too deeply for this Python") from None
