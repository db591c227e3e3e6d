"""The plan cache: a checked and compiled document kept by content, like Python's ``__pycache__``.

A load of a file that checks without errors leaves its result (the spec, what checking found out, the warnings and
the plan) in a cache file; the next load of the same content takes it from there instead of parsing, validating,
checking and compiling again.

**The key.** A cache file is used only when everything a load depends on is what it was when the file was written:

- the text of the document and of every file it includes (SHA-256 of each, read again on every load);
- the registry's types: every registered name; a plugin's with its class's module and qualified name and that
  module's source file (modification time in nanoseconds and size, as ``__pycache__`` does), the built-ins with
  the source files of their packages (``fsm/states``, ``fsm/transitions``, ``fsm/sequencer``), so a plugin whose
  source changes, a type registered under another name or another class misses. Making the key imports nothing:
  a built-in counts by its name whether its module is imported yet or not, and a read imports only the types the
  load that wrote the file had imported (a fresh process pays for the types its machine uses, not for all). The
  installed plugins count once loaded; a file written by a load that needed them loads them before its key is
  compared, so a machine of an installed plugin's type is read back by a fresh process too;
- the loader's version: the package's version, this file format, and the source files of the modules that parse,
  check and compile (a changed loader in a development checkout misses too).

The key is checked before anything of the file is read back; a file whose key, checksum or content does not fit
is ignored (and rewritten by that load), never an error.

**Where.** In the user's cache folder, ``$XDG_CACHE_HOME/tral-fsm/plans`` or ``~/.cache/tral-fsm/plans``;
``FSM_CACHE_DIR`` names another folder. Not beside the document: the document's folder is the user's, and a load
(``fsmctl validate``) is not asked to write there. ``FSM_NO_CACHE=1`` (``fsmctl --no-cache``) neither reads nor
writes the cache. One file per document path (the newest content replaces the older), written atomically (a
temporary file in the folder, then renamed), readable by its owner only; a write that fails (a read-only home)
is skipped. The folder keeps the :data:`MAX_FILES` most recently used files.

**Data only.** A plan holds compiled closures (expressions, ``set`` actions); the cache holds none of them: an
expression is kept as its text and the kind it was checked for, and compiled again when the file is read; an action
as its ``(variable, expression)`` pairs; a file's locator as nothing (made again from the text, read anyway for the
key). The rest is stored in the flat form of :mod:`fsm.loading.flat`: tables of plain values, one per kind of object,
unpickled with every class refused, classes named by ``(module, name)`` in an allow-list (the document model's
classes and the registry's own types and parameter models), objects made in bulk without running any constructor.
A forged cache file therefore cannot run code; what it can do is describe a different machine, as editing the
document could. A file not owned by the current user is not read.
"""

from __future__ import annotations

import _thread
import atexit
import dataclasses
import hashlib
import json
import os
import pickle
import sys
import tempfile
import threading
import time
import types
import zlib
from collections.abc import Callable
from pathlib import Path
from typing import Any, NamedTuple

from fsm.loading import flat
from fsm.loading.checking import Analysis
from fsm.loading.compiling import ACTIONS
from fsm.loading.reading import STDIN_NAME, cache_key, preloaded_copy, read_file_bytes
from fsm.loading.registry import Registry
from fsm.model import expr as E
from fsm.model.document import MachineSpec, Source
from fsm.model.errors import DiagramError, Problem
from fsm.model.jsonpos import locate
from fsm.model.plan import NOTHING, MachinePlan
from fsm.model.version import VERSION

#: The folder of the cache files (overrides the user's cache folder).
CACHE_DIR_ENV = "FSM_CACHE_DIR"
#: ``1``: neither read nor write the cache.
NO_CACHE_ENV = "FSM_NO_CACHE"
#: The cache file's format; a new one misses every older file.
FORMAT = 3
MAGIC = b"tral-fsm plan cache\n"
#: The loader's version as far as the cache is concerned (the package's, and the format).
LOADER_VERSION = f"{VERSION}/{FORMAT}"
#: The modules whose source decides what a load makes of a document (their files are part of the key).
LOADER_MODULES = ("fsm.model.document", "fsm.model.params", "fsm.model.plan", "fsm.model.expr", "fsm.model.errors",
                  "fsm.model.problems", "fsm.loading.parsing", "fsm.loading.checking", "fsm.loading.outcomes",
                  "fsm.loading.compiling", "fsm.loading.cache", "fsm.loading.flat", "fsm.sequencer.layout",
                  "fsm.sequencer.checks")
