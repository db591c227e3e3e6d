"""The plan cache's stored form: a load's object graph (specs, parameters, plans) as tables of plain data.

A pickled object graph is read back one object at a time (about 200,000 pickle opcodes and a Python ``__setstate__``
per parameter model for the 1000-state ring). Here the graph is cut into **batches**: all objects of one class at the
same height in the graph (leaves first) form one table, stored column by column; a column is plain values, one
constant, or references (indices of objects made before). Reading makes each batch's objects in bulk with builtins
mapped over the columns (``tuple.__new__`` for records, ``object.__new__`` and the instance dict for dataclasses and
parameter models), so the work per object is a few C calls, and a column that is the same in every row (the source,
the class, the many defaults) costs nothing per row.

What is stored is plain data only (None, bool, int, float, str and tuples, lists, dicts and sets of them), read back
by an unpickler that refuses every class. Classes are named as ``(module, qualified name)`` and taken from an
allow-list; the few objects that are not data (a source, a compiled expression, an action) are stored as a name and
its arguments and made by the reader's own functions (``makers``), never by anything the file names.

    data = flatten(root, allowed, special)       # special[cls](obj) -> (maker name, args)
    root = unflatten(data, allowed, makers)

A graph may also be stored in **parts**, read one at a time, in order, each when it is first needed: a part holds the
objects its root reaches that no earlier part holds, and refers to those of earlier parts by their index (the reader
keeps one list of every object made). Objects named in ``named`` (by identity) are stored as a call of the reader's
maker of that name without arguments (an object the reader makes itself, such as a shell filled later).

    data = flatten_parts([root0, root1], allowed, special, named)
    reader = Reader(data, makers); root0 = reader.part(0, allowed); root1 = reader.part(1, allowed)
"""

from __future__ import annotations

import bisect
import dataclasses
import enum
import io
import marshal
import pickle
from array import array
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from itertools import chain, islice, repeat
from operator import attrgetter
from typing import Any

from pydantic import BaseModel

from fsm.loading.plain_params import slot_setter

#: The stored form's own version (part of the cache's format).
VERSION = 2
#: Scalars stored as they are.
SCALARS = (type(None), bool, int, float, str)
_CONTAINERS: dict[type, str] = {tuple: "tuple", list: "list", set: "set", frozenset: "frozenset"}
_MODEL_SLOTS = ("__pydantic_fields_set__", "__pydantic_extra__", "__pydantic_private__")


class Unflattenable(Exception):
    """The graph holds something the stored form cannot keep as data (a function, a class not allowed)."""


def plain(value: Any) -> bool:
    """Whether ``value`` is plain data: a scalar, or a tuple, list, set or dict (of exactly those types) of plain
    data. (Asked of ``marshal``, which writes exactly those types in C and refuses subclasses; of what else it
    writes, bytes read back as they are, a bytearray pickles as a class the reader refuses and a code object does
    not pickle, so no such file is ever used.)"""
    kind = type(value)
    if kind in _SCALAR_SET:
        return True
    if kind not in _PLAIN_CONTAINERS:
        return False
    if not value:
        return True
    try:
        marshal.dumps(value)
    except ValueError:
        return False
    return True


_SCALAR_SET = frozenset(SCALARS)
_PLAIN_CONTAINERS = frozenset((tuple, list, dict, set, frozenset))


#: Per class of objects that are not data: a function giving the name of the reader's maker and its arguments.
Special = dict[type, Callable[[Any], tuple[str, tuple[Any, ...]]]]
#: The most passes over the batches to find every object's height (deeper: not stored).
MAX_PASSES = 64


