"""Audit of the runtime's semantics at the edges (docs/semantics.md: one tick, firing, time, pause, sequences).

The EEROS sequencer (monitors, abort/restart, timeouts, pause/resume) is built on exactly these
mechanisms, so these tests pin them down. Tests marked ``# Was a bug (fixed):`` reproduce bugs this audit
found; everything else is a regression test of behaviour the sequencer relies on.
"""

from __future__ import annotations

import io
import json

import pytest

import fsm
from fsm import DiagramError, Registry, State, StateRuntimeError, Transition
from fsm.loading.registry import default_registry
from fsm.model.params import StateParams, TransitionParams
from fsm.runtime.region import wiring
from fsm.trace.recorder import Recorder

LOG: list[str] = []


class Spy(State):
    """Logs its hooks; finishes after `ticks` ticks (0: never); `enter_finish` finishes in on_enter;
    `enter_var` is set true in the blackboard on entry; raises in `fail_in`."""

    can_finish = True
    outcomes = None

    class Params(StateParams):
        ticks: int = 0
        outcome: str = "succeeded"
        enter_finish: bool = False
        enter_var: str | None = None
        emit: str | None = None
        fail_in: str | None = None

    def on_enter(self, ctx):
        LOG.append(f"enter {self.path}")
        self.count = 0
        if self.params.enter_var:
            ctx.vars[self.params.enter_var] = True
        if self.params.enter_finish:
            self.finish(self.params.outcome)
        if self.params.fail_in == "on_enter":
            raise RuntimeError("boom in on_enter")

    def tick(self, ctx):
        LOG.append(f"tick {self.path}")
        if self.params.fail_in == "tick":
            raise ValueError("boom in tick")
        if self.params.emit:
            ctx.set_signal(self.params.emit, True)
        self.count += 1
        if self.params.ticks and self.count >= self.params.ticks:
            self.finish(self.params.outcome)

    def on_exit(self, ctx):
        LOG.append(f"exit {self.path}")
        if self.params.fail_in == "on_exit":
            raise RuntimeError("boom in on_exit")


class Gate(Transition):
    """Fires while blackboard variable `flag` is truthy; logs checks; raises in `fail_in` (check, action, arm)."""

    class Params(TransitionParams):
        flag: str = "go"
        fail_in: str | None = None

    def on_source_enter(self, ctx):
        if self.params.fail_in == "arm":
            raise KeyError("sensor missing")

    def holds(self, ctx):
        LOG.append(f"check {self.source.path}->{self.target.path}")
        if self.params.fail_in == "check":
            raise ValueError("boom in check")
        return bool(ctx.vars.get(self.params.flag))

    def action(self, ctx):
        LOG.append(f"action {self.source.path}->{self.target.path}")
        if self.params.fail_in == "action":
            raise RuntimeError("boom in action")


class PauseMyOwner(State):
    """Pauses its enclosing composite (its region's owner) from its own tick, like a step suspending its sequence."""

    def tick(self, ctx):
        LOG.append(f"tick {self.path}")
        ctx.machine.pause(wiring(self).region.owner.path)


@pytest.fixture()
def registry() -> Registry:
    reg = Registry()
    for kind, name, cls in default_registry():
        (reg.states if kind == "state" else reg.transitions)[name] = cls
    reg.add_state(Spy)
    reg.add_state(PauseMyOwner)
    reg.add_transition(Gate)
    LOG.clear()
    return reg


def doc(initial, states, transitions=(), **extra):
    return {"initial": initial, "states": list(states), "transitions": list(transitions), **extra}


def spy(id, **kw):
    return {"id": id, "type": "Spy", **kw}


def final(id="end", outcome="succeeded"):
    return {"id": id, "type": "Final", "outcome": outcome}


def fsmstate(id, machine):
    return {"id": id, "type": "FSMState", "machine": machine}


def tr(type_, a, b, **kw):
    return {"type": type_, "from": a, "to": b, **kw}


class FakeCar:
    def __init__(self):
        self.stopped = False

    def emergency_stop(self):
        self.stopped = True


class Seen(fsm.Listener):
    def __init__(self):
        self.events: list[tuple] = []

    def on_transition(self, ctx, source, target, transition):
        self.events.append((ctx.tick, source.path if source else None, target.path,
                            transition.type_name if transition else "initial"))


# -- the loader: one level per transition, includes, legacy ---------------------------------------------
@pytest.mark.parametrize("endpoints", [("a/x", "b"), ("b", "a/x"), ("a", "a/x")])
def test_loader_refuses_transitions_naming_states_of_another_level(registry, endpoints):
    inner = doc("x", [spy("x")])
    src, dst = endpoints
    with pytest.raises(DiagramError) as info:
        fsm.load(doc("a", [fsmstate("a", inner), spy("b")], [tr("Always", src, dst)]), registry=registry)
    assert "names unknown state 'a/x'" in str(info.value)


