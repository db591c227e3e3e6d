"""Plants without Python: a small library of simulated machine parts wired to the machine's variables and signals
by expressions of the document language (installed with ``fsm.states``; a scenario attaches them with ``plants``).

- ``Integrator``: an axis. Its position integrates ``rate`` (an expression, units per second: ``"0.25 * cmd"``),
  stays within ``[min, max]``, closes ``low_switch`` / ``high_switch`` at the ends and counts a crash for each tick
  it is still driven against an end after its switch closed.
- ``Queue``: a conveyor with a counter. Parts arrive every ``arrive_every`` seconds (up to ``capacity``); each
  rising edge of ``take`` (a true/false expression) takes one; ``present`` is high while a part waits; taking from
  an empty queue counts a miss.
- ``Button``: an operator (or a device) that presses a button ``delay`` seconds after ``press_when`` becomes true,
  holds it ``duration`` seconds, with contact ``bounce`` as a scenario's press.
- ``TimerSensor``: a sensor that goes high once ``when`` has held for ``delay`` seconds; it falls when ``when``
  stops holding, or after ``hold`` seconds.

Each writes what it measures as variables named after the plant (``axis_x``, ``feed_count``, ...) unless told
otherwise, and its switches as input signals the machine sees from the next tick on. Expressions are checked when
the scenario is loaded (:func:`plant_problems`): a misspelt variable is a located error with suggestions.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, ClassVar

from pydantic import Field, model_validator

from fsm.loading.registry import register_plant
from fsm.model.expr import BOOL, NUMBER, ExprError, compile_expr
from fsm.model.params import ParamsBase
from fsm.runtime.plant import Plant, PlantParams

if TYPE_CHECKING:
    from fsm.runtime.context import Context

_EPS = 1e-9


class _ExprPlant(Plant):
    """A plant whose parameters hold expressions over the machine's variables: compiled when attached."""

    #: parameter -> the kind its expression must give
    expressions: ClassVar[dict[str, str]] = {}

    def compiled(self, key: str, ctx: Context) -> Any:
        """The parameter's expression compiled (checked when the scenario was loaded: any name it reads is taken,
        a variable that has no value when it is read is a run-time error)."""
        from fsm.model.expr import Node, parse

        text = getattr(self.params, key)
        names: dict[str, str] = {}
        todo = [parse(text)]
        while todo:
            node = todo.pop()
            if node.op == "var":
                names[node.args[0]] = "any"
            todo += [a for a in node.args if isinstance(a, Node)]
        return compile_expr(text, names, want=self.expressions[key]).fn


def plant_problems(cls: type[Any], params: Any, kinds: dict[str, str]) -> list[tuple[str, str, str | None]]:
    """The expressions of a plant's parameters checked against the machine's variables (and those plants write):
    (parameter, message, hint) for each that cannot be used."""
    import difflib

    out: list[tuple[str, str, str | None]] = []
    for key, want in getattr(cls, "expressions", {}).items():
        text = getattr(params, key, None)
        if not isinstance(text, str):
            continue
        try:
            compile_expr(text, kinds, want=want)
        except ExprError as exc:
            hint = None
            if exc.message.startswith("unknown variable"):
                close = difflib.get_close_matches(exc.message.split("'")[1], sorted(kinds), n=3)
                hint = ("did you mean " + " or ".join(close) + "?") if close else \
                    "variables: " + (", ".join(sorted(kinds)[:12]) or "none")
            out.append((key, str(exc), hint))
    return out


def var_name(params: Any, key: str) -> str:
    """The variable a plant writes for ``key``: the parameter's value, or NAME_key (``axis_x`` for ``output``)."""
    value = getattr(params, key, None)
    return value if isinstance(value, str) else f"{params.name}_{'x' if key == 'output' else key}"


def written_vars(cls: type[Any], params: Any) -> list[str]:
    """The variables a plant of the library writes (its measurements), so that expressions may read them."""
    return [var_name(params, k) for k in getattr(cls, "var_refs", ())]


# -- Integrator ----------------------------------------------------------------------------------------------------
class IntegratorParams(PlantParams):
    rate: str = Field(min_length=1, description="Units per second, an expression over the variables: "
                                                "\"0.25 * cmd\" (cmd -1, 0 or 1 set by the machine).")
    start: float = Field(default=0.0, description="Position at the start.")
    min: float = Field(default=0.0, description="The low end stop.")
    max: float = Field(default=1.0, description="The high end stop.")
    output: str | None = Field(default=None, min_length=1, description="Variable of the position (default: "
                                                                       "NAME_x).")
    low_switch: str | None = Field(default=None, min_length=1, description="Signal high at the low end.")
    high_switch: str | None = Field(default=None, min_length=1, description="Signal high at the high end.")
    crashes: str | None = Field(default=None, min_length=1, description="Variable counting the ticks it was driven "
                                                                        "on against a closed end (default: "
                                                                        "NAME_crashes).")

    @model_validator(mode="after")
    def _ends(self) -> IntegratorParams:
        if not self.min < self.max:
            raise ValueError(f"'min' {self.min:g} must be below 'max' {self.max:g}")
        if not self.min <= self.start <= self.max:
            raise ValueError(f"'start' {self.start:g} is outside [min, max] = [{self.min:g}, {self.max:g}]")
        return self


