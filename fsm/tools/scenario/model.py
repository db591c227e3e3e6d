"""The scenario document: pydantic models (the committed ``fsm/schema/scenario.schema.json`` is generated from
them), and reading a scenario file with every problem located (file:line:column and JSON pointer) at once.

A scenario names a machine (and optionally a world to drive the simulated car in), a timeline of inputs and a
list of expectations. Shape errors come from the models; the checks that need more (a bounce longer than its
press, a state name the machine does not have, a time after the end of the run) follow in :func:`load_scenario`.
"""

from __future__ import annotations

import copy
import dataclasses
import itertools
import json
import math
import os
import sys
import types
import typing
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, ClassVar, Literal, NamedTuple, Union

from pydantic import Discriminator, Field, Tag, TypeAdapter, ValidationError

from fsm.debug.breakpoints import CAR_READINGS
from fsm.loading.loader import check, machine_files, signal_names, uses_car
from fsm.loading.loader import compile as compile_spec
from fsm.loading.reading import parse_json_bytes, read_file_bytes, reader_for
from fsm.loading.registry import default_registry
from fsm.model.document import Source, file_schema, problems_from_validation
from fsm.model.errors import (
    DiagramError,
    FsmError,
    Problem,
    RegistrationError,
    UsageError,
    print_traceback,
    traceback_wanted,
)
from fsm.model.expr import ANY, BOOL, NUMBER, ExprError, kind_of, kind_phrase, parse
from fsm.model.jsonpos import pointer
from fsm.model.params import Int, ParamsBase
from fsm.model.problems import Problems
from fsm.session.session import NEVER, ticks_for
from fsm.states.plants import plant_problems, written_vars

from .. import did_you_mean
from .paths import active_matches as active_matches
from .paths import first_few, prefixes
from .paths import state_matches as state_matches
from .temporal import TEMPORAL_FUNCTIONS, FormulaError, compile_formula, formula_names, unbounded

if TYPE_CHECKING:
    from collections.abc import Callable, Iterator

    from pydantic_core import ErrorDetails

#: Runs longer than this many ticks are refused (the limit of ``fsmctl run`` without ``--max-ticks``).
MAX_TICKS = 10_000_000
#: Length of a run whose scenario gives neither ``duration`` nor ``max_ticks`` (as ``fsmctl run``), seconds.
DEFAULT_DURATION = 600.0
#: Default tick period (the TRAL car's 80 Hz), as the core's simulated clock.
DEFAULT_DT = 0.0125
#: Tolerance when comparing simulated times (ticks happen at exact multiples of ``dt``; floats do not).
EPS = 1e-9
#: A tick no run reaches (``max_ticks`` is at most one less): the tick of a time too far to count in ticks.

Value = Union[bool, int, float, str]  # noqa: UP007 - pydantic's strict union: true stays a bool, 1 an int


class ScenarioModel(ParamsBase):
    """Strict like machine documents: unknown keys, null, strings for numbers, NaN and infinity are errors."""

    def state_names(self) -> list[StateName]:
        """The states this element names, each with its JSON pointer inside the element."""
        return []

    def formulas(self) -> list[tuple[str, str]]:
        """The formulas of an expectation (of the temporal language): (key, text), the body first."""
        return []


class StateName(NamedTuple):
    """A state an expectation or input names: its id or path, where (a JSON pointer inside the element), and
    whether it is the start of a path (``active``) rather than a state's id or the end of its path."""

    name: str
    pointer: str
    prefix: bool = False


# -- inputs --------------------------------------------------------------------------------------------
class SignalInput(ScenarioModel):
    """A signal at a time: a pulse (high, then low again after ``width``) or, with ``value``, a level."""

    at: float = Field(ge=0, description="Simulated time in seconds.")
    signal: str = Field(min_length=1, description="Name of the input signal.")
    value: bool | None = Field(default=None, description="Set the signal to this level and leave it there "
                                                         "(instead of a pulse).")
    width: float | None = Field(default=None, gt=0, description="How long a pulse stays high, seconds "
                                                                "(default: one tick, dt).")


class Bounce(ScenarioModel):
    """Contact bounce of a button: after the first contact it opens and closes again ``count`` times, each level
    change ``interval`` seconds after the previous one, before it settles; the same on release."""

    count: Int = Field(ge=1, le=1000, description="How many times the contact bounces (opens and closes again).")
    interval: float = Field(gt=0, description="Seconds between two level changes while bouncing.")


class PressInput(ScenarioModel):
    """A button press: high at ``at``, low again ``duration`` seconds later, with optional contact bounce."""

    at: float = Field(ge=0, description="Simulated time of the first contact, seconds.")
    press: str = Field(min_length=1, description="Name of the button's signal.")
    duration: float = Field(default=0.2, gt=0, description="Seconds from the first contact to the release.")
    bounce: Bounce | None = Field(default=None, description="Contact bounce on press and on release.")


class SetInput(ScenarioModel):
    """Blackboard variables set at a time (before the tick at or after it)."""

    at: float = Field(ge=0, description="Simulated time in seconds.")
    set: dict[str, Value] = Field(min_length=1, description="Variable names and their new values.")


class PauseInput(ScenarioModel):
    """Pause the active state at a path and its subtree (as ``Machine.pause``), before the tick at or after
    ``at``."""

    at: float = Field(ge=0, description="Simulated time in seconds.")
    pause: str = Field(min_length=1, description="The state's path from the top ('run/work'); it must be active "
                                                 "then (a state that is not active is left alone).")

    def held(self) -> tuple[str, bool]:
        """(the state's path, paused)."""
        return self.pause.strip("/"), True


class ResumeInput(ScenarioModel):
    """Resume a paused state (as ``Machine.resume``), before the tick at or after ``at``."""

    at: float = Field(ge=0, description="Simulated time in seconds.")
    resume: str = Field(min_length=1, description="The paused state's path from the top.")

    def held(self) -> tuple[str, bool]:
        """(the state's path, paused)."""
        return self.resume.strip("/"), False


def _input_kind(value: Any) -> str | None:
    if isinstance(value, dict):
        for key in ("signal", "press", "set", "pause", "resume"):
            if key in value:
                return f"<{key}>"
    return None


Input = Annotated[
    Union[Annotated[SignalInput, Tag("<signal>")], Annotated[PressInput, Tag("<press>")],  # noqa: UP007
          Annotated[SetInput, Tag("<set>")], Annotated[PauseInput, Tag("<pause>")],
          Annotated[ResumeInput, Tag("<resume>")]],
    Discriminator(_input_kind, custom_error_type="input_kind",
                  custom_error_message="an input is an object with 'signal', 'press', 'set', 'pause' or 'resume' "
                                       "(and 'at')"),
]


# -- expectations --------------------------------------------------------------------------------------
#: A time window ``[start, end]`` in simulated seconds: an event at tick n counts when start <= n*dt <= end.
Window = Annotated[list[Annotated[float, Field(ge=0)]], Field(min_length=2, max_length=2)]
_WINDOW = "A time window [start, end] in simulated seconds: only events at a tick whose time lies in it count."


class Approx(ScenarioModel):
    """A number with a tolerance: the value holds when it is within ``tolerance`` of ``value``."""

    value: float = Field(description="The expected number.")
    tolerance: float = Field(ge=0, description="The largest difference allowed (absolute).")


class OutcomeExpect(ScenarioModel):
    """The machine (or, with ``state``, an inner state) finishes with this outcome (within the run's limits)."""

    outcome: str = Field(min_length=1, description="Expected outcome of the top-level Final state, or of 'state'.")
    state: str | None = Field(default=None, min_length=1,
                              description="An inner state (id or path): one of its runs finishes with this outcome "
                                          "('precondition_failed' for a step skipped by its precondition).")
    within: Window | None = Field(default=None, description=_WINDOW)

    def state_names(self) -> list[StateName]:
        return [] if self.state is None else [StateName(self.state, "/state")]


class _Counted(ScenarioModel):
    """How often an event happens: exactly ``count``, or ``min`` and/or ``max``; at least once without them."""

    within: Window | None = Field(default=None, description=_WINDOW)
    count: Int | None = Field(default=None, ge=0, description="Exactly this many times.")
    min: Int | None = Field(default=None, ge=0, description="At least this many times.")
    max: Int | None = Field(default=None, ge=0, description="At most this many times.")
    #: The key naming the state whose event is counted.
    event: ClassVar[str]

    def state_names(self) -> list[StateName]:
        return [StateName(getattr(self, self.event), "/" + self.event)]


class EnteredExpect(_Counted):
    """A state is entered and runs (an entry skipped by its precondition does not count: see ``skipped``)."""

    event: ClassVar[str] = "entered"
    entered: str = Field(min_length=1, description="State id or path ('grip/closing' matches 'run/work/grip/closing').")


class SkippedExpect(_Counted):
    """A state is entered and at once skipped because its precondition is false."""

    event: ClassVar[str] = "skipped"
    skipped: str = Field(min_length=1, description="State id or path.")


class ExitedExpect(_Counted):
    """A state is left (by a transition of its own level, with its parent, or by a restart)."""

    event: ClassVar[str] = "exited"
    exited: str = Field(min_length=1, description="State id or path.")


class InvariantExpect(ScenarioModel):
    """An expression that holds after every tick (within ``within``, if given)."""

    invariant: str = Field(min_length=1, description="An expression of the document language over the variables, "
                                                     "signal_NAME (true/false) and, with a world, car_NAME readings.")
    within: Window | None = Field(default=None, description="Only the ticks in this window are checked.")

    def formulas(self) -> list[tuple[str, str]]:
        return [("invariant", self.invariant)]