def test_loader_refuses_inner_transition_to_the_enclosing_composite(registry):
    inner = doc("x", [spy("x")], [tr("Always", "x", "a")])  # 'a' is the owner, one level up
    with pytest.raises(DiagramError, match="'to' names unknown state 'a'"):
        fsm.load(doc("a", [fsmstate("a", inner)]), registry=registry)


def test_include_used_twice_builds_separate_state_objects(tmp_path, registry):
    (tmp_path / "step.json").write_text(json.dumps(
        doc("w", [spy("w", ticks=2), final()], [tr("Finished", "w", "end")])))
    (tmp_path / "main.json").write_text(json.dumps(doc(
        "one", [{"id": "one", "type": "FSMState", "machine": {"file": "step.json"}},
                {"id": "two", "type": "FSMState", "machine": {"file": "step.json"}}, final("done")],
        [tr("Finished", "one", "two"), tr("Finished", "two", "done")])))
    m = fsm.load(tmp_path / "main.json", registry=registry)
    assert m.state("one/w") is not m.state("two/w")
    assert wiring(m.state("one")).regions[0] is not wiring(m.state("two")).regions[0]
    assert wiring(m.state("two/w")).region.owner is m.state("two")
    fsm.run(m, max_ticks=2)
    assert m.active_path == "two/w"
    assert m.state("one/w").finished and not m.state("two/w").finished
    assert fsm.run(m, max_ticks=10).outcome == "succeeded"
    assert m.ticks == 4 and m.transition_count == 2 + 2


def test_legacy_form_with_nested_legacy_machine(registry):
    inner = {"root": 0, "states": [{"id": 0, "type": "Spy", "ticks": 1}, {"id": 1, "type": "Final", "outcome": "ok"}],
             "transitions": [{"type": "Finished", "from": 0, "to": 1}]}
    outer = {"root": 0, "states": [{"id": 0, "type": "FSMState", "machine": inner},
                                   {"id": 1, "type": "Final", "outcome": "parked"}],
             "transitions": [{"type": "Finished", "from": 0, "to": 1, "outcome": "ok"}]}
    m = fsm.load(outer, registry=registry)
    m.start()
    assert m.active_path == "0/0"
    assert m.state("0/1").is_final and m.state("1").is_final
    assert fsm.run(m, max_ticks=5).outcome == "parked" and m.ticks == 1


# -- order of firing, entries from on_enter ------------------------------------------------------------
def test_var_set_in_on_enter_of_inner_target_is_seen_by_outer_level_in_the_same_tick(registry):
    inner = doc("x", [spy("x"), spy("y", enter_var="go")], [tr("Always", "x", "y")])
    m = fsm.load(doc("a", [fsmstate("a", inner), spy("b")], [tr("Gate", "a", "b")]), registry=registry)
    m.tick()
    # inner x->y fires, y's on_enter raises the flag, the outer level (checked after its tick) leaves a
    assert m.active_path == "b" and m.transition_count == 2


def test_var_set_in_on_enter_of_a_target_fires_its_own_transition_only_next_tick(registry):
    m = fsm.load(doc("a", [spy("a"), spy("b", enter_var="go"), spy("c")],
                     [tr("Always", "a", "b"), tr("Gate", "b", "c")]), registry=registry)
    m.tick()
    assert m.active_path == "b"
    m.tick()
    assert m.active_path == "c"


def test_state_finishing_in_on_enter_leaves_after_one_tick(registry):
    m = fsm.load(doc("a", [spy("a", enter_finish=True), final()], [tr("Finished", "a", "end")]), registry=registry)
    m.start()
    assert m.state("a").finished and not m.finished
    m.tick()
    assert m.finished and LOG == ["enter a", "tick a", "exit a"]


def test_preemption_on_composite_wins_over_a_child_finishing_in_the_same_tick(registry):
    inner = doc("w", [spy("w", ticks=2), final()], [tr("Finished", "w", "end")])
    m = fsm.load(doc("a", [fsmstate("a", inner), spy("done"), spy("abort")],
                     [tr("Finished", "a", "done"), tr("Gate", "a", "abort", flag="stop", preempt=True)]),
                 registry=registry)
    m.tick()
    m.ctx.vars["stop"] = True  # w would finish in tick 2
    LOG.clear()
    m.tick()
    assert m.active_path == "abort"
    assert "tick a/w" not in LOG and LOG[-2:] == ["action a->abort", "enter abort"]
    assert not m.state("a").finished


