"""Watch expressions of a live run: expressions of the document's language whose values are kept after every tick.

A set of watches is compiled into **one generated Python function** (:func:`row_function`): it reads every name
the watches use once (the car's readings as attributes, the variables from the dictionary, the signals' levels),
and, when any of it moved since the last tick, evaluates all the expressions inline and gives the row as one
tuple. One call per tick, whatever the number of watches; nothing allocated on a tick where nothing read moved.

The generated code is exact: it runs only what the checked expressions mean (the same operators on values of the
kinds the expressions were checked against). Whatever it cannot do the same way raises inside it, and the row is
then computed by the compiled expressions one by one (:class:`Slow`), an expression that fails giving its
error's text as its value: a division by zero, a variable that a reload took away or that now holds another kind,
a run without a car.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple

from fsm.debug.breakpoints import CAR_READINGS, BreakpointError, expression_kinds, with_names
from fsm.model.expr import (
    ANY,
    BOOL,
    MAX_TEXT_LENGTH,
    NUMBER,
    TEXT,
    ExprError,
    ExprRuntimeError,
    Node,
    compile_tree,
    parse,
)

#: What a failing expression may raise (its error's text becomes its value in the row).
FAILURES = (ExprRuntimeError, TypeError, ValueError, ArithmeticError, LookupError, AttributeError)
Row = tuple[Any, ...]


class WatchExpr(NamedTuple):
    """One watch: its text, its parse tree, the kinds of the names it was checked against, its compiled function
    (of a dictionary of names)."""
    text: str
    tree: Node
    kinds: dict[str, str]
    fn: Callable[[dict[str, Any]], Any]


def compile_watch(text: Any, machine: Any, signals: Any = ()) -> WatchExpr:
    """``text`` checked against what the machine has now (variables, ``signal_NAME``, ``car_NAME``); one that does
    not parse or check is a :class:`BreakpointError` with its column."""
    if not isinstance(text, str) or not text.strip():
        raise BreakpointError("a watch is an expression such as car_front or n * 2", 1)
    kinds = expression_kinds(machine, signals)
    try:
        tree = parse(text)
        compiled = compile_tree(tree, text, kinds)
    except ExprError as exc:
        raise BreakpointError(with_names(exc.message, machine, signals), exc.column) from None
    return WatchExpr(text, tree, kinds, compiled.fn)


def names_of(tree: Node) -> list[str]:
    """The names an expression reads, in the order they first appear."""
    out: list[str] = []

    def walk(node: Node) -> None:
        if node.op == "var":
            if node.args[0] not in out:
                out.append(node.args[0])
        elif node.op == "call":
            for a in node.args[1:]:
                walk(a)
        elif node.op != "const":
            for a in node.args:
                walk(a)

    walk(tree)
    return out


class Slow:
    """The row one expression at a time from a dictionary of what they read: the way when the generated function
    cannot (see the module's docstring)."""

    def __init__(self, watches: list[WatchExpr]) -> None:
        self.fns = [w.fn for w in watches]
        names = {n for w in watches for n in names_of(w.tree)}
        self.signals = sorted(n[7:] for n in names if n.startswith("signal_"))
        self.car = [r for r in CAR_READINGS if f"car_{r}" in names]

    def values(self, ctx: Any) -> dict[str, Any]:
        values: dict[str, Any] = dict(ctx.vars)
        for name in self.signals:
            values[f"signal_{name}"] = ctx.signals.get(name, False)
        car = ctx.car
        if car is not None:
            for reading in self.car:
                values[f"car_{reading}"] = getattr(car, reading, None)
        return values

    def row(self, ctx: Any) -> Row:
        values = self.values(ctx)
        try:  # all at once; one that fails: each on its own, the failing one's error as its value
            return tuple([fn(values) for fn in self.fns])
        except FAILURES:
            out: list[Any] = []
            for fn in self.fns:
                try:
                    out.append(fn(values))
                except FAILURES as exc:
                    out.append(f"error: {exc}")
            return tuple(out)


#: Python's spelling of the language's operators (both are evaluated left to right with Python's semantics for
#: values of the checked kinds; ``/`` and ``%`` by zero raise, and the slow path says so as the language does).
_BINARY = {"and": "and", "or": "or", "==": "==", "!=": "!=", "<": "<", "<=": "<=", ">": ">", ">=": ">=",
           "-": "-", "*": "*", "/": "/", "%": "%"}
_CHECKS = {NUMBER: "type({v}) in _NUM", BOOL: "({v} is True or {v} is False)", TEXT: "type({v}) is str"}


class _Source:
    """The generated function's text, its constants and the local name of every name read."""

    def __init__(self) -> None:
        self.consts: dict[str, Any] = {}
        self.local: dict[str, str] = {}

    def const(self, value: Any) -> str:
        name = f"_k{len(self.consts)}"
        self.consts[name] = value
        return name

    def kind(self, node: Node, kinds: dict[str, str]) -> str:
        """The kind an already checked node gives (enough to tell text ``+`` from numbers)."""
        op = node.op
        if op == "const":
            v = node.args[0]
            return BOOL if isinstance(v, bool) else TEXT if isinstance(v, str) else NUMBER
        if op == "var":
            return kinds.get(node.args[0], ANY)
        if op == "+":
            sides = {self.kind(a, kinds) for a in node.args}
            return TEXT if TEXT in sides else ANY if ANY in sides else NUMBER
        if op in ("-", "*", "/", "%", "neg", "call"):
            return NUMBER
        return BOOL

    def expr(self, node: Node, kinds: dict[str, str]) -> str:
        op = node.op
        if op == "const":
            return self.const(node.args[0])
        if op == "var":
            return self.local[node.args[0]]
        if op == "call":
            inner = ", ".join(self.expr(a, kinds) for a in node.args[1:])
            return f"_{node.args[0]}({inner})"
        if op == "neg":
            return f"(-{self.expr(node.args[0], kinds)})"
        if op == "not":
            return f"(not {self.expr(node.args[0], kinds)})"
        left, right = (self.expr(a, kinds) for a in node.args)
        if op == "+":
            if self.kind(node, kinds) == NUMBER:
                return f"({left} + {right})"
            return f"_join({left}, {right})"
        return f"({left} {_BINARY[op]} {right})"


def row_function(watches: list[WatchExpr]) -> Callable[[Any], Row]:
    """One function of a machine's context giving the watches' row (see the module's docstring)."""
    slow = Slow(watches)
    if not watches:
        return lambda ctx: ()
    src = _Source()
    names: list[str] = []
    for w in watches:
        names += [n for n in names_of(w.tree) if n not in names]
    kinds: dict[str, str] = {}
    for w in watches:
        for n in names_of(w.tree):
            kinds.setdefault(n, w.kinds.get(n, ANY))
    lines = ["def row(ctx):", "    try:"]
    if any(n.startswith("car_") for n in names):
        lines.append("        car = ctx.car")
    if any(not n.startswith(("car_", "signal_")) for n in names):
        lines.append("        vs = ctx.vars")
    if any(n.startswith("signal_") for n in names):
        lines.append("        sig = ctx.signals")
    checks = []
    for i, n in enumerate(names):
        v = src.local[n] = f"_v{i}"
        if n.startswith("car_") and n[4:] in CAR_READINGS:
            lines.append(f"        {v} = car.{n[4:]}")
        elif n.startswith("signal_"):
            lines.append(f"        {v} = sig.get({src.const(n[7:])}, False)")
        else:
            lines.append(f"        {v} = vs[{src.const(n)}]")
            if kinds[n] in _CHECKS:
                checks.append(_CHECKS[kinds[n]].format(v=v))
    if checks:  # a variable holding another kind than checked: the slow path says what is wrong
        lines.append(f"        if not ({' and '.join(checks)}): raise _Other")
    # a tick where nothing read moved keeps the last row (the same object); a list or a dict changes in place
    # (equal to itself though changed), so a watch of one is evaluated afresh every tick
    same = all(kinds[n] in (NUMBER, BOOL, TEXT) or n.startswith(("car_", "signal_")) for n in names)
    read = "(" + "".join(f"{src.local[n]}, " for n in names) + ")"
    if same and names:
        lines += [f"        got = {read}", "        if got == last[0]: return last[1]"]
    row = "(" + "".join(f"{src.expr(w.tree, w.kinds)}, " for w in watches) + ")"
    lines.append(f"        out = {row}")
    if same and names:
        lines.append("        last[0] = got; last[1] = out")
    lines += ["        return out", "    except Exception:", "        last[0] = None", "        return slow(ctx)"]
    namespace: dict[str, Any] = {**src.consts, "_NUM": {int, float}, "_Other": _Other, "_join": _join,
                                 "_abs": abs, "_min": min, "_max": max, "last": [None, None], "slow": slow.row}
    exec(compile("\n".join(lines), "<watch expressions>", "exec"), namespace)  # noqa: S102 (our own generated text)
    fn: Callable[[Any], Row] = namespace["row"]
    return fn


class _Other(Exception):
    """A variable holds another kind than the watch was checked against."""


def _join(a: Any, b: Any) -> Any:
    """``+`` where a side may be text: the language's text length cap (the slow path says why it failed)."""
    out = a + b
    if type(out) is str and len(out) > MAX_TEXT_LENGTH:
        raise ExprRuntimeError("text too long")
    return out


__all__ = ["FAILURES", "Slow", "WatchExpr", "compile_watch", "names_of", "row_function"]