class FinishedExpect(ScenarioModel):
    """The machine has (``true``) or has not (``false``) finished when the run ends."""

    finished: bool = Field(description="Whether the machine reached a top-level Final state.")


class VisitsExpect(ScenarioModel):
    """These states are entered in this order (other states may be entered in between)."""

    visits: list[Annotated[str, Field(min_length=1)]] = Field(
        min_length=1, description="State ids or paths ('grip/closing' matches 'run/work/grip/closing').")

    def state_names(self) -> list[StateName]:
        return [StateName(name, pointer("visits", k)) for k, name in enumerate(self.visits)]


class NeverExpect(ScenarioModel):
    """None of these states is ever entered."""

    never: list[Annotated[str, Field(min_length=1)]] = Field(min_length=1, description="State ids or paths.")

    def state_names(self) -> list[StateName]:
        return [StateName(name, pointer("never", k)) for k, name in enumerate(self.never)]


_FORMULA = ("A formula: an expression of the document language over the variables, signal_NAME and car_NAME, with "
            "the state terms active(X), paused(X), suspended(X), entered(X), skipped(X), fired(X), outcome(X) and "
            "the terms prev(e), rose(b), fell(b), changed(e), start(e) (see docs/scenarios.md, 'Over time').")


class AtExpect(ScenarioModel):
    """At the first tick at or after ``at``: these states are active and these variables have these values."""

    at: float = Field(ge=0, description="Simulated time in seconds.")
    active: str | list[Annotated[str, Field(min_length=1)]] | None = Field(
        default=None, description="A state path (or a list of them) that is active: an active leaf's path equals it "
                                  "or starts with it and '/'.")
    vars: dict[str, Value | Approx] | None = Field(
        default=None, description="Blackboard variables and their expected values; a number may be given as "
                                  "{\"value\": 1.5, \"tolerance\": 0.01}.")
    paused: dict[str, bool] | None = Field(
        default=None, description="State id or path -> whether it is active and held by a pause (its own or an "
                                  "ancestor's).")
    suspended: dict[str, bool] | None = Field(
        default=None, description="State id or path -> whether it is active and suspended while a monitor's "
                                  "exception sequence runs (not by a pause).")
    holds: str | None = Field(default=None, min_length=1, description="A formula true at that tick. " + _FORMULA)

    def state_names(self) -> list[StateName]:
        names = [StateName(self.active, "/active", True)] if isinstance(self.active, str) else \
            [StateName(name, pointer("active", k), True) for k, name in enumerate(self.active or ())]
        return names + [StateName(name, pointer(key, name)) for key in ("paused", "suspended")
                        for name in getattr(self, key) or {}]

    def formulas(self) -> list[tuple[str, str]]:
        return [("holds", self.holds)] if self.holds is not None else []


class TemporalExpect(ScenarioModel):
    """An expectation over time: a formula that holds at every tick (``always``), at none (``never``) or at some
    (``eventually``); over a window, until another formula holds, or in the ticks after a trigger."""

    always: str | None = Field(default=None, min_length=1, description="Holds at every tick. " + _FORMULA)
    never: str | None = Field(default=None, min_length=1, description="Holds at no tick. " + _FORMULA)
    eventually: str | None = Field(default=None, min_length=1, description="Holds at some tick. " + _FORMULA)
    until: str | None = Field(default=None, min_length=1,
                              description="With always: the body must hold at every tick before the first tick this "
                                          "formula holds, and it must hold at some tick.")
    after: str | None = Field(default=None, min_length=1,
                              description="A trigger: from each tick it holds, the body is checked over the next "
                                          "'ticks' ticks (or 'seconds'); it must hold at least once.")
    ticks: Int | None = Field(default=None, ge=0, description="With after: how many ticks after the trigger "
                                                              "(the trigger's tick is tick 0).")
    seconds: float | None = Field(default=None, ge=0, description="With after: the same in simulated seconds.")
    nth: Int | None = Field(default=None, ge=1, description="With after: only the nth time the trigger holds.")
    within: Window | None = Field(default=None, description=_WINDOW)
    count: Int | None = Field(default=None, ge=0, description="With eventually: at exactly this many ticks.")
    min: Int | None = Field(default=None, ge=0, description="With eventually: at least at this many ticks.")
    max: Int | None = Field(default=None, ge=0, description="With eventually: at most at this many ticks.")
    at: list[Annotated[float, Field(ge=0)]] | None = Field(
        default=None, description="With eventually: the simulated times (s) of exactly the ticks it holds at.")

    def formulas(self) -> list[tuple[str, str]]:
        return [(k, v) for k in ("always", "never", "eventually", "until", "after") if (v := getattr(self, k))]


class TransitionCount(ScenarioModel):
    """Bounds on the number of transitions fired in the whole run (all levels; initial entries not counted)."""

    count: Int | None = Field(default=None, ge=0, description="Exactly this many.")
    min: Int | None = Field(default=None, ge=0, description="At least this many.")
    max: Int | None = Field(default=None, ge=0, description="At most this many.")


class TransitionsExpect(ScenarioModel):
    """How many transitions fire during the run."""

    transitions: TransitionCount


class MonitorFired(ScenarioModel):
    """Which monitor firings count, and how many there must be (at least one when no count is given)."""

    owner: str = Field(min_length=1,
                       description="The monitor's owner: a state id or path ('w2' matches 'main/sub/w2').")
    behavior: str | None = Field(default=None, min_length=1, description="Only firings with this behaviour.")
    kind: Literal["monitor", "timeout"] | None = Field(default=None, description="Only monitors, or only timeouts.")
    count: Int | None = Field(default=None, ge=0, description="Exactly this many.")
    min: Int | None = Field(default=None, ge=0, description="At least this many.")
    max: Int | None = Field(default=None, ge=0, description="At most this many.")
    at: list[Annotated[float, Field(ge=0)]] | None = Field(
        default=None, description="The simulated times (s) at which it fires, in order (each at the first tick at "
                                  "or after it).")
    within: Window | None = Field(default=None, description=_WINDOW)


class MonitorsExpect(ScenarioModel):
    """A monitor (or timeout) of a state fires during the run."""

    monitors: MonitorFired

    def state_names(self) -> list[StateName]:
        return [StateName(self.monitors.owner, "/monitors/owner")]


_EXPECT_KEYS = ("outcome", "finished", "visits", "never", "transitions", "entered", "skipped", "exited", "invariant",
                "at", "monitors")


def _expect_kind(value: Any) -> str | None:
    if isinstance(value, dict):
        if "always" in value or "eventually" in value or isinstance(value.get("never"), str):
            return "<temporal>"
        for key in _EXPECT_KEYS:
            if key in value:
                return f"<{key}>"
    return None


Expectation = Annotated[
    Union[Annotated[OutcomeExpect, Tag("<outcome>")], Annotated[FinishedExpect, Tag("<finished>")],  # noqa: UP007
          Annotated[VisitsExpect, Tag("<visits>")], Annotated[NeverExpect, Tag("<never>")],
          Annotated[TransitionsExpect, Tag("<transitions>")], Annotated[AtExpect, Tag("<at>")],
          Annotated[MonitorsExpect, Tag("<monitors>")], Annotated[EnteredExpect, Tag("<entered>")],
          Annotated[SkippedExpect, Tag("<skipped>")], Annotated[ExitedExpect, Tag("<exited>")],
          Annotated[InvariantExpect, Tag("<invariant>")], Annotated[TemporalExpect, Tag("<temporal>")]],
    Discriminator(_expect_kind, custom_error_type="expect_kind",
                  custom_error_message="an expectation is an object with one of 'outcome', 'finished', 'visits', "
                                       "'never', 'transitions', 'monitors', 'entered', 'skipped', 'exited', "
                                       "'invariant', 'always', 'eventually', or 'at' (with 'active', 'vars', "
                                       "'paused', 'suspended' and/or 'holds')"),
]

_MODELS: dict[str, type[ScenarioModel]] = {
    "<signal>": SignalInput, "<press>": PressInput, "<set>": SetInput, "<outcome>": OutcomeExpect,
    "<finished>": FinishedExpect, "<visits>": VisitsExpect, "<never>": NeverExpect,
    "<transitions>": TransitionsExpect, "<at>": AtExpect, "<monitors>": MonitorsExpect, "<pause>": PauseInput,
    "<resume>": ResumeInput, "<entered>": EnteredExpect, "<skipped>": SkippedExpect, "<exited>": ExitedExpect,
    "<invariant>": InvariantExpect, "<temporal>": TemporalExpect,
}


class TransitionRef(ScenarioModel):
    """Transitions of the machine: by source and target ids (at any level), optionally by type."""

    from_: str = Field(alias="from", min_length=1, description="The source state's id.")
    to: str = Field(min_length=1, description="The target state's id.")
    type: str | None = Field(default=None, min_length=1, description="Only transitions of this type.")


class Substitution(ScenarioModel):
    """For this test, states (by id or path, or every state of a type) or transitions are replaced: the element
    keeps its id (a transition its from and to) and its step keys; ``with`` gives the new type and parameters."""

    state: str | None = Field(default=None, min_length=1, description="A state id or path ('grip', 'main/grip').")
    type: str | None = Field(default=None, min_length=1, description="Every state of this type.")
    transition: TransitionRef | None = Field(default=None, description="Transitions from one state to another.")
    with_: dict[str, Any] = Field(alias="with", description="The replacement: {\"type\": \"Wait\", \"seconds\": 1} "
                                                            "and its parameters (step keys may be overridden).")


#: A matrix that expands to more cases than this needs ``--max-runs`` (``fsmctl test``, ``--fsm-max-runs`` in pytest).
MAX_RUNS = 10_000