class _Batch:
    """Objects of one kind met together: their node numbers and, per kind, their columns (``("K", value)``,
    ``("L", values)``, ``("N", nodes)``, ``("C", node)``) or, for containers, their lengths and items' nodes."""

    __slots__ = ("tag", "what", "nodes", "columns", "lengths", "items", "heights", "part")

    def __init__(self, tag: str, what: Any, nodes: list[int], part: int = 0) -> None:
        self.part = part
        self.tag = tag
        self.what = what
        self.nodes = nodes
        self.columns: list[tuple[str, Any]] = []
        self.lengths: list[int] = []
        self.items: list[list[int]] = []
        self.heights: list[int] = []

    def row_heights(self, h: list[int]) -> list[int]:
        """Each object's height from the heights of what it refers to (0: nothing)."""
        n = len(self.nodes)
        get = h.__getitem__
        if self.tag in ("lit", "class"):
            return [-1 if self.tag == "lit" else 0] * n
        if self.lengths:  # a container that is not plain holds at least one item
            tops = [list(map(max, map(map, repeat(get), map(islice, repeat(iter(part)), self.lengths))))
                    for part in self.items]
            return [t + 1 for t in (tops[0] if len(tops) == 1 else map(max, *tops))]
        cols: list[Iterable[int]] = []
        for tag, value in self.columns:
            if tag == "N":
                cols.append(map(get, value))
            elif tag == "C":
                cols.append(repeat(get(value), n))
        if not cols:
            return [0] * n
        highest: list[int] = list(cols[0]) if len(cols) == 1 else list(map(max, *cols))
        return [t + 1 for t in highest]