def test_finished_composite_checked_by_preemptive_transition_one_tick_later(registry):
    inner = doc("w", [spy("w", ticks=1), final()], [tr("Finished", "w", "end")])
    m = fsm.load(doc("a", [fsmstate("a", inner), spy("done")], [tr("Finished", "a", "done", preempt=True)]),
                 registry=registry)
    m.tick()  # a finishes at the end of tick 1, after its preemptive transitions were checked
    assert m.active_path == "a/end" and m.state("a").finished
    m.tick()
    assert m.active_path == "done"


def test_preemptive_before_regular_whatever_the_priority(registry):
    m = fsm.load(doc("a", [spy("a"), spy("reg"), spy("pre_low"), spy("pre_high")],
                     [tr("Gate", "a", "reg", priority=100), tr("Gate", "a", "pre_low", preempt=True, priority=-5),
                      tr("Gate", "a", "pre_high", preempt=True, priority=1)]), registry=registry)
    m.start()
    LOG.clear()
    m.tick()
    assert LOG == ["check a->pre_high", "check a->pre_low", "tick a", "check a->reg"]
    m.ctx.vars["go"] = True
    m.tick()
    assert m.active_path == "pre_high"


def test_negative_priority_is_checked_after_default(registry):
    m = fsm.load(doc("a", [spy("a"), spy("b"), spy("c")],
                     [tr("Gate", "a", "b", priority=-1), tr("Gate", "a", "c")]), registry=registry)
    m.ctx.vars["go"] = True
    m.tick()
    assert m.active_path == "c"


# -- finishing and outcomes of composites ------------------------------------------------------------------
def test_composite_finish_and_outcome_reset_on_reentry(registry):
    inner = doc("w", [spy("w", ticks=1), final("end", "aborted")], [tr("Finished", "w", "end")])
    m = fsm.load(doc("a", [fsmstate("a", inner), spy("b")],
                     [tr("Finished", "a", "b", outcome="aborted"), tr("Always", "b", "a")]), registry=registry)
    m.tick()
    a = m.state("a")
    assert m.active_path == "b" and a.finished and a.outcome == "aborted"
    m.tick()
    assert m.active_path == "a/w" and not a.finished and a.outcome is None
    assert not m.state("a/w").finished
    m.tick()
    assert m.active_path == "b" and a.outcome == "aborted"


def test_final_as_initial_state_of_a_submachine_finishes_the_composite_at_its_first_tick(registry):
    m = fsm.load(doc("a", [fsmstate("a", doc("end", [final("end", "empty")])), final("done", "x")],
                     [tr("Finished", "a", "done", outcome="empty")]), registry=registry)
    m.start()
    assert not m.state("a").finished  # finishing is noticed when the composite is ticked
    assert fsm.run(m, max_ticks=5).outcome == "x" and m.ticks == 1


def test_final_as_initial_state_of_the_root_finishes_without_a_tick(registry):
    m = fsm.load(doc("end", [final("end", "nothing")]), registry=registry)
    assert fsm.run(m, max_ticks=5).outcome == "nothing" and m.ticks == 0


def test_parallel_join_any_other_region_keeps_running_until_left(registry):
    left = {"name": "left", "initial": "w", "states": [spy("w", ticks=1), final("end", "fast")],
            "transitions": [tr("Finished", "w", "end")]}
    right = {"name": "right", "initial": "r", "states": [spy("r", ticks=3), final("end", "slow")],
             "transitions": [tr("Finished", "r", "end")]}
    m = fsm.load(doc("p", [{"id": "p", "type": "Parallel", "join": "any", "regions": [left, right]}, spy("b")],
                     [tr("Gate", "p", "b")]), registry=registry)
    fsm.run(m, max_ticks=1)
    p = m.state("p")
    assert p.finished and p.outcome == "fast"
    fsm.run(m, max_ticks=5)  # nothing leaves p: right keeps running and reaches its Final
    assert m.active_paths == ["p/left/end", "p/right/end"]
    assert p.outcome == "fast"  # the first outcome stays
    LOG.clear()
    m.ctx.vars["go"] = True
    m.tick()
    assert m.active_path == "b"


def test_parallel_join_any_leaving_exits_the_region_still_running(registry):
    left = {"name": "left", "initial": "w", "states": [spy("w", ticks=1), final()],
            "transitions": [tr("Finished", "w", "end")]}
    right = {"name": "right", "initial": "r", "states": [spy("r")]}
    m = fsm.load(doc("p", [{"id": "p", "type": "Parallel", "join": "any", "regions": [left, right]}, spy("b")],
                     [tr("Finished", "p", "b")]), registry=registry)
    m.start()
    LOG.clear()
    m.tick()
    assert LOG == ["tick p/left/w", "exit p/left/w", "tick p/right/r", "exit p/right/r", "enter b"]
    assert not m.state("p/right/r").active


