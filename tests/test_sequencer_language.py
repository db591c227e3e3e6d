"""The sequencer's language as issue 23 settled it: repeat_while, actions on completion only, a top-level state that
ends the machine, steps that only a supervisor ends, timeouts read from variables, and the load-time messages that
were wrong (Join before its sequence, a broken exception sequence, timeout keys without a timeout)."""

from __future__ import annotations

from typing import Any

import pytest

import fsm
from fsm.model.errors import DiagramError, StateRuntimeError
from fsm.runtime.region import wiring


def doc(*states: dict[str, Any], transitions: list[dict[str, Any]] | None = None, **variables: Any) -> dict[str, Any]:
    return {"name": "t", "initial": states[0]["id"], "vars": variables, "states": list(states),
            "transitions": transitions or []}


def seq(id: str, *steps: dict[str, Any], **keys: Any) -> dict[str, Any]:
    return {"id": id, "type": "Sequence", "steps": list(steps), **keys}


def errors(document: dict[str, Any]) -> list[str]:
    _spec, problems = fsm.check(document)
    return [f"{p.pointer}: {p.message}" for p in problems if p.severity == "error"]


# -- the top level ------------------------------------------------------------------------------------------
def test_a_top_level_sequence_that_finishes_ends_the_machine_with_its_outcome() -> None:
    m = fsm.load(doc(seq("s", {"id": "a", "type": "Step"}, {"id": "b", "type": "Step"})))
    assert fsm.run(m, duration=1.0).outcome == "succeeded"
    assert m.finished and m.ticks == 2


def test_a_top_level_state_with_transitions_does_not_end_the_machine_when_it_finishes() -> None:
    m = fsm.load(doc(seq("s", {"id": "a", "type": "Step"}), {"id": "idle", "type": "Idle"},
                     transitions=[{"type": "Signal", "from": "s", "to": "idle", "signal": "go"}]))
    fsm.run(m, duration=0.5)
    assert not m.finished and m.root.active.finished


def test_an_aborted_top_level_sequence_ends_the_machine_with_aborted() -> None:
    m = fsm.load(doc(seq("s", {"id": "w", "type": "Wait", "seconds": 5},
                         monitors=[{"condition": "n > 0", "behavior": "abortOwner"}]), n=0))
    fsm.run(m, max_ticks=3)
    m.ctx.vars["n"] = 1
    assert fsm.run(m, duration=1.0).outcome == "aborted"


# -- repeat_while ----------------------------------------------------------------------------------------------
def test_repeat_while_runs_the_steps_again_while_the_condition_holds() -> None:
    m = fsm.load(doc(seq("s", {"id": "inc", "type": "SetVar", "assign": {"n": "n + 1"}}, repeat_while="n < 5"), n=0))
    assert fsm.run(m, duration=5.0).outcome == "succeeded"
    assert m.ctx.vars["n"] == 5


def test_repeat_while_checks_after_each_run_and_repeat_caps_it() -> None:
    m = fsm.load(doc(seq("s", {"id": "inc", "type": "SetVar", "assign": {"n": "n + 1"}}, repeat_while="n < 100",
                         repeat=3), n=0))
    fsm.run(m, duration=5.0)
    assert m.ctx.vars["n"] == 3
    m = fsm.load(doc(seq("s", {"id": "inc", "type": "SetVar", "assign": {"n": "n + 1"}}, repeat_while="false"), n=0))
    fsm.run(m, duration=5.0)
    assert m.ctx.vars["n"] == 1, "the steps run once before the condition is first checked"


def test_repeat_while_as_a_condition_object_and_a_bad_expression() -> None:
    m = fsm.load(doc(seq("s", {"id": "inc", "type": "SetVar", "assign": {"n": "n + 1"}},
                         repeat_while={"type": "Expr", "expr": "n < 2"}), n=0))
    fsm.run(m, duration=5.0)
    assert m.ctx.vars["n"] == 2
    found = errors(doc(seq("s", {"id": "inc", "type": "Step"}, repeat_while="n +"), n=0))
    assert any(e.startswith("/states/0/repeat_while:") for e in found), found


# -- on_complete ----------------------------------------------------------------------------------------------
def test_on_complete_runs_when_the_state_finished_by_itself_and_not_when_aborted() -> None:
    step = {"id": "w", "type": "Wait", "seconds": 0.1,
            "set": {"on_complete": {"done": "done + 1"}, "on_exit": {"left": "left + 1"}}}
    m = fsm.load(doc(seq("s", step), done=0, left=0))
    fsm.run(m, duration=1.0)
    assert (m.ctx.vars["done"], m.ctx.vars["left"]) == (1, 0), "the last step is not left: the machine ends"
    m = fsm.load(doc(seq("s", {**step, "seconds": 5}, monitors=[{"condition": "stop", "behavior": "abortOwner"}]),
                     done=0, left=0, stop=False))
    fsm.run(m, max_ticks=2)
    m.ctx.vars["stop"] = True
    fsm.run(m, duration=1.0)
    assert (m.ctx.vars["done"], m.ctx.vars["left"]) == (0, 1), "an abort leaves the step without completing it"


