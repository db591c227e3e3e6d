"""Transitions on the car's sensors: ``Distance`` (hall sensor) and ``SensorLevel`` (ultrasonic thresholds); the
conditions ``Sensor`` and ``Travelled`` for monitors, exit conditions and guards."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, Literal

from pydantic import Field, model_validator

from fsm.loading.registry import register_condition, register_transition
from fsm.model.params import ConditionParams, TransitionParams
from fsm.runtime.condition import Condition
from fsm.runtime.transition import Transition

if TYPE_CHECKING:
    from fsm.model.expr import Compiled
    from fsm.runtime.context import Context
    from fsm.runtime.state import State


class DistanceParams(TransitionParams):
    distance: float = Field(gt=0, le=10000, description="Travelled distance since the source was entered, m.")


@register_transition
class Distance(Transition[DistanceParams]):
    """Fires when the car has travelled `distance` metres (hall sensor) since the source state was entered."""

    __slots__ = ("distance", "_d0")
    needs_car = True
    Params = DistanceParams

    def __init__(self, params: DistanceParams, source: State[Any], target: State[Any], index: int = 0) -> None:
        super().__init__(params, source, target, index)
        self.distance = params.distance - 1e-9  # slack for sums of floats
        self._d0 = 0.0

    def on_source_enter(self, ctx: Context) -> None:
        self._d0 = ctx.car.distance

    def holds(self, ctx: Context) -> bool:
        travelled: float = ctx.car.distance - self._d0
        return travelled >= self.distance


class SensorLevelParams(TransitionParams):
    sensor: Literal["left", "right", "front"] = Field(description="The ultrasonic sensor.")
    below: float | None = Field(default=None, gt=0, le=10, description="Fire when the reading is below this, m.")
    above: float | None = Field(default=None, gt=0, le=10, description="Fire when the reading is above this, m.")
    samples: int = Field(default=1, ge=1, le=100,
                         description="Consecutive samples the condition must hold (filters outliers).")

    @model_validator(mode="after")
    def _one_threshold(self) -> SensorLevelParams:
        if (self.below is None) == (self.above is None):
            raise ValueError("give exactly one of 'below' and 'above'")
        return self


@register_transition
class SensorLevel(Transition[SensorLevelParams]):
    """Fires when ultrasonic sensor `sensor` (left, right, front) reads `below` or `above` a threshold, for `samples` samples in a row."""  # noqa: E501 (one line: the schema, palette and `fsmctl types` show the first)

    __slots__ = ("sensor", "below", "above", "samples", "_count", "_seen")
    needs_car = True
    Params = SensorLevelParams

    def __init__(self, params: SensorLevelParams, source: State[Any], target: State[Any], index: int = 0) -> None:
        super().__init__(params, source, target, index)
        self.sensor = params.sensor
        self.below = params.below
        self.above = params.above
        self.samples = params.samples
        self._count = 0
        self._seen = -1

    def on_source_enter(self, ctx: Context) -> None:
        self._count = 0
        self._seen = -1

    def holds(self, ctx: Context) -> bool:
        car = ctx.car
        sample = car.sample
        if sample != self._seen:
            self._seen = sample
            value = getattr(car, self.sensor)
            hit = value < self.below if self.below is not None else value > self.above
            self._count = self._count + 1 if hit else 0
        return self._count >= self.samples


class PassPointParams(TransitionParams):
    x: float = Field(default=0.0, ge=-10000, le=10000, description="Point, odometry frame (start: 0, 0), m.")
    y: float = Field(default=0.0, ge=-10000, le=10000, description="Point, odometry frame, m.")
    heading: float = Field(default=0.0, ge=-360, le=360,
                           description="Direction of crossing, degrees in the odometry frame (start: 0).")
    within: float = Field(default=2.0, gt=0, le=100, description="Only crossings this near the point count, m.")
    after: float = Field(default=0.0, ge=0, le=10000,
                         description="Only after this travelled distance since the source was entered, m.")
    beyond: float = Field(default=0.0, ge=0, le=100,
                          description="Also fire when the car is already past the line by at most this much, "
                                      "m (it crossed it in another state, e.g. driving through a gate); 0: "
                                      "only a crossing counts.")


@register_transition
class PassPoint(Transition[PassPointParams]):
    """Fires when the car's odometry crosses the line through the point (`x`, `y`) perpendicular to `heading`, driving that way, within `within` metres of the point, after `after` metres travelled since the source was entered; with `beyond`, also when the car is already up to that far past the line. Odometry starts at the start pose (x ahead, y left), so the defaults mean "back at the start"; odometry drifts (about 1-2 % of the distance travelled)."""  # noqa: E501 (one line: the schema, palette and `fsmctl types` show the first)

    __slots__ = ("_d0", "_last", "_ux", "_uy")
    needs_car = True
    Params = PassPointParams

    def __init__(self, params: PassPointParams, source: State[Any], target: State[Any], index: int = 0) -> None:
        super().__init__(params, source, target, index)
        h = math.radians(params.heading)
        self._ux, self._uy = math.cos(h), math.sin(h)
        self._d0 = 0.0
        self._last: float | None = None

    def on_source_enter(self, ctx: Context) -> None:
        self._d0 = ctx.car.distance
        self._last = None

    def holds(self, ctx: Context) -> bool:
        p = self.params
        car = ctx.car
        x, y, _ = car.pose()
        dx, dy = x - p.x, y - p.y
        along = dx * self._ux + dy * self._uy
        last, self._last = self._last, along
        if car.distance - self._d0 < p.after:
            return False
        near = math.hypot(dx, dy) <= p.within
        if 0.0 <= along <= p.beyond and near:
            return True
        return last is not None and last < 0.0 <= along and near


