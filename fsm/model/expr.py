"""Expressions over blackboard variables: a small safe language for guards and ``set`` actions.

Parsed by our own tokenizer and precedence-climbing parser (never ``eval``, never Python's grammar: its
chained comparisons, ``**``, attribute access and calls would all need to be refused one by one), checked
against the variables a document declares, and compiled to closures over ``ctx.vars``.

Grammar (lowest precedence first)::

    assignments := assignment (";" assignment)* [";"]
    assignment  := NAME "=" expr
    expr        := or
    or          := and ("or" and)*
    and         := not ("and" not)*
    not         := "not" not | compare
    compare     := sum [("==" | "!=" | "<" | "<=" | ">" | ">=") sum]
    sum         := product (("+" | "-") product)*
    product     := unary (("*" | "/" | "%") unary)*
    unary       := "-" unary | atom
    atom        := NUMBER | STRING | "true" | "false" | NAME | NAME "(" [expr ("," expr)*] ")" | "(" expr ")"

Functions: ``abs(x)``, ``min(x, y, ...)``, ``max(x, y, ...)``. Strings are quoted with ``'`` or ``"``.
Kinds are those of :func:`fsm.loading.checking.value_kind`: number, true/false, text; true/false is not a number.
"""

from __future__ import annotations

import difflib
import math
import operator
import re
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, NamedTuple

NUMBER, BOOL, TEXT, ANY = "number", "true/false", "text", "any"
KEYWORDS = frozenset({"true", "false", "and", "or", "not"})
FUNCTIONS = {"abs": (1, 1), "min": (2, None), "max": (2, None)}
#: A longer expression is refused (no guard needs it, and the parser recurses on nesting).
MAX_LENGTH = 2000
MAX_DEPTH = 60


class ExprError(ValueError):
    """An expression that cannot be used; ``column`` is 1-based inside the expression text."""

    def __init__(self, message: str, column: int) -> None:
        super().__init__(message)
        self.message = message
        self.column = column

    def __str__(self) -> str:
        return f"{self.message} (column {self.column} of the expression)"


# -- tokens ------------------------------------------------------------------------------------------
_TOKEN = re.compile(r"""
    (?P<ws>\s+)
  | (?P<num>(?:\d+\.\d*|\.\d+|\d+)(?:[eE][+-]?\d+)?)
  | (?P<name>[^\W\d]\w*)
  | (?P<str>'[^'\\\n]*'|"[^"\\\n]*")
  | (?P<op>==|!=|<=|>=|[-+*/%<>(),;=])
""", re.X)


@dataclass(frozen=True)
class Token:
    kind: str  # num, name, str, op, end
    text: str
    column: int  # 1-based


def tokenize(text: str) -> list[Token]:
    if len(text) > MAX_LENGTH:
        raise ExprError(f"expression longer than {MAX_LENGTH} characters", 1)
    out: list[Token] = []
    pos = 0
    while pos < len(text):
        m = _TOKEN.match(text, pos)
        if m is None:
            ch = text[pos]
            if ch in "'\"":
                raise ExprError("unterminated string (no escapes: use the other quote inside)", pos + 1)
            hint = {"&": " (write 'and')", "|": " (write 'or')", "!": " (write 'not')"}.get(ch, "")
            raise ExprError(f"unexpected character {ch!r}{hint}", pos + 1)
        kind = m.lastgroup or ""
        if kind != "ws":
            if kind == "num" and m.end() < len(text) and (text[m.end()].isalnum() or text[m.end()] == "_"):
                raise ExprError(f"malformed number {text[pos:m.end() + 1]!r}", pos + 1)
            out.append(Token(kind, m.group(), pos + 1))
        pos = m.end()
    out.append(Token("end", "", len(text) + 1))
    return out


# -- syntax tree ------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Node:
    op: str  # const, var, neg, not, and, or, + - * / %, == != < <= > >=, call
    args: tuple[Any, ...]
    column: int


_COMPARE = ("==", "!=", "<", "<=", ">", ">=")


