"""The EEROS sequencer's vocabulary as state types: ``Sequence``, ``Step``, ``Wait``, ``SetVar``,
``ResetTimeout`` and ``Join`` (docs/semantics.md, "Sequences").

A ``Sequence`` is a composite state. The loader compiles its ``steps`` into one region, the *chain*: the
blocking steps in order, linked by ``Finished`` transitions (any outcome goes on to the next step). A
non-blocking sequence (``"blocking": false``) is not in the chain: it gets a region of its own that the
sequence starts when the chain passes its place, and that then runs beside the chain until it finishes.
Exception sequences (``exceptions``) get regions too, started only by a monitor.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from pydantic import Field

from fsm.composite import Composite
from fsm.params import Assignments, Int, StateParams
from fsm.registry import register_state
from fsm.state import State

if TYPE_CHECKING:
    from fsm.context import Context
    from fsm.region import Region

#: Slack for times computed from ticks (80 ticks of 0.0125 s are 1 s).
_EPS = 5e-10


@register_state
class Sequence(Composite):
    """Steps run in order (EEROS); finishes when the last step and its non-blocking sequences have, `repeat` times.

    Outcome "succeeded"; with the step-common keys also "aborted", "timeout" or "precondition_failed"."""

    __slots__ = ("chain", "last", "detached", "running", "done", "exceptions", "repeat", "iteration", "epoch",
                 "tail")

    #: The loader compiles ``steps`` and ``exceptions`` (``fsm.sequencer.compile``).
    compiles_steps = True
    signal_refs = ("pause_signal",)
    outcomes = None

    class Params(StateParams):
        steps: list[dict[str, Any]] = Field(
            min_length=1, description="The steps in order: state elements (any registered state type, Step, Wait, "
                                      "SetVar, ResetTimeout, Join, or a nested Sequence).")
        blocking: bool = Field(
            default=True, description="false: when its caller reaches it, it starts beside the caller's next "
                                      "steps (a parallel region) and the caller goes on at once.")
        repeat: Int = Field(default=1, ge=0, description="Times the steps run; 0: again and again until "
                                                         "stopped from outside.")
        pause_signal: str | None = Field(
            default=None, min_length=1, description="Input signal whose rising edges pause and resume this "
                                                    "sequence (one push button).")
        pause_debounce: float = Field(default=0.0, ge=0, description="Seconds the pause signal must be stable "
                                                                     "before an edge counts (0: none).")
        exceptions: list[dict[str, Any]] | None = Field(
            default=None, min_length=1, description="Exception sequences (Sequence elements), named by monitors "
                                                    "and timeouts of this sequence and of everything inside it.")

    def __init__(self, id: str, params: StateParams | None = None) -> None:
        super().__init__(id, params)
        self.chain: Region | None = None
        self.last: State | None = None
        #: non-blocking sequences: (index of the blocking step after which it starts, -1: at once, region)
        self.detached: list[tuple[int, Region]] = []
        self.running: list[Region] = []
        #: outcome of each non-blocking sequence that finished in this run of the steps, by id
        self.done: dict[str, str] = {}
        self.exceptions: dict[str, Region] = {}
        self.repeat = getattr(self.params, "repeat", 1)
        self.iteration = 0
        #: bumped on each entry: a tick that sees it change was interrupted by a restart from inside
        self.epoch = 0
        self.tail = False

    @classmethod
    def submachines(cls, params: StateParams) -> list[tuple[str | None, Any, str]]:
        return []  # compiled by the loader (compiles_steps)

    @classmethod
    def composite_outcomes(cls, params: StateParams, regions: list[set[str] | None]) -> set[str] | None:
        return {"succeeded"}

    # -- built by the loader ----------------------------------------------------------------------------
    def adopt(self, regions: list[Region], detached_after: list[int], exception_ids: list[str]) -> None:
        """Sort the built regions: the chain, the non-blocking sequences (with where they start), the exceptions."""
        n = len(detached_after)
        self.chain = regions[0]
        self.detached = [(after, regions[1 + i]) for i, after in enumerate(detached_after)]
        self.exceptions = dict(zip(exception_ids, regions[1 + n:]))
        self.regions = (self.chain,)
        steps = list(self.chain.states.values())
        self.last = steps[-1]
        order = {s: i for i, s in enumerate(steps)}
        for after, region in self.detached:
            if after < 0 or after == len(steps) - 1:
                continue
            link = next(t for t in steps[after].transitions if t.target is steps[after + 1])
            _start_on(link, self, region)
        del order
        self._prepare()

    # -- running ----------------------------------------------------------------------------------------
    def on_enter(self, ctx: Context) -> None:
        self.epoch += 1
        self.iteration = 0
        self._begin()

    def _begin(self) -> None:
        """A fresh run of the steps: the chain and the non-blocking sequences placed before the first step."""
        self.done = {}
        self.tail = False
        self.running = [r for after, r in self.detached if after < 0]
        self.regions = (self.chain, *self.running)  # type: ignore[assignment]

    def start_detached(self, region: Region, ctx: Context) -> None:
        """The chain passed the place of a non-blocking sequence: it starts beside the chain."""
        state = region.initial
        self.done.pop(state.id, None)
        if region.started:  # still running from before (a repeat): it goes on
            return
        self.running.append(region)
        self.regions = (*self.regions, region)
        region.start(ctx)

    def tick(self, ctx: Context) -> None:
        epoch = self.epoch
        for region in self.regions:
            region.step(ctx)
            if self.epoch != epoch or self.finished:
                return  # restarted or aborted from inside
            if region is not self.chain and region.active.finished:
                self._detached_done(region, ctx)
        chain = self.chain
        if chain.active is not self.last or not self.last.finished:  # type: ignore[union-attr]
            return
        if not self.tail:
            self.tail = True
            for after, region in self.detached:
                if after == len(chain.states) - 1:  # type: ignore[union-attr]
                    self.start_detached(region, ctx)
        if self.running:
            return  # the last step is done; waiting for the non-blocking sequences (implicit join)
        self.iteration += 1
        if self.repeat == 0 or self.iteration < self.repeat:
            chain.stop(ctx)  # type: ignore[union-attr]
            self._begin()
            for region in self.running:
                region.start(ctx)
            chain.start(ctx)  # type: ignore[union-attr]
            return
        self.finish("succeeded")

    def _detached_done(self, region: Region, ctx: Context) -> None:
        state = region.active
        self.done[state.id] = state.outcome or "succeeded"
        region.stop(ctx)
        self.running.remove(region)
        self.regions = tuple(r for r in self.regions if r is not region)  # type: ignore[assignment]

    def on_exit(self, ctx: Context) -> None:
        self.running = []
        self.regions = (self.chain,)  # type: ignore[assignment]


def _start_on(link: Any, seq: Sequence, region: Region) -> None:
    """Make the chain's link ``link`` start the non-blocking sequence in ``region`` when it fires."""
    link.then(lambda ctx: seq.start_detached(region, ctx))


