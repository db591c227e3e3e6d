"""Tick semantics of the runtime: order of phases, firing, nesting, parallel regions, finishing, pause, time."""

from __future__ import annotations

import json

import pytest

import fsm
from fsm import Registry, State, StateRuntimeError, Transition
from fsm.loading.registry import default_registry
from fsm.model.params import StateParams, TransitionParams

LOG: list[str] = []


class Probe(State):
    """Logs its hooks; finishes after `ticks` ticks when ticks > 0; raises in `fail_in`."""

    can_finish = True
    outcomes = None

    class Params(StateParams):
        ticks: int = 0
        outcome: str = "succeeded"
        fail_in: str | None = None

    def on_enter(self, ctx):
        LOG.append(f"enter {self.path}")
        self.count = 0
        if self.params.fail_in == "on_enter":
            raise RuntimeError("boom")

    def tick(self, ctx):
        LOG.append(f"tick {self.path}")
        if self.params.fail_in == "tick":
            raise ValueError("bad tick")
        self.count += 1
        if self.params.ticks and self.count >= self.params.ticks:
            self.finish(self.params.outcome)

    def on_exit(self, ctx):
        LOG.append(f"exit {self.path}")


class Flag(Transition):
    """Fires while blackboard variable `flag` is truthy; logs each check and its action."""

    class Params(TransitionParams):
        flag: str

    def holds(self, ctx):
        LOG.append(f"check {self.source.path}->{self.target.path}")
        return bool(ctx.vars.get(self.params.flag))

    def action(self, ctx):
        LOG.append(f"action {self.source.path}->{self.target.path}")


@pytest.fixture()
def registry() -> Registry:
    reg = Registry()
    for kind, name, cls in default_registry():
        (reg.states if kind == "state" else reg.transitions)[name] = cls
    reg.add_state(Probe)
    reg.add_transition(Flag)
    LOG.clear()
    return reg


def doc(initial, states, transitions=(), **extra):
    return {"initial": initial, "states": list(states), "transitions": list(transitions), **extra}


def probe(id, **kw):
    return {"id": id, "type": "Probe", **kw}


def tr(type_, a, b, **kw):
    return {"type": type_, "from": a, "to": b, **kw}


# -- order of phases ------------------------------------------------------------------------------------
def test_start_enters_outermost_first_and_first_tick_ticks_then_checks(registry):
    inner = doc("x", [probe("x")])
    m = fsm.load(doc("a", [{"id": "a", "type": "FSMState", "machine": inner}, probe("b")],
                     [tr("Flag", "a", "b", flag="go")]), registry=registry)
    m.start()
    assert LOG == ["enter a/x"]  # FSMState itself has no hook; its initial sub-state is entered
    LOG.clear()
    m.tick()
    assert LOG == ["tick a/x", "check a->b"]


def test_preemptive_transition_fires_before_tick_and_regular_after(registry):
    m = fsm.load(doc("a", [probe("a"), probe("b"), probe("c")],
                     [tr("Flag", "a", "b", flag="reg"), tr("Flag", "a", "c", flag="pre", preempt=True)]),
                 registry=registry)
    m.start()
    LOG.clear()
    m.tick()
    assert LOG == ["check a->c", "tick a", "check a->b"]
    m.ctx.vars["pre"] = True
    LOG.clear()
    m.tick()
    assert LOG == ["check a->c", "exit a", "action a->c", "enter c"]  # a is not ticked
    assert m.active_path == "c"


def test_outer_preemption_checked_before_inner_and_exits_innermost_first(registry):
    inner = doc("x", [probe("x"), probe("y")], [tr("Flag", "x", "y", flag="inner", preempt=True)])
    m = fsm.load(doc("a", [{"id": "a", "type": "FSMState", "machine": inner}, probe("b")],
                     [tr("Flag", "a", "b", flag="outer", preempt=True)]), registry=registry)
    m.start()
    m.ctx.vars.update(inner=True, outer=True)
    LOG.clear()
    m.tick()
    assert LOG == ["check a->b", "exit a/x", "action a->b", "enter b"]


def test_regular_transitions_inner_level_first_and_one_per_level_per_tick(registry):
    inner = doc("x", [probe("x"), probe("y")], [tr("Always", "x", "y")])
    m = fsm.load(doc("a", [{"id": "a", "type": "FSMState", "machine": inner}, probe("b")],
                     [tr("Flag", "a", "b", flag="go")]), registry=registry)
    m.ctx.vars["go"] = True
    m.start()
    LOG.clear()
    m.tick()
    # inner level fires x->y, then the outer level fires a->b: one transition per level
    assert LOG == ["tick a/x", "exit a/x", "enter a/y", "check a->b", "exit a/y", "action a->b", "enter b"]
    assert m.transition_count == 2


