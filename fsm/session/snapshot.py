"""Snapshots of a running session, restored in place: the live debugger's rewind goes back to the nearest one and
re-simulates only the ticks after it.

A snapshot copies **what changes** in a run and shares **what is compiled**. It walks the objects of the run from
the session (the machine, its states, regions, transitions, monitors, context and clock; the world's driver and its
car; the recorder) and keeps, for each, its attributes: plain values as they are, lists, dicts, sets, deques and
arrays copied (so the run going on does not change them), and every object reached by reference (it is walked too).
Functions, bound methods, classes, frozen dataclasses and pydantic models (parameters, plans, worlds), NumPy arrays
and pymunk's objects are shared, never copied: a closure (a compiled expression, the recorder's sampler, the car's
sensor queries) keeps pointing at the same objects, which a restore puts back in the state they had.

:func:`restore` writes the kept attributes back into the same objects, copying the containers again, so one
snapshot can be restored any number of times. It is exact when everything that changes in a run is reachable as
attributes; what is not (C state) is given by the object's own hooks:

- ``__snapshot__()`` returns what the walk cannot see (the car's pymunk bodies and joints) and
  ``__restore__(state)`` puts it back (after its attributes are restored);
- ``__snapshot_skip__``: a class's attributes that never change in a run, or caches whose contents do not depend
  on when they were filled (the car's walls, the recorder's header): neither walked nor restored;
- ``random.Random`` and NumPy generators keep their state through ``getstate``/``setstate`` (``bit_generator.state``).

Objects named in ``shared`` (the recorder's output stream, the listeners' list) are kept by reference: the caller
handles them (:mod:`fsm.debug.control` gives the restored recorder a stream cut at the snapshot's position).
"""

from __future__ import annotations

import array
import dataclasses
import enum
import operator
import random
import sys
import types
from collections import deque
from collections.abc import Callable, Iterable
from typing import Any

#: Classes whose instances are shared as they are (never changed in place, or not this module's to copy).
_ATOMIC: set[type] = {
    int, float, complex, str, bytes, bool, type(None), type, range, slice, frozenset,
    types.FunctionType, types.BuiltinFunctionType, types.MethodType, types.BuiltinMethodType, types.ModuleType,
    types.MethodWrapperType, types.WrapperDescriptorType, type(Ellipsis), type(NotImplemented),
}
#: Module prefixes whose objects are shared (C objects and compiled models: physics, images, validation).
_SHARED_MODULES = ("pymunk", "numpy", "cv2", "pydantic", "re", "pathlib", "operator", "functools", "threading",
                   "_thread", "io", "_io", "logging", "asyncio")
_MISSING = object()
#: The attributes of classes whose instances have a ``__dict__`` (no ``__slots__``) that a snapshot reads by name,
#: besides a class's own ``__snapshot_fields__``: reading an instance's ``__dict__`` makes CPython 3.11 keep its
#: attributes in a dict from then on, and every attribute access of that object slower (a tenth of a tick of the
#: lap, measured). A class without either is read through its ``__dict__``. Tests check the lists are complete.
_FIELDS: dict[str, tuple[str, ...]] = {
    "fsm.runtime.machine.Machine": ("root", "clock", "ctx", "regions", "listeners", "started", "_sim", "_dt",
                                    "_schedule", "_schedule_seq", "_toggles", "_terminal"),
}
#: What the runtime fixes when it builds a machine and never changes while it runs (the hooks ``StateWiring.seal``
#: chooses, the compiled guards, names and paths), by class: a snapshot neither reads nor restores them (about
#: half of what a machine's objects hold). The objects they lead to are reached through other attributes.
_BUILT: dict[str, tuple[str, ...]] = {
    "fsm.runtime.state.State": ("id", "params", "path", "predicates"),
    "fsm.runtime.state.Life": ("state",),
    "fsm.runtime.region.StateWiring": ("region", "preempt", "regular", "entry_action", "exit_action", "tick_hook",
                                       "enter_hook", "exit_hook", "arms", "watched", "resets", "complete_action",
                                       "is_final"),
    "fsm.runtime.transition.Transition": ("params", "source", "target"),
    "fsm.runtime.transition.Link": ("transition", "index"),
    "fsm.runtime.region.TransitionWiring": ("target", "kind", "compare", "test", "effect", "run", "assign", "arm"),
    "fsm.runtime.region.Region": ("name", "path", "first", "owner"),
    "fsm.runtime.supervisor.Monitor": ("behavior", "exception_id", "label", "kind"),
    "fsm.runtime.supervisor.Supervisor": ("owner", "precondition"),
    "fsm.runtime.machine.Machine": ("name", "states_by_path"),
    # the side of the last region of interest is the key of the OpenCV detector's parameters, which a snapshot
    # cannot copy: kept as it is, it stays the key of the parameters the detector has (a cache, not the run's state)
    "fsm.vision.detector.MarkerDetector": ("_roi_side",),
}