def test_on_complete_runs_in_the_tick_the_state_finishes_before_it_is_left() -> None:
    step = {"id": "a", "type": "Step", "set": {"on_complete": {"log": "log + 'c'"}, "on_exit": {"log": "log + 'x'"}}}
    m = fsm.load(doc(seq("s", step, {"id": "b", "type": "Step"}), log=""))
    fsm.run(m, max_ticks=1)
    assert m.ctx.vars["log"] == "cx"
    last = fsm.load(doc(seq("s", {"id": "a", "type": "Step", "set": {"on_complete": {"n": "n + 1"}}}), n=0))
    fsm.run(last, duration=1.0)
    assert last.finished and last.ctx.vars["n"] == 1, "the last step completes though it is never left"


# -- steps ended from outside ----------------------------------------------------------------------------------
def test_a_step_that_never_finishes_is_refused_unless_a_supervisor_can_end_it() -> None:
    idle = {"id": "idle", "type": "Idle"}
    assert any("can never finish" in e for e in errors(doc(seq("s", idle, {"id": "b", "type": "Step"}))))
    for ok in ({**idle, "timeout": 5, "timeout_behavior": "restartOwner"},
               {**idle, "monitors": [{"condition": "n > 0", "behavior": "abortOwner"}]},
               {**idle, "endless": True}):
        assert errors(doc(seq("s", ok, {"id": "b", "type": "Step"}), n=0)) == [], ok
    watched = seq("s", idle, {"id": "b", "type": "Step"}, monitors=[{"condition": "n > 0",
                                                                      "behavior": "restartOwner"}])
    assert errors(doc(watched, n=0)) == []


def test_timeout_keys_without_a_timeout_are_both_errors() -> None:
    for key, value in (("timeout_behavior", "restartOwner"), ("timeout_exception", "e")):
        found = errors(doc(seq("s", {"id": "a", "type": "Step", key: value})))
        assert f"/states/0/steps/0/{key}: {key} without a timeout" in found, found


# -- timeouts from variables --------------------------------------------------------------------------------
def test_a_timeout_read_from_a_variable_at_entry() -> None:
    step = {"id": "w", "type": "Idle", "timeout": "t_max", "timeout_behavior": "abortOwner"}
    m = fsm.load(doc(seq("s", step), t_max=0.5))
    fsm.run(m, duration=5.0)
    assert m.finished and m.now == pytest.approx(0.5, abs=0.02)
    m = fsm.load(doc(seq("s", step), t_max=-1))
    with pytest.raises(StateRuntimeError, match="a timeout is a number of seconds > 0"):
        fsm.run(m, duration=1.0)
    found = errors(doc(seq("s", {**step, "timeout": "'x'"}), t_max=1))
    assert any("/timeout:" in e for e in found), found


# -- load-time messages ----------------------------------------------------------------------------------------
def test_a_join_placed_before_its_non_blocking_sequence_says_so() -> None:
    d = doc(seq("s", {"id": "j", "type": "Join", "sequences": ["bg"]},
                seq("bg", {"id": "x", "type": "Step"}, blocking=False),
                {"id": "end", "type": "Step"}))
    found = errors(d)
    assert any("starts after this Join" in e for e in found) and not any("blocking step" in e for e in found), found


def test_a_broken_exception_sequence_gets_no_second_error_from_the_monitor_naming_it() -> None:
    d = doc(seq("s", {"id": "a", "type": "Idle", "monitors": [{"condition": "n > 0", "exception": "e1",
                                                                "behavior": "abortOwner"}]},
                exceptions=[seq("e1", {"id": "x", "type": "NoSuchStep"})]), n=0)
    found = errors(d)
    assert any("unknown state type 'NoSuchStep'" in e for e in found), found
    assert not any("no exception sequence" in e for e in found), found


# -- listeners see a precondition's skip -----------------------------------------------------------------------
def test_listeners_are_told_when_a_state_is_skipped_by_its_precondition() -> None:
    skipped: list[tuple[int, str]] = []

    class Probe(fsm.Listener):
        def on_skipped(self, ctx: fsm.Context, state: Any) -> None:
            skipped.append((ctx.tick, state.path))

    m = fsm.load(doc(seq("s", {"id": "a", "type": "Step"}, {"id": "b", "type": "Step", "precondition": "false"},
                         {"id": "c", "type": "Step"})))
    m.add_listener(Probe())
    fsm.run(m, duration=1.0)
    assert skipped == [(1, "s/b")]