def test_parallel_inside_parallel(registry):
    def region(name, ticks, outcome="succeeded"):
        return {"name": name, "initial": "w", "states": [spy("w", ticks=ticks), final("end", outcome)],
                "transitions": [tr("Finished", "w", "end")]}

    inner = {"name": "inner", "initial": "q", "states": [
        {"id": "q", "type": "Parallel", "regions": [region("a", 2), region("b", 3, "late")]}, final("end", "nested")],
        "transitions": [tr("Finished", "q", "end", outcome="late")]}
    m = fsm.load(doc("p", [{"id": "p", "type": "Parallel", "regions": [inner, region("c", 1)]}, final("done")],
                     [tr("Finished", "p", "done")]), registry=registry)
    m.start()
    assert m.active_paths == ["p/inner/q/a/w", "p/inner/q/b/w", "p/c/w"]
    LOG.clear()
    m.tick()
    assert [e for e in LOG if e.startswith("tick")] == ["tick p/inner/q/a/w", "tick p/inner/q/b/w", "tick p/c/w"]
    assert m.active_paths == ["p/inner/q/a/w", "p/inner/q/b/w", "p/c/end"]
    m.tick()
    assert m.active_paths == ["p/inner/q/a/end", "p/inner/q/b/w", "p/c/end"] and not m.state("p/inner/q").finished
    m.tick()  # b finishes 'late': q joins, inner routes to its Final, p joins: all in one tick
    assert m.finished and m.ticks == 3 and m.state("p").outcome == "nested"


# -- pause / resume ----------------------------------------------------------------------------------------
def test_pause_state_of_one_parallel_region_freezes_only_that_region(registry):
    def region(name):
        return {"name": name, "initial": "w", "states": [spy("w"), final()],
                "transitions": [tr("Timeout", "w", "end", seconds=0.1)]}

    m = fsm.load(doc("p", [{"id": "p", "type": "Parallel", "regions": [region("left"), region("right")]},
                           final("done")], [tr("Finished", "p", "done")]), registry=registry)
    fsm.run(m, max_ticks=4)  # 0.05 s
    m.pause("p/left/w")
    LOG.clear()
    fsm.run(m, max_ticks=4)
    assert LOG == ["tick p/right/w"] * 4 + ["exit p/right/w"]
    assert m.active_paths == ["p/left/w", "p/right/end"] and not m.finished
    m.resume("p/left/w")
    fsm.run(m, max_ticks=3)
    assert m.active_paths == ["p/left/w", "p/right/end"]
    assert fsm.run(m, max_ticks=10).outcome == "succeeded" and m.ticks == 12


def test_paused_composite_left_by_outer_transition_reenters_fresh(registry):
    leaf = doc("x", [spy("x"), spy("y")], [tr("Timeout", "x", "y", seconds=0.1)])
    mid = doc("a", [fsmstate("a", leaf)])
    m = fsm.load(doc("o", [fsmstate("o", mid), spy("b")],
                     [tr("Gate", "o", "b", flag="leave"), tr("Gate", "b", "o", flag="back")]), registry=registry)
    fsm.run(m, max_ticks=4)
    m.pause("o/a")
    fsm.run(m, max_ticks=4)
    a, x = m.state("o/a"), m.state("o/a/x")
    assert a.paused and x.time_in_state(m.ctx) == pytest.approx(0.05)
    LOG.clear()
    m.ctx.vars["leave"] = True
    m.tick()
    # a paused subtree is exited normally by an outer transition
    assert [e for e in LOG if "check" not in e] == ["exit o/a/x", "action o->b", "enter b"]
    assert not a.paused
    m.ctx.vars.update(leave=False, back=True)
    m.tick()
    m.ctx.vars["back"] = False
    assert m.active_path == "o/a/x" and not a.paused
    assert x.time_in_state(m.ctx) == 0.0
    fsm.run(m, max_ticks=7)
    assert m.active_path == "o/a/x"
    m.tick()
    assert m.active_path == "o/a/y"


def test_timeout_on_the_paused_state_itself_counts_only_unpaused_time(registry):
    m = fsm.load(doc("a", [spy("a"), spy("b")], [tr("Timeout", "a", "b", seconds=0.1)]), registry=registry)
    fsm.run(m, max_ticks=3)
    m.pause("a")
    fsm.run(m, max_ticks=20)
    assert m.active_path == "a"
    m.resume("a")
    assert m.state("a").time_in_state(m.ctx) == pytest.approx(0.0375)
    fsm.run(m, max_ticks=4)
    assert m.active_path == "a"
    m.tick()
    assert m.active_path == "b" and m.ticks == 28


def test_resume_of_something_never_paused_is_a_no_op(registry):
    m = fsm.load(doc("a", [spy("a"), spy("b")], [tr("Timeout", "a", "b", seconds=0.1)]), registry=registry)
    fsm.run(m, max_ticks=4)
    m.resume("a")
    m.resume("b")  # not active, never paused
    m.resume()
    assert m.state("a").time_in_state(m.ctx) == pytest.approx(0.05)
    fsm.run(m, max_ticks=4)
    assert m.active_path == "b"


