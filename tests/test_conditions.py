"""Conditions: signal levels and edges with debounce, Expr, TimeSince (pause excluded), InState, All/Any/Not,
the Condition transition, and writing a condition type of one's own."""

from __future__ import annotations

from typing import Any

import pytest
from pydantic import Field

import fsm
from fsm.loading.registry import Registry, default_registry, register_condition, using
from fsm.model.params import ConditionParams
from fsm.runtime.condition import Condition
from fsm.runtime.region import wiring

REG = default_registry()
DT = 0.0125


def counter(condition: dict[str, Any]) -> fsm.Machine:
    """wait --Condition--> count (n = n + 1) --Always--> wait: counts how often the condition fires."""
    return fsm.load({"initial": "wait", "vars": {"n": 0},
                     "states": [{"id": "wait", "type": "Idle"},
                                {"id": "count", "type": "Idle", "set": {"on_enter": {"n": "n + 1"}}}],
                     "transitions": [{"type": "Condition", "from": "wait", "to": "count", "condition": condition},
                                     {"type": "Always", "from": "count", "to": "wait"}]}, registry=REG)


def press(m: fsm.Machine, at: float, hold: float = 0.1, bounces: int = 3) -> None:
    """A press at ``at`` that bounces ``bounces`` times on closing and on opening (one tick per level)."""
    t = at
    for _ in range(bounces):
        m.schedule_signal("button", t, True)
        m.schedule_signal("button", t + DT, False)
        t += 2 * DT
    m.schedule_signal("button", t, True)
    t += hold
    for _ in range(bounces):
        m.schedule_signal("button", t, False)
        m.schedule_signal("button", t + DT, True)
        t += 2 * DT
    m.schedule_signal("button", t, False)


@pytest.mark.parametrize("debounce, expected", [(0.0, 21), (0.03, 3)])
def test_bouncing_presses_in_rapid_succession(debounce: float, expected: int) -> None:
    """Three presses 0.25 s apart, each bouncing 3 times on both edges: without debounce every bounce counts
    (7 rising edges a press: 4 while closing, 3 while opening), with 30 ms of debounce each press counts once."""
    m = counter({"type": "SignalEdge", "signal": "button", "debounce": debounce})
    for at in (0.1, 0.35, 0.6):
        press(m, at, hold=0.06)
    fsm.run(m, duration=1.5)
    assert m.ctx.vars["n"] == expected


def test_debounced_falling_edge_and_levels() -> None:
    m = counter({"type": "SignalEdge", "signal": "button", "edge": "falling", "debounce": 0.03})
    for at in (0.1, 0.35, 0.6):
        press(m, at, hold=0.06)
    fsm.run(m, duration=1.5)
    assert m.ctx.vars["n"] == 3
    high = fsm.load({"initial": "a", "states": [{"id": "a", "type": "Idle"}, {"id": "b", "type": "Final"}],
                     "transitions": [{"type": "Condition", "from": "a", "to": "b", "condition":
                                      {"type": "SignalHigh", "signal": "button", "debounce": 0.05}}]}, registry=REG)
    press(high, 0.1, hold=0.2)
    fsm.run(high, duration=2)
    # the last bounce closes at 0.1 + 6 dt = 0.175; stable for 0.05 s from then: fires at 0.225
    assert high.finished and high.now == pytest.approx(0.225)


def test_a_short_glitch_never_counts() -> None:
    m = counter({"type": "SignalHigh", "signal": "button", "debounce": 0.05})
    m.schedule_signal("button", 0.1, True)
    m.schedule_signal("button", 0.1375, False)  # 37.5 ms high: a glitch
    fsm.run(m, duration=1)
    assert m.ctx.vars["n"] == 0
    low = counter({"type": "SignalLow", "signal": "button", "debounce": 0.05})
    fsm.run(low, max_ticks=1)
    assert low.ctx.vars["n"] == 1  # low from the start (never set counts as low)


