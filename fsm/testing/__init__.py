"""Testing machines from Python with the scenario vocabulary (installed as ``fsm.testing``).

:class:`MachineTest` loads a machine, starts it (in its initial states, or in a given state with given
variables), takes inputs tick by tick and checks expectations written exactly as in a scenario file
(docs/scenarios.md); a failed expectation raises :class:`AssertionError` with the lines ``fsmctl test`` prints,
the trace around the first diverging tick included. The pytest plugin (:mod:`fsm.testing.plugin`, registered
through the ``pytest11`` entry point) gives it as the ``fsm_machine`` fixture and collects ``*.scenario.json``
files as test items::

    def test_grip_times_out(fsm_machine):
        m = fsm_machine("diagrams/examples/sorter.json", state="cycle/grip", vars={"parts": 2})
        m.run_for(2.5)
        m.expect({"monitors": {"owner": "grip", "kind": "timeout", "count": 1}},
                 {"outcome": "timeout", "state": "grip"}, {"vars": {"parts": 2}})

This sits above :mod:`fsm.tools` (it uses the scenario runner), like the CLI: the core never imports it.
"""

from __future__ import annotations

import difflib
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from fsm.model.errors import DiagramError
from fsm.runtime.region import wiring
from fsm.session.session import NEVER, PauseState, Session, SetSignal, SetVars, StopRules, tick_at

__all__ = ["MachineTest", "ScenarioError"]


class ScenarioError(AssertionError):
    """A failed check, or a scenario that could not run: ``lines`` as ``fsmctl test`` prints them."""

    def __init__(self, lines: list[str]) -> None:
        super().__init__("\n".join(lines))
        self.lines = lines


class _Every:
    """Every tick (the snapshots a test by hand may look back at)."""

    def __contains__(self, tick: object) -> bool:
        return True