def test_chain_of_always_moves_one_state_per_tick(registry):
    m = fsm.load(doc("a", [probe("a"), probe("b"), probe("c")], [tr("Always", "a", "b"), tr("Always", "b", "c")]),
                 registry=registry)
    m.tick()
    assert m.active_path == "b"
    m.tick()
    assert m.active_path == "c"


def test_priority_then_declaration_order(registry):
    states = [probe("a"), probe("b"), probe("c"), probe("d")]
    m = fsm.load(doc("a", states, [tr("Flag", "a", "b", flag="f"), tr("Flag", "a", "c", flag="f"),
                                   tr("Flag", "a", "d", flag="f", priority=5)]), registry=registry)
    m.ctx.vars["f"] = True
    m.tick()
    assert m.active_path == "d"
    m2 = fsm.load(doc("a", states, [tr("Flag", "a", "b", flag="f"), tr("Flag", "a", "c", flag="f")]),
                  registry=registry)
    m2.ctx.vars["f"] = True
    m2.tick()
    assert m2.active_path == "b"


def test_self_transition_exits_and_reenters(registry):
    m = fsm.load(doc("a", [probe("a")], [tr("Flag", "a", "a", flag="f")]), registry=registry)
    m.start()
    m.ctx.vars["f"] = True
    LOG.clear()
    m.tick()
    assert LOG == ["tick a", "check a->a", "exit a", "action a->a", "enter a"]


def test_self_transition_on_composite_restarts_its_submachine(registry):
    inner = doc("x", [probe("x"), probe("y")], [tr("Always", "x", "y")])
    m = fsm.load(doc("a", [{"id": "a", "type": "FSMState", "machine": inner}],
                     [tr("Timeout", "a", "a", seconds=0.05)]), registry=registry)
    m.tick()
    assert m.active_path == "a/y"
    fsm.run(m, max_ticks=3)  # 4 ticks = 0.05 s: the restart happens
    assert m.active_path == "a/x"


# -- finishing and outcomes -------------------------------------------------------------------------------
def test_composite_finishes_with_final_outcome_and_routes_by_outcome(registry):
    inner = doc("work", [probe("work", ticks=2, outcome="bad"), {"id": "fail", "type": "Final", "outcome": "aborted"},
                         {"id": "fine", "type": "Final"}],
                [tr("Finished", "work", "fine", outcome="good"), tr("Finished", "work", "fail")])
    m = fsm.load(doc("job", [{"id": "job", "type": "FSMState", "machine": inner}, probe("ok"), probe("recover")],
                     [tr("Finished", "job", "ok", outcome="succeeded"),
                      tr("Finished", "job", "recover", outcome="aborted")]), registry=registry)
    m.tick()
    assert m.active_path == "job/work"
    m.tick()  # work finishes; inner goes to fail (Final aborted); job finishes; outer routes on outcome
    assert m.active_path == "recover"


def test_machine_finishes_with_outcome_at_root_final(registry):
    m = fsm.load(doc("a", [probe("a", ticks=3), {"id": "end", "type": "Final", "outcome": "done"}],
                     [tr("Finished", "a", "end")]), registry=registry)
    assert fsm.run(m, max_ticks=100).outcome == "done"
    assert m.finished and m.outcome == "done" and m.ticks == 3


def test_state_outcome_resets_on_reentry(registry):
    m = fsm.load(doc("a", [probe("a", ticks=1, outcome="x"), probe("b")],
                     [tr("Finished", "a", "b"), tr("Always", "b", "a")]), registry=registry)
    m.tick()
    assert m.active_path == "b"
    m.tick()
    a = m.state("a")
    assert m.active_path == "a" and not a.finished and a.outcome is None


# -- parallel ---------------------------------------------------------------------------------------------
def parallel(join, r1_ticks, r2_ticks, r2_outcome="succeeded"):
    def region(name, ticks, outcome):
        return {"name": name, "initial": "w", "states": [probe("w", ticks=ticks),
                                                         {"id": "end", "type": "Final", "outcome": outcome}],
                "transitions": [tr("Finished", "w", "end")]}

    return doc("p", [{"id": "p", "type": "Parallel", "join": join,
                      "regions": [region("left", r1_ticks, "succeeded"), region("right", r2_ticks, r2_outcome)]},
                     {"id": "done", "type": "Final"}],
               [tr("Finished", "p", "done")])