# -- conditions on the car (for monitors, exit conditions, preconditions and guards) ------------------------
class SensorConditionParams(ConditionParams):
    sensor: Literal["left", "right", "front"] = Field(description="The ultrasonic sensor.")
    below: float | None = Field(default=None, gt=0, le=10, description="Holds while the reading is below this, m.")
    above: float | None = Field(default=None, gt=0, le=10, description="Holds while the reading is above this, m.")
    samples: int = Field(default=1, ge=1, le=100, description="Consecutive samples it must hold (filters outliers).")

    @model_validator(mode="after")
    def _one_threshold(self) -> SensorConditionParams:
        if (self.below is None) == (self.above is None):
            raise ValueError("give exactly one of 'below' and 'above'")
        return self


@register_condition(name="Sensor")
class SensorCondition(Condition[SensorConditionParams]):
    """Holds while ultrasonic sensor `sensor` reads `below` or `above` a threshold, `samples` samples in a row
    (an obstacle-ahead monitor: {"type": "Sensor", "sensor": "front", "below": 0.25})."""

    __slots__ = ("count", "seen")
    Params = SensorConditionParams
    needs_car = True

    def __init__(self, params: SensorConditionParams, children: list[Condition[Any]] | None = None,
                 exprs: dict[str, Compiled] | None = None) -> None:
        super().__init__(params, children, exprs)
        self.count = 0
        self.seen = -1

    def reset(self, ctx: Context) -> None:
        self.count = 0
        self.seen = -1

    def holds(self, ctx: Context) -> bool:
        car = ctx.car
        if car.sample != self.seen:
            self.seen = car.sample
            p = self.params
            value = getattr(car, p.sensor)
            hit = value < p.below if p.below is not None else value > p.above
            self.count = self.count + 1 if hit else 0
        return self.count >= self.params.samples


class TravelledParams(ConditionParams):
    distance: float = Field(gt=0, le=1000, description="Metres travelled (hall sensor) since the owner was entered.")


@register_condition(name="Travelled")
class TravelledCondition(Condition[TravelledParams]):
    """Holds once the car has travelled `distance` metres since the state that uses it was entered."""

    __slots__ = ("start",)
    Params = TravelledParams
    needs_car = True

    def __init__(self, params: TravelledParams, children: list[Condition[Any]] | None = None,
                 exprs: dict[str, Compiled] | None = None) -> None:
        super().__init__(params, children, exprs)
        self.start = 0.0

    def reset(self, ctx: Context) -> None:
        self.start = ctx.car.distance

    def holds(self, ctx: Context) -> bool:
        travelled: float = ctx.car.distance - self.start
        return travelled >= self.params.distance - 1e-9