class _Flattener:
    """Walks the graph a batch at a time: the objects a batch's columns refer to form the next batches."""

    def __init__(self, allowed: dict[tuple[str, str], type], special: Special,
                 named: dict[int, str] | None = None) -> None:
        self.allowed = allowed
        self.special = special
        self.named = named or {}
        self.part = 0
        self.bounds: list[int] = []  # the first node of each part after the first
        self.memo: dict[int, int] = {}
        self.kept: list[Any] = []  # every object met stays alive while flattening, so no id is reused
        self.count = 0
        self.new: dict[Any, list[tuple[int, Any]]] = {}
        self.batches: list[_Batch] = []
        self.lits: dict[Any, int] = {}
        self.lit_batch = _Batch("lit", None, [])
        self.lit_values: list[Any] = []
        self.kinds: dict[type, Any] = {}

    # -- meeting objects
    def lit(self, value: Any) -> int:
        """A plain value as a node of its own (in a column of references); equal scalars and equal sets shared."""
        kind = type(value)
        if kind is float:
            key: Any = (kind, repr(value))  # 0.0 == -0.0, but they are two values
        elif kind in _SCALAR_SET:
            key = (kind, value)
        elif kind is set or kind is frozenset:
            key = (kind, frozenset(value))
        else:
            self.kept.append(value)
            key = ("id", id(value))
        node = self.lits.get(key)
        if node is None:
            node = self.lits[key] = self.count
            self.count += 1
            self.lit_batch.nodes.append(node)
            self.lit_values.append(value)
        return node

    def ref(self, obj: Any) -> int:
        """The node of an object that is not plain data (met before, or new: then in a batch to come)."""
        node = self.memo.get(id(obj))
        if node is not None:
            return node
        kind = type(obj)
        key = self.kinds.get(kind)
        if id(obj) in self.named:
            key = ("named", self.named[id(obj)])
        elif key is None:
            key = self.kinds[kind] = self.kind_of(kind)
        node = self.memo[id(obj)] = self.count
        self.count += 1
        self.kept.append(obj)
        group = self.new.get(key)
        if group is None:
            self.new[key] = [(node, obj)]
        else:
            group.append((node, obj))
        return node

    def field_sets(self, models: list[Any]) -> list[int]:
        """The nodes of the models' sets of fields set, one literal per distinct set (shared when read back)."""
        keys = list(map(frozenset, map(attrgetter("__pydantic_fields_set__"), models)))
        nodes = {k: self.lit(set(k)) for k in dict.fromkeys(keys)}
        return list(map(nodes.__getitem__, keys))

    def node(self, value: Any) -> int:
        return self.lit(value) if plain(value) else self.ref(value)

    def kind_of(self, kind: type) -> Any:
        """The batch key of objects of the class ``kind``."""
        if kind in self.special:
            return ("call", kind)
        if issubclass(kind, type):
            return ("class",)
        if kind in _CONTAINERS:
            return (_CONTAINERS[kind],)
        if kind is dict:
            return ("dict",)
        if self.allowed.get((kind.__module__, kind.__qualname__)) is not kind:
            raise Unflattenable(f"a class not allowed: {kind.__module__}.{kind.__qualname__}")
        if issubclass(kind, enum.Enum):
            return ("enum", kind)
        if issubclass(kind, tuple) and hasattr(kind, "_fields"):
            return ("record", kind)
        if issubclass(kind, BaseModel):
            return ("model", kind)
        if dataclasses.is_dataclass(kind) and "__slots__" not in vars(kind):
            return ("object", kind)
        raise Unflattenable(f"not data: {kind.__module__}.{kind.__qualname__}")

    def column(self, col: list[Any] | tuple[Any, ...]) -> tuple[str, Any]:
        """A column: one scalar (``K``), plain values (``L``), or nodes (``N``; plain values among objects become
        literals)."""
        kinds = set(map(type, col))
        if kinds <= _SCALAR_SET:
            first = col[0]
            if len(kinds) == 1 and col.count(first) == len(col) and (kinds != {float} or all(c is first for c in col)):
                return ("K", first)  # (floats: the same object, as 0.0 == -0.0)
            return ("L", list(col))
        if not kinds & _PLAIN_SET:
            if len(set(map(id, col))) == 1:
                return ("C", self.ref(col[0]))
            return ("N", list(map(self.ref, col)))
        empty = kinds <= _PLAIN_SET and not any(col)  # (empty containers and falsy scalars: plain)
        flags = [True] * len(col) if empty else list(map(plain, col))
        if all(flags):
            first = col[0]
            if type(first) in (tuple, frozenset) and all(c is first for c in col) and _immutable(first):
                return ("K", first)
            return ("L", list(col))
        return ("N", [self.lit(v) if f else self.ref(v) for v, f in zip(col, flags, strict=True)])

    # -- batches
    def run(self, root: Any) -> int:
        top = self.node(root)
        while self.new:
            new, self.new = self.new, {}
            for key, members in new.items():
                self.batch(key, members)
        return top

    def batch(self, key: Any, members: list[tuple[int, Any]]) -> None:
        tag = key[0]
        nodes = [n for n, _obj in members]
        if tag == "named":  # made by the reader's maker of that name, from nothing
            self.batches.append(_Batch("call", key[1], nodes, self.part))
            return
        objs = [obj for _n, obj in members]
        if tag in ("record", "object", "model"):
            cls = key[1]
            if tag == "record":
                groups: list[tuple[Any, list[int], list[Any]]] = [(None, nodes, objs)]
            else:
                groups = _by_names(nodes, objs)
            for names, ns, os_ in groups:
                b = _Batch(tag, names, ns, self.part)
                b.columns.append(("C", self.ref(cls)))
                if tag == "record":
                    rows: Iterable[tuple[Any, ...]] = zip(*os_, strict=True)
                else:
                    rows = zip(*(d.values() for d in map(vars, os_)), strict=True)
                b.columns.extend(self.column(col) for col in rows)
                if tag == "model":
                    b.columns.append(("N", self.field_sets(os_)))
                    b.columns.append(self.column([o.__pydantic_extra__ for o in os_]))
                    b.columns.append(self.column([o.__pydantic_private__ for o in os_]))
                self.batches.append(b)
            return
        b = _Batch(tag, None, nodes, self.part)
        if tag == "class":
            b.items = [[]]
            b.what = [(c.__module__, c.__qualname__) for c in objs]
            for c in objs:
                if self.allowed.get((c.__module__, c.__qualname__)) is not c:
                    raise Unflattenable(f"a class not allowed: {c.__module__}.{c.__qualname__}")
        elif tag in ("tuple", "list", "set", "frozenset"):
            b.lengths = list(map(len, objs))
            b.items = [list(map(self.node, chain.from_iterable(objs)))]
        elif tag == "dict":
            b.lengths = list(map(len, objs))
            b.items = [list(map(self.node, chain.from_iterable(objs))),
                       list(map(self.node, chain.from_iterable(map(dict.values, objs))))]
        else:  # made by the reader: an enum member, or a special object by its maker
            b.tag = "call"
            if tag == "enum":
                calls = [("_enum", (type(o), o.value)) for o in objs]
            else:
                calls = [self.special[key[1]](o) for o in objs]
            by_name: dict[tuple[str, int], list[int]] = {}
            for i, (name, args) in enumerate(calls):
                by_name.setdefault((name, len(args)), []).append(i)
            for (name, width), rows_at in by_name.items():
                c = _Batch("call", name, [nodes[i] for i in rows_at], self.part)
                c.columns = [self.column([calls[i][1][j] for i in rows_at]) for j in range(width)]
                self.batches.append(c)
            return
        self.batches.append(b)

    # -- layout
    def heights(self) -> list[int]:
        """Every node's height: 1 + the greatest height of what it refers to (a literal -1, a leaf 0), found by
        passes over the batches (the last met first) until nothing changes."""
        h = [0] * self.count
        for n in self.lit_batch.nodes:
            h[n] = -1
        for _ in range(MAX_PASSES):
            changed = False
            for b in reversed(self.batches):
                hs = b.row_heights(h)
                if list(map(h.__getitem__, b.nodes)) != hs:
                    deque(map(h.__setitem__, b.nodes, hs), 0)
                    changed = True
                b.heights = hs
            if not changed:
                return h
        raise Unflattenable("a graph too deep (or with a cycle) for the stored form")

    def layout(self, tops: list[int]) -> list[list[Any]]:
        """Each part's batches in the order they are made (its literals first, then by height), with their columns,
        and the index of its root; indices count on from one part to the next."""
        self.heights()
        parts: list[tuple[int, int, int, _Batch]] = []
        for i, b in enumerate(self.batches):
            parts.extend((b.part, hb, i, part) for hb, part in _split(b))
        parts.sort(key=lambda p: (p[0], p[1], p[2]))
        lits: list[list[int]] = [[] for _ in tops]
        values: list[list[Any]] = [[] for _ in tops]
        for node, value in zip(self.lit_batch.nodes, self.lit_values, strict=True):
            at = bisect.bisect_right(self.bounds, node)
            lits[at].append(node)
            values[at].append(value)
        order: list[int] = []
        for p in range(len(tops)):
            order.extend(lits[p])
            order.extend(n for q, _h, _i, part in parts if q == p for n in part.nodes)
        final = [0] * self.count
        deque(map(final.__setitem__, order, range(len(order))), 0)
        out: list[list[Any]] = []
        for p, top in enumerate(tops):
            batches: list[Any] = [["lit", values[p]]]
            batches.extend(_emitted(part, final) for q, _h, _i, part in parts if q == p)
            out.append([batches, final[top]])
        return out