class MatrixCase(ScenarioModel):
    """One named case of a matrix: the machine's variables it starts with, inputs added to the timeline, markers."""

    name: str = Field(min_length=1, max_length=200, description="The case's name: the scenario is reported as "
                                                                "'scenario[name]'.")
    vars: dict[str, Value] = Field(default_factory=dict, description="Variables of the machine set before it starts "
                                                                     "(their initial values for this case).")
    inputs: list[Input] = Field(default_factory=list, description="Inputs added to the scenario's timeline.")
    skip: str | None = Field(default=None, min_length=1, description="Do not run this case; the reason.")
    xfail: str | None = Field(default=None, min_length=1,
                              description="This case is expected to fail (a known bug); the reason. A case that "
                                          "passes is reported as XPASS.")


class Matrix(ScenarioModel):
    """One scenario run as several named cases: every combination of ``vars`` values, or the ``cases`` listed."""

    vars: dict[str, Annotated[list[Value], Field(min_length=1)]] | None = Field(
        default=None, min_length=1, description="Variable -> the initial values to try: one case per combination, "
                                                "named 'speed=0.2,load=1'.")
    cases: list[MatrixCase] | None = Field(default=None, min_length=1, description="The cases, each named.")


class Scenario(ScenarioModel):
    """A scenario test: a machine, a timeline of inputs and what the run must show."""

    schema_: str | None = Field(default=None, alias="$schema", description="JSON Schema for editors.")
    name: str | None = Field(default=None, min_length=1, description="Name in reports (default: the file's name).")
    description: str | None = Field(default=None, description="Free text for people.")
    machine: str = Field(min_length=1, description="The machine (.json or .uxf), relative to this file.")
    world: str | None = Field(default=None, min_length=1,
                              description="A world file, relative to this file: the machine drives the simulated "
                                          "car in it (as `fsmctl run --world`).")
    seed: Int = Field(default=0, ge=0, le=2**63 - 1, description="Seed of the car's sensor noise.")
    noise: bool = Field(default=True, description="Ultrasonic noise of the simulated car on or off.")
    plugins: list[Annotated[str, Field(min_length=1)]] = Field(
        default_factory=list, description="Modules (or .py files relative to this file) registering types.")
    dt: float | None = Field(default=None, gt=0, description="Tick period in seconds (default 0.0125, 80 Hz).")
    duration: float | None = Field(default=None, gt=0,
                                   description="Stop after this much simulated time (default 600 s without "
                                               "max_ticks).")
    max_ticks: Int | None = Field(default=None, gt=0, le=NEVER - 1, description="Stop after this many ticks.")
    plants: list[dict[str, Any]] = Field(
        default_factory=list, description="Simulated plants behind the machine (registered plant types): "
                                          "{\"name\": \"axis\", \"type\": \"Axis\", ...parameters}.")
    substitute: list[Substitution] = Field(
        default_factory=list, description="States or transitions replaced for this test (a long step by a Wait); "
                                          "the machine so changed is checked like any document.")
    inputs: list[Input] = Field(default_factory=list, description="The timeline of inputs.")
    expect: list[Expectation] = Field(min_length=1, description="What the run must show; all are checked.")
    matrix: Matrix | None = Field(default=None, description="Run this scenario as named cases (like "
                                                            "pytest.mark.parametrize): each is a test of its own.")
    skip: str | None = Field(default=None, min_length=1, description="Do not run this scenario; the reason.")
    xfail: str | None = Field(default=None, min_length=1,
                              description="This scenario is expected to fail (a known bug); the reason.")


# -- the schema ------------------------------------------------------------------------------------------
SCENARIO_SCHEMA_PATH = Path(__file__).resolve().parents[2] / "schema" / "scenario.schema.json"


def scenario_schema() -> dict[str, Any]:
    """The JSON Schema of scenario files (committed as ``fsm/schema/scenario.schema.json``)."""
    return file_schema(Scenario, "scenario.schema.json", "tral-fsm scenario",
                       "A scenario test for `fsmctl test`; generated from fsm.tools.scenario.model by "
                       "`python -m fsm.tools.scenario --schema`.")


def scenario_schema_text() -> str:
    return json.dumps(scenario_schema(), indent=2, ensure_ascii=False) + "\n"


# -- reading a scenario ----------------------------------------------------------------------------------
@dataclass
class LoadedScenario:
    """A checked scenario with everything a run needs: the checked machine, the world, the tick period."""

    file: str
    scenario: Scenario
    spec: Any
    registry: Any
    dt: float
    end_tick: int
    world_path: Path | None
    machine_files: list[str] = field(default_factory=list)
    #: The files of the scenario's plugins (its ``.py`` files, the files of the modules it names).
    plugin_files: list[str] = field(default_factory=list)
    #: the plants to attach: (class, validated parameters)
    plants: list[tuple[type, Any]] = field(default_factory=list)
    #: JSON pointer -> (line, column) of every input and expectation (for messages).
    positions: dict[str, tuple[int, int]] = field(default_factory=dict)
    state_paths: list[str] = field(default_factory=list)
    #: Problems that do not stop the run (a signal the machine does not read).
    warnings: list[Problem] = field(default_factory=list)
    #: the formulas of the expectations, compiled when the scenario was checked: (index, key) -> formula
    formulas: dict[tuple[int, str], Any] = field(default_factory=dict)
    #: a matrix case: its name, the variables the machine starts with, its markers (see :func:`cases`)
    case: str | None = None
    initial_vars: dict[str, Any] = field(default_factory=dict)
    skip: str | None = None
    xfail: str | None = None

    @property
    def name(self) -> str:
        return base_name(self.file, self.scenario.name) + (f"[{self.case}]" if self.case is not None else "")

    def where(self, ptr: str) -> str:
        """``file:line:column`` of the element at ``ptr``."""
        pos = self.positions.get(ptr)
        return f"{self.file}:{pos[0]}:{pos[1]}" if pos else self.file

    @property
    def inputs_files(self) -> list[str]:
        """Every file the run reads (for output checks): the scenario, the machine and its includes, the world,
        the plugins."""
        return ([self.file, *self.machine_files] + ([str(self.world_path)] if self.world_path else [])
                + self.plugin_files)


def base_name(file: str | Path, name: str | None = None) -> str:
    """A scenario's name in reports: its ``name``, or the file's name without ``.scenario.json``."""
    if name:
        return name
    base = Path(file).name
    return scenario_stem(base) or base


def scenario_stem(text: str) -> str:
    """``text`` without the ``.scenario.json`` (or ``.json``) it ends with."""
    for suffix in (".scenario.json", ".json"):
        if text.endswith(suffix):
            return text[: -len(suffix)]
    return text


def case_count(matrix: Matrix | None) -> int:
    """How many cases a matrix expands to (without expanding it)."""
    if matrix is None:
        return 1
    if matrix.cases is not None:
        return len(matrix.cases)
    return math.prod(len(v) for v in (matrix.vars or {}).values())


def _shown_value(value: Any) -> str:
    return json.dumps(value, ensure_ascii=False) if isinstance(value, (bool, str)) else f"{value:g}" \
        if isinstance(value, float) else str(value)


def case_plan(scenario: Scenario) -> list[tuple[str | None, dict[str, Any], list[Any], str | None, str | None]]:
    """The cases of a scenario, in order: (name or None without a matrix, variables, inputs added, skip, xfail); the
    scenario's own markers apply to every case (a case's own reason wins)."""
    m = scenario.matrix
    if m is None:
        return [(None, {}, [], scenario.skip, scenario.xfail)]
    if m.cases is not None:
        return [(c.name, dict(c.vars), list(c.inputs), c.skip or scenario.skip, c.xfail or scenario.xfail)
                for c in m.cases]

    names = list(m.vars or {})
    out: list[tuple[str | None, dict[str, Any], list[Any], str | None, str | None]] = []
    for combo in itertools.product(*(m.vars or {}).values()):
        label = ",".join(f"{n}={_shown_value(v)}" for n, v in zip(names, combo, strict=True))
        out.append((label, dict(zip(names, combo, strict=True)), [], scenario.skip, scenario.xfail))
    return out


def cases(loaded: LoadedScenario) -> list[LoadedScenario]:
    """The runs of a loaded scenario: itself without a matrix, else one per case (each with its own name, initial
    variables, timeline and markers)."""
    out = []
    for name, values, inputs, skip, xfail in case_plan(loaded.scenario):
        scenario = loaded.scenario if not inputs else loaded.scenario.model_copy(
            update={"inputs": [*loaded.scenario.inputs, *inputs]})
        out.append(dataclasses.replace(loaded, scenario=scenario, case=name, initial_vars=values, skip=skip,
                                       xfail=xfail))
    return out


def matrix_problems(scenario: Scenario, spec: Any, name: str, max_runs: int | None) -> list[Problem]:
    """A matrix too large for ``--max-runs``, duplicate case names, variables the machine does not have or of
    another kind, inputs after the end of the run."""
    m = scenario.matrix
    if m is None:
        return []
    if (m.vars is None) == (m.cases is None):
        return [Problem("a matrix has 'vars' (every combination of their values) or 'cases' (a list), one of them",
                        name, "/matrix", hint='"matrix": {"vars": {"speed": [0.2, 0.5]}}')]
    too_large = _matrix_size_problem(m, name, max_runs)
    if too_large is not None:
        return [too_large]
    problems: list[Problem] = []
    if m.cases is not None:
        problems += _case_problems(m.cases, scenario, name)
        where = [(pointer("matrix", "cases", k, "vars"), c.vars) for k, c in enumerate(m.cases)]
    else:
        where = [(pointer("matrix", "vars", v), {v: x}) for v, values in (m.vars or {}).items() for x in values]
    return _said_once(problems + _matrix_var_problems(where, getattr(spec, "vars", {}) or {}, name))


