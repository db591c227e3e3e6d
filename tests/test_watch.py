"""Watch expressions compiled into one generated function per set (fsm/debug/watch.py): the same values as the
compiled expressions one by one, tick by tick, and the same error texts where they fail."""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import pytest

from fsm.debug.breakpoints import BreakpointError
from fsm.debug.watch import Slow, compile_watch, row_function

EXPRS = ["car_front", "car_front < 0.9", "car_left + car_right", "car_distance * 2", "n", "n / 4", "n % 3",
         "-n + 1", "abs(car_left - 2)", "min(n, car_front)", "max(n, 1, car_right)", "name + '!'",
         "flag and n > 2", "not flag or signal_go", "signal_go", "n == 3", "name != 'a'", "1 + 2", "n >= 2.5"]


def _machine(**vars: Any) -> Any:
    car = SimpleNamespace(left=1.0, right=2.0, front=3.0, distance=0.5, speed=0.2, steering=0.0, speed_command=0.3)
    ctx = SimpleNamespace(vars=dict(vars), signals={"go": False}, car=car)
    return SimpleNamespace(ctx=ctx)


def _both(texts: list[str], machine: Any) -> tuple[Any, Any]:
    watches = [compile_watch(t, machine) for t in texts]
    return row_function(watches), Slow(watches).row


def test_the_generated_row_equals_the_expressions_one_by_one_over_many_ticks() -> None:
    machine = _machine(n=1, name="x", flag=True)
    fast, slow = _both(EXPRS, machine)
    ctx = machine.ctx
    for tick in range(200):
        ctx.car.front = 3.0 - tick * 0.02
        ctx.car.left = 1.0 + (tick % 7) * 0.3
        ctx.vars["n"] = tick % 11 if tick % 5 else tick * 0.5
        ctx.vars["flag"] = tick % 3 == 0
        ctx.vars["name"] = "ab"[tick % 2]
        ctx.signals["go"] = tick % 4 == 1
        got, want = fast(ctx), slow(ctx)
        assert got == want, tick
        assert [type(v) for v in got] == [type(v) for v in want]


def test_a_tick_where_nothing_read_moved_keeps_the_row_object() -> None:
    machine = _machine(n=1)
    fast, _ = _both(["car_front", "n * 2"], machine)
    first = fast(machine.ctx)
    assert fast(machine.ctx) is first
    machine.ctx.car.front = 1.5
    second = fast(machine.ctx)
    assert second == (1.5, 2) and second is not first


def test_what_fails_gives_the_error_text_of_the_language() -> None:
    machine = _machine(n=1, name="x")
    fast, slow = _both(["car_front", "10 / n", "n"], machine)
    machine.ctx.vars["n"] = 0
    assert fast(machine.ctx) == slow(machine.ctx) == (3.0, "error: division by zero", 0)
    machine.ctx.vars["n"] = "text"  # a reload gave the variable another kind
    row = fast(machine.ctx)
    assert row[0] == 3.0 and row[1].startswith("error: variable 'n' holds 'text'") and row == slow(machine.ctx)
    del machine.ctx.vars["n"]
    assert fast(machine.ctx)[2].startswith("error: variable 'n' has no value")
    machine.ctx.vars["n"] = 2
    assert fast(machine.ctx) == (3.0, 5.0, 2)  # and back on the generated path
    machine.ctx.car = None  # a run without a car
    assert fast(machine.ctx)[0].startswith("error:")


def test_a_watched_list_is_never_kept_from_an_earlier_tick() -> None:
    machine = _machine(gates=[])
    fast, _ = _both(["gates"], machine)
    first = fast(machine.ctx)
    machine.ctx.vars["gates"].append(1)
    assert fast(machine.ctx) is not first


def test_a_bad_watch_is_refused_with_its_column() -> None:
    machine = _machine(n=1)
    with pytest.raises(BreakpointError) as err:
        compile_watch("n +", machine)
    assert err.value.column == 4
    with pytest.raises(BreakpointError):
        compile_watch("nope * 2", machine)
    with pytest.raises(BreakpointError):
        compile_watch("  ", machine)