_PLAIN_SET = _SCALAR_SET | {tuple, list, dict, set, frozenset}


def _by_names(nodes: list[int], objs: list[Any]) -> list[tuple[Any, list[int], list[Any]]]:
    """Objects with an instance dict grouped by their dict's keys (one group, as a rule)."""
    names = list(map(tuple, map(vars, objs)))
    if names.count(names[0]) == len(names):
        return [(names[0], nodes, objs)]
    groups: dict[tuple[str, ...], tuple[list[int], list[Any]]] = {}
    for n, o, k in zip(nodes, objs, names, strict=True):
        g = groups.setdefault(k, ([], []))
        g[0].append(n)
        g[1].append(o)
    return [(k, ns, os_) for k, (ns, os_) in groups.items()]


def _split(b: _Batch) -> list[tuple[int, _Batch]]:
    """A batch as one part per height of its rows (one part, as a rule)."""
    hs = b.heights
    if not hs or hs.count(hs[0]) == len(hs):
        return [(hs[0] if hs else 0, b)]
    rows: dict[int, list[int]] = {}
    for i, hi in enumerate(hs):
        rows.setdefault(hi, []).append(i)
    parts = []
    starts = []
    at = 0
    for k in b.lengths:
        starts.append(at)
        at += k
    for hi, idx in sorted(rows.items()):
        part = _Batch(b.tag, b.what if b.tag != "class" else [b.what[i] for i in idx], [b.nodes[i] for i in idx],
                      b.part)
        part.columns = [(tag, [value[i] for i in idx]) if tag in ("L", "N") else (tag, value)
                        for tag, value in b.columns]
        if b.lengths:
            part.lengths = [b.lengths[i] for i in idx]
            part.items = [[x for i in idx for x in items[starts[i]:starts[i] + b.lengths[i]]] for items in b.items]
        parts.append((hi, part))
    return parts