def _said_once(problems: list[Problem]) -> list[Problem]:
    """The problems without repeats: the first of those with the same place and words (the cases of a matrix share
    their variables)."""
    unique: dict[str, Problem] = {}
    for p in problems:
        unique.setdefault(f"{p.pointer}:{p.message}", p)
    return list(unique.values())


def _matrix_size_problem(m: Matrix, name: str, max_runs: int | None) -> Problem | None:
    n = case_count(m)
    if n <= (MAX_RUNS if max_runs is None else max_runs):
        return None
    how = (f"more than {MAX_RUNS:,} need --max-runs {n} (fsmctl test) or --fsm-max-runs {n} (pytest)"
           if max_runs is None else f"more than --max-runs {max_runs}")
    return Problem(f"the matrix expands to {n:,} cases; {how}", name, "/matrix",
                   hint="fewer values, or a table of 'cases'")


def _case_problems(cases: list[MatrixCase], scenario: Scenario, name: str) -> list[Problem]:
    """Cases named twice, and each case's inputs checked as the scenario's are."""
    problems: list[Problem] = []
    seen: set[str] = set()
    for k, c in enumerate(cases):
        if c.name in seen:
            problems.append(Problem(f"two cases are named '{c.name}'", name, pointer("matrix", "cases", k, "name"),
                                    hint="give each case its own name"))
        seen.add(c.name)
        problems += _case_input_problems(c.inputs, scenario, name, pointer("matrix", "cases", k, "inputs"))
    return problems


def _matrix_var_problems(where: list[tuple[str, dict[str, Any]]], declared: dict[str, Any], name: str
                         ) -> list[Problem]:
    """The matrix's variables the machine does not declare, or whose values are of another kind than its."""
    problems: list[Problem] = []
    for ptr, values in where:
        for var, value in values.items():
            at = ptr if ptr.endswith("/" + var) else ptr + "/" + var
            if var not in declared:
                problems.append(Problem(f"the machine has no variable '{var}'", name, at,
                                        hint=did_you_mean(var, sorted(declared))
                                        or "variables: " + (", ".join(sorted(declared)) or "none")))
                continue
            want, got = kind_of(declared[var]), kind_of(value)
            if ANY not in (want, got) and want != got:
                problems.append(Problem(f"'{var}' is {kind_phrase(want)} in the machine, this value is "
                                        f"{kind_phrase(got)}: {_shown_value(value)}", name, at))
    return problems


def _case_input_problems(inputs: list[Any], scenario: Scenario, name: str, ptr: str) -> list[Problem]:
    """A case's inputs: the checks of the scenario's own inputs, located under the case."""
    problems = []
    for p in element_problems(inputs, [], scenario, name):
        rest = (p.pointer or "").removeprefix("/inputs")
        problems.append(Problem(p.message, name, ptr + rest, hint=p.hint))
    return problems


def load_scenario(file: str | Path, plugins: tuple[str, ...] = (), max_runs: int | None = None) -> LoadedScenario:
    """Read and check a scenario and its machine (and world); raises :class:`DiagramError` with every problem.

    ``plugins`` (from ``fsmctl --plugin``) are loaded besides the scenario's own; ``max_runs`` (``--max-runs``)
    lets a matrix expand to more than :data:`MAX_RUNS` cases.
    """
    name = str(file)
    path = Path(file)
    raw = read_file_bytes(path, "scenario")
    repeated: list[Problem] = []
    if not raw.strip():
        raise DiagramError([Problem("file is empty; a scenario is a JSON object", name, line=1, column=1,
                                    hint='{"machine": "m.json", "expect": [{"outcome": "succeeded"}]}')])
    data, source = parse_json_bytes(raw, name, path.parent, duplicates=repeated)
    scenario, shape = _validated(data, path, name)
    problems = repeated + shape
    loaded: LoadedScenario | None = None
    if scenario is not None:
        problems += timeline_problems(scenario, name)
        loaded, more = _machine_unless_errors(scenario, path, name, problems, plugins, max_runs)
        problems += more
    _locate(problems, name, source)
    if loaded is None or errors_of(problems):
        raise DiagramError(sorted(problems, key=lambda p: (p.file != name, p.file or "", p.line or 0, p.column or 0)))
    loaded.positions = source.locator(_element_pointers(loaded.scenario))
    loaded.warnings = [p for p in problems if p.severity != "error"]
    return loaded


def _machine_unless_errors(scenario: Scenario, path: Path, name: str, found: list[Problem],
                           plugins: tuple[str, ...], max_runs: int | None) -> tuple[LoadedScenario | None,
                                                                                    list[Problem]]:
    """The scenario's machine loaded, when the scenario itself has no error so far (warnings do not stop it), with
    the matrix's problems; after an error, only whether the machine's file is missing."""
    if errors_of(found):
        machine = path.parent / scenario.machine
        return None, [] if machine.is_file() else [_missing_machine(machine, name)]
    loaded, problems = _load_machine(scenario, path, name, plugins)
    if loaded is not None:
        problems += matrix_problems(scenario, loaded.spec, name, max_runs)
    return loaded, problems


def errors_of(problems: list[Problem]) -> list[Problem]:
    """The problems that are errors (the rest are warnings, which do not stop a scenario)."""
    return [p for p in problems if p.severity == "error"]


def _validated(data: Any, path: Path, name: str) -> tuple[Scenario | None, list[Problem]]:
    """The scenario the document's data is, or ``None`` and why not: not an object, a machine document, or the
    models' problems (with the checks of the inputs and expectations whose shape is right)."""
    if not isinstance(data, dict):
        kind = "array" if isinstance(data, list) else type(data).__name__
        return None, [Problem(f"a scenario must be a JSON object, got {kind}", name,
                              hint='{"machine": "m.json", "expect": [{"outcome": "succeeded"}]}')]
    if {"states", "initial", "root"} & data.keys() and "expect" not in data:
        return None, [Problem("this is a machine document (it has 'states' or 'initial'), not a scenario test",
                              name, hint="run a machine with `fsmctl run FILE`; a scenario names it: "
                                         f'{{"machine": "{path.name}", "expect": [{{"outcome": "succeeded"}}]}}')]
    try:
        return Scenario.model_validate(data), []
    except ValidationError as err:
        return None, problems_from_errors(err, data, name) + _partial_problems(data, path, name)


def _locate(problems: list[Problem], name: str, source: Source) -> None:
    """Line and column for the scenario file's own problems by the located-problems path machine documents take
    (:class:`fsm.model.problems.Problems`): an error in a formula points at its character in the JSON string."""
    found = Problems()
    found.extend([p for p in problems if p.file == name and p.line is None], source)
    found.located()


def _element_pointers(scenario: Scenario) -> set[str]:
    return ({pointer("inputs", i) for i in range(len(scenario.inputs))}
            | {pointer("expect", i) for i in range(len(scenario.expect))} | {"/machine"})


# -- shape problems --------------------------------------------------------------------------------------------
#: The discriminators' own errors: an object that is no input (expectation) at all.
_KIND_ERRORS = ("input_kind", "expect_kind")


def problems_from_errors(err: ValidationError, data: Any, name: str) -> list[Problem]:
    """pydantic's errors as problems by the core's path, as a machine document's
    (:func:`fsm.model.document.problems_from_validation`): each is reported at the object it belongs to (an
    input, an expectation, a bounce, a matrix case), in its words and with "did you mean" among its keys."""
    groups: dict[tuple[str, type[ScenarioModel]], tuple[Any, str | None, list[ErrorDetails]]] = {}
    for e in err.errors(include_url=False):
        at, model, node, rest = _owner(e, data)
        group = groups.setdefault((pointer(*at), model), (node, _element(at), []))
        group[2].append({**e, "loc": tuple(rest)})
    problems: list[Problem] = []
    for (base, model), (node, element, details) in groups.items():
        found = problems_from_validation(details, source=Source(name=name), base=base, element=element, model=model,
                                         kind="key", data=node)
        if details[0]["type"] in _KIND_ERRORS and isinstance(node, dict) and node:
            found[0].hint = f"this one has {', '.join(repr(k) for k in sorted(node))}"
        problems += found
    return problems


def _owner(e: ErrorDetails, data: Any) -> tuple[list[Any], type[ScenarioModel], Any, list[Any]]:
    """Where an error's object starts in ``data`` (the innermost model its location passes through), that model,
    the object, and the error's location from there on (the union tags, ``<signal>``, left out)."""
    model: type[ScenarioModel] = Scenario
    at: list[Any] = []
    path: list[Any] = []
    owner, node = data, data
    expected: Any = Scenario
    found = True
    for token in e["loc"]:
        if isinstance(token, str) and token.startswith("<"):
            if found and token in _MODELS:  # the tagged union's branch: the object is this model
                model = expected = _MODELS[token]
                at, owner = list(path), node
            continue
        path.append(token)
        found = found and _has(node, token)
        if found:
            node, expected = node[token], _unwrap(_inner(expected, token))
            if isinstance(expected, type) and issubclass(expected, ScenarioModel) and isinstance(node, dict):
                model, at, owner = expected, list(path), node
    if e["type"] in _KIND_ERRORS:
        at, owner = path, node
    return at, model, owner, path[len(at):]


def _has(node: Any, token: Any) -> bool:
    if isinstance(node, dict):
        return isinstance(token, str) and token in node
    return isinstance(node, list) and isinstance(token, int) and 0 <= token < len(node)


