"""The sequencer's semantics (issue 10, item 4; docs/semantics.md "Sequences"), tick by tick.

The clock is the default simulated one (dt = 0.0125 s), so times are exact multiples of a tick."""

from __future__ import annotations

from typing import Any

import pytest

import fsm
from fsm import DiagramError
from fsm.loading.registry import Registry, default_registry
from fsm.runtime.supervisor import supervisor_of

DT = 0.0125


class Log(fsm.Listener):
    def __init__(self) -> None:
        self.entered: list[tuple[float, str, str]] = []  # (time, path, how)
        self.monitors: list[tuple[float, str, str]] = []  # (time, owner, behavior)
        self.pauses: list[tuple[float, str, bool]] = []

    def on_transition(self, ctx: Any, source: Any, target: Any, transition: Any) -> None:
        how = transition.type_name if transition is not None else "initial"
        self.entered.append((round(ctx.now, 6), target.path, how))

    def on_monitor(self, ctx: Any, owner: Any, monitor: Any) -> None:
        self.monitors.append((round(ctx.now, 6), owner.path, monitor.behavior))

    def on_pause(self, ctx: Any, state: Any, paused: bool) -> None:
        self.pauses.append((round(ctx.now, 6), state.path, paused))

    def when(self, path: str, nth: int = 0) -> float:
        """Time of the nth entry of ``path``."""
        return [t for t, p, _ in self.entered if p == path][nth]

    def entries(self, path: str) -> list[float]:
        return [t for t, p, _ in self.entered if p == path]


def machine(states: list[dict[str, Any]], transitions: list[dict[str, Any]] | None = None, initial: str | None = None,
            **variables: Any) -> tuple[fsm.Machine, Log]:
    doc = {"name": "t", "initial": initial or states[0]["id"], "states": states, "transitions": transitions or [],
           "vars": variables}
    m = fsm.load(doc)
    log = m.add_listener(Log())
    return m, log


def seq(id: str, *steps: dict[str, Any], **keys: Any) -> dict[str, Any]:
    return {"id": id, "type": "Sequence", "steps": list(steps), **keys}


def wait(id: str, seconds: float, **keys: Any) -> dict[str, Any]:
    return {"id": id, "type": "Wait", "seconds": seconds, **keys}


def setvar(id: str, **assign: Any) -> dict[str, Any]:
    return {"id": id, "type": "SetVar", "assign": assign}


def done(id: str = "end", outcome: str = "succeeded") -> dict[str, Any]:
    return {"id": id, "type": "Final", "outcome": outcome}


def route(a: str, b: str, outcome: str | None = None) -> dict[str, Any]:
    t = {"type": "Finished", "from": a, "to": b}
    if outcome:
        t["outcome"] = outcome
    return t


def problems(doc_states: list[dict[str, Any]], transitions: list[dict[str, Any]] | None = None,
             **variables: Any) -> list[str]:
    doc = {"name": "t", "initial": doc_states[0]["id"], "states": doc_states, "transitions": transitions or [],
           "vars": variables}
    with pytest.raises(DiagramError) as err:
        fsm.load(doc)
    return [f"{p.pointer}: {p.message}" for p in err.value.problems]


# -- steps ----------------------------------------------------------------------------------------------------
def test_steps_run_in_order_and_the_sequence_finishes_after_its_last() -> None:
    m, log = machine([seq("s", setvar("a", n="n + 1"), wait("w", 0.5),
                          {"id": "b", "type": "Step", "set": {"on_enter": {"x": 5}}, "until": "x == 5"}),
                      done()], [route("s", "end")], n=0, x=0)
    assert fsm.run(m, duration=5).outcome == "succeeded"
    assert log.when("s/a") == 0.0
    assert log.when("s/w") == DT  # SetVar finished on entry; its link fires at the next tick
    assert log.when("s/b") == pytest.approx(DT + 0.5)
    assert log.when("end") == pytest.approx(DT + 0.5 + DT)  # until held at b's first tick
    assert m.ctx.vars == {"n": 1, "x": 5}


def test_a_step_without_until_finishes_at_its_first_tick_and_repeat_runs_the_steps_again() -> None:
    m, log = machine([seq("s", {"id": "a", "type": "Step", "set": {"on_enter": {"n": "n + 1"}}}, repeat=3), done()],
                     [route("s", "end")], n=0)
    assert fsm.run(m, duration=5).outcome == "succeeded"
    assert m.ctx.vars["n"] == 3
    assert log.entries("s/a") == [0.0, DT, 2 * DT]