def test_parallel_ticks_regions_in_order_and_join_all(registry):
    m = fsm.load(parallel("all", 2, 4), registry=registry)
    m.start()
    assert m.active_paths == ["p/left/w", "p/right/w"]
    LOG.clear()
    m.tick()
    assert LOG == ["tick p/left/w", "tick p/right/w"]
    fsm.run(m, max_ticks=2)
    assert m.active_path == "p/left/end, p/right/w"
    fsm.run(m, max_ticks=10)
    assert m.finished and m.ticks == 4


def test_parallel_join_any_and_outcome(registry):
    m = fsm.load(parallel("any", 5, 2, r2_outcome="timeout"), registry=registry)
    fsm.run(m, max_ticks=3)
    assert m.state("p").outcome == "timeout"
    assert m.finished


def test_parallel_join_all_reports_first_non_success(registry):
    m = fsm.load(parallel("all", 1, 2, r2_outcome="aborted"), registry=registry)
    fsm.run(m, max_ticks=5)
    assert m.state("p").outcome == "aborted"


def test_instate_synchronises_regions(registry):
    left = {"name": "left", "initial": "go", "states": [probe("go"), probe("after")],
            "transitions": [tr("InState", "go", "after", state="right/ready")]}
    right = {"name": "right", "initial": "prep", "states": [probe("prep"), probe("ready")],
             "transitions": [tr("Timeout", "prep", "ready", seconds=0.1)]}
    m = fsm.load(doc("p", [{"id": "p", "type": "Parallel", "regions": [left, right]}]), registry=registry)
    fsm.run(m, max_ticks=8)  # 0.1 s = 8 ticks: right reaches ready at tick 8, after left was checked
    assert m.active_paths == ["p/left/go", "p/right/ready"]
    m.tick()
    assert m.active_paths == ["p/left/after", "p/right/ready"]


# -- time, pause, signals, vars ---------------------------------------------------------------------------
def test_timeout_fires_exactly_after_its_seconds(registry):
    m = fsm.load(doc("a", [probe("a"), probe("b")], [tr("Timeout", "a", "b", seconds=1.0)]), registry=registry)
    fsm.run(m, max_ticks=79)
    assert m.active_path == "a"
    m.tick()
    assert m.active_path == "b" and m.now == pytest.approx(1.0)


def test_pause_freezes_subtree_and_time_in_state(registry):
    inner = doc("x", [probe("x"), probe("y")], [tr("Timeout", "x", "y", seconds=0.5)])
    m = fsm.load(doc("a", [{"id": "a", "type": "FSMState", "machine": inner}]), registry=registry)
    fsm.run(m, max_ticks=20)  # 0.25 s in x
    m.pause("a")
    LOG.clear()
    fsm.run(m, max_ticks=100)
    assert LOG == []  # not ticked, no exit/enter
    assert m.state("a/x").time_in_state(m.ctx) == pytest.approx(0.25)
    m.resume("a")
    fsm.run(m, max_ticks=19)
    assert m.active_path == "a/x"
    m.tick()
    assert m.active_path == "a/y"
    assert m.ticks == 140


def test_paused_state_left_by_outer_transition_is_not_paused_on_reentry(registry):
    inner = doc("x", [probe("x")])
    m = fsm.load(doc("a", [{"id": "a", "type": "FSMState", "machine": inner}, probe("b")],
                     [tr("Flag", "a", "b", flag="leave", preempt=True), tr("Flag", "b", "a", flag="back")]),
                 registry=registry)
    m.tick()
    m.pause("a/x")
    m.ctx.vars["leave"] = True
    m.tick()
    assert m.active_path == "b"
    m.ctx.vars.update(leave=False, back=True)
    m.tick()
    LOG.clear()
    m.ctx.vars["back"] = False
    m.tick()
    assert "tick a/x" in LOG


def test_pause_without_path_pauses_the_whole_machine(registry):
    m = fsm.load(doc("a", [probe("a"), probe("b")], [tr("Timeout", "a", "b", seconds=0.1)]), registry=registry)
    fsm.run(m, max_ticks=4)
    m.pause()
    fsm.run(m, max_ticks=50)
    assert m.active_path == "a" and m.state("a").time_in_state(m.ctx) == pytest.approx(0.05)
    m.resume()
    fsm.run(m, max_ticks=4)
    assert m.active_path == "b"


