"""The runtime's wiring of a state or transition is one record in one slot (``_fsm``): a plugin author's instance holds
their own names, and may use ``region``, ``transitions``, ``supervisor`` (or ``kind``, ``test``, ``run``) for
themselves without the runtime noticing. The old names still read the record for one release, with a warning."""

from __future__ import annotations

import textwrap
from pathlib import Path
from typing import Any

import pytest

import fsm
from fsm.runtime.region import StateWiring, TransitionWiring, transition_wiring, wiring
from fsm.runtime.state import Life, use_record
from test_typing import errors_where_marked

#: What the base classes put in an instance: identity, parameters, how it finished, its predicates, the record.
STATE_BASE = {"id", "params", "path", "finished", "outcome", "predicates", "_fsm"}
TRANSITION_BASE = {"params", "source", "target", "conditions", "_fsm"}


class Counter(fsm.State[fsm.StateParams]):
    """A plugin state written without ``__slots__``: its instance ``__dict__`` is its author's."""

    can_finish = True

    def __init__(self, id: str, params: fsm.StateParams | None = None) -> None:
        super().__init__(id, params)
        self.count = 0

    def tick(self, ctx: fsm.Context) -> None:
        self.count += 1
        if self.count >= 3:
            self.finish("succeeded")


class Squatter(fsm.State[fsm.StateParams]):
    """A plugin state whose own attributes are named like the runtime's old wiring."""

    can_finish = True

    def __init__(self, id: str, params: fsm.StateParams | None = None) -> None:
        super().__init__(id, params)
        self.region = "north"
        self.regions = ["north", "south"]
        self.transitions = 0
        self.supervisor = "Ada"
        self.checks = ["brakes"]

    def on_enter(self, ctx: fsm.Context) -> None:
        self.transitions += 1

    def tick(self, ctx: fsm.Context) -> None:
        ctx.vars["seen"] = f"{self.region}/{self.supervisor}/{self.transitions}/{self.checks[0]}"
        if self.time_in_state(ctx) >= 0.05:
            self.finish("succeeded")


class Plain(fsm.State[fsm.StateParams]):
    """What ``Squatter`` does, without attributes of its own."""

    can_finish = True

    def tick(self, ctx: fsm.Context) -> None:
        ctx.vars["seen"] = "plain"
        if self.time_in_state(ctx) >= 0.05:
            self.finish("succeeded")


class SlottedSquatter(fsm.State[fsm.StateParams]):
    """The same names as ``__slots__`` of a plugin class."""

    __slots__ = ("region", "supervisor", "transitions")
    can_finish = True

    def __init__(self, id: str, params: fsm.StateParams | None = None) -> None:
        super().__init__(id, params)
        self.region, self.supervisor, self.transitions = "east", None, ()

    def tick(self, ctx: fsm.Context) -> None:
        self.finish("succeeded")


class Busy(fsm.Transition[fsm.TransitionParams]):
    """A plugin transition with attributes named like the old wiring of a transition (``kind``, ``test``, ``run``,
    ``effect``, ``index``-free): firing is decided by ``holds`` alone."""

    def __init__(self, params: fsm.TransitionParams, source: fsm.State[Any], target: fsm.State[Any],
                 index: int = 0) -> None:
        super().__init__(params, source, target, index)
        self.kind = "mine"
        self.test = False
        self.run = "not a function"
        self.effect = None
        self.arm = 3

    def holds(self, ctx: fsm.Context) -> bool:
        return bool(ctx.vars.get("seen"))


def registry() -> fsm.Registry:
    builtins = fsm.Registry.with_builtins()
    out = fsm.Registry()
    for cls in (Counter, Squatter, Plain, SlottedSquatter, builtins.states["Final"], builtins.states["FSMState"],
                builtins.states["Sequence"], builtins.states["Wait"]):
        out.add_state(cls)
    for tcls in (Busy, builtins.transitions["Finished"], builtins.transitions["Timeout"]):
        out.add_transition(tcls)
    return out