class _Parser:
    def __init__(self, text: str, functions: dict[str, tuple[int, int | None]] | None = None) -> None:
        self.tokens = tokenize(text)
        self.i = 0
        self.depth = 0
        self.functions = FUNCTIONS if functions is None else functions

    @property
    def tok(self) -> Token:
        return self.tokens[self.i]

    def take(self) -> Token:
        t = self.tokens[self.i]
        self.i += 1
        return t

    def at(self, *texts: str) -> bool:
        t = self.tok
        return t.kind in ("op", "name") and t.text in texts

    def expect(self, text: str, what: str) -> Token:
        if not self.at(text):
            raise ExprError(f"expected {what}, found {_found(self.tok)}", self.tok.column)
        return self.take()

    def expr(self) -> Node:
        self.depth += 1
        if self.depth > MAX_DEPTH:
            raise ExprError(f"expression nested more than {MAX_DEPTH} levels deep", self.tok.column)
        try:
            return self.or_()
        finally:
            self.depth -= 1

    def or_(self) -> Node:
        left = self.and_()
        while self.at("or"):
            col = self.take().column
            left = Node("or", (left, self.and_()), col)
        return left

    def and_(self) -> Node:
        left = self.not_()
        while self.at("and"):
            col = self.take().column
            left = Node("and", (left, self.not_()), col)
        return left

    def not_(self) -> Node:
        if self.at("not"):
            col = self.take().column
            self.depth += 1
            if self.depth > MAX_DEPTH:
                raise ExprError(f"expression nested more than {MAX_DEPTH} levels deep", col)
            try:
                return Node("not", (self.not_(),), col)
            finally:
                self.depth -= 1
        return self.compare()

    def compare(self) -> Node:
        left = self.sum()
        if self.tok.kind == "op" and self.tok.text in _COMPARE:
            t = self.take()
            left = Node(t.text, (left, self.sum()), t.column)
            if self.tok.kind == "op" and self.tok.text in _COMPARE:
                raise ExprError("comparisons do not chain: write 'a < b and b < c'", self.tok.column)
        return left

    def sum(self) -> Node:
        left = self.product()
        while self.tok.kind == "op" and self.tok.text in ("+", "-"):
            t = self.take()
            left = Node(t.text, (left, self.product()), t.column)
        return left

    def product(self) -> Node:
        left = self.unary()
        while self.tok.kind == "op" and self.tok.text in ("*", "/", "%"):
            t = self.take()
            left = Node(t.text, (left, self.unary()), t.column)
        return left

    def unary(self) -> Node:
        if self.tok.kind == "op" and self.tok.text == "-":
            col = self.take().column
            self.depth += 1
            if self.depth > MAX_DEPTH:
                raise ExprError(f"expression nested more than {MAX_DEPTH} levels deep", col)
            try:
                return Node("neg", (self.unary(),), col)
            finally:
                self.depth -= 1
        return self.atom()

    def atom(self) -> Node:
        t = self.tok
        if t.kind == "num":
            self.take()
            value: Any = float(t.text) if any(c in t.text for c in ".eE") else int(t.text)
            if isinstance(value, float) and not math.isfinite(value):
                raise ExprError(f"number {t.text} is too large", t.column)
            return Node("const", (value,), t.column)
        if t.kind == "str":
            self.take()
            return Node("const", (t.text[1:-1],), t.column)
        if t.kind == "name":
            self.take()
            if t.text in ("true", "false"):
                return Node("const", (t.text == "true",), t.column)
            if t.text in KEYWORDS:
                raise ExprError(f"expected a value, found '{t.text}'", t.column)
            if self.at("("):
                return self.call(t)
            return Node("var", (t.text,), t.column)
        if t.kind == "op" and t.text == "(":
            self.take()
            inner = self.expr()
            self.expect(")", "')'")
            return inner
        raise ExprError(f"expected a value, found {_found(t)}", t.column)

    def call(self, name: Token) -> Node:
        functions = self.functions
        if name.text not in functions:
            close = difflib.get_close_matches(name.text, list(functions), n=1)
            guess = f"did you mean '{close[0]}'? " if close else ""
            raise ExprError(f"unknown function '{name.text}' ({guess}known: {', '.join(functions)})", name.column)
        self.take()  # (
        args: list[Node] = []
        if not self.at(")"):
            args.append(self.expr())
            while self.at(","):
                self.take()
                args.append(self.expr())
        self.expect(")", "',' or ')'")
        low, high = functions[name.text]
        if len(args) < low or (high is not None and len(args) > high):
            want = f"{low}" if low == high else f"at least {low}"
            raise ExprError(f"{name.text}() takes {want} argument{'s' if low != 1 else ''}, got {len(args)}",
                            name.column)
        return Node("call", (name.text, *args), name.column)