def test_repeat_zero_runs_until_stopped_from_outside() -> None:
    m, _log = machine([seq("s", setvar("a", n="n + 1"), repeat=0, timeout=1.0), done("to", "timeout")],
                      [route("s", "to", "timeout")], n=0)
    assert fsm.run(m, duration=5).outcome == "timeout"
    assert m.now == pytest.approx(1.0)
    assert m.ctx.vars["n"] > 10


# -- monitors -------------------------------------------------------------------------------------------------
def _two_levels(behavior: str, exception: bool = True) -> list[dict[str, Any]]:
    monitor = {"condition": {"type": "SignalHigh", "signal": "btn"}, "behavior": behavior}
    if exception:
        monitor["exception"] = "exc"
    return [seq("main",
                seq("sub", wait("w1", 1), wait("w2", 1, monitors=[monitor])),
                wait("after", 0.5),
                exceptions=[seq("exc", setvar("e1", e="e + 1"), wait("e2", 0.25))]),
            done(), done("aborted", "aborted")]


@pytest.mark.parametrize("behavior", ["nothing", "abortOwner", "restartOwner", "abortCallerOfOwner",
                                      "restartCallerOfOwner"])
def test_the_five_behaviours_after_an_exception_sequence(behavior: str) -> None:
    m, log = machine(_two_levels(behavior), [route("main", "end")], e=0)
    m.schedule_signal("btn", 1.5)
    m.schedule_signal("btn", 1.5 + DT / 2, False)  # one tick high
    assert fsm.run(m, duration=10).outcome == "succeeded"
    assert log.monitors == [(1.5, "main/sub/w2", behavior)]
    assert log.when("main/exc") == 1.5 and log.when("main/exc/e2") == 1.5 + DT
    resumed = 1.5 + DT + 0.25  # the exception's last step ends; the behaviour applies in that tick
    sub = m.state("main/sub")
    if behavior == "nothing":  # w2 resumes where it was: its clock stood still for the exception
        assert log.when("main/after") == pytest.approx(1.0 + 1.0 + (resumed - 1.5))
        assert sub.outcome == "succeeded"
    elif behavior == "abortOwner":  # w2 ends aborted; sub goes on with its next step (none: sub is done)
        assert m.state("main/sub/w2").outcome == "aborted"
        assert log.when("main/after") == pytest.approx(resumed)
        assert sub.outcome == "succeeded"
    elif behavior == "restartOwner":  # w2 again from its start, with a fresh clock
        assert [(t, h) for t, p, h in log.entered if p == "main/sub/w2"] == [(1.0, "Finished"), (resumed, "restart")]
        assert log.when("main/after") == pytest.approx(resumed + 1.0)
    elif behavior == "abortCallerOfOwner":  # sub ends aborted; main goes on with 'after'
        assert sub.outcome == "aborted"
        assert log.when("main/after") == pytest.approx(resumed)
    else:  # restartCallerOfOwner: sub from its first step
        assert log.entries("main/sub/w1") == [0.0, pytest.approx(resumed)]
        assert log.when("main/after") == pytest.approx(resumed + 2.0)
    assert m.ctx.vars["e"] == 1


def test_nothing_without_exception_fires_each_tick_the_condition_holds_and_the_owner_goes_on() -> None:
    m, log = machine(_two_levels("nothing", exception=False), [route("main", "end")], e=0)
    m.schedule_signal("btn", 1.5)
    m.schedule_signal("btn", 1.5 + 3 * DT - DT / 2, False)
    fsm.run(m, duration=10)
    assert [t for t, _, _ in log.monitors] == [1.5, 1.5 + DT, pytest.approx(1.5 + 2 * DT)]
    assert log.when("main/after") == pytest.approx(2.0)  # not delayed