def test_invalid_documents_are_diagram_errors() -> None:
    with pytest.raises(DiagramError):
        fsm.load(doc(seq("s", {"id": "a", "type": "Step", "timeout_behavior": "restartOwner"})))


# -- scenario inputs between ticks -----------------------------------------------------------------------------
@pytest.mark.parametrize("at", [0.0, 0.0125, 0.013, 0.02])
def test_a_scenario_set_in_the_first_tick_period_is_applied(tmp_path: Any, at: float,
                                                            capsys: pytest.CaptureFixture[str]) -> None:
    """A ``set`` input at a time in (0, dt] was dropped: it applies before the first tick at or after its time."""
    import json

    from fsm.tools.cli import main

    (tmp_path / "m.json").write_text(json.dumps({"name": "m", "initial": "idle", "vars": {"x": 0},
                                                 "states": [{"id": "idle", "type": "Idle"}]}))
    (tmp_path / "s.scenario.json").write_text(json.dumps({
        "machine": "m.json", "duration": 0.5, "inputs": [{"at": at, "set": {"x": 5}}],
        "expect": [{"at": 0.5, "vars": {"x": 5}}]}))
    assert main(["test", str(tmp_path / "s.scenario.json")]) == 0, capsys.readouterr()


# -- calling a declared sequence ---------------------------------------------------------------------------------
GRIP = seq("grip", {"id": "close", "type": "SetVar", "assign": {"grips": "grips + 1"}},
           {"id": "hold", "type": "Wait", "seconds": 0.1})


def test_the_same_sequence_is_called_twice_in_one_chain() -> None:
    main = seq("main", {"id": "g1", "type": "Call", "sequence": "grip"}, {"id": "move", "type": "Step"},
               {"id": "g2", "type": "Call", "sequence": "grip", "timeout": 5}, sequences=[GRIP])
    m = fsm.load(doc(main, grips=0))
    seen: list[str] = []

    class Entries(fsm.Listener):
        def on_transition(self, ctx: Any, source: Any, target: Any, transition: Any) -> None:
            seen.append(target.path)

    m.add_listener(Entries())
    assert fsm.run(m, duration=2.0).outcome == "succeeded"
    assert m.ctx.vars["grips"] == 2
    assert "main/g1/close" in seen and "main/g2/hold" in seen
    assert wiring(m.state("main/g2")).supervisor is not None, "the Call's own keys (a timeout) apply to its instance"


def test_a_call_of_an_undeclared_sequence_a_call_outside_a_sequence_and_a_recursive_call() -> None:
    found = errors(doc(seq("main", {"id": "g", "type": "Call", "sequence": "nope"}, sequences=[GRIP]), grips=0))
    assert any("no sequence 'nope' is declared for Call" in e and "/steps/0/sequence" in e for e in found), found
    found = errors(doc({"id": "g", "type": "Call", "sequence": "grip"}))
    assert any("a Call is a step of a Sequence" in e for e in found), found
    loop = seq("again", {"id": "inner", "type": "Call", "sequence": "again"})
    found = errors(doc(seq("main", {"id": "g", "type": "Call", "sequence": "again"}, sequences=[loop])))
    assert any("calls itself" in e for e in found), found


def test_a_problem_inside_a_sequence_called_twice_is_reported_once_at_its_declaration() -> None:
    bad = seq("grip", {"id": "close", "type": "SetVar", "assign": {"grips": "grips +"}})
    found = errors(doc(seq("main", {"id": "g1", "type": "Call", "sequence": "grip"},
                           {"id": "g2", "type": "Call", "sequence": "grip"}, sequences=[bad]), grips=0))
    assert len([e for e in found if e.startswith("/states/0/sequences/0/steps/0/assign/grips")]) == 1, found


# -- hostile documents and the Python API (issue 22) -------------------------------------------------------------
def test_nan_in_a_layout_and_a_number_too_long_are_located_errors(tmp_path: Any) -> None:
    bad = tmp_path / "nan.json"
    bad.write_text('{"initial": "a", "states": [{"id": "a", "type": "Idle", "layout": {"x": NaN}}]}')
    _spec, problems = fsm.check(str(bad))
    assert [(p.pointer, p.line) for p in problems] == [("/states/0/layout", 1)], problems
    long = tmp_path / "long.json"
    long.write_text('{"initial": "a", "vars": {"n": ' + "9" * 5000 + '}, "states": [{"id": "a", "type": "Idle"}]}')
    _spec, problems = fsm.check(str(long))
    assert len(problems) == 1 and "is too long to read" in problems[0].message and problems[0].column == 32


def test_machine_resolve_checks_its_arguments() -> None:
    m = fsm.load(doc({"id": "a", "type": "Idle"}))
    with pytest.raises(TypeError, match="path and scope are strings"):
        m.resolve(None)  # type: ignore[arg-type]
    with pytest.raises(KeyError):
        m.resolve("nope")