def _found(t: Token) -> str:
    return "the end" if t.kind == "end" else f"'{t.text}'"


def parse(text: str, functions: dict[str, tuple[int, int | None]] | None = None) -> Node:
    """The syntax tree of one expression, or :class:`ExprError` with the column. ``functions`` (name -> (fewest,
    most arguments)) replaces the language's own for a language built on this one (the scenario's temporal terms);
    the caller then rewrites those calls before compiling the tree with :func:`compile_tree`."""
    if not isinstance(text, str):
        raise ExprError("an expression is a string", 1)
    p = _Parser(text, functions)
    if p.tok.kind == "end":
        raise ExprError("empty expression", 1)
    node = p.expr()
    if p.tok.kind != "end":
        raise ExprError(f"unexpected {_found(p.tok)} after the expression", p.tok.column)
    return node


def parse_assignments(text: str) -> list[tuple[str, str, int]]:
    """``a = expr; b = expr`` -> ``[(name, expression text, column of the expression)]`` (syntax checked)."""
    p = _Parser(text)
    out: list[tuple[str, str, int]] = []
    while p.tok.kind != "end":
        name = p.tok
        if name.kind != "name" or name.text in KEYWORDS:
            raise ExprError(f"expected a variable name to assign, found {_found(name)}", name.column)
        p.take()
        p.expect("=", "'=' (an action is 'name = expression')")
        start = p.tok
        p.expr()
        end = p.tok
        if end.kind != "end" and not (end.kind == "op" and end.text == ";"):
            raise ExprError(f"expected ';' or the end, found {_found(end)}", end.column)
        out.append((name.text, text[start.column - 1:end.column - 1].strip(), start.column))
        if end.kind == "op":
            p.take()
    if not out:
        raise ExprError("empty action (write 'name = expression')", 1)
    return out


# -- printing ---------------------------------------------------------------------------------------
_PREC = {"or": 1, "and": 2, "not": 3, **{op: 4 for op in _COMPARE}, "+": 5, "-": 5, "*": 6, "/": 6, "%": 6,
         "neg": 7}


def unparse(node: Node) -> str:
    """Text that parses back to ``node`` (fully parenthesised where precedence needs it)."""
    op = node.op
    if op == "const":
        v = node.args[0]
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, str):
            return f"'{v}'" if "'" not in v else f'"{v}"'
        return repr(v)
    if op == "var":
        name: str = node.args[0]
        return name
    if op == "call":
        return f"{node.args[0]}({', '.join(unparse(a) for a in node.args[1:])})"
    if op in ("neg", "not"):
        inner = unparse(node.args[0])
        if _PREC.get(node.args[0].op, 9) < _PREC[op] or (op == "neg" and node.args[0].op == "neg"):
            inner = f"({inner})"
        return ("-" if op == "neg" else "not ") + inner
    left, right = (unparse(a) for a in node.args)
    p = _PREC[op]
    if _PREC.get(node.args[0].op, 9) < p or (p == 4 and _PREC.get(node.args[0].op, 9) == 4):
        left = f"({left})"
    if _PREC.get(node.args[1].op, 9) <= p:
        right = f"({right})"
    return f"{left} {op} {right}"


# -- checking and compiling -------------------------------------------------------------------------
Fn = Callable[[dict[str, Any]], Any]


def kind_of(value: Any) -> str:
    if isinstance(value, bool):
        return BOOL
    if isinstance(value, (int, float)):
        return NUMBER
    if isinstance(value, str):
        return TEXT
    return ANY