@dataclasses.dataclass(repr=False)
class Snapshot:
    """What a session was at ``tick`` (between two ticks): each object's attributes (containers copied), the
    states of its generators and hooks, and ``extra`` for the caller (the trace's length then)."""

    tick: int
    entries: list[tuple[Any, dict[str, Any]]]
    hooks: list[tuple[Any, Any]]
    generators: list[tuple[Any, Any]]
    extra: dict[str, Any] = dataclasses.field(default_factory=dict)

    def objects(self) -> int:
        """How many objects it keeps."""
        return len(self.entries)

    def __repr__(self) -> str:
        return f"<Snapshot tick={self.tick} objects={len(self.entries)}>"


class _Kinds:
    """Per class: whether its instances are shared, and how a walk reads them: the slot names (skips left out),
    one getter of all of them, the names skipped, whether instances have a ``__dict__``."""

    def __init__(self) -> None:
        self.shared: dict[type, bool] = {}
        self.slots: dict[type, tuple[tuple[str, ...], Any, frozenset[str]]] = {}
        #: whether a walk reads the class's instances' ``__dict__`` (no list of fields names their attributes)
        self.by_dict: dict[type, bool] = {}

    def is_shared(self, cls: type) -> bool:
        found = self.shared.get(cls)
        if found is None:
            found = self.shared[cls] = _shared_class(cls)
        return found

    def layout(self, cls: type) -> tuple[tuple[str, ...], Any, frozenset[str]]:
        found = self.slots.get(cls)
        if found is None:
            names: list[str] = []
            for klass in cls.__mro__:
                slots = klass.__dict__.get("__slots__", ())
                for name in (slots,) if isinstance(slots, str) else slots:
                    if name not in ("__dict__", "__weakref__") and _mangled(klass, name) not in names:
                        names.append(_mangled(klass, name))
            skip = frozenset(getattr(cls, "__snapshot_skip__", ())).union(
                *(_BUILT.get(f"{k.__module__}.{k.__qualname__}", ()) for k in cls.__mro__))
            fields = getattr(cls, "__snapshot_fields__", None) or _FIELDS.get(f"{cls.__module__}.{cls.__qualname__}")
            self.by_dict[cls] = fields is None
            names += [n for n in fields or () if n not in names]
            kept = tuple(n for n in names if n not in skip)
            getter = operator.attrgetter(*kept) if len(kept) > 1 else None
            found = self.slots[cls] = (kept, getter, skip)
        return found


def _mangled(klass: type, name: str) -> str:
    if name.startswith("__") and not name.endswith("__"):
        return f"_{klass.__name__.lstrip('_')}{name}"
    return name


def _shared_class(cls: type) -> bool:
    if cls in _ATOMIC or issubclass(cls, (enum.Enum, BaseException)):
        return True
    if any((k.__module__ or "").split(".")[0] in _SHARED_MODULES for k in cls.__mro__[:-1]):
        return not _is_generator(cls)
    params = getattr(cls, "__dataclass_params__", None)
    if params is not None and params.frozen:
        return True
    return not hasattr(cls, "__dict__") and not any("__slots__" in k.__dict__ for k in cls.__mro__[:-1])


def _is_generator(cls: type) -> bool:
    return (cls.__module__ or "").startswith("numpy.random") and hasattr(cls, "bit_generator")


_KINDS = _Kinds()


class _Walk:
    """One snapshot's walk: objects met (by id), what is kept of each, containers copied (by id: aliasing kept)."""

    def __init__(self, shared: Iterable[Any]) -> None:
        self.met: dict[int, Any] = {id(obj): obj for obj in shared}
        self.todo: list[Any] = []
        self.entries: list[tuple[Any, dict[str, Any]]] = []
        self.hooks: list[tuple[Any, Any]] = []
        self.generators: list[tuple[Any, Any]] = []
        self.copies: dict[int, Any] = {}

    def value(self, v: Any) -> Any:
        cls = v.__class__
        if cls in _ATOMIC:
            return v
        if cls is tuple:
            return self._tuple(v)
        if cls is list or cls is dict or cls is set or cls is deque or cls is array.array:
            return self._container(v)
        key = id(v)
        if key in self.met:
            return v
        self.met[key] = v
        if isinstance(v, random.Random):
            self.generators.append((v, v.getstate()))
        elif _is_generator(cls):
            self.generators.append((v, v.bit_generator.state))
        elif not _KINDS.is_shared(cls):
            self.todo.append(v)
        return v

    def _tuple(self, v: tuple[Any, ...]) -> tuple[Any, ...]:
        atomic = _ATOMIC
        if all(x.__class__ in atomic for x in v):
            return v
        out = [self.value(x) for x in v]
        return v if all(a is b for a, b in zip(out, v, strict=True)) else tuple(out)

    def _container(self, v: Any) -> Any:
        done = self.copies.get(id(v))
        if done is not None:
            return done
        if id(v) in self.met:
            return v
        return _copy_container(v, self.copies, self.value)

    def run(self) -> None:
        todo = self.todo
        value = self.value
        atomic = _ATOMIC
        while todo:
            obj = todo.pop()
            names, getter, skip = _KINDS.layout(obj.__class__)
            kept: dict[str, Any] = {}
            if names:
                try:  # every slot in one call
                    got = getter(obj) if getter is not None else (getattr(obj, names[0]),)
                except AttributeError:  # a slot not set (yet): one by one
                    pairs = [(n, getattr(obj, n, _MISSING)) for n in names]
                else:
                    pairs = list(zip(names, got, strict=True))
                for name, v in pairs:
                    if v.__class__ in atomic:
                        kept[name] = v
                    elif v is not _MISSING:
                        kept[name] = value(v)
            d = getattr(obj, "__dict__", None) if _KINDS.by_dict[obj.__class__] else None
            if d is not None:
                for name, v in list(d.items()):
                    if name not in skip:
                        kept[name] = v if v.__class__ in atomic else value(v)
            self.entries.append((obj, kept))
            hook = getattr(obj, "__snapshot__", None)
            if hook is not None and callable(hook):
                self.hooks.append((obj, hook()))