#: The modules of the document model whose classes a cache file may hold.
MODEL_MODULES = ("fsm.model.document", "fsm.model.params", "fsm.model.plan", "fsm.model.errors")


class Entry:
    """What a load of a document without errors found: its spec, analysis, problems (warnings) and plan.

    An entry read from a cache file makes its plan when it is first asked for, and its spec's states, transitions
    and the rest of the spec's contents when one of them is first read (:class:`_Later`): ``fsmctl validate`` asks
    for the problems only, and a load for the plan, not the spec."""

    __slots__ = ("spec", "analysis", "problems", "_plan", "_later")

    def __init__(self, spec: MachineSpec, analysis: Analysis, problems: list[Problem],
                 plan: MachinePlan | None = None, later: _Later | None = None) -> None:
        if plan is None and later is None:
            raise TypeError("an entry needs its plan, or a cache file to make it from")
        self.spec = spec
        self.analysis = analysis
        self.problems = problems
        self._plan = plan
        self._later = later

    @property
    def plan(self) -> MachinePlan:
        if self._plan is None:
            assert self._later is not None
            self._plan = self._later.plan()
        return self._plan

    def with_problems(self, problems: list[Problem]) -> Entry:
        """The same entry with other problems (copies: callers add to a problem's text), sharing what is made."""
        return Entry(self.spec, self.analysis, problems, self._plan, self._later)


class _NotCachable(Exception):
    """Something in a load's result the cache cannot hold as data: the load is simply not cached."""


def enabled() -> bool:
    """Whether loads use the cache (``FSM_NO_CACHE`` unset, empty or ``0``)."""
    return os.environ.get(NO_CACHE_ENV, "").strip() in ("", "0")


def folder() -> Path:
    """The folder of the cache files: ``FSM_CACHE_DIR``, else ``$XDG_CACHE_HOME/tral-fsm/plans``, else
    ``~/.cache/tral-fsm/plans``."""
    chosen = os.environ.get(CACHE_DIR_ENV)
    if chosen:
        return Path(chosen)
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "tral-fsm" / "plans"


def file_of(name: str) -> Path:
    """The cache file of the document ``name`` (as given, and where it really is)."""
    where = os.path.realpath(name) if name else ""
    digest = hashlib.sha256(f"{FORMAT}\0{name}\0{where}".encode("utf-8", "surrogatepass")).hexdigest()
    return folder() / f"{digest[:40]}.plan"


# -- the key -----------------------------------------------------------------------------------------------------
#: Stamps of imported modules' source files, taken once per process and module object: the code that runs is the
#: code that was imported, so a stamp taken at the first key stands for it until the module is imported again (a new
#: module object, or the same one reloaded: a new ``__spec__``), and a key never pays ``os.stat`` twice for the same
#: code.
_STAMPED: dict[str, tuple[Any, list[Any] | None]] = {}


def _stamp_of(path: str) -> tuple[int, int] | None:
    try:
        st = os.stat(path)
    except OSError:
        return None
    return st.st_mtime_ns, st.st_size


def _source_stamp(module: str) -> list[Any] | None:
    """``[module, file, mtime_ns, size]`` of a module's source, or None when it has no file to stamp."""
    mod = sys.modules.get(module)
    if mod is None:
        return None
    known = _STAMPED.get(module)
    imported = getattr(mod, "__spec__", None) or mod
    if known is not None and known[0] is imported:
        return known[1]
    path = getattr(mod, "__file__", None)
    found = _stamp_of(path) if path else None
    stamp = None if found is None else [module, path, *found]
    _STAMPED[module] = (imported, stamp)
    return stamp


#: The packages of the built-in types: their files' stamps stand for every built-in name in the key, imported or
#: not, so the key is the same before a load imports the types it uses and after (the registry is lazy).
BUILTIN_PACKAGES = ("fsm.states", "fsm.transitions", "fsm.sequencer")
_PACKAGE_ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
#: Each built-in package's folder listing, with the folder's modification time it was taken at.
_LISTINGS: dict[str, tuple[int, list[str]]] = {}


def _tables(registry: Registry) -> tuple[tuple[str, Any], ...]:
    return (("state", registry.states), ("transition", registry.transitions), ("condition", registry.conditions),
            ("plant", registry.plants))


