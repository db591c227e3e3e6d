"""The Python API checks its arguments when called, as fsmctl does: a wrong type is a TypeError, a value out
of range a ValueError, each naming the argument; the machine is unchanged by a refused call. States cannot
move the machine's clock (ctx.now, ctx.dt, ctx.tick are read-only)."""

from __future__ import annotations

import math
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import fsm
from fsm import Listener, State
from fsm.loading.registry import Registry
from fsm.runtime.clock import RealTimeClock, SimulatedClock
from fsm.runtime.machine import DEFAULT_RUN_DURATION

DOC = {
    "initial": "a",
    "states": [{"id": "a", "type": "Idle"}, {"id": "b", "type": "Final"}],
    "transitions": [{"type": "Signal", "from": "a", "to": "b", "signal": "go"}],
}


def machine() -> fsm.Machine:
    return fsm.load(DOC)


# -- run ----------------------------------------------------------------------------------------------
@pytest.mark.parametrize(("kwargs", "error", "words"), [
    ({"duration": math.nan}, ValueError, "duration"),
    ({"duration": math.inf}, ValueError, "duration"),
    ({"duration": -1.0}, ValueError, "duration"),
    ({"duration": "3"}, TypeError, "duration"),
    ({"duration": True}, TypeError, "duration"),
    ({"max_ticks": True}, TypeError, "max_ticks"),
    ({"max_ticks": 10.0}, TypeError, "max_ticks"),
    ({"max_ticks": "10"}, TypeError, "max_ticks"),
    ({"max_ticks": -1}, ValueError, "max_ticks"),
    ({"until": 3}, TypeError, "until"),
])
def test_run_refuses_bad_arguments_before_running(kwargs: dict[str, Any], error: type, words: str) -> None:
    m = machine()
    with pytest.raises(error, match=words):
        fsm.run(m, **kwargs)
    assert not m.started and m.ticks == 0


def test_run_accepts_good_limits() -> None:
    m = machine()
    assert fsm.run(m, max_ticks=0).outcome is None and m.ticks == 0
    assert fsm.run(m, duration=0.05).outcome is None and m.ticks == 4
    assert fsm.run(m, max_ticks=3, duration=10).outcome is None and m.ticks == 7


def test_run_without_a_limit_stops_at_the_default_duration() -> None:
    """A machine that can never finish returns after 600 s of machine time, like fsmctl run."""
    m = machine()
    assert fsm.run(m).outcome is None
    assert not m.finished
    assert m.now == pytest.approx(DEFAULT_RUN_DURATION)
    m2 = machine()
    m2.schedule_signal("go", 1.0)
    assert fsm.run(m2).outcome == "succeeded" and m2.now == pytest.approx(1.0)


def test_until_alone_still_has_the_default_limit() -> None:
    m = machine()
    assert fsm.run(m, until=lambda _m: False).outcome is None
    assert m.now == pytest.approx(DEFAULT_RUN_DURATION)


# -- signals ------------------------------------------------------------------------------------------
@pytest.mark.parametrize(("args", "error"), [
    ((None, 1.0), TypeError),
    ((3, 1.0), TypeError),
    (("", 1.0), ValueError),
    (("go", -0.5), ValueError),
    (("go", math.nan), ValueError),
    (("go", math.inf), ValueError),
    (("go", "1"), TypeError),
    (("go", None), TypeError),
    (("go", 1.0, 2), ValueError),
    (("go", 1.0, -1), ValueError),
    (("go", 1.0, "1"), TypeError),
    (("go", 1.0, 0.5), TypeError),
    (("go", 1.0, None), TypeError),
])
def test_schedule_signal_refuses_bad_arguments(args: tuple[Any, ...], error: type) -> None:
    m = machine()
    with pytest.raises(error):
        m.schedule_signal(*args)
    assert m._schedule == []


@pytest.mark.parametrize("value", [True, False, 0, 1])
def test_schedule_signal_accepts_bools_and_0_1(value: Any) -> None:
    m = machine()
    m.schedule_signal("go", 0, value)
    fsm.run(m, max_ticks=2)
    assert m.finished is bool(value)


def test_set_signal_checks_like_schedule_signal() -> None:
    ctx = machine().ctx
    with pytest.raises(TypeError):
        ctx.set_signal(None)  # type: ignore[arg-type]
    with pytest.raises(ValueError):
        ctx.set_signal("go", 2)
    ctx.set_signal("go", 1)
    assert ctx.signal("go") is True


# -- pause / resume / state lookup --------------------------------------------------------------------
def test_pause_none_pauses_the_whole_machine_and_resume_none_resumes_it() -> None:
    m = machine()
    m.pause(None)
    assert m.state("a").paused
    m.resume(None)
    assert not m.state("a").paused


@pytest.mark.parametrize("path", [3, 1.5, b"a", ["a"], True])
def test_pause_and_resume_refuse_non_string_paths(path: Any) -> None:
    m = machine()
    with pytest.raises(TypeError, match="path"):
        m.pause(path)
    with pytest.raises(TypeError, match="path"):
        m.resume(path)
    with pytest.raises(TypeError, match="path"):
        m.state(path)