def kind_phrase(kind: str) -> str:
    """A value kind as messages name it: "a number", "true/false", "text"."""
    return {NUMBER: "a number", BOOL: "true/false", TEXT: "text"}.get(kind, kind)


class VarOp(NamedTuple):
    """An expression of the form ``variable OP constant`` (a number variable, a number constant): the common guard
    (``n < 3``) and counter (``n + 1``), which the runtime runs inline instead of calling a closure.

    ``read(vars)`` gives the variable's value, or raises the run-time error, when it is not a plain number.
    ``swapped``: written ``constant OP variable``."""

    variable: str
    op: Callable[[Any, Any], Any]
    constant: Any
    swapped: bool
    read: Fn


@dataclass(frozen=True)
class Compiled:
    """A checked expression: its closure over the variables, its kind, its constant value (if constant), and
    its ``variable OP constant`` form when it has one."""

    fn: Fn
    kind: str
    text: str
    constant: bool = False
    value: Any = None
    var_op: VarOp | None = None

    def comparison(self) -> VarOp | None:
        """The expression as ``variable OP constant`` with a comparison operator, read left to right (``3 > n``
        becomes ``n < 3``), or None."""
        v = self.var_op
        if v is None or v.op not in _FLIPPED:
            return None
        return v._replace(op=_FLIPPED[v.op], swapped=False) if v.swapped else v

    def counter(self) -> VarOp | None:
        """The expression as ``variable OP constant`` (not swapped: ``1 - n`` is not a counter), or None."""
        v = self.var_op
        return v if v is not None and not v.swapped else None


def constant(value: Any) -> Compiled:
    """A constant written as a JSON number or true/false (not as an expression text)."""
    return Compiled(lambda v: value, kind_of(value), repr(value), True, value)


class ExprRuntimeError(ValueError):
    """An expression that failed while the machine ran (a variable without a value, a division by zero)."""


def compile_expr(text: str, kinds: dict[str, str], want: str | None = None) -> Compiled:
    """Parse, check and compile ``text``. ``kinds``: every known variable -> its kind (``any`` if unknown).

    Raises :class:`ExprError` for a syntax error, an unknown variable, a kind mismatch, a division by a
    constant zero, or (with ``want``) a result of another kind.
    """
    return compile_tree(parse(text), text, kinds, want)


def compile_tree(node: Node, text: str, kinds: dict[str, str], want: str | None = None) -> Compiled:
    """Check and compile a parsed expression (``text`` is its source, for messages); as :func:`compile_expr`."""
    fn, kind, const, value = _compile(node, kinds)
    if want is not None and kind not in (want, ANY):
        raise ExprError(f"the expression gives {kind_phrase(kind)}, {kind_phrase(want)} is needed here", node.column)
    if want == BOOL and kind == ANY:
        fn = _checked_bool(fn, text)
    return Compiled(fn, kind, text, const, value, None if const else _var_op(node, kinds))


def _checked_bool(fn: Fn, text: str) -> Fn:
    def run(v: dict[str, Any]) -> Any:
        out = fn(v)
        if out is not True and out is not False:
            raise ExprRuntimeError(f"'{text}' gave {out!r}, not true/false")
        return out
    return run


def _const(value: Any) -> Fn:
    return lambda v: value


class _Part(NamedTuple):
    """A compiled subexpression: its function, kind, whether it is constant and then its value."""

    fn: Fn
    kind: str
    const: bool
    value: Any


def _compile(node: Node, kinds: dict[str, str]) -> _Part:
    """The compiled node; constants are folded."""
    op = node.op
    if op == "const":
        value = node.args[0]
        return _Part(_const(value), kind_of(value), True, value)
    if op == "var":
        name = node.args[0]
        if name not in kinds:
            raise ExprError(f"unknown variable '{name}'", node.column)
        return _Part(_var(name, kinds[name]), kinds[name], False, None)
    if op == "call":
        return _compile_call(node, kinds)
    if op in ("neg", "not"):
        return _compile_unary(node, kinds)
    left, right = (_compile(a, kinds) for a in node.args)
    if op in ("and", "or"):
        return _compile_logic(node, left, right)
    if op in ("==", "!=", "<", "<=", ">", ">="):
        return _compile_comparison(node, kinds, left, right)
    return _compile_arithmetic(node, kinds, left, right)