def _loaded_types(registry: Registry) -> list[tuple[str, str, type]]:
    """The types the registry has imported, without importing the others (a table listed imports them all)."""
    return [(kind, name, cls) for kind, table in _tables(registry) for name, cls in sorted(dict.items(table))]


def _is_builtin(cls: type) -> bool:
    return cls.__module__.rpartition(".")[0] in BUILTIN_PACKAGES


def _listing(where: str) -> list[str]:
    """The ``.py`` files of a folder, sorted; listed again only when the folder changed (a file added or removed)."""
    stamp = _stamp_of(where)
    known = _LISTINGS.get(where)
    if stamp is not None and known is not None and known[0] == stamp[0]:
        return known[1]
    try:
        names = sorted(e.name for e in os.scandir(where) if e.name.endswith(".py"))
    except OSError:
        names = []
    if stamp is not None:
        _LISTINGS[where] = (stamp[0], names)
    return names


def _builtin_stamps() -> list[Any]:
    """``[package, file, mtime_ns, size]`` of every source file of the built-in types' packages (found by their
    folders, nothing imported; a file whose module is imported stamped once, see :data:`_STAMPED`)."""
    stamps: list[Any] = []
    for package in BUILTIN_PACKAGES:
        where = os.path.join(_PACKAGE_ROOT, package.split(".", 1)[1])
        for name in _listing(where):
            path = os.path.join(where, name)
            module = package if name == "__init__.py" else f"{package}.{name[:-3]}"
            mod = sys.modules.get(module)
            found: list[Any] | tuple[int, int] | None
            if mod is not None and getattr(mod, "__file__", None) == path:
                stamp = _source_stamp(module)
                found = None if stamp is None else stamp[2:]
            else:
                found = _stamp_of(path)
            if found is not None:
                stamps.append([package, name, *found])
    return stamps


def registry_key(registry: Registry) -> str | None:
    """The key of the registry's types and the loader's version; None when a type has no source file to stamp
    (such a registry's loads are not cached).

    Built-in names count by name, whether imported yet or not, and their packages' files by their stamps; a plugin's
    type counts by its class and module once it is registered (installed plugins are loaded when a document needs
    one; a cache file says whether its load had them, see :func:`lookup`). Nothing is imported to make the key.
    What the key is made of is compared with the last key's: the same parts give the same key without hashing
    them again (a miss asks before its load and again when it stores the result)."""
    entries: list[Any] = [LOADER_VERSION]
    modules = set(LOADER_MODULES)
    for kind, table in _tables(registry):
        names: dict[str, list[str] | None] = dict.fromkeys(table.pending)
        for name, cls in dict.items(table):
            if _is_builtin(cls):
                names[name] = None
                continue
            names[name] = [cls.__module__, cls.__qualname__]
            modules.add(cls.__module__)
            params = getattr(cls, "Params", None)
            if isinstance(params, type) and not _is_builtin(params):
                modules.add(params.__module__)
        entries.extend([kind, name, names[name]] for name in sorted(names))
    for module in sorted(modules):
        stamp = _source_stamp(module)
        if stamp is None:
            return None
        entries.append(stamp)
    entries.append(_builtin_stamps())
    last = _LAST_KEY.get("parts")
    if last is not None and last[0] == entries:
        return last[1]
    key = hashlib.sha256(json.dumps(entries).encode("utf-8", "surrogatepass")).hexdigest()
    _LAST_KEY["parts"] = (entries, key)
    return key


#: The parts of the last key made, and the key.
_LAST_KEY: dict[str, tuple[list[Any], str]] = {}


def _model_classes() -> dict[tuple[str, str], type]:
    """The document model's data classes (made once): all a cache file's first part may name."""
    if not _MODEL:
        for module in MODEL_MODULES:
            for value in vars(sys.modules[module]).values():
                if isinstance(value, type) and value.__module__ == module:
                    _MODEL[(module, value.__qualname__)] = value
    return _MODEL


_MODEL: dict[tuple[str, str], type] = {}