def test_pause_of_an_unknown_path_is_a_key_error_with_a_suggestion() -> None:
    m = machine()
    with pytest.raises(KeyError, match="did you mean a"):
        m.pause("aa")


# -- listeners ----------------------------------------------------------------------------------------
class OnlyTick:
    def on_tick(self, machine: Any) -> None:
        pass


@pytest.mark.parametrize("listener", [None, 3, "x", print, OnlyTick()])
def test_add_listener_refuses_what_is_not_a_listener(listener: Any) -> None:
    m = machine()
    with pytest.raises(TypeError, match="listener"):
        m.add_listener(listener)
    assert m.listeners == []
    fsm.run(m, max_ticks=2)  # and the machine still runs


def test_listeners_that_have_both_methods_are_accepted_and_removable() -> None:
    m = machine()
    seen: list[int] = []

    class Ticks(Listener):
        def on_tick(self, machine: fsm.Machine) -> None:
            seen.append(machine.ticks)

    listener = m.add_listener(Ticks())
    fsm.run(m, max_ticks=2)
    m.remove_listener(listener)
    fsm.run(m, max_ticks=2)
    assert seen == [1, 2]
    with pytest.raises(ValueError, match="not a listener"):
        m.remove_listener(listener)


# -- clocks ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize(("dt", "error"), [(0, ValueError), (-1, ValueError), (math.nan, ValueError),
                                           (math.inf, ValueError), ("0.01", TypeError), (None, TypeError),
                                           (True, TypeError)])
def test_clocks_refuse_bad_periods(dt: Any, error: type) -> None:
    for clock in (SimulatedClock, RealTimeClock):
        with pytest.raises(error, match="dt"):
            clock(dt)
    if dt is not None:  # load(dt=None) means the default period
        with pytest.raises(error, match="dt"):
            fsm.load(DOC, dt=dt)


# -- the clock is read-only to states -------------------------------------------------------------------
class ClockMover(State):
    """Test type: tries to move the machine's clock."""

    def tick(self, ctx: Any) -> None:
        ctx.now = 100.0


class TickMover(State):
    """Test type: tries to change the tick number."""

    def tick(self, ctx: Any) -> None:
        ctx.tick = 0


@pytest.mark.parametrize("kind", ["ClockMover", "TickMover"])
def test_states_cannot_move_the_clock(kind: str) -> None:
    registry = Registry()  # not the process registry: these types must not reach the schema or palette
    registry.add_state(ClockMover)
    registry.add_state(TickMover)
    m = fsm.load({"initial": "a", "states": [{"id": "a", "type": kind}]}, registry=registry)
    with pytest.raises(fsm.model.errors.StateRuntimeError, match="read-only"):
        m.tick()
    assert m.now == pytest.approx(0.0125) and m.ticks == 1


@pytest.mark.parametrize("name", ["now", "dt", "tick"])
def test_context_time_is_read_only(name: str) -> None:
    m = machine()
    fsm.run(m, max_ticks=3)
    with pytest.raises(AttributeError, match="read-only"):
        setattr(m.ctx, name, 1)
    assert (m.ctx.now, m.ctx.tick, m.ctx.dt) == (pytest.approx(0.0375), 3, pytest.approx(0.0125))


# -- hypothesis: random arguments raise only TypeError/ValueError (or run) --------------------------------
_anything = st.one_of(
    st.none(), st.booleans(), st.integers(-10**20, 10**20), st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=5), st.binary(max_size=3), st.lists(st.integers(), max_size=2),
    st.dictionaries(st.text(max_size=2), st.integers(), max_size=2), st.just(object()), st.just(print),
)


@settings(max_examples=200, deadline=None)
@given(until=st.one_of(st.none(), _anything), max_ticks=st.one_of(st.none(), _anything, st.integers(-3, 50)),
       duration=st.one_of(st.none(), _anything, st.floats(-1, 2)))
def test_random_run_arguments(until: Any, max_ticks: Any, duration: Any) -> None:
    if callable(until):
        until = None  # print() would write to the test output
    if isinstance(max_ticks, int) and max_ticks > 1000:
        max_ticks = 1000
    if isinstance(duration, (int, float)) and not isinstance(duration, bool) and duration > 10:
        duration = 10.0
    m = machine()
    try:
        fsm.run(m, until=until, max_ticks=max_ticks, duration=duration)
    except (TypeError, ValueError) as exc:
        assert str(exc)
    else:
        assert m.ticks <= 1000 or m.now == pytest.approx(DEFAULT_RUN_DURATION)


@settings(max_examples=200, deadline=None)
@given(name=st.one_of(_anything, st.sampled_from(["go", "x"])), at=st.one_of(_anything, st.floats(0, 5)),
       value=st.one_of(_anything, st.sampled_from([0, 1, True, False])), path=_anything)
def test_random_signal_and_pause_arguments(name: Any, at: Any, value: Any, path: Any) -> None:
    m = machine()
    try:
        m.schedule_signal(name, at, value)
    except (TypeError, ValueError) as exc:
        assert str(exc)
        assert m._schedule == []
    for call in (m.pause, m.resume):
        try:
            call(path)
        except (TypeError, ValueError, KeyError):
            pass
    fsm.run(m, max_ticks=3)
