"""What a state's supervisor tells its region before the state is ticked (see ``fsm.runtime.supervisor``)."""

from __future__ import annotations

import enum


class Verdict(enum.Enum):
    """The answer of ``Supervisor.check``."""

    #: nothing to do: tick the state as usual
    PROCEED = "proceed"
    #: this tick is used up (a monitor fired, an exception sequence ran a tick, the owner was restarted)
    CONSUMED = "consumed"
    #: the owner is halted (aborted, or skipped by its precondition): not ticked, but its transitions are
    #: checked, so a sequence goes on with its next step in the same tick
    HALTED = "halted"


__all__ = ["Verdict"]