def _inner(annotation: Any, token: Any) -> Any:
    """What a model's field, a list's item or a dict's value (``token`` into ``annotation``) should be."""
    if isinstance(annotation, type) and issubclass(annotation, ScenarioModel):
        fields = {f.alias or n: f for n, f in annotation.model_fields.items()}
        return fields[token].annotation if token in fields else None
    args = typing.get_args(annotation)
    origin = typing.get_origin(annotation)
    if origin is list and args:
        return args[0]
    return args[1] if origin is dict and len(args) == 2 else None


def _unwrap(annotation: Any) -> Any:
    """``annotation`` without ``Annotated`` and ``| None``."""
    while True:
        args = typing.get_args(annotation)
        if typing.get_origin(annotation) is Annotated:
            annotation = args[0]
        elif typing.get_origin(annotation) in (Union, types.UnionType) and len(args) == 2 and type(None) in args:
            annotation = args[0] if args[1] is type(None) else args[1]
        else:
            return annotation


def _element(at: list[Any]) -> str | None:
    if len(at) >= 2 and at[0] in ("inputs", "expect") and isinstance(at[1], int):
        return f"{'input' if at[0] == 'inputs' else 'expectation'} {at[1]}"
    return None


# -- checks beyond shape -----------------------------------------------------------------------------------
def _missing_machine(machine_path: Path, name: str) -> Problem:
    what = "is not a file" if machine_path.exists() else "not found"
    return Problem(f"machine file {what}: {machine_path}", name, "/machine",
                   hint="the machine's path is relative to the scenario file")


def _partial_problems(data: dict[str, Any], path: Path, name: str) -> list[Problem]:
    """When the scenario's shape is wrong somewhere: the checks of the inputs and expectations that are right
    (and of the machine's path), so that one run of ``fsmctl test`` reports every problem."""
    problems: list[Problem] = []
    machine = data.get("machine")
    if isinstance(machine, str) and machine and not (path.parent / machine).is_file():
        problems.append(_missing_machine(path.parent / machine, name))
    inputs = _shaped(data.get("inputs"), TypeAdapter(Input))
    expect = _shaped(data.get("expect"), TypeAdapter(Expectation))
    try:
        lim = Scenario.model_validate({"machine": "-", "expect": [{"outcome": "-"}],
                                       **{k: data[k] for k in ("dt", "duration", "max_ticks") if k in data}})
    except ValidationError:
        lim = None
    return problems + element_problems(inputs, expect, lim, name)


def _shaped(items: Any, adapter: TypeAdapter[Any]) -> list[Any]:
    """Each of ``items`` (when it is a list) as ``adapter`` validates it, ``None`` for one whose shape is wrong."""
    out: list[Any] = []
    for item in items if isinstance(items, list) else ():
        try:
            out.append(adapter.validate_python(item))
        except ValidationError:
            out.append(None)
    return out


class Limits(NamedTuple):
    """The tick period of a scenario's run and the tick at which it ends."""

    dt: float
    end_tick: int


def limits(scenario: Scenario) -> Limits:
    """The tick period and the tick at which the run ends (``duration`` and ``max_ticks``, the tighter)."""
    dt = scenario.dt or DEFAULT_DT
    ends = []
    if scenario.duration is not None or scenario.max_ticks is None:
        duration = scenario.duration if scenario.duration is not None else DEFAULT_DURATION
        ends.append(ticks_for(duration, dt))
    if scenario.max_ticks is not None:
        ends.append(scenario.max_ticks)
    return Limits(dt, min(ends))


def timeline_problems(scenario: Scenario, name: str) -> list[Problem]:
    """Problems of the timeline the models cannot see: a pulse with both a level and a width, a bounce that
    outlasts its press, times after the end of the run, a run of too many ticks."""
    problems: list[Problem] = []
    dt = scenario.dt or DEFAULT_DT
    duration = scenario.duration if scenario.duration is not None else DEFAULT_DURATION
    ticks = duration / dt
    where = "/dt" if scenario.dt is not None else "/duration"
    if scenario.max_ticks is None and not ticks <= MAX_TICKS:
        shown = f"{ticks:.3g}" if math.isfinite(ticks) else "infinitely many"
        problems.append(Problem(f"dt {dt:g} s over {duration:g} s makes {shown} ticks, more than {MAX_TICKS:,}",
                                name, where,
                                hint="give max_ticks to allow a run that long, or a larger dt / shorter duration"))
    elif limits(scenario).end_tick < 1:
        problems.append(Problem(f"dt {dt:g} s is longer than the run ({duration:g} s): not one tick would run",
                                name, where, hint="make dt shorter than the duration"))
    return problems + element_problems(list(scenario.inputs), list(scenario.expect), scenario, name)


def element_problems(inputs: list[Any], expect: list[Any], lim: Scenario | None, name: str) -> list[Problem]:
    """The checks of single inputs and expectations (``None`` for one whose shape is wrong); with ``lim``, the
    scenario whose ``dt``, ``duration`` and ``max_ticks`` give the end of the run, also times after it."""
    problems: list[Problem] = []
    end_time = math.inf
    if lim is not None:
        dt, end_tick = limits(lim)
        end_time = end_tick * dt if end_tick < NEVER else math.inf  # too many ticks: said of dt or duration
    for i, item in enumerate(inputs):
        if item is not None:
            problems += _input_problems(item, name, pointer("inputs", i), f"input {i}", end_time)
    for i, exp in enumerate(expect):
        problems += _expect_problems(exp, name, pointer("expect", i), f"expectation {i}", end_time)
    return problems


def _input_problems(item: Any, name: str, ptr: str, label: str, end_time: float) -> list[Problem]:
    """One input: a level and a pulse at once, a bounce as long as its press, a time after the run."""
    problems: list[Problem] = []
    if isinstance(item, SignalInput) and item.value is not None and item.width is not None:
        problems.append(Problem("'value' sets a level and 'width' makes a pulse; give one of them", name,
                                ptr + "/width", element=label,
                                hint="a pulse: {\"at\": 1, \"signal\": \"s\", \"width\": 0.1}; a level: "
                                     "{\"at\": 1, \"signal\": \"s\", \"value\": true}"))
    if isinstance(item, PressInput) and item.bounce is not None:
        settle = 2 * item.bounce.count * item.bounce.interval
        if not settle < item.duration:
            problems.append(Problem(
                f"the bounce lasts {settle:g} s ({item.bounce.count} bounces of two level changes "
                f"{item.bounce.interval:g} s apart), "
                f"not shorter than the press ({item.duration:g} s)", name, ptr + "/bounce", element=label,
                hint="make the press longer, or the bounce shorter or rarer"))
    if item.at > end_time + EPS:
        problems.append(Problem(f"at {item.at:g} s is after the end of the run ({end_time:g} s)", name,
                                ptr + "/at", element=label, hint="raise 'duration' (or 'max_ticks'), or move it"))
    return problems


def _expect_problems(exp: Any, name: str, ptr: str, label: str, end_time: float) -> list[Problem]:
    """One expectation: its window, and the checks of its kind (:data:`_EXPECT_CHECKS`)."""
    problems: list[Problem] = []
    monitors = isinstance(exp, MonitorsExpect)
    within = exp.monitors.within if monitors else getattr(exp, "within", None)
    if within is not None and within[1] < within[0]:
        problems.append(Problem(f"the window ends ({within[1]:g} s) before it starts ({within[0]:g} s)", name,
                                ptr + ("/monitors" if monitors else "") + "/within", element=label,
                                hint="a window is [start, end] with start <= end"))
    check = _EXPECT_CHECKS.get(type(exp))
    return problems + check(exp, name, ptr, label, end_time) if check is not None else problems


def _monitors_problems(exp: MonitorsExpect, name: str, ptr: str, label: str, end_time: float) -> list[Problem]:
    """A monitor expectation: its counts, and times after the end of the run."""
    problems = _count_problems(exp.monitors, name, ptr + "/monitors", label)
    return problems + [Problem(f"at {at:g} s is after the end of the run ({end_time:g} s)", name,
                               f"{ptr}/monitors/at/{k}", element=label, hint="raise 'duration' (or 'max_ticks')")
                       for k, at in enumerate(exp.monitors.at or ()) if at > end_time + EPS]


def _counted_problems(exp: _Counted, name: str, ptr: str, label: str, end_time: float) -> list[Problem]:
    return _count_problems(exp, name, ptr, label)


def _invariant_parse_problems(exp: InvariantExpect, name: str, ptr: str, label: str, end_time: float
                              ) -> list[Problem]:
    """An invariant that does not parse."""
    try:
        parse(exp.invariant, TEMPORAL_FUNCTIONS)
    except ExprError as exc:
        return [Problem(f"the invariant does not parse: {exc}", name, ptr + "/invariant", element=label,
                        hint="e.g. \"x >= 0 and not signal_estop\"", expr_column=exc.column)]
    return []


def _at_problems(exp: AtExpect, name: str, ptr: str, label: str, end_time: float) -> list[Problem]:
    """An 'at' expectation that checks nothing, or looks after the end of the run."""
    problems: list[Problem] = []
    if all(getattr(exp, key) is None for key in ("active", "vars", "paused", "suspended", "holds")):
        problems.append(Problem("an 'at' expectation needs 'active', 'vars', 'paused', 'suspended' or "
                                "'holds'", name, ptr, element=label, hint='{"at": 2.0, "active": "run/work"}'))
    if exp.at > end_time + EPS:
        problems.append(Problem(f"at {exp.at:g} s is after the end of the run ({end_time:g} s)", name,
                                ptr + "/at", element=label, hint="raise 'duration' (or 'max_ticks')"))
    return problems