def _compile_call(node: Node, kinds: dict[str, str]) -> _Part:
    """``abs(x)``, ``min(...)``, ``max(...)``: numbers in, a number out."""
    fname = node.args[0]
    parts = [_compile(a, kinds) for a in node.args[1:]]
    for a, part in zip(node.args[1:], parts, strict=True):
        _need(part.kind, NUMBER, f"{fname}()", a.column)
    fns = [p.fn for p in parts]
    impls: dict[str, Callable[..., Any]] = {"abs": abs, "min": min, "max": max}
    impl = impls[fname]
    if fname == "abs":
        f0 = fns[0]
        fn: Fn = lambda v: abs(f0(v))
    elif len(fns) == 2:
        f0, f1 = fns
        fn = (lambda v: min(f0(v), f1(v))) if fname == "min" else (lambda v: max(f0(v), f1(v)))
    else:
        fn = lambda v: impl(f(v) for f in fns)  # noqa: E731
    return _fold(fn, NUMBER, parts)


def _compile_unary(node: Node, kinds: dict[str, str]) -> _Part:
    """``-x`` (a number) and ``not x`` (true/false)."""
    part = _compile(node.args[0], kinds)
    inner = part.fn
    if node.op == "neg":
        _need(part.kind, NUMBER, "'-'", node.column)
        return _fold(lambda v: -inner(v), NUMBER, [part])
    _need(part.kind, BOOL, "'not'", node.column)
    return _fold(lambda v: not inner(v), BOOL, [part])


def _compile_logic(node: Node, left: _Part, right: _Part) -> _Part:
    """``and``/``or`` of two true/false values (the right one asked only when needed)."""
    op = node.op
    lf, rf = left.fn, right.fn
    _need(left.kind, BOOL, f"'{op}'", node.args[0].column)
    _need(right.kind, BOOL, f"'{op}'", node.args[1].column)
    fn = (lambda v: lf(v) and rf(v)) if op == "and" else (lambda v: lf(v) or rf(v))
    return _fold(fn, BOOL, [left, right])


def _compile_comparison(node: Node, kinds: dict[str, str], left: _Part, right: _Part) -> _Part:
    """``==``/``!=`` of two values of one kind; ``<``, ``<=``, ``>``, ``>=`` of numbers or of texts."""
    op = node.op
    lf, rf = left.fn, right.fn
    lk, rk = left.kind, right.kind
    fn: Fn
    if op in ("==", "!="):
        if ANY not in (lk, rk) and lk != rk:
            raise ExprError(f"cannot compare {kind_phrase(lk)} with {kind_phrase(rk)} (true/false is not a number, "
                            "'5' is not 5)", node.column)
        fn = (lambda v: lf(v) == rf(v)) if op == "==" else (lambda v: lf(v) != rf(v))
        return _fold(_fused(op, node, kinds) or fn, BOOL, [left, right])
    if BOOL in (lk, rk):
        raise ExprError(f"'{op}' on true/false: true/false values are only equal or not", node.column)
    if ANY not in (lk, rk) and lk != rk:
        raise ExprError(f"cannot compare {kind_phrase(lk)} with {kind_phrase(rk)}", node.column)
    fn = {"<": lambda v: lf(v) < rf(v), "<=": lambda v: lf(v) <= rf(v),
          ">": lambda v: lf(v) > rf(v), ">=": lambda v: lf(v) >= rf(v)}[op]
    return _fold(_fused(op, node, kinds) or fn, BOOL, [left, right])


