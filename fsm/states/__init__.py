"""The library of state classes, installed as ``fsm.states``.

Each module registers its types when it is imported; a registry imports a module when a document first names one
of its types (``fsm.loading.registry.BUILTIN_MODULES``), so importing this package imports none of them. The
classes are offered here by name too (``from fsm.states import Idle``), each module imported on first use.
"""

from __future__ import annotations

import typing as _typing

#: Each class offered here -> the module of this package that defines it.
_NAMES = {
    "FSMState": "composites", "Parallel": "composites",
    "ApproachPoint": "driving", "BasicFollowWall": "driving", "FollowWall": "driving", "FollowWallRamp": "driving",
    "Motor": "driving", "Stop": "driving",
    "AlignHeading": "gate_driving", "ArucoGateApproach": "gate_driving", "ArucoGateCenter": "gate_driving",
    "Final": "generic", "Idle": "generic",
    "Button": "plants", "Integrator": "plants", "Queue": "plants", "TimerSensor": "plants",
    "Call": "sequence", "Join": "sequence", "ResetTimeout": "sequence", "Sequence": "sequence", "SetVar": "sequence",
    "Step": "sequence", "Wait": "sequence",
}

if _typing.TYPE_CHECKING:
    from .composites import FSMState, Parallel
    from .driving import ApproachPoint, BasicFollowWall, FollowWall, FollowWallRamp, Motor, Stop
    from .gate_driving import AlignHeading, ArucoGateApproach, ArucoGateCenter
    from .generic import Final, Idle
    from .plants import Button, Integrator, Queue, TimerSensor
    from .sequence import Call, Join, ResetTimeout, Sequence, SetVar, Step, Wait
else:  # at run time each name is imported on first use (PEP 562)
    from fsm.loading.registry import lazy_exports

    __getattr__, __dir__ = lazy_exports(__name__, _NAMES)


__all__ = [
    "AlignHeading",
    "ApproachPoint",
    "ArucoGateApproach",
    "ArucoGateCenter",
    "BasicFollowWall",
    "Button",
    "Call",
    "FSMState",
    "Final",
    "FollowWall",
    "FollowWallRamp",
    "Idle",
    "Integrator",
    "Join",
    "Motor",
    "Parallel",
    "Queue",
    "ResetTimeout",
    "Sequence",
    "SetVar",
    "Step",
    "Stop",
    "TimerSensor",
    "Wait",
]