@register_state
class Step(State):
    """A step (EEROS): its action is its `set.on_enter`; finishes when `until` holds (at once without `until`)."""

    __slots__ = ()
    can_finish = True

    def tick(self, ctx: Context) -> None:
        if self._until is None:
            self.finish("succeeded")


@register_state
class Wait(State):
    """Finishes after `seconds` in the state (paused and suspended time excluded)."""

    __slots__ = ("seconds",)
    can_finish = True

    class Params(StateParams):
        seconds: float = Field(ge=0, description="How long to wait, in seconds of machine time.")

    def __init__(self, id: str, params: StateParams | None = None) -> None:
        super().__init__(id, params)
        self.seconds = getattr(self.params, "seconds", 0.0) - _EPS

    def tick(self, ctx: Context) -> None:
        if self.time_in_state(ctx) >= self.seconds:
            self.finish("succeeded")


@register_state
class SetVar(State):
    """Assigns blackboard variables on entry and finishes in the tick it is entered."""

    __slots__ = ()
    can_finish = True

    class Params(StateParams):
        assign: Assignments = Field(description='Variables assigned on entry, in order: {"var": "expression"}.')

    def on_enter(self, ctx: Context) -> None:
        self.finish("succeeded")


@register_state
class ResetTimeout(State):
    """Restarts the timeout clock of `owner` (a sequence or step: its id); finishes at once."""

    __slots__ = ("target",)
    can_finish = True
    state_refs = ("owner",)

    class Params(StateParams):
        owner: str = Field(min_length=1, description="The sequence or step whose timeout restarts: its id, or a "
                                                     "path relative to this machine or absolute.")

    def __init__(self, id: str, params: StateParams | None = None) -> None:
        super().__init__(id, params)
        self.target: State | None = None

    def on_enter(self, ctx: Context) -> None:
        target = self.target
        if target is not None and target._watcher is not None and target.active:
            target._watcher.reset_timeout(ctx)
        self.finish("succeeded")


@register_state
class Join(State):
    """Waits until the named non-blocking sequences (started before, here or in an enclosing sequence) finished."""

    __slots__ = ("holders",)
    can_finish = True

    class Params(StateParams):
        sequences: list[str] = Field(min_length=1, description="Ids of non-blocking sequences to wait for.")

    def __init__(self, id: str, params: StateParams | None = None) -> None:
        super().__init__(id, params)
        #: (sequence that starts it, its id) per name, bound when the machine is built
        self.holders: list[tuple[Sequence, str]] = []

    def tick(self, ctx: Context) -> None:
        for holder, name in self.holders:
            if name not in holder.done:
                return
        self.finish("succeeded")