def _allowed(registry: Registry, key: str) -> dict[tuple[str, str], type]:
    """The classes a cache file may name: the model's data classes, the registered types imported so far and the
    parameter models and enums of their modules (made once per registry key and set of imported types)."""
    types_ = _loaded_types(registry)
    known = _ALLOWED.get(key)
    if known is not None and known[0] == len(types_) and all(
            known[1].get((cls.__module__, cls.__qualname__)) is cls for _k, _n, cls in types_):
        return known[1]  # (a plugin file imported again makes new classes under the same names and sources)
    allowed = dict(_model_classes())

    def add_module(module: str, keep: Callable[[type], bool]) -> None:
        for value in vars(sys.modules[module]).values():
            if isinstance(value, type) and value.__module__ == module and keep(value):
                allowed[(module, value.__qualname__)] = value

    from enum import Enum

    from pydantic import BaseModel

    for _kind, _name, cls in types_:
        allowed[(cls.__module__, cls.__qualname__)] = cls
        params = getattr(cls, "Params", None)
        for module in {cls.__module__, getattr(params, "__module__", cls.__module__)}:
            if module in sys.modules:
                add_module(module, lambda c: issubclass(c, (BaseModel, Enum)))
    _ALLOWED.clear()  # one registry in a process, as a rule: keep the last
    _ALLOWED[key] = (len(types_), allowed)
    return allowed


_ALLOWED: dict[str, tuple[int, dict[tuple[str, str], type]]] = {}


# -- the texts read ----------------------------------------------------------------------------------------------
#: The UTF-8 byte-order mark, which the loader reads past (and the digests leave out).
_BOM = b"\xef\xbb\xbf"


def text_of(name: str) -> tuple[str, bytes | None] | None:
    """The text of a document file as the loader reads it (the caller's preloaded copy if there is one), with the
    bytes when they were read here; None when it cannot be read or decoded (the load itself says why)."""
    item = preloaded_copy(name)
    if isinstance(item, tuple):
        text = getattr(item[1], "text", None)
        return (text, None) if isinstance(text, str) else None
    try:
        raw = read_file_bytes(Path(name))
    except DiagramError:
        return None
    try:
        text = raw.removeprefix(_BOM).decode("utf-8")
    except UnicodeDecodeError:
        return None
    return text, (None if isinstance(item, bytes) else raw)


class Document(NamedTuple):
    """A document file as a load through the cache sees it: its text, its bytes when read here (the load takes
    them, so the file is read once and the text hashed is the text parsed), and its reader's cache token."""

    text: str
    raw: bytes | None
    token: str


def document(name: str) -> Document | None:
    """The document file ``name`` if its load may be cached (not standard input, a reader that names what it
    depends on, a text that can be read), else None."""
    if name == STDIN_NAME or not name:
        return None
    key = cache_key(Path(name))
    if key is None:
        return None
    token, text = key
    if text is not None:
        return Document(text, None, token)
    found = text_of(name)
    return Document(found[0], found[1], token) if found is not None else None


def _digest(text: str, raw: bytes | None = None) -> str:
    """The SHA-256 of a text's UTF-8; of ``raw``, the bytes it was decoded from, when given (the same bytes without
    a byte-order mark: a strict decode encodes back to exactly them), which saves encoding it again."""
    if raw is None:
        return hashlib.sha256(text.encode("utf-8", "surrogatepass")).hexdigest()
    return hashlib.sha256(memoryview(raw)[3:] if raw.startswith(_BOM) else raw).hexdigest()


class _Locator:
    """A file's locator made again from its text on first use (a cache file holds no function)."""

    def __init__(self, name: str, text: str) -> None:
        self.name = name
        self.text = text
        self._made: Any = None

    def __call__(self, pointers: set[str]) -> Any:
        if self._made is None:
            from fsm.loading.reading import preloaded, read_json, reader_for

            path = Path(self.name)
            reader = reader_for(path)
            if reader is read_json:
                text = self.text
                self._made = lambda ptrs: locate(text, ptrs)
            else:
                with preloaded({self.name: self.text.encode("utf-8", "surrogatepass")}):
                    self._made = reader(path)[1].locator
        return self._made(pointers)