def _compile_arithmetic(node: Node, kinds: dict[str, str], left: _Part, right: _Part) -> _Part:
    """``+ - * / %`` of numbers; ``+`` of texts joins them."""
    op = node.op
    lf, rf = left.fn, right.fn
    lk, rk = left.kind, right.kind
    fn: Fn
    if op == "+" and TEXT in (lk, rk):
        if {lk, rk} - {TEXT, ANY}:
            raise ExprError(f"cannot add {kind_phrase(lk)} and {kind_phrase(rk)}", node.column)
        return _fold(lambda v: _join_text(lf(v), rf(v)), TEXT, [left, right])
    _need(lk, NUMBER, f"'{op}'", node.args[0].column)
    _need(rk, NUMBER, f"'{op}'", node.args[1].column)
    if op in ("/", "%") and right.const and right.value == 0:
        raise ExprError("division by zero", node.column)
    kind = NUMBER if ANY not in (lk, rk) else ANY
    if op == "+":
        fn = lambda v: lf(v) + rf(v)  # noqa: E731
    elif op == "-":
        fn = lambda v: lf(v) - rf(v)  # noqa: E731
    elif op == "*":
        fn = lambda v: lf(v) * rf(v)  # noqa: E731
    elif op == "/":
        fn = lambda v: _div(lf(v), rf(v))  # noqa: E731
    else:
        fn = lambda v: _mod(lf(v), rf(v))  # noqa: E731
    return _fold(_fused(op, node, kinds) or fn, kind, [left, right])


#: The operators :func:`_fused` runs as one C call (division keeps its own zero handling).
_FUSABLE = {"<": operator.lt, "<=": operator.le, ">": operator.gt, ">=": operator.ge, "==": operator.eq,
            "!=": operator.ne, "+": operator.add, "-": operator.sub, "*": operator.mul}


def _var_op(node: Node, kinds: dict[str, str]) -> VarOp | None:
    """``number_var OP constant`` (or the other way round) as a record, for the runtime's inline forms. Called
    after the generic path has checked the kinds; a variable holding another kind still gets the generic error."""
    f = _FUSABLE.get(node.op)
    if f is None:
        return None
    a, b = node.args
    if a.op == "var" and b.op == "const":
        name, const, swapped = a.args[0], b.args[0], False
    elif a.op == "const" and b.op == "var":
        name, const, swapped = b.args[0], a.args[0], True
    else:
        return None
    if kinds.get(name) != NUMBER or kind_of(const) != NUMBER:
        return None
    return VarOp(name, f, const, swapped, _var(name, NUMBER))


def _fused(op: str, node: Node, kinds: dict[str, str]) -> Fn | None:
    """``number_var OP constant`` as one closure: the common guard (``n < 3``) and counter (``n + 1``) forms, which
    would otherwise call three closures per evaluation."""
    form = _var_op(node, kinds)
    if form is None:
        return None
    name, f, const, swapped, read = form
    numeric = _NUMERIC
    if swapped:
        return lambda v: f(const, x if type(x := v.get(name)) in numeric else read(v))
    return lambda v: f(x if type(x := v.get(name)) in numeric else read(v), const)


def on_context(c: Compiled) -> Callable[[Any], Any]:
    """A compiled expression over the variables as a function of the context: ``ctx -> fn(ctx.vars)``, one
    closure for the ``var OP constant`` form (the common guard), so a guard costs one call."""
    form = c.var_op
    if form is None:
        fn = c.fn
        return lambda ctx: fn(ctx.vars)
    name, f, const, swapped, read = form
    numeric = _NUMERIC
    if swapped:
        return lambda ctx: f(const, x if type(x := (v := ctx.vars).get(name)) in numeric else read(v))
    return lambda ctx: f(x if type(x := (v := ctx.vars).get(name)) in numeric else read(v), const)


#: ``const OP var`` is ``var FLIPPED[OP] const``: a guard's test is always read as ``var OP const``.
_FLIPPED = {operator.lt: operator.gt, operator.le: operator.ge, operator.gt: operator.lt, operator.ge: operator.le,
            operator.eq: operator.eq, operator.ne: operator.ne}


#: The longest text an expression may make (characters): a text doubled on every tick would fill the memory in
#: seconds, so a longer result is a run-time error of the state or transition that computes it.
MAX_TEXT_LENGTH = 65536