def machine(squatter: str = "Squatter", slotted: str = "SlottedSquatter") -> fsm.Machine:
    """Squatters inside a nested machine and a sequence with a timeout monitor, so that every old name the
    runtime used (a level, sub-levels, transitions, a supervisor) has a meaning of its own here."""
    inner = {"initial": "sq", "states": [{"id": "sq", "type": squatter}, {"id": "slot", "type": slotted},
                                         {"id": "done", "type": "Final"}],
             "transitions": [{"type": "Busy", "from": "sq", "to": "slot"},
                             {"type": "Finished", "from": "slot", "to": "done"}]}
    return fsm.load({"initial": "nest", "states": [
        {"id": "nest", "type": "FSMState", "machine": inner},
        {"id": "count", "type": "Counter"},
        {"id": "seq", "type": "Sequence", "timeout": 5, "steps": [{"id": "w", "type": "Wait", "seconds": 0.1}]},
        {"id": "end", "type": "Final"}],
        "transitions": [{"type": "Finished", "from": "nest", "to": "count"},
                        {"type": "Finished", "from": "count", "to": "seq"},
                        {"type": "Finished", "from": "seq", "to": "end"}]}, registry=registry())


def test_the_base_puts_one_slot_of_wiring_in_an_instance() -> None:
    assert set(fsm.State.__slots__) == STATE_BASE and set(fsm.Transition.__slots__) == TRANSITION_BASE
    m = machine()
    assert fsm.run(m).outcome == "succeeded"
    counter = m.state("count")
    assert vars(counter) == {"count": 3}, "a plugin state's __dict__ holds its author's names only"
    busy = wiring(m.state("nest/sq")).transitions[0]
    assert set(vars(busy)) == {"kind", "test", "run", "effect", "arm"}
    assert isinstance(counter._fsm, StateWiring) and isinstance(busy._fsm, TransitionWiring)
    assert wiring(counter) is counter._fsm and transition_wiring(busy) is busy._fsm


def test_a_plugin_may_name_its_attributes_region_transitions_supervisor() -> None:
    m = machine()
    result = fsm.run(m)
    assert result.outcome == "succeeded"
    assert m.ctx.vars["seen"] == "north/Ada/1/brakes"
    sq = m.state("nest/sq")
    assert (sq.region, sq.regions, sq.transitions, sq.supervisor) == ("north", ["north", "south"], 1, "Ada")
    assert wiring(sq).region is not None and wiring(sq).region.path == "nest"
    assert wiring(sq).transitions[0].type_name == "Busy"
    slotted = m.state("nest/slot")
    assert (slotted.region, slotted.supervisor, slotted.transitions) == ("east", None, ())
    assert wiring(m.state("seq")).supervisor is not None, "the sequence's timeout is supervised"
    assert m.transition_count == 5


def test_the_runtime_reads_no_plugin_attribute_of_those_names() -> None:
    """The same machine with plain states gives the same run: the squatters' names change nothing."""
    plain = machine("Plain", "Counter")
    for state in plain.states_by_path.values():
        assert isinstance(state._fsm, StateWiring)
    first = [(e.tick, e.path) for e in _entries(plain)]
    second = [(e.tick, e.path) for e in _entries(machine())]
    assert [p for _t, p in first] == [p for _t, p in second] == ["nest", "nest/sq", "nest/slot", "nest/done", "count",
                                                                 "seq", "seq/w", "end"]
    assert [t for t, _p in first][:3] == [t for t, _p in second][:3]


class _Entry:
    def __init__(self, tick: int, path: str) -> None:
        self.tick, self.path = tick, path


def _entries(m: fsm.Machine) -> list[_Entry]:
    seen: list[_Entry] = []

    class Watch(fsm.Listener):
        def on_transition(self, ctx: fsm.Context, source: Any, target: Any, transition: Any) -> None:
            seen.append(_Entry(ctx.tick, target.path))

    m.add_listener(Watch())
    fsm.run(m)
    return seen


