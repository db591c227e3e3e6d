"""The expression language (fsm/model/expr.py): grammar, kinds, constant checks, evaluation equal to Python's."""

from __future__ import annotations

import math
import operator

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import fsm
from fsm.model.expr import (
    ANY,
    BOOL,
    NUMBER,
    TEXT,
    ExprError,
    ExprRuntimeError,
    Node,
    compile_expr,
    parse,
    parse_assignments,
    unparse,
)

KINDS = {"x": NUMBER, "y": NUMBER, "flag": BOOL, "name": TEXT, "free": ANY}


def ev(text: str, **values: object) -> object:
    return compile_expr(text, {**KINDS, **{k: ANY for k in values if k not in KINDS}}).fn(values)


@pytest.mark.parametrize("text, values, expected", [
    ("1 + 2 * 3", {}, 7),
    ("(1 + 2) * 3", {}, 9),
    ("-x + 1", {"x": 3}, -2),
    ("7 % 3", {}, 1),
    ("7 / 2", {}, 3.5),
    ("x > 3 and not flag", {"x": 4, "flag": False}, True),
    ("x > 3 or flag", {"x": 1, "flag": False}, False),
    ("name == 'go'", {"name": "go"}, True),
    ("name + \"!\"", {"name": "go"}, "go!"),
    ("abs(-2) + min(x, 1) + max(1, 2, 3)", {"x": 5}, 6),
    ("not not true", {}, True),
    ("1e3 + .5", {}, 1000.5),
])
def test_evaluates(text: str, values: dict[str, object], expected: object) -> None:
    assert ev(text, **values) == expected


@pytest.mark.parametrize("text, column, words", [
    ("", 1, "empty"),
    ("x +", 4, "expected a value"),
    ("(x + 1", 7, "')'"),
    ("x & y", 3, "write 'and'"),
    ("1 < x < 3", 7, "do not chain"),
    ("zz + 1", 1, "unknown variable 'zz'"),
    ("x + flag", 5, "needs a number"),
    ("flag < true", 6, "only equal or not"),
    ("x == 'a'", 3, "cannot compare"),
    ("x / 0", 3, "division by zero"),
    ("x % (2 - 2)", 3, "division by zero"),
    ("pow(2, 3)", 1, "unknown function"),
    ("abs(1, 2)", 1, "takes 1 argument"),
    ("'open", 1, "unterminated string"),
    ("x.y", 2, "unexpected"),
    ("12abc", 1, "malformed number"),
    ("not x", 1, "'not' needs true/false"),
])
def test_errors_are_located(text: str, column: int, words: str) -> None:
    with pytest.raises(ExprError) as info:
        compile_expr(text, KINDS)
    assert info.value.column == column and words in info.value.message, str(info.value)
    assert f"column {column} of the expression" in str(info.value)


def test_wanted_kind() -> None:
    with pytest.raises(ExprError, match="gives a number, true/false is needed"):
        compile_expr("x + 1", KINDS, BOOL)
    assert compile_expr("free", KINDS, BOOL).fn({"free": True}) is True
    with pytest.raises(ExprRuntimeError, match="not true/false"):
        compile_expr("free", KINDS, BOOL).fn({"free": 3})


def test_runtime_errors() -> None:
    fn = compile_expr("x / y", KINDS).fn
    with pytest.raises(ExprRuntimeError, match="division by zero"):
        fn({"x": 1, "y": 0})
    with pytest.raises(ExprRuntimeError, match="no value yet"):
        fn({"x": 1})
    with pytest.raises(ExprRuntimeError, match="holds True"):
        fn({"x": True, "y": 1})


def test_constants_fold() -> None:
    c = compile_expr("2 * (3 + 4) > 10", KINDS)
    assert c.constant and c.value is True and c.kind == BOOL


def test_assignments() -> None:
    assert parse_assignments("a = a + 1; b = 'x;y'; c = true;") == [("a", "a + 1", 5), ("b", "'x;y'", 16),
                                                                      ("c", "true", 27)]
    for bad, column in (("a", 2), ("a = ", 5), ("= 1", 1), ("a = 1 b = 2", 7), ("true = 1", 1), (";", 1)):
        with pytest.raises(ExprError) as info:
            parse_assignments(bad)
        assert info.value.column == column, (bad, str(info.value))


def test_deep_nesting_is_an_error_not_a_crash() -> None:
    with pytest.raises(ExprError, match="nested"):
        parse("(" * 500 + "1" + ")" * 500)
    with pytest.raises(ExprError, match="nested|longer"):
        parse("-" * 3000 + "1")
    with pytest.raises(ExprError):
        parse("not " * 300 + "true")


# -- hypothesis: random well-kinded expressions ---------------------------------------------------------
NUM_VARS = {"x": 3, "y": -2.5, "z": 7}
BOOL_VARS = {"p": True, "q": False}


def numbers() -> st.SearchStrategy[Node]:
    leaf = st.one_of(
        st.integers(0, 1000).map(lambda n: Node("const", (n,), 1)),
        st.sampled_from([0.5, 2.25, 10.0]).map(lambda f: Node("const", (f,), 1)),
        st.sampled_from(sorted(NUM_VARS)).map(lambda n: Node("var", (n,), 1)),
    )
    return st.recursive(leaf, lambda inner: st.one_of(
        st.tuples(st.sampled_from(["+", "-", "*"]), inner, inner).map(lambda t: Node(t[0], (t[1], t[2]), 1)),
        inner.map(lambda a: Node("neg", (a,), 1)),
        st.tuples(st.sampled_from(["abs", "min", "max"]), inner, inner).map(
            lambda t: Node("call", (t[0], t[1]) if t[0] == "abs" else (t[0], t[1], t[2]), 1)),
    ), max_leaves=12)