def test_the_owners_monitor_is_not_checked_during_its_exception_but_its_callers_are() -> None:
    inner = {"condition": "x > 0", "exception": "slow", "behavior": "nothing"}
    outer = {"condition": "y > 0", "behavior": "abortOwner"}
    m, log = machine([seq("main", seq("sub", wait("w", 5, monitors=[inner])), monitors=[outer],
                          exceptions=[seq("slow", setvar("s1", y=1), wait("s2", 1))]), done(), done("ab", "aborted")],
                     [route("main", "end", "succeeded"), route("main", "ab", "aborted")], x=1, y=0)
    assert fsm.run(m, duration=10).outcome == "aborted"
    # inner fires at 0 + one tick (w's first tick); its exception sets y; the caller's monitor fires next tick,
    # while the exception runs; the inner monitor (x > 0 all along) is not checked again meanwhile
    assert log.monitors == [(DT, "main/sub/w", "nothing"), (2 * DT, "main", "abortOwner")]


def test_monitors_are_checked_outermost_first() -> None:
    m, log = machine([seq("main", seq("sub", wait("w", 5, monitors=[{"condition": "x > 0", "behavior": "abortOwner"}]),
                                      monitors=[{"condition": "x > 0", "behavior": "abortOwner"}]),
                          monitors=[{"condition": "x > 0", "behavior": "abortOwner"}]), done(), done("ab", "aborted")],
                     [route("main", "end", "succeeded"), route("main", "ab", "aborted")], x=0)
    fsm.run(m, max_ticks=3)
    m.ctx.vars["x"] = 1
    assert fsm.run(m, duration=1).outcome == "aborted"
    assert [o for _, o, _ in log.monitors] == ["main"]


class SeqProbe(fsm.State):
    """Records its exits."""

    exits: list[str] = []

    def on_exit(self, ctx: Any) -> None:
        SeqProbe.exits.append(self.path)


def _with_probe() -> Registry:
    registry = Registry()
    base = default_registry()
    registry.states.update(base.states)
    registry.transitions.update(base.transitions)
    registry.conditions.update(base.conditions)
    registry.add_state(SeqProbe, "SeqProbe")
    return registry


def test_abort_owner_ends_everything_inside_non_blocking_sequences_too() -> None:
    SeqProbe.exits = []
    doc = {"name": "t", "initial": "main", "vars": {"stop": False, "never": 0},
           "states": [seq("main", seq("bg", {"id": "p", "type": "SeqProbe", "until": "never == 1"}, blocking=False),
                          {"id": "q", "type": "SeqProbe", "until": "never == 1"},
                          monitors=[{"condition": "stop", "behavior": "abortOwner"}]),
                      done(), done("ab", "aborted")],
           "transitions": [route("main", "end", "succeeded"), route("main", "ab", "aborted")]}
    m = fsm.load(doc, registry=_with_probe())
    fsm.run(m, duration=1)
    assert sorted(m.active_paths) == ["main/bg/p", "main/q"]
    m.ctx.vars["stop"] = True
    assert fsm.run(m, duration=1).outcome == "aborted"
    assert sorted(SeqProbe.exits) == ["main/bg/p", "main/q"]
    assert m.state("main").outcome == "aborted"


def test_restart_caller_of_owner_on_a_step_two_levels_down_restarts_the_steps_sequence() -> None:
    monitor = {"condition": {"type": "SignalEdge", "signal": "b"}, "behavior": "restartCallerOfOwner"}
    m, log = machine([seq("top", seq("mid", setvar("count", n="n + 1"), seq("low", wait("w", 2, monitors=[monitor]))),
                          setvar("tail", t=1)), done()], [route("top", "end")], n=0, t=0)
    m.schedule_signal("b", 1.0)
    assert fsm.run(m, duration=10).outcome == "succeeded"
    # the owner is 'w', its caller 'low': the edge at 1.0 restarts 'low' (so 'w' again), 'mid' goes on
    assert log.monitors == [(1.0, "top/mid/low/w", "restartCallerOfOwner")]
    assert log.entries("top/mid/low/w") == [DT, 1.0]
    assert m.ctx.vars == {"n": 1, "t": 1}


def test_restart_caller_of_owner_on_a_sequence_restarts_its_caller_from_its_first_step() -> None:
    monitor = {"condition": {"type": "SignalEdge", "signal": "b"}, "behavior": "restartCallerOfOwner"}
    m, log = machine([seq("top", seq("mid", setvar("count", n="n + 1"), seq("low", wait("w", 2), monitors=[monitor])),
                          setvar("tail", t=1)), done()], [route("top", "end")], n=0, t=0)
    m.schedule_signal("b", 1.0)
    assert fsm.run(m, duration=10).outcome == "succeeded"
    assert log.monitors == [(1.0, "top/mid/low", "restartCallerOfOwner")]
    assert log.entries("top/mid/count") == [0.0, 1.0]
    assert m.ctx.vars == {"n": 2, "t": 1}
    assert log.when("top/tail") == pytest.approx(1.0 + DT + 2.0)  # count ends on entry; w 2 s