def take(roots: Iterable[Any], tick: int, *, shared: Iterable[Any] = ()) -> Snapshot:
    """A snapshot of everything reachable from ``roots`` (see the module docstring), at ``tick``."""
    walk = _Walk(shared)
    for root in roots:
        walk.value(root)
    walk.run()
    return Snapshot(tick, walk.entries, walk.hooks, walk.generators)


def _copy_container(v: Any, copies: dict[int, Any], item: Callable[[Any], Any]) -> Any:
    """A copy of the list, dict, set, deque or array ``v`` with ``item`` of each element, noted in ``copies`` (by
    ``v``'s id, before its elements: a container that holds itself is copied once)."""
    cls = v.__class__
    out: Any
    if cls is array.array:
        out = copies[id(v)] = array.array(v.typecode, v)
    elif cls is dict:
        out = copies[id(v)] = {}
        for k, x in v.items():
            out[k] = item(x)
    elif cls is list:
        out = copies[id(v)] = []
        out.extend([item(x) for x in v])
    elif cls is set:
        out = copies[id(v)] = {item(x) for x in v}
    else:
        out = copies[id(v)] = deque([item(x) for x in v], v.maxlen)
    return out


class _Copy:
    """A restore's copier: containers copied again (aliasing kept), everything else as it is."""

    def __init__(self) -> None:
        self.copies: dict[int, Any] = {}

    def value(self, v: Any) -> Any:
        cls = v.__class__
        if cls is tuple:
            items = [self.value(x) for x in v]
            return v if all(a is b for a, b in zip(items, v, strict=True)) else tuple(items)
        if cls is list or cls is dict or cls is set or cls is deque or cls is array.array:
            done = self.copies.get(id(v))
            return done if done is not None else _copy_container(v, self.copies, self.value)
        return v


def restore(snapshot: Snapshot) -> None:
    """Put every object the snapshot kept back in the state it had (in place; the snapshot stays as it was)."""
    copy = _Copy()
    setter = object.__setattr__
    for obj, kept in snapshot.entries:
        names, _getter, skip = _KINDS.layout(obj.__class__)
        d = getattr(obj, "__dict__", None) if _KINDS.by_dict[obj.__class__] else None
        values = {name: copy.value(v) for name, v in kept.items()}
        if d is not None:
            keep = {name: v for name, v in d.items() if name in skip}
            d.clear()
            d.update(keep)
        for name, v in values.items():
            if d is not None or getattr(obj, name, _MISSING) is not v:
                setter(obj, name, v)
        for name in names:  # a slot set since the snapshot was not then
            if name not in kept and getattr(obj, name, _MISSING) is not _MISSING:
                object.__delattr__(obj, name)
    for gen, state in snapshot.generators:
        if isinstance(gen, random.Random):
            gen.setstate(state)
        else:
            gen.bit_generator.state = state
    for obj, state in snapshot.hooks:
        obj.__restore__(state)


def sizeof(snapshot: Snapshot) -> int:
    """About how many bytes the snapshot holds of its own: the containers it copied (lists, dicts, sets, deques,
    arrays, and the tuples and dicts that hold them), the generators' and hooks' states. The values in them are
    shared with the run (or small), and not counted."""
    seen: set[int] = set()
    total = 0
    stack: list[Any] = [kept for _obj, kept in snapshot.entries] + [s for _o, s in snapshot.generators + snapshot.hooks]
    while stack:
        v = stack.pop()
        if id(v) in seen or not isinstance(v, (dict, list, tuple, set, deque, array.array, bytes)):
            continue
        seen.add(id(v))
        total += sys.getsizeof(v)
        if isinstance(v, dict):
            stack.extend(v.values())
        elif isinstance(v, (list, tuple, set, deque)):
            stack.extend(v)
    return total


__all__ = ["Snapshot", "restore", "sizeof", "take"]