@register_plant
class Integrator(_ExprPlant):
    """An axis: its position integrates `rate` within [min, max], with a limit switch at each end."""

    Params = IntegratorParams
    params: IntegratorParams
    signal_refs = ("low_switch", "high_switch")
    var_refs = ("output", "crashes")
    expressions = {"rate": NUMBER}

    def reset(self, ctx: Context) -> None:
        self.out_name, self.crash_name = var_name(self.params, "output"), var_name(self.params, "crashes")
        self.x = self.params.start
        self.count = 0
        self.at_end = False
        self.rate = self.compiled("rate", ctx)
        self._publish(ctx)

    def step(self, ctx: Context, dt: float) -> None:
        p = self.params
        v = self.rate(ctx.vars)
        if v:
            x = self.x + v * dt
            if self.at_end and ((x <= p.min and self.x <= p.min + _EPS) or (x >= p.max and self.x >= p.max - _EPS)):
                self.count += 1  # driven on against the end a tick after its switch closed
            self.x = min(max(x, p.min), p.max)
        self._publish(ctx)

    def _publish(self, ctx: Context) -> None:
        p = self.params
        low, high = self.x <= p.min + _EPS, self.x >= p.max - _EPS
        self.at_end = low or high
        for signal, level in ((p.low_switch, low), (p.high_switch, high)):
            if signal is not None and ctx.signal(signal) != level:
                ctx.set_signal(signal, level)
        ctx.vars[self.out_name] = round(self.x, 9)
        ctx.vars[self.crash_name] = self.count


# -- Queue ---------------------------------------------------------------------------------------------------------
class QueueParams(PlantParams):
    start: int = Field(default=0, ge=0, description="Parts waiting at the start.")
    capacity: int = Field(default=1_000_000, ge=1, description="At most this many parts wait.")
    arrive_every: float | None = Field(default=None, gt=0, description="Seconds between two arrivals (none: no "
                                                                       "supply).")
    take: str | None = Field(default=None, min_length=1, description="A true/false expression: each rising edge "
                                                                     "takes one part.")
    count: str | None = Field(default=None, min_length=1, description="Variable of the parts waiting (default: "
                                                                      "NAME_count).")
    taken: str | None = Field(default=None, min_length=1, description="Variable counting the parts taken "
                                                                      "(default: NAME_taken).")
    misses: str | None = Field(default=None, min_length=1, description="Variable counting takes from an empty queue "
                                                                       "(default: NAME_misses).")
    present: str | None = Field(default=None, min_length=1, description="Signal high while a part waits.")

    @model_validator(mode="after")
    def _names(self) -> QueueParams:
        if self.start > self.capacity:
            raise ValueError(f"'start' {self.start} is more than 'capacity' {self.capacity}")
        return self


@register_plant
class Queue(_ExprPlant):
    """A conveyor with a counter: parts arrive every `arrive_every` s; each rising edge of `take` takes one."""

    Params = QueueParams
    params: QueueParams
    signal_refs = ("present",)
    var_refs = ("count", "taken", "misses")
    expressions = {"take": BOOL}

    def reset(self, ctx: Context) -> None:
        p = self.params
        self.names = tuple(var_name(p, k) for k in ("count", "taken", "misses"))
        self.n, self.got, self.missed = p.start, 0, 0
        self.elapsed = 0.0
        self.arrivals = 0
        self.take = self.compiled("take", ctx) if p.take else None
        self.was = False
        self._publish(ctx)

    def step(self, ctx: Context, dt: float) -> None:
        p = self.params
        self.elapsed += dt
        if p.arrive_every is not None:
            due = math.floor(self.elapsed / p.arrive_every + _EPS)  # arrivals counted, not summed: exact
            for _ in range(due - self.arrivals):
                self.n = min(self.n + 1, p.capacity)
            self.arrivals = due
        if self.take is not None:
            now = self.take(ctx.vars) is True
            if now and not self.was:
                if self.n:
                    self.n -= 1
                    self.got += 1
                else:
                    self.missed += 1
            self.was = now
        self._publish(ctx)

    def _publish(self, ctx: Context) -> None:
        p = self.params
        count, taken, misses = self.names
        ctx.vars[count], ctx.vars[taken], ctx.vars[misses] = self.n, self.got, self.missed
        if p.present is not None and ctx.signal(p.present) != (self.n > 0):
            ctx.set_signal(p.present, self.n > 0)