def test_a_caller_behaviour_at_the_top_level_is_a_load_error() -> None:
    found = problems([seq("s", wait("w", 1), monitors=[{"condition": "x > 0", "behavior": "abortCallerOfOwner"}])], x=0)
    assert found == ["/states/0/monitors/0/behavior: 'abortCallerOfOwner' acts on the state that contains 's', but "
                     "'s' is at the top level: it has no caller"]


# -- timeouts -------------------------------------------------------------------------------------------------
def test_a_timeout_with_abort_owner_ends_the_owner_with_outcome_timeout_and_the_caller_goes_on() -> None:
    m, log = machine([seq("main", wait("slow", 10, timeout=2), setvar("next", n=1)), done()], [route("main", "end")],
                     n=0)
    assert fsm.run(m, duration=20).outcome == "succeeded"
    assert m.state("main/slow").outcome == "timeout"
    assert log.monitors == [(2.0, "main/slow", "abortOwner")]
    assert log.when("main/next") == 2.0


def test_a_5s_timeout_paused_for_3s_fires_at_8s() -> None:
    m, log = machine([seq("main", {"id": "idle", "type": "Idle", "until": "false_ == 1"}, timeout=5,
                          pause_signal="pause"), done("to", "timeout")], [route("main", "to", "timeout")], false_=0)
    m.schedule_signal("pause", 1.0)
    m.schedule_signal("pause", 1.1, False)
    m.schedule_signal("pause", 4.0)
    m.schedule_signal("pause", 4.1, False)
    assert fsm.run(m, duration=20).outcome == "timeout"
    assert log.pauses == [(1.0, "main", True), (4.0, "main", False)]
    assert log.monitors == [(8.0, "main", "abortOwner")]


def test_a_timeout_stands_still_while_an_exception_sequence_suspends_its_owner() -> None:
    m, log = machine([seq("main", wait("w", 10, monitors=[{"condition": {"type": "SignalEdge", "signal": "b"},
                                                            "exception": "e", "behavior": "nothing"}]),
                          timeout=3, exceptions=[seq("e", wait("e1", 1))]),
                      done("to", "timeout")], [route("main", "to", "timeout")])
    m.schedule_signal("b", 1.0)
    assert fsm.run(m, duration=20).outcome == "timeout"
    # main's own timeout keeps counting while the inner owner 'w' is suspended (main is not suspended)
    assert log.monitors[-1] == (3.0, "main", "abortOwner")
    m2, log2 = machine([seq("main", wait("w", 10), timeout=3,
                            monitors=[{"condition": {"type": "SignalEdge", "signal": "b"}, "exception": "e",
                                       "behavior": "nothing"}],
                            exceptions=[seq("e", wait("e1", 1))]),
                        done("to", "timeout")], [route("main", "to", "timeout")])
    m2.schedule_signal("b", 1.0)
    assert fsm.run(m2, duration=20).outcome == "timeout"
    # main itself is suspended for its exception (1.0 to 2.0 s): its timeout fires 1 s later
    assert log2.monitors[-1] == (4.0, "main", "abortOwner")


def test_reset_timeout_restarts_the_owners_timeout_clock() -> None:
    m, log = machine([seq("main", wait("a", 1.5), {"id": "r", "type": "ResetTimeout", "owner": "main"},
                          wait("b", 1.5), timeout=2), done(), done("to", "timeout")],
                     [route("main", "end", "succeeded"), route("main", "to", "timeout")])
    assert fsm.run(m, duration=20).outcome == "succeeded"
    assert log.monitors == []


# -- precondition ---------------------------------------------------------------------------------------------
def test_a_false_precondition_skips_the_step_with_outcome_precondition_failed() -> None:
    m, log = machine([seq("main", setvar("a", n=1), wait("skipped", 5, precondition="n > 1",
                                                         set={"on_enter": {"entered": True}}),
                          setvar("c", m_=2)), done()], [route("main", "end")], n=0, entered=False, m_=0)
    assert fsm.run(m, duration=20).outcome == "succeeded"
    assert m.state("main/skipped").outcome == "precondition_failed"
    assert m.ctx.vars["entered"] is False  # nothing of it ran
    assert log.when("main/c") == pytest.approx(2 * DT)  # one tick in the skipped step


