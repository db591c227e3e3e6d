"""The EEROS sequencer's vocabulary as state types: ``Sequence``, ``Step``, ``Wait``, ``SetVar``, ``ResetTimeout``
and ``Join`` (docs/semantics.md, "Sequences"). The classes live in the core (:mod:`fsm.sequencer.steps`), because
the sequencer lays them out, checks and binds them; they are registered here like every other state type."""

from fsm.loading.registry import register_state
from fsm.sequencer.steps import Call, Join, ResetTimeout, Sequence, SetVar, Step, Wait

for _cls in (Sequence, Step, Wait, SetVar, ResetTimeout, Join, Call):
    register_state(_cls)

__all__ = ["Call", "Join", "ResetTimeout", "Sequence", "SetVar", "Step", "Wait"]
