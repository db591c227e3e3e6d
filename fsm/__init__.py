"""tral-fsm: declarative, tick-driven state machines for robots.

Run a machine document (JSON, or a UMLet diagram) from Python in one call::

    import fsm
    result = fsm.run("diagrams/examples/traffic_light.json", duration=30.0)
    print(result.outcome, result.stopped)

``fsm.load`` builds a machine to tick yourself, ``fsm.check`` validates a document; ``State``, ``Transition`` and
``Condition`` with their ``Params`` bases and ``register_*`` decorators are the plugin contract. The names in
``__all__`` are the documented set (docs/api/running.md); the others imported here stay for older code.
"""

from __future__ import annotations

from fsm.loading.loader import check, load
from fsm.loading.registry import Registry, register_condition, register_state, register_transition
from fsm.loading.registry import default_registry as default_registry
from fsm.loading.registry import register_plant as register_plant
from fsm.model.errors import DiagramError, StateRuntimeError
from fsm.model.errors import FsmError as FsmError
from fsm.model.errors import Problem as Problem
from fsm.model.errors import RegistrationError as RegistrationError
from fsm.model.params import ConditionParams, StateParams, TransitionParams
from fsm.model.version import VERSION
from fsm.runtime.clock import DEFAULT_DT as DEFAULT_DT
from fsm.runtime.clock import Clock as Clock
from fsm.runtime.clock import RealTimeClock as RealTimeClock
from fsm.runtime.clock import SimulatedClock as SimulatedClock
from fsm.runtime.composite import Composite
from fsm.runtime.condition import Condition
from fsm.runtime.context import Context
from fsm.runtime.machine import Listener, Machine
from fsm.runtime.plant import Plant as Plant
from fsm.runtime.plant import PlantParams as PlantParams
from fsm.runtime.state import State
from fsm.runtime.transition import Transition
from fsm.session.run import RunSource, run
from fsm.session.session import RunResult, Session, StopRules

__version__ = VERSION

__all__ = [
    "Composite",
    "Condition",
    "ConditionParams",
    "Context",
    "DiagramError",
    "Listener",
    "Machine",
    "Registry",
    "RunResult",
    "RunSource",
    "Session",
    "State",
    "StateParams",
    "StateRuntimeError",
    "StopRules",
    "Transition",
    "TransitionParams",
    "check",
    "load",
    "register_condition",
    "register_state",
    "register_transition",
    "run",
]