def test_pause_of_inactive_state_is_refused(registry):
    m = fsm.load(doc("a", [probe("a"), probe("b")], [tr("Always", "a", "b")]), registry=registry)
    m.start()
    with pytest.raises(ValueError, match="not active"):
        m.pause("b")


def test_signal_edges_and_levels(registry):
    states = [probe("a"), probe("b"), probe("c")]
    m = fsm.load(doc("a", states, [tr("Signal", "a", "b", signal="btn"), tr("Signal", "b", "c", signal="btn",
                                                                             edge="falling")]),
                 registry=registry)
    m.schedule_signal("btn", 0.1)
    m.schedule_signal("btn", 0.2, False)
    fsm.run(m, max_ticks=7)
    assert m.active_path == "a"
    m.tick()  # tick 8 at t=0.1: rising edge
    assert m.active_path == "b"
    fsm.run(m, max_ticks=8)  # tick 16 at t=0.2: falling edge
    assert m.active_path == "c"


def test_rising_edge_lasts_one_tick(registry):
    m = fsm.load(doc("a", [probe("a"), probe("b"), probe("c")],
                     [tr("Timeout", "a", "b", seconds=0.05), tr("Signal", "b", "c", signal="s")]), registry=registry)
    m.schedule_signal("s", 0.0125)
    fsm.run(m, max_ticks=10)
    assert m.active_path == "b"  # the edge happened while a was active; b never saw it


def test_signal_high_level(registry):
    m = fsm.load(doc("a", [probe("a"), probe("b")], [tr("Signal", "a", "b", signal="s", edge="high")]),
                 registry=registry)
    m.ctx.set_signal("s", True)
    fsm.run(m, max_ticks=5)
    assert m.active_path == "b"


def test_var_transition_and_document_vars(registry):
    m = fsm.load(doc("a", [probe("a"), probe("b")], [tr("Var", "a", "b", var="n", op=">=", value=3)],
                     vars={"n": 0}), registry=registry)
    fsm.run(m, max_ticks=5)
    assert m.active_path == "a"
    m.ctx.vars["n"] = 3
    m.tick()
    assert m.active_path == "b"


def test_var_with_incomparable_value_is_a_runtime_error(registry):
    m = fsm.load(doc("a", [probe("a"), probe("b")], [tr("Var", "a", "b", var="n", op="<", value=3)]),
                 registry=registry)
    m.ctx.vars["n"] = "text"  # set at run time: the loader could not see it
    with pytest.raises(StateRuntimeError, match="cannot compare variable 'n'"):
        m.tick()


# -- errors at run time ------------------------------------------------------------------------------------
class FakeCar:
    def __init__(self):
        self.stopped = False

    def emergency_stop(self):
        self.stopped = True


@pytest.mark.parametrize("phase", ["tick", "on_enter"])
def test_exception_in_state_names_path_phase_tick_and_stops_car(registry, phase):
    inner = doc("x", [probe("x"), probe("y", fail_in=phase)], [tr("Timeout", "x", "y", seconds=0.025)])
    car = FakeCar()
    m = fsm.load(doc("a", [{"id": "a", "type": "FSMState", "machine": inner}]), registry=registry, car=car)
    with pytest.raises(StateRuntimeError) as info:
        fsm.run(m, max_ticks=10)
    err = info.value
    assert err.path == "a/y" and err.phase == phase
    assert err.tick == (2 if phase == "on_enter" else 3)
    assert car.stopped
    assert "a/y" in str(err) and f"tick {err.tick}" in str(err)


# -- lookup, listeners, determinism, clocks ----------------------------------------------------------------
def test_lookup_by_path(registry):
    inner = doc("x", [probe("x")])
    m = fsm.load(doc("a", [{"id": "a", "type": "FSMState", "machine": inner}]), registry=registry)
    assert m.state("a/x").path == "a/x"
    assert m.ctx.state("a/x") is m.state("/a/x")
    with pytest.raises(KeyError, match="did you mean"):
        m.state("a/z")


def test_listener_sees_every_transition(registry):
    seen = []

    class L(fsm.Listener):
        def on_transition(self, ctx, source, target, transition):
            seen.append((ctx.tick, source.path if source else None, target.path,
                         transition.type_name if transition else "initial"))

    m = fsm.load(doc("a", [probe("a"), probe("b")], [tr("Always", "a", "b")]), registry=registry)
    m.add_listener(L())
    fsm.run(m, max_ticks=2)
    assert seen == [(0, None, "a", "initial"), (1, "a", "b", "Always")]