def test_a_false_precondition_on_a_sequence_routes_by_its_outcome() -> None:
    m, _ = machine([seq("main", wait("w", 1), precondition="ready"), done(), done("no", "precondition_failed")],
                   [route("main", "end", "succeeded"), route("main", "no", "precondition_failed")], ready=False)
    assert fsm.run(m, duration=5).outcome == "precondition_failed"


# -- non-blocking and Join ------------------------------------------------------------------------------------
def test_a_non_blocking_sequence_runs_beside_its_caller_and_join_waits_for_it() -> None:
    m, log = machine([seq("main", seq("bg", wait("b1", 2), setvar("b2", k=1), blocking=False), wait("w", 1),
                          {"id": "j", "type": "Join", "sequences": ["bg"]}, setvar("after", seen="k")),
                      done()], [route("main", "end")], k=0, seen=0)
    fsm.run(m, duration=0.5)
    assert sorted(m.active_paths) == ["main/bg/b1", "main/w"]
    assert fsm.run(m, duration=10).outcome == "succeeded"
    assert log.when("main/j") == pytest.approx(1.0)
    assert log.when("main/bg/b2") == pytest.approx(2.0)
    assert log.when("main/after") == pytest.approx(2.0 + DT)  # the Join sees bg done at its next tick
    assert m.ctx.vars["seen"] == 1


def test_a_sequence_waits_for_its_non_blocking_sequences_before_it_finishes() -> None:
    m, log = machine([seq("main", setvar("a", x=1), seq("bg", wait("b", 1), blocking=False)), done()],
                     [route("main", "end")], x=0)
    assert fsm.run(m, duration=5).outcome == "succeeded"
    # 'a' finishes on entry; bg, placed after the last step, starts at the next tick and runs 1 s
    assert log.when("end") == pytest.approx(DT + 1.0)


@pytest.mark.parametrize("bad, message", [
    ({"id": "j", "type": "Join", "sequences": ["w"]},
     "/states/0/steps/1/sequences/0: 'w' is a blocking step: it has finished before the Join is reached, so there "
     "is nothing to wait for"),
    ({"id": "j", "type": "Join", "sequences": ["nope"]},
     "/states/0/steps/1/sequences/0: no non-blocking sequence 'nope' starts before this Join"),
])
def test_join_errors(bad: dict[str, Any], message: str) -> None:
    assert problems([seq("s", wait("w", 1), bad)]) == [message]


# -- pause ----------------------------------------------------------------------------------------------------
def test_pause_by_api_freezes_the_subtree_and_resume_continues_where_it_was() -> None:
    m, log = machine([seq("main", wait("w", 2), setvar("x", n=1)), done()], [route("main", "end")], n=0)
    fsm.run(m, duration=1.0)
    m.pause("main")
    fsm.run(m, duration=5.0)
    assert m.active_paths == ["main/w"] and not m.finished
    m.resume("main")
    assert fsm.run(m, duration=5).outcome == "succeeded"
    assert log.when("main/x") == pytest.approx(7.0)


def test_two_sequences_paused_through_a_common_ancestor_stay_paused_together() -> None:
    arm = lambda name: seq(name, wait(f"{name}_w", 1), setvar(f"{name}_n", **{name: f"{name} + 1"}),  # noqa: E731
                           repeat=0)
    m, log = machine([seq("both", arm("a") | {"blocking": False}, arm("b") | {"blocking": False},
                          {"id": "j", "type": "Join", "sequences": ["a", "b"]}, pause_signal="p")],
                     a=0, b=0)
    m.schedule_signal("p", 2.5)
    m.schedule_signal("p", 2.6, False)
    fsm.run(m, duration=10)
    assert m.ctx.vars == {"a": 2, "b": 2}  # both stopped together at 2.5 s
    assert [p for _, p, _ in log.pauses] == ["both"]


def test_a_bouncing_pause_button_toggles_once_per_press_with_debounce() -> None:
    m, log = machine([seq("main", wait("w", 100), pause_signal="p", pause_debounce=0.05)])
    for at in (1.0, 3.0):  # two presses, each bouncing
        for i in range(5):
            m.schedule_signal("p", at + i * 0.013, i % 2 == 0)  # each bounce lasts one tick
        m.schedule_signal("p", at + 0.2, False)
    fsm.run(m, duration=5)
    # each press counts once, when stable for 50 ms: its last bounce is seen at the tick at + 0.0625
    assert log.pauses == [(1.1125, "main", True), (3.1125, "main", False)]


