"""tral-fsm: declarative, tick-driven state machines for robots.

Run a machine document (JSON, or a UMLet diagram) from Python in one call::

    import fsm
    result = fsm.run("diagrams/examples/blinker.json", duration=30.0)
    print(result.outcome, result.stopped)    # None limit

(a blinker never finishes: it stops at the limit of 30 s of machine time, with no outcome).

``fsm.load`` builds a machine to tick yourself, ``fsm.check`` validates a document; ``State``, ``Transition`` and
``Condition`` with their ``Params`` bases and ``register_*`` decorators are the plugin contract. The names in
``__all__`` are the documented set (docs/api/running.md); the others offered here stay for older code.

The names are imported on first use (PEP 562), so that ``import fsm`` and the command line (``fsmctl --help``,
``fsmctl validate``) pay only for the layers they use; type checkers and editors read the imports under
``TYPE_CHECKING`` below.
"""

from __future__ import annotations

import typing as _typing

from fsm.model.version import VERSION

__version__ = VERSION

#: Each name offered here -> the module that defines it, imported when the name is first asked for.
_NAMES = {
    "check": "fsm.loading.loader", "load": "fsm.loading.loader",
    "Registry": "fsm.loading.registry", "register_condition": "fsm.loading.registry",
    "register_state": "fsm.loading.registry", "register_transition": "fsm.loading.registry",
    "default_registry": "fsm.loading.registry", "register_plant": "fsm.loading.registry",
    "DiagramError": "fsm.model.errors", "StateRuntimeError": "fsm.model.errors", "FsmError": "fsm.model.errors",
    "Problem": "fsm.model.errors", "RegistrationError": "fsm.model.errors",
    "ConditionParams": "fsm.model.params", "StateParams": "fsm.model.params", "TransitionParams": "fsm.model.params",
    "DEFAULT_DT": "fsm.runtime.clock", "Clock": "fsm.runtime.clock", "RealTimeClock": "fsm.runtime.clock",
    "SimulatedClock": "fsm.runtime.clock",
    "Composite": "fsm.runtime.composite", "Condition": "fsm.runtime.condition", "Context": "fsm.runtime.context",
    "Listener": "fsm.runtime.machine", "Machine": "fsm.runtime.machine",
    "Plant": "fsm.runtime.plant", "PlantParams": "fsm.runtime.plant",
    "State": "fsm.runtime.state", "Transition": "fsm.runtime.transition",
    "RunSource": "fsm.session.run", "run": "fsm.session.run",
    "RunResult": "fsm.session.session", "Session": "fsm.session.session", "StopRules": "fsm.session.session",
}
#: The layers that ``import fsm`` imported eagerly before, still reached as attributes (``fsm.runtime``); their modules
#: are imported as any package's are (``import fsm.runtime.clock``).
_LAYERS = ("loading", "model", "runtime", "sequencer", "session", "trace")
#: What this module defines for itself and ``dir(fsm)`` leaves out.
_OWN = ("_NAMES", "_LAYERS", "_OWN", "_typing", "__getattr__", "__dir__")

if _typing.TYPE_CHECKING:
    from fsm.loading.loader import check, load
    from fsm.loading.registry import Registry, register_condition, register_state, register_transition
    from fsm.loading.registry import default_registry as default_registry
    from fsm.loading.registry import register_plant as register_plant
    from fsm.model.errors import DiagramError, StateRuntimeError
    from fsm.model.errors import FsmError as FsmError
    from fsm.model.errors import Problem as Problem
    from fsm.model.errors import RegistrationError as RegistrationError
    from fsm.model.params import ConditionParams, StateParams, TransitionParams
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
else:  # defined only at run time, so that a type checker still flags a misspelt ``fsm.Stat``

    def __getattr__(name: str) -> _typing.Any:
        import importlib

        if name in _NAMES:
            value = getattr(importlib.import_module(_NAMES[name]), name)
        elif name in _LAYERS:
            value = importlib.import_module(f"{__name__}.{name}")
        else:
            raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
        globals()[name] = value  # asked once: later look-ups find it without this function
        return value

    def __dir__() -> list[str]:
        return sorted((set(globals()) | set(_NAMES) | set(_LAYERS)) - set(_OWN))


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