def _transitions_problems(exp: TransitionsExpect, name: str, ptr: str, label: str, end_time: float
                          ) -> list[Problem]:
    """The bounds on the number of transitions: at least one, then as every count (:func:`_count_problems`)."""
    c = exp.transitions
    if unbounded(c):
        return [Problem("give 'count', 'min' or 'max'", name, ptr + "/transitions", element=label)]
    return _count_problems(c, name, ptr + "/transitions", label)


def _temporal_shape(exp: TemporalExpect, name: str, ptr: str, label: str, end_time: float) -> list[Problem]:
    """Which keys of a temporal expectation go together, and times after the end of the run."""
    modes = [k for k in ("always", "never", "eventually") if getattr(exp, k) is not None]
    if len(modes) != 1:
        return [Problem(f"give one of 'always', 'never' and 'eventually', not {' and '.join(repr(m) for m in modes)}",
                        name, ptr, element=label, hint='{"always": "x >= 0"}; two expectations for two formulas')]
    problems = [Problem(message, name, ptr + (f"/{key}" if key else ""), element=label, hint=hint)
                for message, key, hint in [*_trigger_conflicts(exp, modes[0]), *_count_conflicts(exp, modes[0])]]
    problems += _count_problems(exp, name, ptr, label)
    return problems + [Problem(f"at {at:g} s is after the end of the run ({end_time:g} s)", name, f"{ptr}/at/{k}",
                               element=label, hint="raise 'duration' (or 'max_ticks')")
                       for k, at in enumerate(exp.at or ()) if at > end_time + EPS]


def _trigger_conflicts(exp: TemporalExpect, mode: str) -> Iterator[tuple[str, str, str | None]]:
    """The keys of a temporal expectation's end (``until``) and trigger (``after`` and its span) that do not go with
    its mode or with each other: (message, key, hint)."""
    if exp.until is not None:
        if mode != "always":
            yield (f"'until' goes with 'always' ('{mode}' cannot take it)", "until",
                   '{"always": "not active(drive)", "until": "signal_start"}')
        if exp.after is not None:
            yield "'until' and 'after' do not go together: give 'after' with 'ticks' for a span after a trigger", \
                "until", None
    for key in ("ticks", "seconds", "nth"):
        if getattr(exp, key) is not None and exp.after is None:
            yield (f"'{key}' counts from a trigger: give 'after' too", key,
                   '{"eventually": "entered(B)", "after": "entered(A)", "ticks": 8}')
    if exp.ticks is not None and exp.seconds is not None:
        yield "give 'ticks' or 'seconds', not both", "seconds", None


def _count_conflicts(exp: TemporalExpect, mode: str) -> Iterator[tuple[str, str, str | None]]:
    """The counts of a temporal expectation (``count``, ``min``, ``max``, ``at``) where they do not go: (message,
    key, hint)."""
    counted = [k for k in ("count", "min", "max", "at") if getattr(exp, k) is not None]
    if counted and (mode != "eventually" or exp.after is not None):
        yield (f"'{counted[0]}' counts the ticks an 'eventually' (without 'after') holds at", counted[0],
               '{"eventually": "rose(paused(cycle))", "count": 2}')
    if exp.at is not None and counted != ["at"]:
        yield "'at' lists every tick already: give it alone, or 'count', 'min' and/or 'max'", "at", None


def _count_problems(c: Any, name: str, ptr: str, label: str) -> list[Problem]:
    if c.count is not None and (c.min is not None or c.max is not None):
        return [Problem("'count' is exact; give it alone, or 'min' and/or 'max'", name, ptr, element=label)]
    if c.min is not None and c.max is not None and c.min > c.max:
        return [Problem(f"'min' {c.min} is greater than 'max' {c.max}", name, ptr, element=label)]
    return []


#: The checks of each kind of expectation beyond its shape: (expectation, file, pointer, label, end of the run).
_EXPECT_CHECKS: dict[type[ScenarioModel], Callable[[Any, str, str, str, float], list[Problem]]] = {
    EnteredExpect: _counted_problems, SkippedExpect: _counted_problems, ExitedExpect: _counted_problems,
    InvariantExpect: _invariant_parse_problems, TemporalExpect: _temporal_shape, AtExpect: _at_problems,
    TransitionsExpect: _transitions_problems, MonitorsExpect: _monitors_problems,
}


def _world_problems(spec: Any, world_path: Path | None, machine_path: Path, base: Path, name: str) -> list[Problem]:
    """A car machine needs a world; a world named must load."""
    if world_path is None and uses_car(spec):
        return [Problem("this machine drives the car; name the world to drive it in", name, "",
                        hint=_world_hint(machine_path, base))]
    if world_path is not None and world_path.is_file():
        from fsm.sim.world import load_world

        try:
            load_world(world_path)
        except DiagramError as exc:
            return list(exc.problems)
    return []


def _pause_warnings(spec: Any, given: set[str], name: str) -> list[Problem]:
    """A warning for each pause button of the machine that the scenario never presses."""
    problems: list[Problem] = []
    for level in spec.levels():
        for st in level.states:
            pause = getattr(st.params, "pause_signal", None)
            if pause and pause not in given:
                problems.append(Problem(f"the pause button '{pause}' of '{st.id}' is never pressed by this scenario",
                                        name, "/inputs", severity="warning",
                                        hint=f'add {{"at": 1.0, "press": "{pause}"}} to test the pause'))
    return problems


def _signal_warnings(scenario: Scenario, known: set[str], name: str) -> list[Problem]:
    """A warning for each input of a signal the machine does not read."""
    problems: list[Problem] = []
    for i, item in enumerate(scenario.inputs):
        sig = _signal_of(item)
        if sig is not None and sig not in known:
            problems.append(Problem(f"the machine reads no signal '{sig}'", name, pointer("inputs", i),
                                    element=f"input {i}", severity="warning",
                                    hint=did_you_mean(sig, sorted(known))
                                    or "signals it reads: " + (", ".join(sorted(known)) or "none")))
    return problems


def _load_machine(scenario: Scenario, path: Path, name: str,
                  cli_plugins: tuple[str, ...]) -> tuple[LoadedScenario | None, list[Problem]]:
    """Check the machine (and world) a scenario names, and the state names its expectations use."""
    base = path.parent
    registry = default_registry(tuple(cli_plugins))  # a --plugin that fails is the command line's error
    plugin_files, problems = _load_plugins(scenario, base, name, registry)
    if problems:
        return None, problems
    machine_path = base / scenario.machine
    spec, world_path, problems = _checked_machine(scenario, base, name, registry)
    if spec is None:
        return None, problems
    files = machine_files(spec)
    if scenario.substitute:
        spec, problems = substituted(scenario, machine_path, registry, name)
        if spec is None:
            return None, problems
    dt, end_tick = limits(scenario)
    paths = [sp.path for sp in compile_spec(spec).states()]
    problems += name_problems(scenario, paths, name)
    plants, more = _plants(scenario, registry, name)
    problems += more + _plant_expression_problems(scenario, spec, plants, name)
    known = signal_names(spec)
    given = _driven_signals(scenario, plants)
    problems += _pause_warnings(spec, given, name)
    formulas: dict[tuple[int, str], Any] = {}
    problems += _invariant_problems(scenario, spec, known | given, world_path is not None, name, paths, formulas)
    problems += _signal_warnings(scenario, known, name)
    return LoadedScenario(file=name, scenario=scenario, spec=spec, registry=registry, dt=dt, end_tick=end_tick,
                          world_path=world_path, machine_files=files, plugin_files=plugin_files,
                          state_paths=paths, plants=plants, formulas=formulas), problems


def _driven_signals(scenario: Scenario, plants: list[tuple[type, Any]]) -> set[str]:
    """The signals the scenario drives: by its inputs (levels, pulses, presses) and by its plants."""
    given = {sig for item in scenario.inputs if (sig := _signal_of(item)) is not None}
    return given | {sig for cls, params in plants for sig in cls(params).signals()}


def _signal_of(item: Any) -> str | None:
    """The signal an input drives (a level, a pulse or a press), or ``None``."""
    return item.signal if isinstance(item, SignalInput) else item.press if isinstance(item, PressInput) else None


def _checked_machine(scenario: Scenario, base: Path, name: str, registry: Any
                     ) -> tuple[Any, Path | None, list[Problem]]:
    """The scenario's machine checked, with its world's path: (spec, world path, []); or ``None`` for the spec
    and the problems: a missing machine or world file, the machine's errors, a world it cannot drive in."""
    machine_path = base / scenario.machine
    if not machine_path.is_file():
        return None, None, [_missing_machine(machine_path, name)]
    problems: list[Problem] = []
    world_path = None if scenario.world is None else base / scenario.world
    if world_path is not None and not world_path.is_file():
        problems.append(Problem(f"world file not found: {world_path}", name, "/world",
                                hint="the world's path is relative to the scenario file"))
    spec, machine_problems = check(str(machine_path), registry=registry)
    errors = errors_of(machine_problems)
    if spec is None or errors:
        problems.append(Problem(f"the machine {machine_path} has {len(errors) or 1} error(s), listed with it", name,
                                "/machine"))
        return None, None, problems + (errors or machine_problems)
    problems += _world_problems(spec, world_path, machine_path, base, name)
    return (None if problems else spec), world_path, problems


def set_names(scenario: Scenario) -> list[str]:
    """The variables the scenario's ``set`` inputs set, in the order they are written (a name may repeat)."""
    return [k for item in scenario.inputs if isinstance(item, SetInput) for k in item.set]