# -- writing -------------------------------------------------------------------------------------------------------
class _Special:
    """What of a load's result is not data, as the name of the reader's maker and its arguments: a source as its
    file's name, an expression as its text and the kind it was checked for, an action as its ``(variable,
    expression)`` pairs, a comparison as the expression it belongs to (each made again when the file is read)."""

    def __init__(self, entry: Entry, texts: dict[str, str]) -> None:
        self.texts = texts
        self.expr_keys = {id(c): key for key, c in entry.analysis.expressions.items()}
        self.wants = entry.analysis.wants
        self.var_ops = {id(c.var_op): c for c in entry.analysis.expressions.values() if c.var_op is not None}

    def table(self) -> flat.Special:
        return {Source: self.source, E.Compiled: self.expression, E.VarOp: self.var_op,
                types.MappingProxyType: self.proxy, types.FunctionType: self.action}

    def source(self, obj: Source) -> tuple[str, tuple[Any, ...]]:
        if obj.name not in self.texts or obj.text != self.texts[obj.name]:
            raise _NotCachable(f"a source not read from a file: {obj.name}")
        return "_source", (obj.name,)

    def expression(self, obj: E.Compiled) -> tuple[str, tuple[Any, ...]]:
        if obj.constant:
            return "_constant", (obj.value,)
        key = self.expr_keys.get(id(obj))
        if key is None:
            raise _NotCachable(f"an expression of no analysis: {obj.text}")
        return "_expression", (obj.text, self.wants.get(key))

    def var_op(self, obj: E.VarOp) -> tuple[str, tuple[Any, ...]]:
        if id(obj) not in self.var_ops:
            raise _NotCachable("a comparison of no expression")
        return "_var_op", (self.var_ops[id(obj)],)

    @staticmethod
    def proxy(obj: types.MappingProxyType[Any, Any]) -> tuple[str, tuple[Any, ...]]:
        return ("_nothing", ()) if obj is NOTHING else ("_proxy", (dict(obj),))

    @staticmethod
    def action(obj: Callable[..., Any]) -> tuple[str, tuple[Any, ...]]:
        pairs = ACTIONS.get(obj)
        if pairs is None:
            raise _NotCachable(f"a function: {obj!r}")
        return "_action", (pairs,)


def store(name: str, registry: Registry, entry: Entry, token: str, *, background: bool = True) -> bool:
    """Keep a load's result in memory and write the cache file of the document ``name``; False (and nothing
    written) when the result cannot be kept.

    The file is written in a thread of its own by default (:func:`flush` waits for it), so a miss returns as soon as
    the load is done: the writing never delays the result, a reader of the same file in this process waits for it,
    and the process waits for it before it ends or forks (a file is complete or absent, never half written).
    ``background=False`` writes before returning, and says whether the file was written."""
    key = registry_key(registry)
    if key is None:
        return False
    texts: dict[str, str] = {}
    for level in entry.spec.levels():
        if level.source.name is not None and level.source.text is not None:
            texts.setdefault(level.source.name, level.source.text)
    if name not in texts:
        return False
    files = [[name, _digest(texts[name]), token]] + [[n, _digest(t)] for n, t in texts.items() if n != name]
    # the problems copied: a caller adds to the ones it was given while the writer may still be reading these
    entry = entry.with_problems([dataclasses.replace(p) for p in entry.problems])
    keep(name, key, files, entry)
    loaded = _loaded_types(registry)
    used = [[kind, name_] for kind, name_, _cls in loaded]  # what a read imports first
    plugins = any(not _is_builtin(cls) for _k, _n, cls in loaded)
    job = (file_of(name), key, files, entry, texts, _allowed(registry, key), used, plugins)
    if not background:
        return _write(*job)
    done = threading.Event()
    with _PENDING_LOCK:
        _PENDING.setdefault(name, []).append(done)
    # A bare thread: threading.Thread.start() would wait for the new thread to run, and then for the interpreter
    # lock, before the load could return. The interpreter's end (atexit) and a fork wait for it instead.
    _thread.start_new_thread(_write_in_background, (name, done, *job))
    return True


def _write(target: Path, key: str, files: list[list[str]], entry: Entry, texts: dict[str, str],
           allowed: dict[tuple[str, str], type], used: list[list[str]], plugins: bool) -> bool:
    spec = entry.spec
    try:
        payload = flat.flatten_parts(
            [(entry.problems, (entry.analysis.expressions, entry.analysis.paths, entry.analysis.wants),
              tuple(getattr(spec, f) for f in SHELL_FIELDS)),
             entry.plan,
             tuple(getattr(spec, f) for f in LATER_FIELDS)],
            allowed, _Special(entry, texts).table(), {id(spec): "_spec"})
    except (_NotCachable, flat.Unflattenable, pickle.PicklingError, TypeError, AttributeError, RecursionError):
        return False
    header = json.dumps({"key": key, "files": files, "kinds": dict(entry.analysis.kinds),
                         "types": used, "plugins": plugins, "payload": zlib.crc32(payload)}).encode()
    written = write_atomic(target, MAGIC + len(header).to_bytes(4, "big") + header + payload)
    if written:
        prune(target.parent)
    return written


