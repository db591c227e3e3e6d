"""The library of transition and condition classes, installed as ``fsm.transitions``.

Each module registers its types when it is imported; a registry imports a module when a document first names one
of its types (``fsm.loading.registry.BUILTIN_MODULES``), so importing this package imports none of them. The
transition classes are offered here by name too (``from fsm.transitions import Always``), each module imported on
first use.
"""

from __future__ import annotations

import typing as _typing

#: Each class offered here -> the module of this package that defines it.
_NAMES = {
    "Distance": "car", "PassPoint": "car", "SensorLevel": "car",
    "ConditionTransition": "conditions",
    "Always": "generic", "Finished": "generic", "Timeout": "generic",
    "InState": "inputs", "Signal": "inputs", "Var": "inputs",
    "ArucoGateFound": "markers", "ArucoMarkerFound": "markers", "ArucoMarkerUnpaired": "markers",
    "TopicQuiet": "topics",
}

if _typing.TYPE_CHECKING:
    from .car import Distance, PassPoint, SensorLevel
    from .conditions import ConditionTransition
    from .generic import Always, Finished, Timeout
    from .inputs import InState, Signal, Var
    from .markers import ArucoGateFound, ArucoMarkerFound, ArucoMarkerUnpaired
    from .topics import TopicQuiet
else:  # at run time each name is imported on first use (PEP 562)
    from fsm.loading.registry import lazy_exports

    __getattr__, __dir__ = lazy_exports(__name__, _NAMES)


__all__ = ["Always", "ArucoGateFound", "ArucoMarkerFound", "ArucoMarkerUnpaired", "ConditionTransition", "Distance",
           "Finished", "InState", "PassPoint", "SensorLevel", "Signal", "Timeout", "TopicQuiet", "Var"]