def test_pause_twice_keeps_the_first_pause_time(registry):
    m = fsm.load(doc("a", [spy("a"), spy("b")], [tr("Timeout", "a", "b", seconds=0.1)]), registry=registry)
    fsm.run(m, max_ticks=4)
    m.pause("a")
    fsm.run(m, max_ticks=4)
    m.pause("a")
    fsm.run(m, max_ticks=4)
    m.resume("a")
    assert m.state("a").time_in_state(m.ctx) == pytest.approx(0.05)


def test_nested_pauses_freeze_time_once(registry):
    # Was a bug (fixed): pausing a state inside an already paused (or later paused) subtree counts the overlap twice.
    # x is frozen from t=0.125 (its own pause) to t=0.875, so its time in state stays 0.125, but
    # time_in_state takes the *outermost* paused ancestor's paused_since (0.625 -> 0.375 while both are
    # paused), and resume() shifts entered_at by each pause's full length (0.25 for 'a' + 0.75 for 'x'),
    # giving -0.125 after both resumes; its Timeout then fires late. The sequencer pauses owners while
    # their steps may already be paused, so this will happen.
    # Responsible: fsm/runtime/state.py State.time_in_state (last paused ancestor wins instead of the earliest
    # paused_since) and fsm/runtime/machine.py Machine.resume (shifts every state of the subtree, even those that
    # stay frozen by another paused state, and by the resumed state's pause length, not theirs).
    inner = doc("x", [spy("x"), spy("y")], [tr("Timeout", "x", "y", seconds=1.0)])
    m = fsm.load(doc("a", [fsmstate("a", inner)]), registry=registry, dt=0.125)
    x = m.state("a/x")
    fsm.run(m, max_ticks=1)  # t = 0.125
    m.pause("a/x")
    fsm.run(m, max_ticks=2)  # t = 0.375
    m.pause("a")
    fsm.run(m, max_ticks=2)  # t = 0.625
    assert x.time_in_state(m.ctx) == pytest.approx(0.125)
    m.resume("a")
    fsm.run(m, max_ticks=2)  # t = 0.875
    assert x.time_in_state(m.ctx) == pytest.approx(0.125)
    m.resume("a/x")
    assert x.time_in_state(m.ctx) == pytest.approx(0.125)


def test_pause_requested_during_a_tick_stops_the_paused_state_from_leaving(registry):
    # Was a bug (fixed): a step pauses its sequence (its region's owner) from its tick. The owner's Region.tick checked
    # `paused` before ticking, so after the tick it still checks the owner's regular transitions and
    # fires Always a->b: the "paused" subtree is exited in the very tick it was paused (docs/semantics.md: a
    # paused subtree has no exit/enter), and the exit silently clears the pause.
    # Responsible: fsm/runtime/region.py Region.tick; re-check `state.paused` after `state._tick(ctx)` and return.
    inner = doc("x", [{"id": "x", "type": "PauseMyOwner"}])
    m = fsm.load(doc("a", [fsmstate("a", inner), spy("b")], [tr("Always", "a", "b")]), registry=registry)
    m.tick()
    assert m.active_path == "a/x" and m.state("a").paused


# -- signals -------------------------------------------------------------------------------------------------
def test_signal_set_by_a_state_is_an_edge_for_another_region_in_the_next_tick(registry):
    left = {"name": "left", "initial": "s", "states": [spy("s", emit="sync"), spy("t")],
            "transitions": [tr("Timeout", "s", "t", seconds=0.0125)]}
    right = {"name": "right", "initial": "w", "states": [spy("w"), spy("got")],
             "transitions": [tr("Signal", "w", "got", signal="sync")]}
    m = fsm.load(doc("p", [{"id": "p", "type": "Parallel", "regions": [left, right]}]), registry=registry)
    m.tick()  # left sets the signal during tick 1 (level high at once, edge in tick 2)
    assert m.ctx.signal("sync") and not m.ctx.rising("sync")
    assert m.active_paths == ["p/left/t", "p/right/w"]
    m.tick()
    assert m.active_paths == ["p/left/t", "p/right/got"]


def test_signal_scheduled_at_time_zero_is_an_edge_in_the_first_tick(registry):
    m = fsm.load(doc("a", [spy("a"), spy("b")], [tr("Signal", "a", "b", signal="s")]), registry=registry)
    m.schedule_signal("s", 0.0)
    m.start()
    assert m.ctx.signal("s") and m.active_path == "a"
    m.tick()
    assert m.active_path == "b"