def _write_in_background(name: str, done: threading.Event, *job: Any) -> None:
    try:
        _write(*job)
    except BaseException:  # noqa: BLE001 - the cache's failures are never errors; the next load writes it again
        pass
    finally:
        with _PENDING_LOCK:
            mine = _PENDING.get(name, [])
            if done in mine:
                mine.remove(done)
            if not mine:
                _PENDING.pop(name, None)
        done.set()


#: The cache files being written in the background, by document: each write's "done".
_PENDING: dict[str, list[threading.Event]] = {}
_PENDING_LOCK = threading.Lock()


def flush(name: str | None = None) -> None:
    """Wait until the cache files being written in the background (of the document ``name``, or all) are written."""
    with _PENDING_LOCK:
        events = [e for n, es in _PENDING.items() if name is None or n == name for e in es]
    for event in events:
        event.wait()


atexit.register(flush)  # the process ends with its files written, never half of one
os.register_at_fork(before=flush)  # and a child never inherits a writer stopped halfway


#: The most cache files kept: beyond it, the least recently used go (a file is touched when it is read).
MAX_FILES = 256
#: A temporary file older than this (seconds) was left by a writer that died: removed.
STALE_TEMPORARY = 3600.0


def prune(where: Path, keep_files: int | None = None) -> None:
    """The cache folder held to :data:`MAX_FILES` files (the least recently used removed first) and cleared of
    temporary files writers left behind; whatever cannot be removed stays (another process may be at it)."""
    limit = MAX_FILES if keep_files is None else keep_files
    try:
        entries = list(os.scandir(where))
    except OSError:
        return
    now = time.time()
    plans: list[tuple[float, str]] = []
    for e in entries:
        try:
            if e.name.endswith(".plan"):
                plans.append((e.stat().st_mtime, e.path))
            elif e.name.endswith(".tmp") and now - e.stat().st_mtime > STALE_TEMPORARY:
                os.unlink(e.path)
        except OSError:
            continue
    if len(plans) <= limit:
        return
    for _mtime, path in sorted(plans)[:len(plans) - limit]:
        try:
            os.unlink(path)
        except OSError:
            pass


def write_atomic(target: Path, data: bytes) -> bool:
    """The core's one writer of its own files: a private temporary file in the target's folder, renamed over the
    target (a reader sees the old file or the new one, never half of one; two writers: the last rename wins)."""
    tmp = None
    try:
        target.parent.mkdir(parents=True, exist_ok=True, mode=0o700)
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.replace(tmp, target)
        return True
    except OSError:
        if tmp is not None:
            try:
                os.unlink(tmp)
            except OSError:
                pass
        return False


# -- reading -------------------------------------------------------------------------------------------------------
def _makers(texts: dict[str, str], kinds: dict[str, str]) -> dict[str, Callable[..., Any]]:
    """What the reader makes again of what the writer stored as a name and arguments (see :class:`_Special`)."""

    def source(name: str) -> Source:
        text = texts[name]
        return Source(name=name, directory=Path(name).parent, text=text, locator=_Locator(name, text))

    def expression(text: str, want: str | None) -> E.Compiled:
        return E.compile_expr(text, kinds, want)

    return {"_source": source, "_expression": expression, "_constant": E.constant, "_var_op": _var_op_of,
            "_nothing": _the_nothing, "_proxy": types.MappingProxyType, "_action": _action_of, "_enum": flat.make_enum}


def _var_op_of(c: E.Compiled) -> E.VarOp | None:
    return c.var_op


def _the_nothing() -> Any:
    return NOTHING


def _action_of(pairs: tuple[tuple[str, E.Compiled], ...]) -> Any:
    action = E.assigner(list(pairs))
    ACTIONS[action] = tuple(pairs)
    return action