def test_listener_is_a_protocol_and_a_base_class(registry):
    """Any object with on_transition and on_tick is a Listener; a subclass gets the methods it does not write
    (doing nothing), and the optional hooks only when it writes them."""
    from fsm.runtime.machine import MonitorListener, PauseListener

    class ByMethods:
        def on_transition(self, ctx, source, target, transition):
            pass

        def on_tick(self, machine):
            self.ticks = machine.ticks

    class Ticks(fsm.Listener):
        def on_tick(self, machine):
            self.ticks = machine.ticks

    class Pauses(Ticks):
        def on_pause(self, ctx, state, paused):
            self.paused = (state.path, paused)

    assert isinstance(ByMethods(), fsm.Listener) and isinstance(Ticks(), fsm.Listener)
    assert not isinstance(object(), fsm.Listener) and not isinstance(Ticks(), (MonitorListener, PauseListener))
    assert isinstance(Pauses(), PauseListener) and not isinstance(Pauses(), MonitorListener)
    m = fsm.load(doc("a", [probe("a"), probe("b")], [tr("Always", "a", "b")]), registry=registry)
    listeners = [m.add_listener(ByMethods()), m.add_listener(Ticks()), m.add_listener(Pauses())]
    fsm.run(m, max_ticks=2)
    m.pause()
    assert [x.ticks for x in listeners] == [2, 2, 2] and listeners[2].paused == ("b", True)


def test_identical_runs_give_identical_traces(tmp_path, registry):
    from fsm.trace.recorder import Recorder

    d = parallel("all", 3, 7)

    def run():
        m = fsm.load(d, registry=registry)
        import io

        out = io.StringIO()
        rec = m.add_listener(Recorder(out))
        m.start()
        rec.flush(m)
        fsm.run(m, max_ticks=50)
        return out.getvalue()

    first, second = run(), run()
    assert first == second
    lines = [line for line in map(json.loads, first.splitlines()) if line["type"] == "event"]
    assert lines[0]["transitions"][0]["type"] == "initial"
    assert all({"tick", "time", "from", "to", "type"} <= set(t) for line in lines for t in line["transitions"])


def test_simulated_clock_dt_and_duration(registry):
    m = fsm.load(doc("a", [probe("a")]), registry=registry, dt=0.01)
    fsm.run(m, duration=1.0)
    assert m.ticks == 100 and m.now == pytest.approx(1.0)


def test_realtime_clock_keeps_period(registry):
    import time

    m = fsm.load(doc("a", [probe("a")]), registry=registry, clock=fsm.RealTimeClock(0.01))
    t0 = time.monotonic()
    fsm.run(m, max_ticks=10)
    assert time.monotonic() - t0 >= 0.09
    assert 0.08 <= m.now <= 1.0


def test_run_until(registry):
    m = fsm.load(doc("a", [probe("a")]), registry=registry)
    fsm.run(m, until=lambda mm: mm.ticks >= 7)
    assert m.ticks == 7


def test_included_machine_relative_to_including_file(tmp_path, registry):
    sub = tmp_path / "sub"
    sub.mkdir()
    (sub / "turn.json").write_text(json.dumps(doc("l", [probe("l", ticks=1), {"id": "end", "type": "Final"}],
                                                  [tr("Finished", "l", "end")])))
    (tmp_path / "main.json").write_text(json.dumps(
        doc("t", [{"id": "t", "type": "FSMState", "machine": {"file": "sub/turn.json"}},
                  {"id": "done", "type": "Final"}], [tr("Finished", "t", "done")])))
    m = fsm.load(tmp_path / "main.json", registry=registry)
    assert fsm.run(m, max_ticks=10).outcome == "succeeded"
    assert m.state("t/l").path == "t/l"


def test_legacy_tral_form(registry):
    legacy = {"root": 0, "states": [{"id": 0, "type": "Probe"}, {"id": 1, "type": "Final"}],
              "transitions": [{"type": "Always", "from": 0, "to": 1}]}
    m = fsm.load(legacy, registry=registry)
    assert fsm.run(m, max_ticks=5).outcome == "succeeded"
    assert m.state("1").is_final


def test_parallel_regions_exit_in_reverse_order_innermost_first(registry):
    # leave the parallel state by a preemptive transition added to the document
    d = parallel("all", 50, 50)
    d["states"].append(probe("out"))
    d["transitions"].append(tr("Flag", "p", "out", flag="stop", preempt=True))
    m = fsm.load(d, registry=registry)
    m.start()
    m.ctx.vars["stop"] = True
    LOG.clear()
    m.tick()
    assert LOG == ["check p->out", "exit p/right/w", "exit p/left/w", "action p->out", "enter out"]