def booleans() -> st.SearchStrategy[Node]:
    leaf = st.one_of(
        st.booleans().map(lambda b: Node("const", (b,), 1)),
        st.sampled_from(sorted(BOOL_VARS)).map(lambda n: Node("var", (n,), 1)),
        st.tuples(st.sampled_from(["<", "<=", ">", ">=", "==", "!="]), numbers(), numbers()).map(
            lambda t: Node(t[0], (t[1], t[2]), 1)),
    )
    return st.recursive(leaf, lambda inner: st.one_of(
        st.tuples(st.sampled_from(["and", "or"]), inner, inner).map(lambda t: Node(t[0], (t[1], t[2]), 1)),
        inner.map(lambda a: Node("not", (a,), 1)),
    ), max_leaves=10)


_PY = {"+": operator.add, "-": operator.sub, "*": operator.mul, "<": operator.lt, "<=": operator.le,
       ">": operator.gt, ">=": operator.ge, "==": operator.eq, "!=": operator.ne}


def python_value(node: Node, env: dict[str, object]) -> object:
    """The reference semantics, by Python's own operators."""
    op = node.op
    if op == "const":
        return node.args[0]
    if op == "var":
        return env[node.args[0]]
    if op == "neg":
        return -python_value(node.args[0], env)  # type: ignore[operator]
    if op == "not":
        return not python_value(node.args[0], env)
    if op == "call":
        args = [python_value(a, env) for a in node.args[1:]]
        return {"abs": abs, "min": min, "max": max}[node.args[0]](*args)  # type: ignore[operator]
    if op == "and":
        return python_value(node.args[0], env) and python_value(node.args[1], env)
    if op == "or":
        return python_value(node.args[0], env) or python_value(node.args[1], env)
    return _PY[op](python_value(node.args[0], env), python_value(node.args[1], env))


def strip_columns(node: Node) -> Node:
    args = tuple(strip_columns(a) if isinstance(a, Node) else a for a in node.args)
    return Node(node.op, args, 1)


ENV = {**NUM_VARS, **BOOL_VARS}
ENV_KINDS = {**{k: NUMBER for k in NUM_VARS}, **{k: BOOL for k in BOOL_VARS}}


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.one_of(numbers(), booleans()))
def test_print_parse_round_trip_and_python_semantics(node: Node) -> None:
    text = unparse(node)
    assert strip_columns(parse(text)) == strip_columns(node), text
    expected = python_value(node, ENV)
    got = compile_expr(text, ENV_KINDS).fn(dict(ENV))
    if isinstance(expected, float):
        assert isinstance(got, (int, float)) and (math.isclose(got, expected, rel_tol=1e-9, abs_tol=1e-9)
                                                  or got == expected)
    else:
        assert got == expected and type(got) is type(expected), text


@settings(max_examples=400, deadline=None)
@given(st.text(alphabet=st.sampled_from(list("xyzpq01234.+-*/%<>=!()',;\" andornt_eE\n[]&|")), max_size=40))
def test_garbage_gives_only_located_errors(text: str) -> None:
    for run in (lambda: compile_expr(text, ENV_KINDS), lambda: parse_assignments(text)):
        try:
            run()
        except ExprError as exc:
            assert 1 <= exc.column <= len(text) + 1


def test_fused_number_comparisons_and_arithmetic_behave_like_the_generic_path() -> None:
    """``n < 3`` and ``n + 1`` run as one closure; results and errors stay those of the generic closures."""
    from fsm.model.expr import ExprRuntimeError, compile_expr

    kinds = {"n": "number"}
    for text, n, want in [("n < 3", 2, True), ("3 < n", 2, False), ("n + 1", 2, 3), ("1 - n", 2, -1),
                          ("n * 2.5", 2, 5.0), ("n == 2", 2, True), ("2 != n", 2, False), ("n >= 0", -1, False)]:
        assert compile_expr(text, kinds).fn({"n": n}) == want, text
    with pytest.raises(ExprRuntimeError, match="no value yet"):
        compile_expr("n < 3", kinds).fn({})
    with pytest.raises(ExprRuntimeError, match="holds True"):
        compile_expr("n + 1", kinds).fn({"n": True})


def test_the_one_closure_guard_and_counter_keep_the_run_time_errors() -> None:
    """The fused ``var OP constant`` guard and ``x = var OP constant`` set (one closure each) still name a missing
    value or a value of the wrong kind, as the generic path does."""
    from fsm.model.errors import StateRuntimeError

    doc = {"initial": "a", "vars": {"n": 0, "m": 0},
           "states": [{"id": "a", "type": "Idle"}, {"id": "b", "type": "Idle"}],
           "transitions": [{"type": "Always", "from": "a", "to": "b", "guard": "n >= 0", "set": {"m": "n + 1"}}]}
    m = fsm.load(doc)
    fsm.run(m, max_ticks=2)
    assert m.ctx.vars["m"] == 1 and m.active_path == "b"
    for bad, message in (({"n": "x"}, "holds 'x'"), ({}, "has no value yet")):
        m = fsm.load(doc)
        m.ctx.vars.pop("n")
        m.ctx.vars.update(bad)
        with pytest.raises(StateRuntimeError, match=message):
            fsm.run(m, max_ticks=2)