def lookup(name: str, registry: Registry, doc: Document) -> Entry | None:
    """The cached result of loading the document ``name`` (as it is now: ``doc``), or None: no cache file, another
    key or content, or a file that cannot be read back (ignored; the load writes it again).

    A result this process read or wrote is kept in memory too (the last few documents): with the same key and
    texts, it is answered without reading the file again (a scenario suite, a sweep, a reload load one machine
    many times). Specs and plans are never changed after a load (an override copies what it changes), so loads
    may share them; the problems are copied, since callers add to a problem's text."""
    key = registry_key(registry)
    if key is None:
        return None
    kept = _KEPT.get(name)
    if kept is not None and kept[0] == key and _texts(kept[1], name, doc) is not None:
        entry = kept[2]
        return entry.with_problems([dataclasses.replace(p) for p in entry.problems])
    flush(name)  # this process's own write of it, if one is under way
    try:
        with open(file_of(name), "rb") as fh:
            st = os.fstat(fh.fileno())
            if st.st_uid != os.geteuid():
                return None
            data = fh.read()
            try:
                found = _read(data, name, registry, doc, key)
            except Exception:  # noqa: BLE001 - a corrupt or foreign file is ignored, whatever it holds
                return None
            if found is not None and time.time() - st.st_mtime > TOUCHED_WITHIN:
                _touch(fh.fileno() if os.utime in os.supports_fd else file_of(name))
    except OSError:
        return None
    return found


def _touch(where: int | Path) -> None:
    """The cache file (open: its descriptor) marked as recently used (the last to be pruned), if it can be."""
    try:
        os.utime(where)
    except OSError:
        pass


#: A file read is marked as recently used (its modification time set to now) unless it was within this many seconds
#: already: pruning keeps the most recently used files, and a minute is as recent as any.
TOUCHED_WITHIN = 60.0


def _read(data: bytes, name: str, registry: Registry, doc: Document, key: str) -> Entry | None:
    if not data.startswith(MAGIC):
        return None
    start = len(MAGIC) + 4
    size = int.from_bytes(data[len(MAGIC):start], "big")
    header = json.loads(data[start:start + size])
    if header.get("key") != key:
        if not (header.get("plugins") is True and registry.plugins_due()):
            return None
        registry.load_due_plugins()  # the load that wrote it needed the installed plugins: so does this one
        if header.get("key") != registry_key(registry):
            return None
    key = header["key"]
    files = header["files"]
    texts = _texts(files, name, doc)
    payload = data[start + size:]
    if texts is None or zlib.crc32(payload) != header["payload"]:
        return None
    kinds = header["kinds"]
    shell = _LaterSpec.__new__(_LaterSpec)
    makers = _makers(texts, kinds)
    makers["_spec"] = lambda: shell
    reader = flat.Reader(payload, makers)
    if len(reader) != 3:
        return None
    problems, (expressions, paths, wants), fields = reader.part(0, _model_classes())
    if not isinstance(problems, list) or len(fields) != len(SHELL_FIELDS):
        return None
    later = _Later(reader, name, registry, key, header["types"])
    shell.__dict__.update(zip(SHELL_FIELDS, fields, strict=True))
    shell.__dict__[_LaterSpec.LATER] = later
    entry = Entry(shell, Analysis(kinds, expressions, paths, wants), problems, later=later)
    keep(name, key, files, entry)
    return entry.with_problems([dataclasses.replace(p) for p in problems])


#: The fields of a spec read from a cache file with its problems; the others (:data:`LATER_FIELDS`) when one of them
#: is first read. A field with a default is a class attribute, read without asking the instance: it is read at once.
LATER_FIELDS = tuple(f.name for f in dataclasses.fields(MachineSpec)
                     if f.name in ("states", "transitions", "vars", "edges", "raw_states", "raw_transitions")
                     and f.name not in vars(MachineSpec))
SPEC_FIELDS = tuple(f.name for f in dataclasses.fields(MachineSpec))
SHELL_FIELDS = tuple(f for f in SPEC_FIELDS if f not in LATER_FIELDS)


class _LaterSpec(MachineSpec):
    """A machine spec read from a cache file whose contents (:data:`LATER_FIELDS`) are made when first read: then it
    becomes a plain :class:`MachineSpec` (its class changed in place, its fields in their order)."""

    LATER = "_fsm_later"

    def __getattr__(self, name: str) -> Any:  # only asked for what the instance and its class do not have
        later = self.__dict__.get(_LaterSpec.LATER)
        if later is None or name.startswith("__"):
            raise AttributeError(name)
        later.fill(self)
        return getattr(self, name)

    def __reduce_ex__(self, protocol: Any) -> Any:
        """A copy (``copy``, ``deepcopy``, ``pickle``) is of the plain spec: its contents made first."""
        later = self.__dict__.get(_LaterSpec.LATER)
        if later is not None:
            later.fill(self)
        return object.__reduce_ex__(self, protocol)


