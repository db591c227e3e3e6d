"""Conditions on a car's topics: ``TopicQuiet`` holds while an input has been silent too long (a car on ROS 2 topics,
fsm.ros; a car without topics never goes quiet)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Literal

from pydantic import Field

from fsm.loading.registry import register_condition
from fsm.model.params import ConditionParams
from fsm.runtime.condition import Condition

if TYPE_CHECKING:
    from fsm.runtime.context import Context

#: The inputs of a car on topics (the profile's names).
INPUT_NAMES = ("left", "right", "front", "odometry", "hall", "camera")


class TopicQuietParams(ConditionParams):
    input: Literal["left", "right", "front", "odometry", "hall", "camera", "any"] = Field(
        description="The input (as the I/O profile names it), or any of them.")
    seconds: float = Field(gt=0, le=3600, description="Holds once the input has been silent longer than this, s.")


@register_condition
class TopicQuiet(Condition[TopicQuietParams]):
    """Holds while `input` has had no message for more than `seconds` (never: since the start), on a car whose readings
    come from topics (`fsmctl run --ros`): a monitor {"type": "TopicQuiet", "input": "front", "seconds": 0.3} stops
    the behaviour when a sensor goes silent. Inputs the profile does not bind, and cars without topics (the
    simulator, the test double), never go quiet."""

    __slots__ = ()
    Params = TopicQuietParams
    needs_car = True

    def holds(self, ctx: Context) -> bool:
        times = getattr(ctx.car, "input_time", None)
        if times is None:
            return False
        p = self.params
        now = ctx.now
        for name in INPUT_NAMES if p.input == "any" else (p.input,):
            last = times(name)
            if last is not None and now - last > p.seconds + 1e-9:
                return True
        return False