@pytest.mark.parametrize("dt", [0.01, 0.0125, 0.1, 1 / 3])
def test_signal_scheduled_at_exactly_a_tick_time_is_an_edge_in_that_tick(registry, dt):
    for n in (1, 3, 7, 29, 57, 99):
        m = fsm.load(doc("a", [spy("a"), spy("b")], [tr("Signal", "a", "b", signal="s")]), registry=registry, dt=dt)
        m.schedule_signal("s", round(n * dt, 12))
        fsm.run(m, max_ticks=n - 1)
        assert m.active_path == "a", (dt, n)
        m.tick()
        assert m.active_path == "b", (dt, n)


def test_many_scheduled_signals_step_a_chain(registry):
    n = 60
    states = [spy(f"s{i}") for i in range(n + 1)]
    trs = [tr("Signal", f"s{i}", f"s{i + 1}", signal=f"k{i}") for i in range(n)]
    m = fsm.load(doc("s0", states, trs), registry=registry)
    for i in reversed(range(n)):  # scheduled out of order
        m.schedule_signal(f"k{i}", (i + 1) * 0.025)
        m.schedule_signal(f"noise{i}", (i + 1) * 0.0125)
    fsm.run(m, max_ticks=2 * n)
    assert m.active_path == f"s{n}" and m.transition_count == n


def test_signal_changed_and_restored_between_ticks_is_no_edge(registry):
    # Was a bug (fixed): a signal raised and lowered again between two ticks (a button click shorter than a tick, or
    # schedule_signal('s', t) and schedule_signal('s', t, False) for the same t) reports a *falling*
    # edge in the next tick although the level was low at the previous tick too, and the rising edge
    # is lost. Expected: no edge (level low before and after), or both edges latched; never a falling
    # edge without the signal having been seen high.
    # Responsible: fsm/runtime/context.py Context.set_signal records only "changed in tick k"; it should keep
    # the level the signal had at the last tick boundary and drop the edge when the value returns to it.
    m = fsm.load(doc("a", [spy("a"), spy("b")], [tr("Signal", "a", "b", signal="s", edge="falling")]),
                 registry=registry)
    m.schedule_signal("s", 0.05)
    m.schedule_signal("s", 0.05, False)
    fsm.run(m, max_ticks=10)
    assert m.active_path == "a"


def test_falling_edge_after_a_high_level(registry):
    m = fsm.load(doc("a", [spy("a"), spy("b")], [tr("Signal", "a", "b", signal="s", edge="falling")]),
                 registry=registry)
    m.ctx.set_signal("s", True)
    fsm.run(m, max_ticks=3)
    m.ctx.set_signal("s", False)
    assert m.active_path == "a"
    m.tick()
    assert m.active_path == "b" and m.ctx.falling("s")
    m.tick()
    assert not m.ctx.falling("s")


# -- InState --------------------------------------------------------------------------------------------------
def _sync_doc(state_ref):
    left = {"name": "left", "initial": "go", "states": [spy("go"), spy("after")],
            "transitions": [tr("InState", "go", "after", state=state_ref)]}
    right = {"name": "right", "initial": "prep", "states": [
        spy("prep"), fsmstate("ready", doc("r1", [spy("r1")]))],
        "transitions": [tr("Timeout", "prep", "ready", seconds=0.025)]}
    return doc("p", [{"id": "p", "type": "Parallel", "regions": [left, right]}])


@pytest.mark.parametrize("ref", ["right/ready", "p/right/ready", "/p/right/ready", "right/ready/r1",
                                 "/p/right/ready/r1"])
def test_instate_relative_absolute_and_naming_a_composite(registry, ref):
    m = fsm.load(_sync_doc(ref), registry=registry)
    fsm.run(m, max_ticks=2)  # right enters ready at tick 2, after left was checked
    assert m.active_paths == ["p/left/go", "p/right/ready/r1"]
    m.tick()
    assert m.active_paths == ["p/left/after", "p/right/ready/r1"]


def test_instate_of_a_state_inside_an_exited_composite_is_false(registry):
    inner = doc("x", [spy("x")])
    m = fsm.load(doc("a", [fsmstate("a", inner), spy("b"), spy("c")],
                     [tr("Always", "a", "b"), tr("InState", "b", "c", state="a/x")]), registry=registry)
    m.start()
    assert m.state("a/x").active
    fsm.run(m, max_ticks=5)
    assert m.active_path == "b" and not m.state("a/x").active


def test_loader_refuses_instate_naming_a_region_step(registry):
    with pytest.raises(DiagramError, match="'state' names no state: 'p/left'"):
        fsm.load(doc("o", [spy("o"), {"id": "p", "type": "Parallel", "regions": [
            {"name": "left", "initial": "w", "states": [spy("w")]}]}],
            [tr("InState", "o", "p", state="p/left")]), registry=registry)