def test_three_rapid_bouncing_presses_counted_as_three() -> None:
    edge = {"type": "SignalEdge", "signal": "btn", "debounce": 0.02}
    m, log = machine([seq("count", wait("w", 100, monitors=[{"condition": edge, "exception": "inc",
                                                            "behavior": "nothing"}]),
                          exceptions=[seq("inc", setvar("plus", n="n + 1"))])], n=0)
    t = 1.0
    for _press in range(3):  # press 0.1 s, release 0.1 s, each edge bouncing 3 times within 4 ms
        for level in (True, False):
            for i in range(5):
                m.schedule_signal("btn", t + i * 0.001, level if i % 2 == 0 else not level)
            t += 0.1
    fsm.run(m, duration=5)
    assert m.ctx.vars["n"] == 3
    assert len(log.monitors) == 3


# -- bad input ------------------------------------------------------------------------------------------------
def test_unknown_behaviour_and_exception_are_located_load_errors() -> None:
    found = problems([seq("s", wait("w", 1, monitors=[{"condition": "x > 0", "behavior": "abortOwnr"}]),
                          wait("v", 1, monitors=[{"condition": "x > 0", "exception": "recovr"}]),
                          exceptions=[seq("recover", wait("r", 1))])], x=0)
    assert any(p.startswith("/states/0/steps/0/monitors/0/behavior:") and "abortOwner" in p for p in found), found
    assert "/states/0/steps/1/monitors/0/exception: no exception sequence 'recovr'" in found


def test_a_step_that_can_never_finish_is_a_load_error() -> None:
    assert problems([seq("s", {"id": "idle", "type": "Idle"})]) == [
        "/states/0/steps/0: step 'idle' (Idle) can never finish, so the sequence would stop there"]


def test_an_exception_sequence_used_inside_itself_is_a_load_error() -> None:
    found = problems([seq("s", wait("w", 1, monitors=[{"condition": "x > 0", "exception": "e"}]),
                          exceptions=[seq("e", wait("e1", 1, monitors=[{"condition": "x > 0", "exception": "e"}]))])],
                     x=0)
    assert found == ["/states/0/exceptions/0/steps/0/monitors/0/exception: exception sequence 'e' would start itself: "
                     "it is used inside itself"]


def test_bad_expressions_in_step_keys_are_located_load_errors() -> None:
    found = problems([seq("s", wait("w", 1, until="nope > 1"), wait("v", 1, precondition="x >"),
                          wait("u", 1, monitors=[{"condition": "1 / 0 > x"}]))], x=0)
    assert [f.split(":")[0] for f in found] == ["/states/0/steps/0/until", "/states/0/steps/1/precondition",
                                                "/states/0/steps/2/monitors/0/condition"]
    assert "unknown variable 'nope'" in found[0] and "division by zero" in found[2]


def test_duplicate_step_ids_and_an_empty_or_non_blocking_only_sequence() -> None:
    assert problems([seq("s", wait("w", 1), wait("w", 2))])[0].startswith("/states/0/steps/1/id: duplicate id 'w'")
    assert problems([seq("s", seq("bg", wait("b", 1), blocking=False))]) == [
        "/states/0/steps: a sequence needs at least one blocking step"]


def test_the_outcome_of_an_aborted_step_is_visible_to_a_later_precondition() -> None:
    aborted = {"type": "Outcome", "state": "slow", "outcome": "timeout"}
    m, _ = machine([seq("main", wait("slow", 10, timeout=1), setvar("retry", r=1) | {"precondition": aborted},
                        setvar("fine", f=1) | {"precondition": {"type": "Not", "condition": aborted}}), done()],
                   [route("main", "end")], r=0, f=0)
    assert fsm.run(m, duration=20).outcome == "succeeded"
    assert m.ctx.vars == {"r": 1, "f": 0}