class MachineTest:
    """A machine under test, ticked by hand; see the module's documentation.

    ``source``: a machine file (``.json`` or ``.uxf``) or a document dict. ``state``: a state path from the top
    to start in instead of the initial states (each level on the way starts at the state the path names).
    ``vars``: variables set before the start. ``dt``: the tick period (default 80 Hz). ``plugins``: modules or
    ``.py`` files registering types. ``plants``: simulated parts behind the machine, as a scenario's ``plants``
    (``[{"name": "axis", "type": "Axis", "speed": 0.25}]``). ``world``: a world file (relative paths as the fixture
    resolves the machine's): the machine drives the simulated car in it, ``seed`` and ``noise`` drive its sensors;
    a machine that drives the car needs one. Invariants may then read ``car_front``, ``car_speed``, ...
    """

    def __init__(self, source: str | os.PathLike[str] | Mapping[str, Any], *, state: str | None = None,
                 vars: Mapping[str, Any] | None = None, dt: float | None = None, plugins: tuple[str, ...] = (),
                 plants: list[Mapping[str, Any]] | None = None,
                 base_dir: str | os.PathLike[str] | None = None, world: str | os.PathLike[str] | None = None,
                 seed: int = 0, noise: bool = True) -> None:
        from fsm.loading.loader import check
        from fsm.loading.loader import compile as compile_spec
        from fsm.loading.registry import default_registry
        from fsm.tools.scenario.model import DEFAULT_DT, LoadedScenario, Scenario
        from fsm.tools.scenario.runner import Recording

        self.file = str(source) if not isinstance(source, Mapping) else "<document>"
        registry = default_registry(tuple(plugins))
        doc: Any = dict(source) if isinstance(source, Mapping) else str(source)
        spec, problems = check(doc, registry=registry, base_dir=base_dir)
        errors = [p for p in problems if p.severity == "error"]
        if spec is None or errors:
            raise DiagramError(errors or problems)
        self.dt = dt if dt is not None else DEFAULT_DT
        plan = compile_spec(spec)
        self.paths = [sp.path for sp in plan.states()]
        self.session = self._open(plan, spec, world, seed, noise)
        self.machine = self.session.machine
        finished = Scenario.model_validate({"machine": self.file, "expect": [{"finished": True}]})
        self._loaded = LoadedScenario(file=self.file, scenario=finished, spec=spec, registry=registry, dt=self.dt,
                                      end_tick=NEVER - 1, world_path=Path(world) if world is not None else None,
                                      state_paths=self.paths)
        # every tick's snapshot and every state's outcome: a test may look back at any of them
        self.record = self.machine.add_listener(Recording(_Every(), list(self.machine.states_by_path.values())))
        for raw in plants or ():
            self._attach_plant(raw, registry.plants)
        if vars:
            self.machine.ctx.vars.update(vars)
        self._start(state)
        self.record.on_tick(self.machine)

    def _open(self, plan: Any, spec: Any, world: str | os.PathLike[str] | None, seed: int, noise: bool) -> Session:
        """The session: the car in a world (as a scenario's "world" and `fsmctl run --world`), or no car."""
        stop = StopRules(max_ticks=NEVER - 1)
        if world is not None:
            from fsm.sim import simulate

            return simulate(plan, world=world, seed=seed, noise=noise, dt=self.dt, stop=stop)
        from fsm.loading.loader import uses_car

        if uses_car(spec):
            raise ValueError("this machine drives the car: give the world to drive it in, "
                             "fsm_machine(..., world=\"worlds/hallway.json\")")
        return Session.open(plan, dt=self.dt, stop=stop, record=False)

    def _attach_plant(self, raw: Mapping[str, Any], plants: Mapping[str, Any]) -> None:
        """A simulated part, as a scenario's ``plants`` entry, attached to the machine."""
        kind = raw.get("type")
        cls = plants.get(kind) if isinstance(kind, str) else None
        if cls is None:
            raise ValueError(f"unknown plant type {kind!r}; plant types: "
                             + (", ".join(sorted(plants)) or "none (load the plugin that registers it)"))
        cls(cls.Params.model_validate(dict(raw))).attach(self.machine)

    # -- starting ------------------------------------------------------------------------------------------------
    def _start(self, state: str | None) -> None:
        if state is None:
            self.session.start()
            return
        path = state.strip("/")
        if path not in self.paths:
            raise ValueError(self._no_state(state, path))
        parts = path.split("/")
        # the state and each of its owners start their regions, for this start only
        found = (self.machine.states_by_path.get("/".join(parts[:k])) for k in range(1, len(parts) + 1))
        saved = [(region, region.initial, st) for st in found
                 if st is not None and (region := wiring(st).region) is not None]
        for region, _initial, st in saved:
            region.initial = st
        try:
            self.session.start()
        finally:
            for region, initial, _st in reversed(saved):
                region.initial = initial

    def _no_state(self, state: str, path: str) -> str:
        """No state at ``path``: the paths that end with it or are spelt alike, or the first states."""
        close = [p for p in self.paths if p.endswith("/" + path)] or difflib.get_close_matches(path, self.paths, n=3)
        return f"the machine has no state at the path {state!r}" + (
            f"; did you mean {' or '.join(repr(c) for c in close)}?" if close else
            f"; states: {', '.join(self.paths[:12])}")

    # -- inputs, applied before the next tick ---------------------------------------------------------------------
    def set(self, **values: Any) -> MachineTest:
        """Set blackboard variables before the next tick."""
        self.session.submit(SetVars(values))
        return self

    def signal(self, name: str, value: bool = True) -> MachineTest:
        """Set an input signal's level before the next tick (an edge when it changes)."""
        self.session.submit(SetSignal(name, value))
        return self

    def pulse(self, name: str) -> MachineTest:
        """The signal high for the next tick, low again after it."""
        self.signal(name, True).tick()
        return self.signal(name, False)

    def pause(self, path: str = "") -> MachineTest:
        """Pause the active state at ``path`` (from the top; the whole machine without one) before the next tick."""
        self.session.submit(PauseState(path.strip("/"), True))
        return self

    def resume(self, path: str = "") -> MachineTest:
        self.session.submit(PauseState(path.strip("/"), False))
        return self

    # -- ticking ----------------------------------------------------------------------------------------------
    def tick(self, n: int = 1) -> MachineTest:
        """Run ``n`` ticks (fewer if the machine finishes); an invariant that fails raises at once."""
        __tracebackhide__ = True
        for _ in range(n):
            if self.machine.finished:
                break
            self.session.step(1)
            self._invariants()
        return self

    def run_for(self, seconds: float) -> MachineTest:
        """Run until ``seconds`` of simulated time more have passed (or the machine finishes)."""
        return self.tick(max(0, tick_at(self.machine.now + seconds, self.dt) - self.machine.ticks))

    def always(self, invariant: str) -> MachineTest:
        """Check ``invariant`` (an expression over variables, ``signal_NAME``) now and after every tick."""
        from fsm.loading.loader import signal_names
        from fsm.model.expr import BOOL, ExprError, compile_expr
        from fsm.tools.scenario.model import invariant_kinds
        from fsm.tools.scenario.runner import InvariantWatch, expression_names

        signals = set(signal_names(self._loaded.spec)) | set(self.machine.ctx.signals)
        kinds = invariant_kinds(self._loaded.spec, signals, self._loaded.world_path is not None, self._loaded.scenario)
        kinds.update({k: "any" for k in self.machine.ctx.vars if k not in kinds})
        try:
            fn = compile_expr(invariant, kinds, want=BOOL).fn
        except ExprError as exc:
            raise ValueError(f"invariant {invariant!r}: {exc}") from None
        names = expression_names(invariant)
        watch = InvariantWatch(len(self.record.invariants), invariant, fn, names,
                               all(not n.startswith(("signal_", "car_")) for n in names), self.machine.ticks, NEVER,
                               tuple(sorted(signals)))
        self.record.invariants.append(watch)
        watch.check(self.machine, self.machine.ticks)
        self._invariants()
        return self

    def _invariants(self) -> None:
        __tracebackhide__ = True
        from fsm.tools.scenario.model import InvariantExpect

        for w in self.record.invariants:
            if w.failed is not None and not w.reported:
                w.reported = True
                self._fail([(InvariantExpect(invariant=w.text), w.index)])

    # -- expectations ---------------------------------------------------------------------------------------------
    def expect(self, *expectations: Mapping[str, Any]) -> MachineTest:
        """Check expectations written as in a scenario's ``expect``; ``active``, ``vars``, ``paused`` and
        ``suspended`` without ``at`` look at the machine now. Raises :class:`ScenarioError` with every failure."""
        __tracebackhide__ = True
        now = round(self.machine.ticks * self.dt, 9)
        sc = self._scenario(expectations, now)
        self._refuse_unusable(sc, now)
        self._fail([(e, i) for i, e in enumerate(sc.expect)])
        return self

    def _scenario(self, expectations: tuple[Mapping[str, Any], ...], now: float) -> Any:
        """The expectations as a scenario's (without a time, what the machine is ``now``); ValueError with the
        located problems of one that is not written as a scenario's."""
        from pydantic import ValidationError

        from fsm.tools.scenario.model import Scenario, problems_from_errors

        items = [{**e, "at": now} if _now_is_meant(e) else dict(e) for e in expectations]
        data = {"machine": self.file, "expect": items}
        try:
            return Scenario.model_validate(data)
        except ValidationError as err:
            raise ValueError("\n".join(str(p) for p in problems_from_errors(err, data, "expect"))) from None

    def _refuse_unusable(self, sc: Any, now: float) -> None:
        """ValueError for expectations a test by hand cannot check: checked while a run goes on, naming what the
        machine does not have, or looking after ``now``."""
        from fsm.tools.scenario.model import AtExpect, InvariantExpect, TemporalExpect, element_problems, name_problems

        during = [i for i, e in enumerate(sc.expect) if isinstance(e, (InvariantExpect, TemporalExpect))
                  or getattr(e, "holds", None) is not None]
        if during:
            raise ValueError(f"expect[{during[0]}]: invariants and the temporal language (always, never, eventually, "
                             "holds) are checked while a run goes on: use m.always(\"...\") for an invariant, or a "
                             "scenario file")
        problems = element_problems([], list(sc.expect), None, "expect") + name_problems(sc, self.paths, "expect")
        late = [f"expect[{i}]: at {e.at:g} s is after now ({now:g} s)" for i, e in enumerate(sc.expect)
                if isinstance(e, AtExpect) and e.at > now + 1e-9]
        if problems or late:
            raise ValueError("\n".join([str(p) for p in problems if p.severity == "error"] + late))

    def _fail(self, checks: list[tuple[Any, int]]) -> None:
        __tracebackhide__ = True
        from fsm.tools.scenario.runner import Checker

        checker = Checker(self._loaded, self.machine, self.record, [], [])
        failures = [f for e, i in checks if (f := checker.expectation(i, e)) is not None]
        if failures:
            raise ScenarioError([line for f in failures for line in f.lines()])

    # -- what a test reads ------------------------------------------------------------------------------------------
    @property
    def active_paths(self) -> list[str]:
        return list(self.machine.active_paths)

    @property
    def vars(self) -> dict[str, Any]:
        return self.machine.ctx.vars

    @property
    def now(self) -> float:
        return self.machine.now

    @property
    def outcome(self) -> str | None:
        return self.machine.outcome