def test_all_any_not() -> None:
    def outcome(cond: dict[str, Any], **vars: Any) -> bool:
        m = fsm.load({"initial": "a", "vars": {"x": 0, "y": 0, **vars},
                      "states": [{"id": "a", "type": "Idle"}, {"id": "b", "type": "Final"}],
                      "transitions": [{"type": "Condition", "from": "a", "to": "b", "condition": cond}]},
                     registry=REG)
        fsm.run(m, max_ticks=2)
        return m.finished

    x = {"type": "Expr", "expr": "x > 0"}
    y = {"type": "Expr", "expr": "y > 0"}
    for xv in (0, 1):
        for yv in (0, 1):
            assert outcome({"type": "All", "conditions": [x, y]}, x=xv, y=yv) == bool(xv and yv)
            assert outcome({"type": "Any", "conditions": [x, y]}, x=xv, y=yv) == bool(xv or yv)
            assert outcome({"type": "Not", "condition": {"type": "Any", "conditions": [x, y]}},
                           x=xv, y=yv) == (not (xv or yv))


def test_time_since_excludes_pause() -> None:
    m = fsm.load({"initial": "a", "states": [{"id": "a", "type": "Idle"}, {"id": "b", "type": "Final"}],
                  "transitions": [{"type": "Condition", "from": "a", "to": "b",
                                   "condition": {"type": "TimeSince", "seconds": 1.0}}]}, registry=REG)
    fsm.run(m, duration=0.5)
    m.pause("a")
    fsm.run(m, duration=2.0)
    assert not m.finished
    m.resume("a")
    fsm.run(m, duration=2.0)
    assert m.finished and m.now == pytest.approx(3.0)


def test_time_since_a_signal() -> None:
    m = fsm.load({"initial": "a", "states": [{"id": "a", "type": "Idle"}, {"id": "b", "type": "Final"}],
                  "transitions": [{"type": "Condition", "from": "a", "to": "b",
                                   "condition": {"type": "TimeSince", "seconds": 0.5, "signal": "go"}}]},
                 registry=REG)
    m.schedule_signal("go", 1.0)
    m.schedule_signal("go", 1.1, False)
    fsm.run(m, duration=3)
    assert m.finished and m.now == pytest.approx(1.5)


def test_in_state_syncs_parallel_regions() -> None:
    region = {"initial": "w", "states": [{"id": "w", "type": "Idle"}, {"id": "f", "type": "Final"}],
              "transitions": [{"type": "Timeout", "from": "w", "to": "f", "seconds": 0.25}]}
    other = {"name": "other", "initial": "w", "states": [{"id": "w", "type": "Idle"}, {"id": "f", "type": "Final"}],
             "transitions": [{"type": "Condition", "from": "w", "to": "f",
                              "condition": {"type": "InState", "state": "/p/one/f"}}]}
    m = fsm.load({"initial": "p", "states": [
        {"id": "p", "type": "Parallel", "regions": [{"name": "one", **region}, other]},
        {"id": "end", "type": "Final"}], "transitions": [{"type": "Finished", "from": "p", "to": "end"}]},
        registry=REG)
    fsm.run(m, duration=2)
    # region "other" is ticked after "one" in the same tick: it sees one/f at once, and the join follows
    assert m.finished and m.now == pytest.approx(0.25)


def test_each_transition_has_its_own_condition_state() -> None:
    m = counter({"type": "SignalEdge", "signal": "button", "debounce": 0.03})
    t1 = wiring(m.root.states["wait"]).transitions[0]
    other = counter({"type": "SignalEdge", "signal": "button", "debounce": 0.03})
    assert t1.conditions["condition"] is not wiring(other.root.states["wait"]).transitions[0].conditions["condition"]


def test_a_condition_type_of_ones_own() -> None:
    registry = Registry()
    with using(registry):
        @register_condition
        class Above(Condition):
            """Holds while variable `var` is above `limit`."""

            class Params(ConditionParams):
                var: str = Field(min_length=1)
                limit: float

            def holds(self, ctx: Any) -> bool:
                return ctx.vars.get(self.params.var, 0) > self.params.limit
    registry.states.update(REG.states)
    registry.transitions.update(REG.transitions)
    m = fsm.load({"initial": "a", "vars": {"t": 5}, "states": [{"id": "a", "type": "Idle"},
                                                                {"id": "b", "type": "Final"}],
                  "transitions": [{"type": "Always", "from": "a", "to": "b",
                                   "guard": {"type": "Above", "var": "t", "limit": 3}}]}, registry=registry)
    fsm.run(m, max_ticks=2)
    assert m.finished
    registry.add_condition(Above)  # the same class again: one registration
    assert registry.conditions["Above"] is Above

    class Other(Condition):
        """Another condition."""

        class Params(ConditionParams):
            pass

    with pytest.raises(fsm.RegistrationError, match="already registered by .*Above.* is another class"):
        registry.add_condition(Other, "Above")