def invariant_kinds(spec: Any, signals: set[str], car: bool, scenario: Scenario) -> dict[str, str]:
    """The names an invariant may use and their kinds: the machine's variables (and those the scenario sets),
    ``signal_NAME`` for every signal the machine reads or declares (``inputs``) or the scenario drives,
    ``car_NAME`` with a world."""
    kinds = {f"signal_{s}": BOOL for s in (*signals, *(getattr(spec, "inputs", None) or ()))}
    if car:
        kinds.update({f"car_{n}": NUMBER for n in CAR_READINGS})
    kinds.update(dict.fromkeys(set_names(scenario), ANY))
    kinds.update({k: kind_of(v) for k, v in getattr(spec, "vars", {}).items()})
    return kinds


def formula_kinds(loaded_spec: Any, signals: set[str], car: bool, scenario: Scenario) -> dict[str, str]:
    """The names formulas may read: those of :func:`invariant_kinds`, and with plants any other name (a variable a
    plant writes; read when the run starts)."""
    kinds = invariant_kinds(loaded_spec, signals, car, scenario)
    if scenario.plants:
        for exp in scenario.expect:
            for _key, text in exp.formulas():
                try:
                    names = formula_names(text)
                except ExprError:
                    names = []
                kinds.update({n: "any" for n in names if n not in kinds and not n.startswith(("signal_", "car_"))})
    return kinds


def _invariant_problems(scenario: Scenario, spec: Any, signals: set[str], car: bool, name: str,
                        paths: list[str], compiled: dict[tuple[int, str], Any]) -> list[Problem]:
    """Every formula of the expectations compiled against the machine (kept in ``compiled`` for the runs): located
    errors with suggestions."""
    problems: list[Problem] = []
    kinds = formula_kinds(spec, signals, car, scenario)
    for i, exp in enumerate(scenario.expect):
        for key, text in exp.formulas():
            try:
                compiled[i, key] = compile_formula(text, kinds, paths)
            except ExprError as exc:  # a FormulaError has its own hint (did you mean ...)
                hint = exc.hint if isinstance(exc, FormulaError) else "e.g. \"x >= 0 and not active(stopped)\""
                problems.append(Problem(f"{key}: {exc}", name, pointer("expect", i, key), element=f"expectation {i}",
                                        hint=hint, expr_column=exc.column))
    return problems


# -- substitution ------------------------------------------------------------------------------------------
_STEP_KEYS: tuple[str, ...] = ("id", "description", "set", "layout", "precondition", "until", "monitors", "timeout",
                               "timeout_behavior", "timeout_exception", "endless")


def _child_states(node: dict[str, Any]) -> Iterator[tuple[str, int, dict[str, Any]]]:
    """The objects in ``node``'s lists of states (``states``, ``steps``, ``exceptions``, ``sequences``, in that
    order): (key, index, element)."""
    for key in ("states", "steps", "exceptions", "sequences"):
        items = node.get(key)
        for i, el in enumerate(items if isinstance(items, list) else ()):
            if isinstance(el, dict):
                yield key, i, el


def _elements(node: Any, prefix: str, ptr: str) -> Any:
    """Every state element of a document (inline sub-machines, regions, steps, exceptions included): (path, JSON
    pointer, element), and every transition list: (None, pointer, list)."""
    if not isinstance(node, dict):
        return
    if isinstance(node.get("transitions"), list):
        yield None, ptr + "/transitions", node["transitions"]
    for key, i, el in _child_states(node):
        if isinstance(el.get("id"), str):
            path = prefix + el["id"]
            yield path, f"{ptr}/{key}/{i}", el
            yield from _elements(el, path + "/", f"{ptr}/{key}/{i}")
    regions = node.get("regions")
    for i, r in enumerate(regions if isinstance(regions, list) else ()):
        if isinstance(r, dict):
            yield from _elements(r, prefix + str(r.get("name", "")) + "/", f"{ptr}/regions/{i}")
    inline = node.get("machine")
    if isinstance(inline, dict) and "file" not in inline:
        yield from _elements(inline, prefix, ptr + "/machine")


def substituted(scenario: Scenario, machine_path: Path, registry: Any, name: str) -> tuple[Any, list[Problem]]:
    """The machine with the scenario's substitutions applied and checked: (spec, problems); ``None`` for the
    spec when a substitution matches nothing, names an unknown type or makes the machine invalid."""
    data, _source = reader_for(machine_path)(machine_path)
    doc = copy.deepcopy(data)
    _inline_includes(doc, machine_path.parent, [os.path.realpath(machine_path)])
    problems: list[Problem] = []
    touched: list[tuple[str, int]] = []  # (document pointer, substitution index)
    for k, sub in enumerate(scenario.substitute):
        problem = _substitution_problem(sub, pointer("substitute", k), registry, name)
        if problem is None:
            replaced = _substitute(doc, sub)
            touched += [(at, k) for at in replaced]
            problem = None if replaced else _no_match(sub, pointer("substitute", k), name)
        if problem is not None:
            problems.append(problem)
    if problems:
        return None, problems
    spec, found = check(doc, registry=registry, base_dir=machine_path.parent)
    errors = errors_of(found)
    if spec is not None and not errors:
        return spec, []
    return None, _said_of_substitutions(errors or found, touched, name)


def _substitution_problem(sub: Substitution, ptr: str, registry: Any, name: str) -> Problem | None:
    """What is wrong with a substitution before it is applied: not one target, or a replacement of no known type."""
    if sum(getattr(sub, key) is not None for key in ("state", "type", "transition")) != 1:
        return Problem("a substitution names one of 'state', 'type' or 'transition'", name, ptr,
                       hint='{"state": "grip", "with": {"type": "Wait", "seconds": 1}}')
    kind = sub.with_.get("type")
    what = "transition" if sub.transition is not None else "state"
    known = sorted(registry.transitions if sub.transition is not None else registry.states)
    if isinstance(kind, str) and kind in known:
        return None
    return Problem(f"unknown {what} type {kind!r}" if kind is not None else "the replacement needs a 'type'", name,
                   ptr + "/with" + ("/type" if kind else ""),
                   hint=did_you_mean(str(kind), known) or f"{what} types: " + ", ".join(known[:15]))


def _substitute(doc: Any, sub: Substitution) -> list[str]:
    """Apply one substitution to ``doc`` in place; the pointers of the elements it replaced."""
    replaced: list[str] = []
    for path, at, el in list(_elements(doc, "", "")):
        if path is None:
            replaced += _substitute_transitions(el, at, sub)
        elif _state_hit(sub, path, el):
            kept = {key: v for key, v in el.items() if key in _STEP_KEYS}
            el.clear()
            el.update({**kept, **sub.with_, "id": kept["id"]})
            replaced.append(at)
    return replaced


def _state_hit(sub: Substitution, path: str, el: dict[str, Any]) -> bool:
    if sub.state is not None:
        return state_matches(sub.state, path)
    return sub.type is not None and el.get("type") == sub.type


def _substitute_transitions(transitions: list[Any], at: str, sub: Substitution) -> list[str]:
    """Replace the transitions of one list that ``sub.transition`` names; their pointers."""
    ref = sub.transition
    if ref is None:
        return []
    replaced: list[str] = []
    for j, tr in enumerate(transitions):
        if isinstance(tr, dict) and (tr.get("from"), tr.get("to")) == (ref.from_, ref.to) and \
                ref.type in (None, tr.get("type")):
            transitions[j] = {"from": tr["from"], "to": tr["to"], **sub.with_}
            replaced.append(f"{at}/{j}")
    return replaced


def _no_match(sub: Substitution, ptr: str, name: str) -> Problem:
    ref = sub.transition
    if sub.state is not None:
        what = f"state '{sub.state}'"
    elif sub.type is not None or ref is None:
        what = f"state of type '{sub.type}'"
    else:
        what = f"transition from '{ref.from_}' to '{ref.to}'"
    return Problem(f"the machine has no {what} to substitute", name, ptr,
                   hint="a state's id or the end of its path, as 'visits' names it")


def _said_of_substitutions(found: list[Problem], touched: list[tuple[str, int]], name: str) -> list[Problem]:
    """The substituted machine's problems, each at the substitution that made it (under ``/with``); one problem per
    place in the scenario: a substitution that matched five states says a misspelt key once."""
    out = []
    for (at, message, hint), elements in _by_substitution(found, touched).items():
        named = sorted({e.removeprefix("state ") for e in elements if e})
        more = f" (in {len(elements)} states: {first_few(named, 6)})" if len(elements) > 1 and named else ""
        out.append(Problem(f"with this substitution the machine is invalid: {message}{more}", name, at, hint=hint))
    return out


def _by_substitution(found: list[Problem], touched: list[tuple[str, int]]) -> dict[tuple[str, str, str | None],
                                                                                list[str]]:
    """The problems grouped by where they are in the scenario (the substitution that replaced the element they are
    in, and their pointer inside it) and what they say: (pointer, message, hint) -> the elements said of."""
    grouped: dict[tuple[str, str, str | None], list[str]] = {}
    for p in found:
        where = next(((at, k) for at, k in touched if f"{p.pointer}/".startswith(at + "/")), None)
        at = pointer("substitute", where[1]) + "/with" + p.pointer[len(where[0]):] if where else \
            pointer("substitute", 0)
        grouped.setdefault((at, p.message, p.hint), []).append(p.element or "")
    return grouped


def _inline_includes(node: Any, base: Path, stack: list[str]) -> None:
    """Put the machines of ``{"file": ...}`` includes in place (their own includes too, relative to them), so that a
    substitution reaches the states inside them; a file that cannot be read is left as an include, for the
    machine's check to report."""
    if not isinstance(node, dict):
        return
    subs: list[tuple[Any, Any]] = []
    for _key, _i, el in _child_states(node):
        subs += _machine_slots(el)
        _inline_includes(el, base, stack)
    for holder, key in subs:
        sub = holder[key]
        if isinstance(sub, dict) and isinstance(sub.get("file"), str) and len(sub) == 1 and len(stack) < 32:
            _inline_one(holder, key, base, stack)
        else:
            _inline_includes(sub, base, stack)