# -- listeners and counts ------------------------------------------------------------------------------------
def test_listener_order_for_nested_entries(registry):
    deep = doc("y", [spy("y")])
    inner = doc("x", [fsmstate("x", deep)])
    m = fsm.load(doc("a", [spy("a"), fsmstate("b", inner)], [tr("Always", "a", "b"), tr("Always", "b", "b")]),
                 registry=registry)
    seen = m.add_listener(Seen())
    fsm.run(m, max_ticks=2)
    assert seen.events == [
        (0, None, "a", "initial"),
        (1, "a", "b", "Always"), (1, None, "b/x", "initial"), (1, None, "b/x/y", "initial"),
        (2, "b", "b", "Always"), (2, None, "b/x", "initial"), (2, None, "b/x/y", "initial"),
    ]
    assert m.transition_count == 2


def test_listener_order_inner_then_outer_in_one_tick(registry):
    inner = doc("x", [spy("x"), spy("y")], [tr("Always", "x", "y")])
    m = fsm.load(doc("a", [fsmstate("a", inner), spy("b")], [tr("Gate", "a", "b")]), registry=registry)
    m.ctx.vars["go"] = True
    seen = m.add_listener(Seen())
    m.tick()
    assert seen.events == [(0, None, "a", "initial"), (0, None, "a/x", "initial"),
                           (1, "a/x", "a/y", "Always"), (1, "a", "b", "Gate")]
    assert m.transition_count == 2


def test_transition_count_across_levels_and_restarts(registry):
    inner = doc("x", [spy("x"), spy("y")], [tr("Always", "x", "y"), tr("Always", "y", "x")])
    m = fsm.load(doc("a", [fsmstate("a", inner)], [tr("Timeout", "a", "a", seconds=0.05)]), registry=registry)
    rec = m.add_listener(Recorder())
    fsm.run(m, max_ticks=8)
    # inner fires every tick (8); the self-transition restarts a at ticks 4 and 8
    assert m.transition_count == 10 == rec.transitions


# -- run / tick ------------------------------------------------------------------------------------------------
def test_run_duration_with_a_dt_that_does_not_divide_it(registry):
    # Was a bug (fixed): run(duration=0.1) with dt=0.03 stops after 3 ticks at t=0.09: less than the duration asked
    # for, while duration=0.05 runs 2 ticks (t=0.06, more than asked): `int(round(duration / dt))`
    # rounds to nearest. The real-time branch stops at the first tick with now >= end_time, so the same
    # call gives a different number of ticks on the two clocks. Expected: the first tick at or after the
    # duration (4 ticks, t=0.12), like the real-time branch.
    # Responsible: fsm/runtime/machine.py Machine.run, `ticks_for_duration = int(round(duration / self._dt))`;
    # use `math.ceil(duration / self._dt - 1e-9)`.
    m = fsm.load(doc("a", [spy("a")]), registry=registry, dt=0.03)
    fsm.run(m, duration=0.1)
    assert m.now >= 0.1 - 1e-9 and m.ticks == 4


def test_run_duration_that_is_a_multiple_of_dt(registry):
    for dt, duration, ticks in [(0.0125, 1.0, 80), (0.01, 0.3, 30), (0.1, 0.7, 7), (0.03, 0.09, 3)]:
        m = fsm.load(doc("a", [spy("a")]), registry=registry, dt=dt)
        fsm.run(m, duration=duration)
        assert m.ticks == ticks, (dt, duration)


def test_run_combinations_stop_at_the_first_limit(registry):
    m = fsm.load(doc("a", [spy("a")]), registry=registry)
    fsm.run(m, max_ticks=10, duration=1.0)
    assert m.ticks == 10
    fsm.run(m, max_ticks=100, duration=0.05)
    assert m.ticks == 14
    fsm.run(m, until=lambda mm: mm.ticks >= 20, max_ticks=100)
    assert m.ticks == 20
    fsm.run(m, until=lambda mm: False, duration=0.025)
    assert m.ticks == 22
    fsm.run(m, max_ticks=0)
    assert m.ticks == 22


def test_run_after_finished_does_not_tick_and_tick_after_finished_keeps_the_outcome(registry):
    m = fsm.load(doc("a", [spy("a", ticks=1), final("end", "ok")], [tr("Finished", "a", "end")]), registry=registry)
    assert fsm.run(m).outcome == "ok" and m.ticks == 1
    assert fsm.run(m, max_ticks=10).outcome == "ok" and m.ticks == 1
    m.tick()
    assert m.finished and m.outcome == "ok" and m.ticks == 2 and m.transition_count == 1