# -- Button --------------------------------------------------------------------------------------------------------
class ButtonBounce(ParamsBase):
    count: int = Field(ge=1, le=1000, description="How many times the contact bounces.")
    interval: float = Field(gt=0, description="Seconds between two level changes while bouncing.")


class ButtonParams(PlantParams):
    signal: str = Field(min_length=1, description="The button's signal.")
    press_when: str = Field(min_length=1, description="A true/false expression: each time it becomes true, the "
                                                      "button is pressed (after 'delay').")
    delay: float = Field(default=0.0, ge=0, description="Seconds from the condition to the press.")
    duration: float = Field(default=0.2, gt=0, description="Seconds the button is held.")
    bounce: ButtonBounce | None = Field(default=None, description="Contact bounce on press and release.")

    @model_validator(mode="after")
    def _bounce(self) -> ButtonParams:
        if self.bounce is not None and not 2 * self.bounce.count * self.bounce.interval < self.duration:
            raise ValueError("the bounce lasts as long as the press or longer: make the press longer")
        return self


@register_plant
class Button(_ExprPlant):
    """A button pressed `delay` s after `press_when` becomes true, held `duration` s, with optional bounce."""

    Params = ButtonParams
    params: ButtonParams
    signal_refs = ("signal",)
    expressions = {"press_when": BOOL}

    def reset(self, ctx: Context) -> None:
        self.when = self.compiled("press_when", ctx)
        self.was = False
        self.t = 0.0
        #: (time, level) changes to come, in order
        self.changes: list[tuple[float, bool]] = []
        if ctx.signal(self.params.signal):
            ctx.set_signal(self.params.signal, False)

    def step(self, ctx: Context, dt: float) -> None:
        p = self.params
        self.t += dt
        now = self.when(ctx.vars) is True
        if now and not self.was:
            at = self.t + p.delay
            levels = [(at, True), (at + p.duration, False)]
            if p.bounce is not None:  # as a scenario's press: k-th change at + k * interval
                b = p.bounce
                levels = [(at + k * b.interval, k % 2 == 0) for k in range(2 * b.count + 1)]
                end = at + p.duration
                levels += [(end + k * b.interval, k % 2 == 1) for k in range(2 * b.count + 1)]
            self.changes = sorted(self.changes + levels, key=lambda c: c[0])
        self.was = now
        level = None
        while self.changes and self.changes[0][0] <= self.t + dt + _EPS:  # seen by the next tick
            level = self.changes.pop(0)[1]
        if level is not None and ctx.signal(p.signal) != level:
            ctx.set_signal(p.signal, level)


# -- TimerSensor ---------------------------------------------------------------------------------------------------
class TimerSensorParams(PlantParams):
    signal: str = Field(min_length=1, description="The sensor's signal.")
    when: str = Field(min_length=1, description="A true/false expression: the sensor goes high once it has held "
                                                "for 'delay' seconds.")
    delay: float = Field(default=0.0, ge=0, description="Seconds 'when' must hold before the sensor goes high.")
    hold: float | None = Field(default=None, gt=0, description="Seconds the sensor stays high (none: while 'when' "
                                                               "holds).")


@register_plant
class TimerSensor(_ExprPlant):
    """A sensor high once `when` has held `delay` s; low when it stops holding (or after `hold` s)."""

    Params = TimerSensorParams
    params: TimerSensorParams
    signal_refs = ("signal",)
    expressions = {"when": BOOL}

    def reset(self, ctx: Context) -> None:
        self.when = self.compiled("when", ctx)
        self.since: float | None = None
        self.high_for = 0.0
        self.fired = False
        if ctx.signal(self.params.signal):
            ctx.set_signal(self.params.signal, False)

    def step(self, ctx: Context, dt: float) -> None:
        p = self.params
        level = False
        if self.when(ctx.vars) is True:
            self.since = (self.since or 0.0) + dt
            if self.since >= p.delay - _EPS:
                if p.hold is None:
                    level = True
                elif not self.fired:
                    self.high_for += dt
                    level = self.high_for <= p.hold + _EPS
                    self.fired = not level
        else:
            self.since, self.high_for, self.fired = None, 0.0, False
        if ctx.signal(p.signal) != level:
            ctx.set_signal(p.signal, level)


__all__ = ["Button", "Integrator", "Queue", "TimerSensor", "plant_problems", "written_vars"]