def _join_text(a: Any, b: Any) -> Any:
    out = a + b
    if type(out) is str and len(out) > MAX_TEXT_LENGTH:
        raise ExprRuntimeError(f"text longer than {MAX_TEXT_LENGTH} characters ({len(out)}): text variables are "
                               "capped so a growing text cannot fill the memory")
    return out


def _div(a: Any, b: Any) -> Any:
    if b == 0:
        raise ExprRuntimeError("division by zero")
    return a / b


def _mod(a: Any, b: Any) -> Any:
    if b == 0:
        raise ExprRuntimeError("modulo by zero")
    return a % b


def _fold(fn: Fn, kind: str, parts: list[_Part]) -> _Part:
    """``fn`` of ``parts``, computed now when they all are constant."""
    if all(p.const for p in parts):
        value = fn({})
        if isinstance(value, float) and not math.isfinite(value):
            raise ExprError("the constant part of the expression overflows", 1)
        return _Part(_const(value), kind_of(value), True, value)
    return _Part(fn, kind, False, None)


def _need(kind: str, want: str, what: str, column: int) -> None:
    if kind not in (want, ANY):
        raise ExprError(f"{what} needs {kind_phrase(want)}, got {kind_phrase(kind)}", column)


_NUMERIC = (int, float)


def _var(name: str, kind: str) -> Fn:
    """Read a variable; a value of another kind than the document declares is a run-time error."""

    def missing() -> Any:
        raise ExprRuntimeError(f"variable '{name}' has no value yet (give it one in 'vars')")

    if kind == NUMBER:
        def read(v: dict[str, Any]) -> Any:
            x = v.get(name, missing)
            if type(x) in _NUMERIC:
                return x
            return _wrong(name, x, kind, missing)
    elif kind == BOOL:
        def read(v: dict[str, Any]) -> Any:
            x = v.get(name, missing)
            if x is True or x is False:
                return x
            return _wrong(name, x, kind, missing)
    elif kind == TEXT:
        def read(v: dict[str, Any]) -> Any:
            x = v.get(name, missing)
            if type(x) is str:
                return x
            return _wrong(name, x, kind, missing)
    else:
        def read(v: dict[str, Any]) -> Any:
            x = v.get(name, missing)
            if x is missing:
                missing()
            return x
    return read


def _wrong(name: str, x: Any, kind: str, missing: Any) -> Any:
    if x is missing:
        missing()
    if kind == NUMBER and isinstance(x, (int, float)) and not isinstance(x, bool):
        return x  # a subclass of int/float
    raise ExprRuntimeError(f"variable '{name}' holds {x!r} ({kind_phrase(kind_of(x))}), expressions use it as "
                           f"{kind_phrase(kind)}")


def assigner(targets: list[tuple[str, Compiled]]) -> Callable[[Any], None]:
    """One closure running ``name = expr`` in order (each sees the values assigned before it) on ``ctx.vars``."""
    if len(targets) == 1:
        name, c = targets[0]
        if c.constant:
            value = c.value

            def assign_constant(ctx: Any) -> None:
                ctx.vars[name] = value
            return assign_constant
        form = c.counter()
        if form is not None:  # name = var OP constant (a counter): one closure
            var, f, const, _swapped, read = form
            numeric = _NUMERIC

            def count(ctx: Any) -> None:
                v = ctx.vars
                x = v.get(var)
                v[name] = f(x if type(x) in numeric else read(v), const)
            return count
        fn = c.fn

        def assign_one(ctx: Any) -> None:
            v = ctx.vars
            v[name] = fn(v)
        return assign_one
    pairs = tuple((name, c.fn) for name, c in targets)

    def assign_all(ctx: Any) -> None:
        v = ctx.vars
        for name, f in pairs:
            v[name] = f(v)
    return assign_all


__all__ = ["ANY", "BOOL", "NUMBER", "TEXT", "Compiled", "VarOp", "constant", "ExprError", "ExprRuntimeError", "Node",
           "assigner", "compile_expr", "kind_of", "kind_phrase", "on_context", "parse", "parse_assignments", "tokenize",
           "unparse"]