def test_declared_inputs_make_an_unpressable_pause_button_and_a_misspelt_signal_load_errors() -> None:
    doc = {"name": "t", "initial": "main", "inputs": ["start", "pause_btn"],
           "states": [seq("main", {"id": "go", "type": "Step", "until": {"type": "SignalHigh", "signal": "strat"}},
                          pause_signal="pause")]}
    with pytest.raises(DiagramError) as err:
        fsm.load(doc)
    found = [f"{p.pointer}: {p.message}" for p in err.value.problems]
    assert found == [
        "/states/0/pause_signal: pause button 'pause' is not one of the machine's inputs (pause_btn, start)",
        "/states/0/steps/0/until/signal: signal 'strat' is not one of the machine's inputs (pause_btn, start)"]
    assert "did you mean 'pause_btn'?" in str(err.value) and "did you mean 'start'?" in str(err.value)
    doc["inputs"] = ["strat", "pause"]
    fsm.load(doc)  # declared: fine; without "inputs" nothing is checked
    del doc["inputs"]
    fsm.load(doc)


# -- a suspended owner aborted after its exception sequence (issue 34) ----------------------------------------
def _suspended_owner(behavior: str = "abortOwner", exception: bool = True, blocking: bool = False,
                     repeat: int = 1) -> tuple[fsm.Machine, Log]:
    """The issue's smallest case: S (non-blocking unless told) suspended at 0.5 s, 0.5 s into B1's 1 s wait."""
    monitor: dict[str, Any] = {"condition": "x > 0", "behavior": behavior}
    keys: dict[str, Any] = {"monitors": [monitor]}
    if exception:
        monitor["exception"] = "E"
        keys["exceptions"] = [seq("E", wait("w", 1.0))]
    s = seq("S", wait("B1", 1.0), wait("B2", 1.0), setvar("x_off", x=0), blocking=blocking, **keys)
    steps = [s, wait("A1", 3.0), {"id": "join", "type": "Join", "sequences": ["S"]}] if not blocking else [s, wait(
        "A1", 3.0)]
    m, log = machine([seq("main", *steps, repeat=repeat), done()], [route("main", "end")], x=0)
    fsm.run(m, duration=0.5)
    m.ctx.vars["x"] = 1
    return m, log


def test_abort_owner_after_an_exception_ends_a_non_blocking_owner_without_ticking_it_again() -> None:
    m, log = _suspended_owner()
    assert fsm.run(m, duration=10).outcome == "succeeded"
    suspended = 0.5 + DT  # x is seen at the next tick
    assert log.monitors == [(suspended, "main/S", "abortOwner")]
    assert log.entries("main/S/B2") == []  # B1 was not finished, S's next step not entered
    assert m.state("main/S").outcome == "aborted"
    assert not m.state("main/S/B1").finished
    assert log.when("main/join") == pytest.approx(3.0)  # S was done at suspended + 1 s; A1 takes 3 s


def test_abort_owner_without_exception_on_a_non_blocking_owner() -> None:
    m, log = _suspended_owner(exception=False)
    assert fsm.run(m, duration=10).outcome == "succeeded"
    assert log.entries("main/S/B2") == [] and m.state("main/S").outcome == "aborted"
    assert not m.state("main/S/B1").finished


def test_abort_owner_after_an_exception_on_a_blocking_owner_goes_on_with_the_callers_next_step() -> None:
    m, log = _suspended_owner(blocking=True)
    assert fsm.run(m, duration=10).outcome == "succeeded"
    resumed = 0.5 + DT + DT + 1.0  # E entered at 0.5125, its wait from the same tick: 1 s later it ends
    assert log.entries("main/S/B2") == [] and m.state("main/S").outcome == "aborted"
    assert log.when("main/A1") == pytest.approx(resumed - DT)


def test_nothing_after_an_exception_resumes_a_non_blocking_owner_where_it_was() -> None:
    m, log = _suspended_owner(behavior="nothing")
    fsm.run(m, duration=0.05)  # the monitor fired; x back to 0 so it does not fire again when S resumes
    m.ctx.vars["x"] = 0
    assert fsm.run(m, duration=10).outcome == "succeeded"
    # B1 stood still for the 1 s of E: its remaining 0.5 s runs after, so B2 is entered 1 s late
    assert log.when("main/S/B2") == pytest.approx(2.0)
    assert m.state("main/S").outcome == "succeeded" and m.state("main/S/B1").outcome == "succeeded"