def _now_is_meant(expectation: Mapping[str, Any]) -> bool:
    """``active``, ``vars``, ``paused`` and ``suspended`` without ``at`` (and not of ``monitors``) look at now."""
    keys = expectation.keys()
    return "at" not in keys and "monitors" not in keys and bool({"active", "vars", "paused", "suspended"} & keys)


def scenario_lines(path: str | Path, coverage: Any = None, case: str | None = None, max_runs: int | None = None,
                   marked: bool = False) -> tuple[bool, list[str]]:
    """Run one scenario file (or, with ``case``, that case of its matrix; without, every case): (passed, the lines
    ``fsmctl test`` prints for it). ``marked``: pytest applies the skip and xfail markers itself, so the run
    ignores them and reports plainly."""
    import dataclasses

    from fsm.model.errors import printable
    from fsm.tools.scenario import load_scenario, run_scenario
    from fsm.tools.scenario.model import cases

    try:
        loaded = load_scenario(path, max_runs=max_runs)
    except DiagramError as exc:
        name = Path(path).name.removesuffix(".scenario.json") or str(path)
        return False, [printable(str(p)) for p in exc.problems] + [f"ERROR {name}: invalid scenario"]
    runs = [c for c in cases(loaded) if case is None or c.case == case]
    if not runs:
        return False, [f"ERROR {loaded.name}: no case '{case}' in its matrix"]
    lines = [printable(str(w)) for w in loaded.warnings]
    passed = True
    for run in runs:
        if marked:
            run = dataclasses.replace(run, skip=None, xfail=None)
        result = run_scenario(run, coverage)
        passed = passed and result.passed
        lines += [printable(result.summary_line())]
        lines += [printable(f"    {line}") for f in result.failures for line in f.lines()]
    return passed, lines