def _machine_slots(el: dict[str, Any]) -> list[tuple[Any, Any]]:
    """Where a state holds a machine: its ``machine`` and each of its ``regions``, as (holder, key)."""
    slots: list[tuple[Any, Any]] = [(el, "machine")] if "machine" in el else []
    regions = el.get("regions")
    if isinstance(regions, list):
        slots += [(regions, i) for i in range(len(regions))]
    return slots


def _inline_one(holder: Any, key: Any, base: Path, stack: list[str]) -> None:
    """The machine of the include ``holder[key]`` in its place, when its file is there, readable and not one of the
    files being inlined (a cycle)."""
    path = os.path.realpath(base / holder[key]["file"])
    if path in stack or not os.path.isfile(path):
        return
    try:
        data, _source = reader_for(Path(path))(Path(path))
    except (DiagramError, OSError):
        return
    _inline_includes(data, Path(path).parent, [*stack, path])
    holder[key] = data


def _load_plugins(scenario: Scenario, base: Path, name: str, registry: Any) -> tuple[list[str], list[Problem]]:
    """Import the scenario's ``plugins`` into ``registry``: the files they were loaded from, and a problem at
    ``/plugins/N`` for each one that is missing or fails (the scenario's error, not the command line's)."""
    files: list[str] = []
    problems: list[Problem] = []
    for i, plugin in enumerate(scenario.plugins):
        target = str(base / plugin) if plugin.endswith(".py") else plugin
        problem = _plugin_problem(plugin, target, registry, pointer("plugins", i), name)
        if problem is not None:
            problems.append(problem)
            continue
        module = sys.modules.get(plugin) if not plugin.endswith(".py") else None
        files.append(target if module is None else str(getattr(module, "__file__", None) or target))
    return files, problems


def _plugin_problem(plugin: str, target: str, registry: Any, ptr: str, name: str) -> Problem | None:
    """Import one plugin (``target``: a module, or the path of the ``.py`` file ``plugin`` names) into
    ``registry``; the problem when it is missing or fails."""
    if plugin.endswith(".py") and not Path(target).is_file():
        return Problem(f"plugin file not found: {target}", name, ptr,
                       hint="plugin files are relative to the scenario file")
    try:
        registry.load_module(target)
    except UsageError as exc:  # its words name a --plugin flag: say it of the scenario's entry instead
        reason = str(exc).removeprefix(f"--plugin {target}: ").removeprefix(f"--plugin {target!r}: ")
        return Problem(f"plugin '{plugin}' cannot be loaded: {reason}", name, ptr)
    except RegistrationError as exc:
        if traceback_wanted():  # fsmctl --traceback: the plugin's own frames, before the located line
            print_traceback(exc)
        where = [getattr(exc, "file", None), getattr(exc, "line", None)]
        return Problem(f"plugin error: {' '.join(str(exc).split())}", name, ptr,
                       hint=f"it failed at {where[0]}:{where[1]}" if all(where) else None)
    return None


def named_files(file: str | Path) -> list[str]:
    """Every file a scenario names, as far as it can be told without running it: the scenario, its machine and
    the machine's includes, its world and its plugin files. For the output checks of a scenario whose loading
    stopped at a problem; never raises."""
    path = Path(file)
    try:
        data, _source = parse_json_bytes(read_file_bytes(path, "scenario"), str(file), path.parent)
    except (FsmError, RecursionError, MemoryError):
        data = None
    if not isinstance(data, dict):
        return [str(file)]
    plugins = data.get("plugins")
    named = [data.get("machine"), data.get("world")] + (plugins if isinstance(plugins, list) else [])
    return ([str(file)] + [str(path.parent / n) for n in named if isinstance(n, str) and n and "\0" not in n]
            + _machine_files(path.parent, data.get("machine")))


def _machine_files(base: Path, machine: Any) -> list[str]:
    """The files of a scenario's ``machine`` entry: its file and includes, and the files its problems are in, as far
    as it loads; never raises."""
    if not isinstance(machine, str):
        return []
    try:
        if (base / machine).is_file():
            spec, problems = check(str(base / machine), registry=default_registry())
            return machine_files(spec) + [p.file for p in problems if p.file]
    except (FsmError, RecursionError, OSError, ValueError):
        pass
    return []


def _plants(scenario: Scenario, registry: Any, name: str) -> tuple[list[tuple[type, Any]], list[Problem]]:
    """The scenario's plants: each type registered and its parameters valid (located problems otherwise)."""
    out: list[tuple[type, Any]] = []
    problems: list[Problem] = []
    names: set[str] = set()
    for i, raw in enumerate(scenario.plants):
        ptr = pointer("plants", i)
        kind = raw.get("type")
        cls = registry.plants.get(kind) if isinstance(kind, str) else None
        if cls is None:
            known = sorted(registry.plants)
            problems.append(Problem(f"unknown plant type {kind!r}" if kind is not None else "a plant needs a 'type'",
                                    name, ptr + ("/type" if kind is not None else ""), element=f"plant {i}",
                                    hint=did_you_mean(str(kind), known) or ("plant types: " + ", ".join(known)
                                    if known else "load the plugin that registers it (\"plugins\": [...])")))
            continue
        try:
            params = cls.Params.model_validate(raw)
        except ValidationError as err:
            problems += problems_from_validation(err, source=Source(name=name), base=ptr, element=f"plant {i}",
                                                 model=cls.Params, kind="parameter", data=raw)
            continue
        if params.name in names:
            problems.append(Problem(f"two plants are named '{params.name}'", name, ptr + "/name", element=f"plant {i}",
                                    hint="give each plant its own name"))
            continue
        names.add(params.name)
        out.append((cls, params))
    return out, problems


def _plant_expression_problems(scenario: Scenario, spec: Any, plants: list[tuple[type, Any]],
                                name: str) -> list[Problem]:
    """The expressions of the library's plants (``rate``, ``take``, ``press_when``, ``when``) over the machine's
    variables, those the scenario sets and those the plants write."""
    kinds = {k: kind_of(v) for k, v in (getattr(spec, "vars", {}) or {}).items()}
    kinds.update(dict.fromkeys(set_names(scenario), ANY))
    for cls, params in plants:
        kinds.update({v: "any" for v in written_vars(cls, params)})
    problems = []
    for cls, params in plants:
        i = next(k for k, raw in enumerate(scenario.plants) if raw.get("name") == params.name)
        for key, message, hint in plant_problems(cls, params, kinds):
            problems.append(Problem(f"{key}: {message}", name, pointer("plants", i, key), element=f"plant {i}",
                                    hint=hint))
    return problems


def name_problems(scenario: Scenario, paths: list[str], name: str) -> list[Problem]:
    """The state names and paths of the scenario's expectations and pause inputs that name no state of ``paths``."""
    known = _KnownStates(paths)
    problems: list[Problem] = []
    for i, exp in enumerate(scenario.expect):
        for state in exp.state_names():
            unknown = known.unknown(state)
            if unknown is not None:
                problems.append(Problem(unknown[0], name, pointer("expect", i) + state.pointer,
                                        element=f"expectation {i}", hint=unknown[1]))
    for i, inp in enumerate(scenario.inputs):
        if isinstance(inp, (PauseInput, ResumeInput)) and inp.held()[0] not in paths:
            target, paused = inp.held()
            problems.append(Problem(f"the machine has no state at the path '{target}'", name,
                                    pointer("inputs", i, "pause" if paused else "resume"), element=f"input {i}",
                                    hint=known.path_hint(target)))
    return problems


class _KnownStates:
    """A machine's state paths, to tell whether (and how nearly) a name an expectation gives is one of them."""

    def __init__(self, paths: list[str]) -> None:
        self.paths = paths
        self.ids = sorted({p.rsplit("/", 1)[-1] for p in paths} | set(paths))
        self.prefixes = prefixes(paths)

    def unknown(self, state: StateName) -> tuple[str, str] | None:
        """(message, hint) when ``state`` names no state (no path starting with it, for a prefix), else ``None``."""
        if state.prefix and state.name.strip("/") in self.prefixes:
            return None
        if not state.prefix and any(state_matches(state.name, p) for p in self.paths):
            return None
        what = "no state path starts with" if state.prefix else "the machine has no state"
        close = did_you_mean(state.name, sorted(self.prefixes) if state.prefix else self.ids, n=3)
        return f"{what} '{state.name}'", close or self.listed()

    def path_hint(self, target: str) -> str:
        """What to write for ``target``, no state's path from the top: the one path it is the end of, paths spelt
        alike, or the first states."""
        suffix = [p for p in self.paths if state_matches(target, p)]
        return f"a path from the top: {suffix[0]!r}" if len(suffix) == 1 else \
            did_you_mean(target, self.paths, n=3) or self.listed()

    def listed(self) -> str:
        return "states: " + first_few(self.paths, 12)


def _world_hint(machine: Path, base: Path) -> str:
    """``"world": PATH`` with the world ``fsmctl run`` would take for the machine, relative to the scenario."""
    from fsm.sim.world import default_world

    try:
        found = default_world(str(machine))
    except UsageError:
        return 'add "world": "PATH/TO/WORLD.json", relative to the scenario file'
    world = os.path.relpath(found, base.resolve())
    if world.split(os.sep).count("..") > 2:
        return f'add "world": "{found}", the world fsmctl run takes for this machine'
    return f'add "world": "{world}", the world fsmctl run takes for this machine, relative to the scenario file'