def _emitted(b: _Batch, final: list[int]) -> list[Any]:
    """A batch as stored: references as indices (4-byte unsigned integers)."""
    get = final.__getitem__
    if b.tag == "class":
        return ["class", b.what]
    if b.tag in ("tuple", "list", "set", "frozenset", "dict"):
        return [b.tag, b.lengths, *(_indices(map(get, items)) for items in b.items)]
    columns: list[list[Any]] = []
    for tag, value in b.columns:
        if tag == "N":
            if value.count(value[0]) == len(value):
                columns.append(["C", get(value[0])])
            else:
                columns.append(["R", _indices(map(get, value))])
        elif tag == "C":
            columns.append(["C", get(value)])
        else:
            columns.append([tag, value])
    n = len(b.nodes)
    if b.tag == "call":
        return ["call", b.what, n, columns]
    if b.tag == "record":
        return ["record", n, columns]
    return [b.tag, b.what, n, columns]


def _indices(values: Iterable[int]) -> bytes:
    return array("I", values).tobytes()


def _immutable(value: Any) -> bool:
    kind = type(value)
    return kind in _SCALAR_SET or (kind in (tuple, frozenset) and all(_immutable(v) for v in value))


def flatten(root: Any, allowed: dict[tuple[str, str], type], special: Special) -> bytes:
    """``root`` as the stored form's bytes; raises :class:`Unflattenable` for what cannot be stored as data.

    ``allowed`` names every class the graph may hold; ``special`` says how to store an object that is not data, by
    its class (any other class with a ``__call__``, a function among them, is refused)."""
    return flatten_parts([root], allowed, special)


def flatten_parts(roots: list[Any], allowed: dict[tuple[str, str], type], special: Special,
                  named: dict[int, str] | None = None) -> bytes:
    """``roots`` as parts of one stored form, each read when it is first needed (:class:`Reader`): a part holds what
    its root reaches and no earlier part holds. ``named``: objects (by ``id``) stored as the reader's maker of that
    name, called without arguments."""
    f = _Flattener(allowed, special, named)
    tops = []
    for i, root in enumerate(roots):
        f.part = i
        if i:
            f.bounds.append(f.count)
        tops.append(f.run(root))
    parts = f.layout(tops)
    buf = io.BytesIO()
    pickler = pickle.Pickler(buf, protocol=pickle.HIGHEST_PROTOCOL)
    pickler.dump([VERSION, len(parts)])
    for part in parts:  # one pickle after the other, with one memo: plain values shared by two parts stay shared
        pickler.dump(part)
    return buf.getvalue()


class _PlainOnly(pickle.Unpickler):
    """Plain data only: any class or function a pickle names is refused."""

    def find_class(self, module: str, name: str) -> Any:
        raise pickle.UnpicklingError(f"the stored form holds plain data only, not {module}.{name}")