def test_restart_owner_after_an_exception_restarts_a_non_blocking_owner_from_its_first_step() -> None:
    m, log = _suspended_owner(behavior="restartOwner")
    fsm.run(m, duration=0.05)
    m.ctx.vars["x"] = 0
    assert fsm.run(m, duration=10).outcome == "succeeded"
    restarted = log.entries("main/S")[-1]
    assert log.entries("main/S/B1")[-1] == restarted
    assert log.when("main/S/B2") == pytest.approx(restarted + 1.0)
    assert m.state("main/S").outcome == "succeeded"


def test_an_owner_aborted_while_suspended_runs_afresh_on_its_next_entry() -> None:
    m, log = _suspended_owner(blocking=True, repeat=2)
    fsm.run(m, duration=2.0)
    m.ctx.vars["x"] = 0
    assert fsm.run(m, duration=20).outcome == "succeeded"
    second = log.entries("main/S")[1]
    # no clock left frozen from the abort: B1 takes its full second in the second round
    assert log.when("main/S/B2") == pytest.approx(second + 1.0)


# -- rules of docs/semantics.md that had no test of their own -------------------------------------------------
def test_rule_1_the_timeout_is_checked_before_the_owners_other_monitors_and_one_fires_per_tick() -> None:
    monitors = [{"condition": "x > 0", "behavior": "abortOwner"}, {"condition": "x > 0", "behavior": "nothing"}]
    m, log = machine([seq("main", wait("w", 10, timeout=1.0, monitors=monitors), setvar("next", n=1)), done()],
                     [route("main", "end")], x=0, n=0)
    fsm.run(m, duration=1.0 - DT)
    m.ctx.vars["x"] = 1  # from the tick at 1.0 s on, the timeout and both monitors hold
    assert fsm.run(m, duration=5).outcome == "succeeded"
    assert log.monitors == [(1.0, "main/w", "abortOwner")]
    assert m.state("main/w").outcome == "timeout"  # the timeout, not the first monitor
    supervisor = supervisor_of(m.state("main/w"))
    assert supervisor is not None and [mon.fired for mon in supervisor.monitors] == [1, 0, 0]


def test_rule_2_an_exception_sequence_busy_for_another_owner_makes_the_firing_wait() -> None:
    def owner(name: str) -> dict[str, Any]:
        return seq(name, wait(f"{name}1", 10, monitors=[{"condition": "x > 0", "behavior": "abortOwner",
                                                          "exception": "E"}]), blocking=False)
    m, log = machine([seq("main", owner("A"), owner("B"), {"id": "j", "type": "Join", "sequences": ["A", "B"]},
                          exceptions=[seq("E", setvar("e1", n="n + 1"), wait("e2", 0.5))]), done()],
                     [route("main", "end")], x=0, n=0)
    fsm.run(m, duration=1.0 - DT)
    m.ctx.vars["x"] = 1
    assert fsm.run(m, duration=10).outcome == "succeeded"
    first, second = log.monitors
    assert first == (1.0, "main/A/A1", "abortOwner")
    # B's monitor held at 1.0 s too, but E was busy for A: B fires once E has ended for A (B is ticked after A)
    assert second[1] == "main/B/B1" and second[0] == pytest.approx(1.0 + DT + 0.5)
    assert log.entries("main/E") == [1.0, pytest.approx(1.0 + DT + 0.5)]
    assert m.ctx.vars["n"] == 2


@pytest.mark.parametrize("bad", [
    {"machine": {"initial": "q", "states": [{"id": "q", "type": "Wait", "secondz": 1,
                                             "monitors": [{"condition": "x > 0", "exception": "e1"}]}]}},
    {"monitors": [{"condition": "x > 0", "exception": "e1"}]},
    {"bogus": 2, "machine": {"initial": "q", "states": [{"id": "q", "type": "Wait", "seconds": 1,
                                                          "monitors": [{"condition": "x > 0", "exception": "e1"}]}]}},
])
def test_a_malformed_fsmstate_adds_no_spurious_missing_exception_sequence(bad: dict[str, Any]) -> None:
    """Issue 34 reported "no exception sequence 'e1'" for a declared one next to a malformed FSMState."""
    found = problems([seq("main", {"id": "f", "type": "FSMState", **bad},
                          wait("z", 1, monitors=[{"condition": "x > 0", "exception": "e1"}]),
                          exceptions=[seq("e1", wait("w", 1))])], x=0)
    assert found and not any("no exception sequence" in f for f in found), found