class _Later:
    """What of a cache file is made on first use: the plan (the types it names imported then), and the spec's
    contents (after the plan: they share its parameters). Made once, under a lock (a live run's reload may ask in
    another thread). A file that passed the key and checksum checks but cannot be made (forged, or a type gone from
    an installed plugin) is removed and reported as a problem of the document, with how to go on."""

    def __init__(self, reader: flat.Reader, name: str, registry: Registry, key: str, used: list[list[str]]) -> None:
        self.reader = reader
        self.name = name
        self.registry = registry
        self.key = key
        self.used = used
        self.lock = threading.Lock()
        self.made: MachinePlan | None = None
        self.fields: tuple[Any, ...] | None = None

    def plan(self) -> MachinePlan:
        with self.lock:
            if self.made is None:
                self.made = self._made(self._plan)
            return self.made

    def _plan(self) -> MachinePlan:
        tables = dict(_tables(self.registry))
        for kind, type_name in self.used:  # the types the load had imported, imported here (no others)
            if tables[kind].get(type_name) is None:
                raise LookupError(f"{kind} type {type_name}")
        plan = self.reader.part(1, _allowed(self.registry, self.key))
        if not isinstance(plan, MachinePlan):
            raise TypeError("not a plan")
        return plan

    def fill(self, spec: _LaterSpec) -> None:
        """The spec's contents set (what was set on it meanwhile kept), and it made a plain MachineSpec."""
        self.plan()
        with self.lock:
            if self.fields is None:
                self.fields = self._made(self._fields)
            values = dict(zip(LATER_FIELDS, self.fields, strict=True))
            now = spec.__dict__
            if _LaterSpec.LATER not in now:
                return
            spec.__dict__ = {f: now[f] if f in now else values[f] for f in SPEC_FIELDS}
            spec.__class__ = MachineSpec  # type: ignore[assignment]

    def _fields(self) -> tuple[Any, ...]:
        fields = self.reader.part(2, _allowed(self.registry, self.key))
        if type(fields) is not tuple or len(fields) != len(LATER_FIELDS):
            raise TypeError("not a spec's fields")
        return fields

    def _made(self, make: Callable[[], Any]) -> Any:
        try:
            return make()
        except Exception as exc:  # noqa: BLE001 - whatever the file holds, the user gets one message
            _forget(self.name)
            raise DiagramError([Problem(
                f"the plan cache's file of this document could not be read back ({type(exc).__name__}); it is "
                f"removed", file=self.name,
                hint=f"run the command again (or with --no-cache); the file was {file_of(self.name)}")]) from None


def _forget(name: str) -> None:
    _KEPT.pop(name, None)
    try:
        os.unlink(file_of(name))
    except OSError:
        pass


def _texts(files: list[list[str]], name: str, doc: Document) -> dict[str, str] | None:
    """The text of each file of a cache entry (``[name, digest, token]`` first, then ``[include, digest]``) if
    every one is still what it was, else None."""
    if files[0] != [name, _digest(doc.text, doc.raw), doc.token]:
        return None
    texts = {name: doc.text}
    for other, digest in files[1:]:
        found = text_of(other)
        if found is None or _digest(*found) != digest:
            return None
        texts[other] = found[0]
    return texts


#: The results this process read or wrote, by document: (registry key, files, entry); the newest few.
_KEPT: dict[str, tuple[str, list[list[str]], Entry]] = {}
KEPT_DOCUMENTS = 8


def keep(name: str, key: str, files: list[list[str]], entry: Entry) -> None:
    _KEPT.pop(name, None)
    _KEPT[name] = (key, files, entry)
    while len(_KEPT) > KEPT_DOCUMENTS:
        del _KEPT[next(iter(_KEPT))]


__all__ = ["CACHE_DIR_ENV", "Document", "Entry", "LOADER_VERSION", "NO_CACHE_ENV", "document", "enabled", "file_of",
           "flush", "folder", "lookup", "prune", "registry_key", "store", "text_of", "write_atomic"]