def unflatten(data: bytes, allowed: dict[tuple[str, str], type], makers: dict[str, Callable[..., Any]]) -> Any:
    """The object graph of :func:`flatten`'s bytes. Raises (anything) on a file that is not such data."""
    return Reader(data, makers).part(0, allowed)


class Reader:
    """The parts of :func:`flatten_parts`'s bytes, each made when asked for (after the parts before it): one list of
    the objects made, so a part's references to earlier parts' objects are indices into it. Raises (anything) on a
    file that is not such data."""

    def __init__(self, data: bytes, makers: dict[str, Callable[..., Any]]) -> None:
        self.unpickler = _PlainOnly(io.BytesIO(data))
        version, parts = self.unpickler.load()
        if version != VERSION or type(parts) is not int:
            raise ValueError(f"stored form {version!r}")
        self.parts = parts
        self.makers = makers
        self.objs: list[Any] = []
        self.roots: list[Any] = []

    def __len__(self) -> int:
        return self.parts

    def part(self, k: int, allowed: dict[tuple[str, str], type]) -> Any:
        """The root of part ``k``, made with the parts before it if they are not made yet."""
        while len(self.roots) <= k:
            if len(self.roots) >= self.parts:
                raise IndexError(f"no part {k}")
            batches, root = self.unpickler.load()  # the next pickle of the stream, with the memo of those before
            objs = self.objs
            for batch in batches:
                _BATCHES[batch[0]](objs, batch, allowed, self.makers)
            self.roots.append(objs[root])
        return self.roots[k]


def _column(objs: list[Any], n: int, column: list[Any]) -> Iterable[Any]:
    """A column's ``n`` values: ``K`` one value, ``C`` one object, ``L`` the values, ``R`` objects by index (a
    bytes of 4-byte unsigned integers)."""
    tag, value = column
    if tag == "K":
        return repeat(value, n)
    if tag == "C":
        return repeat(objs[value], n)
    if tag == "L":
        if len(value) != n:
            raise ValueError("a column of another length")
        return value  # type: ignore[no-any-return]
    if tag == "R":
        refs = memoryview(value).cast("I")
        if len(refs) != n:
            raise ValueError("a column of another length")
        return map(objs.__getitem__, refs)
    raise ValueError(f"a column {tag!r}")


def _rows(objs: list[Any], n: int, columns: list[list[Any]]) -> Iterable[tuple[Any, ...]]:
    return zip(*(_column(objs, n, c) for c in columns), strict=True) if columns else repeat((), n)


def _lits(objs: list[Any], batch: list[Any], _allowed: Any, _makers: Any) -> None:
    objs.extend(batch[1])


def _classes(objs: list[Any], batch: list[Any], allowed: dict[tuple[str, str], type], _makers: Any) -> None:
    for module, name in batch[1]:  # as a list of pairs, or pickled tuples
        cls = allowed.get((module, name))
        if cls is None:
            raise pickle.UnpicklingError(f"a cache file may not name {module}.{name}")
        objs.append(cls)


def _items(objs: list[Any], lengths: list[int], data: bytes) -> Iterator[Any]:
    refs = memoryview(data).cast("I")
    if sum(lengths) != len(refs):
        raise ValueError("items of another length")
    return map(objs.__getitem__, refs)


def _container(make: Callable[[Iterable[Any]], Any]) -> Callable[..., None]:
    """Containers of one kind: their items one run of references, cut by their lengths."""

    def made(objs: list[Any], batch: list[Any], _allowed: Any, _makers: Any) -> None:
        _tag, lengths, data = batch
        items = _items(objs, lengths, data)
        width = lengths[0] if lengths else 0
        if width and lengths.count(width) == len(lengths):  # all of one length (a thousand 1-tuples): cut by zip
            groups = zip(*[items] * width, strict=True)
            objs.extend(groups if make is tuple else map(make, groups))
        else:
            objs.extend(map(make, map(islice, repeat(items), lengths)))
    return made