def test_the_old_names_read_the_record_with_a_warning() -> None:
    m = machine()
    fsm.run(m)
    count = m.state("count")
    with pytest.warns(DeprecationWarning, match=r"Counter\.region is deprecated.*wiring\(state\)\.region"):
        assert count.region is wiring(count).region  # type: ignore[attr-defined]
    with pytest.warns(DeprecationWarning, match="transitions"):
        assert count.transitions == wiring(count).transitions  # type: ignore[attr-defined]
    with pytest.warns(DeprecationWarning, match="supervisor"):
        assert m.state("seq").supervisor is wiring(m.state("seq")).supervisor  # type: ignore[attr-defined]
    with pytest.warns(DeprecationWarning, match="regions"):
        assert m.state("nest").regions == wiring(m.state("nest")).regions  # type: ignore[attr-defined]
    with pytest.warns(DeprecationWarning, match=r"Counter\.checks is deprecated.*predicates"):
        assert count.checks is count.predicates  # type: ignore[attr-defined]


def test_a_state_in_no_machine_keeps_its_clock_and_finishes() -> None:
    lone = Counter("lone")
    assert isinstance(lone._fsm, StateWiring), "made with its record: the runtime is imported"
    assert lone.active and not lone.paused and wiring(lone).region is None
    lone.finish("succeeded")
    assert lone.finished and lone.outcome == "succeeded" and lone._fsm.completed
    with pytest.warns(DeprecationWarning):
        assert lone.region is None and lone.regions == ()  # type: ignore[attr-defined]


def test_a_state_made_before_the_runtime_is_wired_when_asked() -> None:
    """Made with the base record (:class:`Life`, what ``fsm.runtime.state`` alone knows), a state gets its full
    record from ``wiring`` the first time, keeping its clock and how it finished."""
    use_record(Life)
    try:
        early = Counter("early")
    finally:
        use_record(StateWiring)
    assert type(early._fsm) is Life and early.active
    early.finish("succeeded")
    record = wiring(early)
    assert isinstance(record, StateWiring) and record.completed and record.state is early
    assert wiring(early) is record and early._fsm is record


# -- the plugin contract type-checks written the natural way -------------------------------------------------------
PLUGIN = textwrap.dedent('''
    from collections.abc import Callable
    from typing import Any

    from fsm import Context, Machine, State, StateParams, Transition, TransitionParams
    from fsm.model.params import ConditionParams
    from fsm.runtime.condition import Condition
    from fsm.runtime.context import MachineView, StateView


    class FollowParams(StateParams):
        leader: str


    class Follow(State[FollowParams]):
        can_finish = True
        leader: State[Any]

        def bind(self, machine: Machine) -> None:
            self.leader = machine.state(self.params.leader)

        def tick(self, ctx: Context) -> None:
            if self.leader.finished:
                self.finish("succeeded")


    class Watch(State[FollowParams]):
        leader: StateView

        def bind(self, machine: MachineView) -> None:
            self.leader = machine.resolve(self.params.leader)


    class Joined(Transition[TransitionParams]):
        other: State[Any]

        def bind(self, machine: Machine) -> None:
            self.other = machine.state("a")

        def holds(self, ctx: Context) -> bool:
            return self.other.active


    class Near(Condition[ConditionParams]):
        def bind(self, machine: Machine, owner: State[Any]) -> None:
            super().bind(machine, owner)

        def holds(self, ctx: Context) -> bool:
            return True


    class Own(State[StateParams]):
        region: str
        transitions: int
        supervisor: str | None

        def on_enter(self, ctx: Context) -> None:
            self.region, self.transitions, self.supervisor = "north", 1, None
            until: Callable[[Context], bool] | None = self.predicates.get("until")


    class Wrong(State[StateParams]):
        def bind(self, machine: Machine, extra: int) -> None:  # error: not the contract's signature
            pass


    old: int = Own("x").checks  # error: the old name is not offered to type checkers
''')


def test_the_plugin_contract_type_checks_written_the_natural_way(tmp_path: Path) -> None:
    """``bind(machine: Machine)`` and ``bind(machine: MachineView)`` are both accepted by mypy strict, as are a
    plugin's own ``region``/``transitions``/``supervisor``; a ``bind`` of another signature is not."""
    done = errors_where_marked(tmp_path / "natural_plugin.py", PLUGIN)
    assert 'Signature of "bind" incompatible with supertype' in done.stdout
