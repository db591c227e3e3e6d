"""The libraries of the core benchmark, one module each, behind one interface (:mod:`.adapter`).

``ADAPTERS`` and ``LOADERS`` are in table order; ``rate_adapters`` pairs each adapter with the
workloads it can run, flat first.
"""

from __future__ import annotations

from .adapter import Adapter, Loader
from .py_trees import PyTrees
from .python_statemachine import Psm, PsmLoad, PsmLoadNoValidate
from .pytransitions import Hsm, HsmLoad, Transitions, TransitionsLoad
from .sismic import Sismic, SismicLoad
from .tral_fsm import TralFsm, TralFsmLoad
from .workloads import WORKLOADS, Workload

ADAPTERS: list[type[Adapter]] = [TralFsm, Transitions, Hsm, Psm, Sismic, PyTrees]
LOADERS: list[type[Loader]] = [TralFsmLoad, PsmLoad, PsmLoadNoValidate, SismicLoad, TransitionsLoad, HsmLoad]
#: --only name -> (import name, distribution name)
LIBRARIES: dict[str, tuple[str, str]] = {c.key: (c.module, c.dist) for c in [*ADAPTERS, *LOADERS]}


def rate_adapters() -> list[tuple[type[Adapter], Workload]]:
    """(adapter class, workload) for every rate row, in table order."""
    return [(cls, w) for w in WORKLOADS.values() for cls in ADAPTERS if w.name in cls.notes]