def _dicts(objs: list[Any], batch: list[Any], _allowed: Any, _makers: Any) -> None:
    _tag, lengths, keys, values = batch
    ks, vs = repeat(_items(objs, lengths, keys)), repeat(_items(objs, lengths, values))
    objs.extend(map(dict, map(zip, map(islice, ks, lengths), map(islice, vs, lengths))))


def _class_of(objs: list[Any], columns: list[list[Any]], base: type) -> type:
    tag, value = columns[0]
    cls = objs[value] if tag == "C" else None
    if not isinstance(cls, type) or not issubclass(cls, base):
        raise ValueError("a batch of no allowed class")
    return cls


def _records(objs: list[Any], batch: list[Any], _allowed: Any, _makers: Any) -> None:
    _tag, n, columns = batch
    cls = _class_of(objs, columns, tuple)
    if len(columns) - 1 != len(getattr(cls, "_fields", ())):
        raise ValueError(f"a {cls.__qualname__} of another shape")
    objs.extend(map(tuple.__new__, repeat(cls, n), _rows(objs, n, columns[1:])))


def _instances(objs: list[Any], batch: list[Any], model: bool) -> None:
    """Objects with an instance dict (dataclasses, parameter models): each dict a copy of the batch's constant
    fields, the varying ones set column by column."""
    _tag, names, n, columns = batch
    cls = _class_of(objs, columns, BaseModel if model else object)
    if not model and not dataclasses.is_dataclass(cls):
        raise ValueError("a batch of no dataclass")
    fields = len(names) + 1
    if len(columns) != fields + (3 if model else 0) or len(set(names)) != len(names):
        raise ValueError(f"a {cls.__qualname__} of another shape")
    template: dict[str, Any] = {}
    varying: list[tuple[str, Iterable[Any]]] = []
    for name, column in zip(names, columns[1:fields], strict=True):
        tag, value = column
        if tag == "K":
            template[name] = value
        elif tag == "C":
            template[name] = objs[value]
        else:
            template[name] = None  # the key in its place: the dict's order is the fields' order
            varying.append((name, _column(objs, n, column)))
    made: list[Any] = list(map(object.__new__, repeat(cls, n)))
    dicts = list(map(dict.copy, repeat(template, n)))
    for name, values in varying:
        deque(map(dict.__setitem__, dicts, repeat(name), values), 0)
    deque(map(slot_setter(cls, "__dict__"), made, dicts), 0)
    if model:
        for slot, column in zip(_MODEL_SLOTS, columns[fields:], strict=True):
            deque(map(slot_setter(cls, slot), made, _column(objs, n, column)), 0)
    objs.extend(made)


def _objects(objs: list[Any], batch: list[Any], _allowed: Any, _makers: Any) -> None:
    _instances(objs, batch, False)


def _models(objs: list[Any], batch: list[Any], _allowed: Any, _makers: Any) -> None:
    _instances(objs, batch, True)


def _calls(objs: list[Any], batch: list[Any], _allowed: Any, makers: dict[str, Callable[..., Any]]) -> None:
    _tag, name, n, columns = batch
    maker = makers[name]
    objs.extend(maker(*args) for args in _rows(objs, n, columns))


_BATCHES: dict[str, Callable[[list[Any], list[Any], Any, Any], None]] = {
    "lit": _lits, "class": _classes, "tuple": _container(tuple), "list": _container(list), "set": _container(set),
    "frozenset": _container(frozenset), "dict": _dicts, "record": _records, "object": _objects, "model": _models,
    "call": _calls,
}


def make_enum(cls: Any, value: Any) -> Any:
    """An enum member of an allowed class, by value (the maker of ``_enum``)."""
    if not (isinstance(cls, type) and issubclass(cls, enum.Enum)):
        raise ValueError("not an enum")
    return cls(value)


__all__ = ["Reader", "Unflattenable", "VERSION", "flatten", "flatten_parts", "make_enum", "plain", "unflatten"]