# -- errors at run time -----------------------------------------------------------------------------------------
def test_exception_in_on_exit_during_an_outer_transition(registry):
    inner = doc("x", [spy("x", fail_in="on_exit")])
    car = FakeCar()
    m = fsm.load(doc("a", [fsmstate("a", inner), spy("b")], [tr("Gate", "a", "b")]), registry=registry, car=car)
    m.tick()
    m.ctx.vars["go"] = True
    with pytest.raises(StateRuntimeError) as info:
        m.tick()
    assert (info.value.path, info.value.phase, info.value.tick) == ("a/x", "on_exit", 2)
    assert car.stopped
    assert "enter b" not in LOG and m.root.active is m.state("a")


def test_exception_in_a_transition_check_names_the_source_and_the_transition(registry):
    car = FakeCar()
    m = fsm.load(doc("a", [spy("a"), spy("b")], [tr("Gate", "a", "b", fail_in="check")]), registry=registry, car=car)
    with pytest.raises(StateRuntimeError) as info:
        m.tick()
    assert info.value.path == "a" and info.value.phase.startswith("check")
    assert "Gate a -> b" in info.value.phase and car.stopped


def test_exception_in_a_composites_child_names_the_child(registry):
    inner = doc("x", [spy("x", fail_in="tick")])
    par = {"id": "p", "type": "Parallel", "regions": [{"name": "l", "initial": "w", "states": [spy("w")]},
                                                       {"name": "r", "initial": "f", "states": [fsmstate("f", inner)]}]}
    m = fsm.load(doc("p", [par]), registry=registry)
    with pytest.raises(StateRuntimeError) as info:
        m.tick()
    assert (info.value.path, info.value.phase) == ("p/r/f/x", "tick")
    assert isinstance(info.value.cause, ValueError)


def test_exception_in_a_transition_action_is_reported_as_action(registry):
    # Was a bug (fixed): StateRuntimeError's docstring promises the phase names on_enter, tick, on_exit, check,
    # action; an action that raises is reported as phase "firing of transition Gate a -> b", which does
    # not say that the action failed (on_source_enter hooks and listeners land in the same bucket).
    # Responsible: fsm/runtime/region.py Region.tick/fire: set phase = "action" around `tr._action(ctx)`.
    m = fsm.load(doc("a", [spy("a"), spy("b")], [tr("Gate", "a", "b", fail_in="action")]), registry=registry)
    m.ctx.vars["go"] = True
    with pytest.raises(StateRuntimeError) as info:
        m.tick()
    assert info.value.path == "a" and "action" in info.value.phase


def test_exception_in_on_source_enter_of_the_initial_state_is_a_state_runtime_error(registry):
    # Was a bug (fixed): a transition's on_source_enter (Distance reads ctx.car.distance there) that raises while the
    # machine starts escapes as the raw KeyError: no state path, no tick, and the car is not stopped
    # (docs/semantics.md, "Errors at run time": the error names the state's path and the tick; the car gets an
    # emergency stop).
    # Responsible: fsm/runtime/state.py State._enter_full calls the source hooks outside its try block, and
    # Machine.start only catches StateRuntimeError. Move the hooks into the try (phase "on_enter" or
    # "on_source_enter of <transition>").
    car = FakeCar()
    m = fsm.load(doc("a", [spy("a"), spy("b")], [tr("Gate", "a", "b", fail_in="arm")]), registry=registry, car=car)
    with pytest.raises(StateRuntimeError) as info:
        m.start()
    assert info.value.path == "a" and info.value.tick == 0
    assert car.stopped


# -- determinism -----------------------------------------------------------------------------------------------
def test_same_document_twice_gives_identical_traces_with_parallel_regions_and_signals(registry):
    def region(name, seconds):
        return {"name": name, "initial": "w", "states": [spy("w"), spy("v"), final()],
                "transitions": [tr("Timeout", "w", "v", seconds=seconds), tr("Signal", "v", "end", signal=name)]}

    inner = doc("q", [{"id": "q", "type": "Parallel", "regions": [region("l", 0.05), region("r", 0.1)]},
                      final("done")], [tr("Finished", "q", "done")])
    d = doc("a", [fsmstate("a", inner), spy("b")], [tr("Finished", "a", "b"), tr("Timeout", "b", "a", seconds=0.1)])

    def run():
        m = fsm.load(json.loads(json.dumps(d)), registry=registry)
        out = io.StringIO()
        rec = m.add_listener(Recorder(out))
        for k in range(4):
            m.schedule_signal("l", 0.1 + k * 0.3)
            m.schedule_signal("r", 0.2 + k * 0.3)
        m.start()
        rec.flush(m)
        fsm.run(m, max_ticks=100)
        return out.getvalue(), m.transition_count

    first, second = run(), run()
    assert first == second
    lines = [line for line in map(json.loads, first[0].splitlines()) if line["type"] == "event"]
    assert sum(1 for line in lines for t in line["transitions"] if t["type"] != "initial") == first[1]
    assert any(line["active"] == ["b"] for line in lines) and first[1] >= 9
