"""The EEROS sequencer's vocabulary as state types: ``Sequence``, ``Step``, ``Wait``, ``SetVar``,
``ResetTimeout`` and ``Join`` (docs/semantics.md, "Sequences"). They live in the core because the sequencer
compiles and binds them; ``fsm.states`` registers them.

A ``Sequence`` is a composite state. The loader compiles its ``steps`` into one region, the *chain*: the
blocking steps in order, linked by ``Finished`` transitions (any outcome goes on to the next step). A
non-blocking sequence (``"blocking": false``) is not in the chain: it gets a region of its own that the
sequence starts when the chain passes its place, and that then runs beside the chain until it finishes.
Exception sequences (``exceptions``) get regions too, started only by a monitor.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from pydantic import Field

from fsm.model.params import Assignments, ConditionField, Int, StateParams
from fsm.runtime.composite import Composite
from fsm.runtime.region import Region, StateWiring, transition_wiring, wiring
from fsm.runtime.state import State
from fsm.runtime.supervisor import supervisor_of

if TYPE_CHECKING:
    from fsm.model.plan import StatePlan
    from fsm.runtime.context import Context, MachineView

#: Slack for times computed from ticks (80 ticks of 0.0125 s are 1 s).
_EPS = 5e-10


class SequenceParams(StateParams):
    steps: list[dict[str, Any]] = Field(
        min_length=1, description="The steps in order: state elements (any registered state type, Step, Wait, "
                                  "SetVar, ResetTimeout, Join, or a nested Sequence).")
    blocking: bool = Field(
        default=True, description="false: when its caller reaches it, it starts beside the caller's next "
                                  "steps (a parallel region) and the caller goes on at once.")
    repeat: Int = Field(default=1, ge=0, description="Times the steps run; 0: again and again until "
                                                     "stopped from outside (or while repeat_while holds).")
    repeat_while: str | ConditionField | None = Field(
        default=None, description="Checked each time the steps have run: while it holds they run again (at most "
                                  "'repeat' times in all, unless repeat is 0).")
    pause_signal: str | None = Field(
        default=None, min_length=1, description="Input signal whose rising edges pause and resume this "
                                                "sequence (one push button).")
    pause_debounce: float = Field(default=0.0, ge=0, description="Seconds the pause signal must be stable "
                                                                 "before an edge counts (0: none).")
    exceptions: list[dict[str, Any]] | None = Field(
        default=None, min_length=1, description="Exception sequences (Sequence elements), named by monitors "
                                                "and timeouts of this sequence and of everything inside it.")
    sequences: list[dict[str, Any]] | None = Field(
        default=None, min_length=1, description="Sequences declared for Call steps of this sequence and of the "
                                                "sequences inside it (Sequence elements); not run by themselves.")


class Sequence(Composite[SequenceParams]):
    """Steps run in order (EEROS); finishes when the last step and its non-blocking sequences have, `repeat` times.

    Outcome "succeeded"; with the step-common keys also "aborted", "timeout" or "precondition_failed"."""

    __slots__ = ("chain", "last", "detached", "running", "done", "exceptions", "repeat", "iteration", "epoch",
                 "tail", "record")

    signal_refs = ("pause_signal",)
    condition_fields = ("repeat_while",)
    outcomes = None
    Params = SequenceParams

    def __init__(self, id: str, params: SequenceParams | None = None) -> None:
        super().__init__(id, params)
        self.chain: Region | None = None
        self.last: State[Any] | None = None
        #: non-blocking sequences: (index of the blocking step after which it starts, -1: at once, region)
        self.detached: list[tuple[int, Region]] = []
        self.running: list[Region] = []
        #: outcome of each non-blocking sequence that finished in this run of the steps, by id
        self.done: dict[str, str] = {}
        self.exceptions: dict[str, Region] = {}
        self.repeat = self.params.repeat
        self.iteration = 0
        #: bumped on each entry: a tick that sees it change was interrupted by a restart from inside
        self.epoch = 0
        self.tail = False
        #: its wiring record (its regions change as non-blocking sequences start and end)
        self.record: StateWiring = wiring(self)

    @classmethod
    def submachines(cls, params: SequenceParams) -> list[tuple[str | None, Any, str]]:
        return []  # its regions come from its steps: fsm.sequencer.layout.parse_sequence

    @classmethod
    def composite_outcomes(cls, params: SequenceParams, regions: list[set[str] | None]) -> set[str] | None:
        return {"succeeded"}

    # -- built from the plan ----------------------------------------------------------------------------
    def attach_regions(self, regions: list[Region], plan: StatePlan) -> None:
        """Sort the built regions: the chain, the non-blocking sequences (with where they start), the exceptions."""
        layout = plan.sequence
        assert layout is not None
        n = len(layout.detached_after)
        self.chain = regions[0]
        self.detached = [(after, regions[1 + i]) for i, after in enumerate(layout.detached_after)]
        self.exceptions = dict(zip(layout.exception_ids, regions[1 + n:], strict=True))
        self.record.regions = (self.chain,)
        steps = list(self.chain.states.values())
        self.last = steps[-1]
        for after, region in self.detached:
            if after < 0 or after == len(steps) - 1:
                continue
            link = next(t for t in wiring(steps[after]).transitions if t.target is steps[after + 1])
            _start_on(link, self, region)

    def bind(self, machine: MachineView) -> None:
        """A pause button (``pause_signal``): each debounced rising edge pauses or resumes this sequence."""
        signal = self.params.pause_signal
        if signal:
            machine.add_pause_button(self, signal, self.params.pause_debounce)

    # -- running ----------------------------------------------------------------------------------------
    def on_enter(self, ctx: Context) -> None:
        self.epoch += 1
        self.iteration = 0
        self._begin()

    def _begin(self) -> None:
        """A fresh run of the steps: the chain and the non-blocking sequences placed before the first step."""
        chain = self.chain
        assert chain is not None  # attach_regions set it when the machine was built
        self.done = {}
        self.tail = False
        self.running = [r for after, r in self.detached if after < 0]
        self.record.regions = (chain, *self.running)

    def start_detached(self, region: Region, ctx: Context) -> None:
        """The chain passed the place of a non-blocking sequence: it starts beside the chain."""
        state = region.initial
        self.done.pop(state.id, None)
        if region.started:  # still running from before (a repeat): it goes on
            return
        self.running.append(region)
        record = self.record
        record.regions = (*record.regions, region)
        region.start(ctx)

    def tick(self, ctx: Context) -> None:
        epoch = self.epoch
        for region in self.record.regions:
            region.tick(ctx)
            if self.epoch != epoch or self.finished:
                return  # restarted or aborted from inside
            if region is not self.chain and region.active.finished:
                self._detached_done(region, ctx)
        chain, last = self.chain, self.last
        assert chain is not None and last is not None  # attach_regions set them when the machine was built
        if chain.active is not last or not last.finished:
            return
        if not self.tail:
            self.tail = True
            for after, region in self.detached:
                if after == len(chain.states) - 1:
                    self.start_detached(region, ctx)
        if self.running:
            return  # the last step is done; waiting for the non-blocking sequences (implicit join)
        self.iteration += 1
        again = self.repeat == 0 or self.iteration < self.repeat
        repeat_while = self.predicates.get("repeat_while")
        if repeat_while is not None:
            again = (self.repeat == 0 or self.iteration < self.repeat or "repeat" not in self.params.model_fields_set) \
                and repeat_while(ctx)
        if again:
            chain.stop(ctx)
            self._begin()
            for region in self.running:
                region.start(ctx)
            chain.start(ctx)
            return
        self.finish("succeeded")

    def _detached_done(self, region: Region, ctx: Context) -> None:
        state = region.active
        self.done[state.id] = state.outcome or "succeeded"
        region.stop(ctx)
        self.running.remove(region)
        record = self.record
        record.regions = tuple(r for r in record.regions if r is not region)

    def on_exit(self, ctx: Context) -> None:
        self.running = []
        self.record.regions = () if self.chain is None else (self.chain,)


def _start_on(link: Any, seq: Sequence, region: Region) -> None:
    """Make the chain's link ``link`` start the non-blocking sequence in ``region`` when it fires."""
    transition_wiring(link).then(lambda ctx: seq.start_detached(region, ctx))


class Step(State[StateParams]):
    """A step (EEROS): its action is its `set.on_enter`; finishes when `until` holds (at once without `until`)."""

    __slots__ = ()
    can_finish = True

    def tick(self, ctx: Context) -> None:
        if wiring(self).until is None:
            self.finish("succeeded")


class WaitParams(StateParams):
    seconds: float = Field(ge=0, description="How long to wait, in seconds of machine time.")


class Wait(State[WaitParams]):
    """Finishes after `seconds` in the state (paused and suspended time excluded)."""

    __slots__ = ("seconds",)
    can_finish = True
    Params = WaitParams

    def __init__(self, id: str, params: WaitParams | None = None) -> None:
        super().__init__(id, params)
        self.seconds = self.params.seconds - _EPS

    def tick(self, ctx: Context) -> None:
        if self.time_in_state(ctx) >= self.seconds:
            self.finish("succeeded")


class SetVarParams(StateParams):
    assign: Assignments = Field(description='Variables assigned on entry, in order: {"var": "expression"}.')


class SetVar(State[SetVarParams]):
    """Assigns blackboard variables on entry and finishes in the tick it is entered."""

    __slots__ = ()
    can_finish = True
    Params = SetVarParams

    assignment_fields = ("assign",)

    def on_enter(self, ctx: Context) -> None:
        self.finish("succeeded")


class ResetTimeoutParams(StateParams):
    owner: str = Field(min_length=1, description="The sequence or step whose timeout restarts: its id, or a "
                                                 "path relative to this machine or absolute.")


class ResetTimeout(State[ResetTimeoutParams]):
    """Restarts the timeout clock of `owner` (a sequence or step: its id); finishes at once."""

    __slots__ = ("target",)
    can_finish = True
    state_refs = ("owner",)
    Params = ResetTimeoutParams

    def __init__(self, id: str, params: ResetTimeoutParams | None = None) -> None:
        super().__init__(id, params)
        self.target: State[Any] | None = None

    def bind(self, machine: MachineView) -> None:
        """The owner: the nearest enclosing sequence of that id, or a step of one (the checks found it)."""
        name = self.params.owner.strip("/").split("/")[-1]
        seq = enclosing_sequence(self)
        target: State[Any] | None = None
        while seq is not None and target is None:
            if seq.id == name:
                target = seq
            else:
                target = seq.chain.states.get(name) if seq.chain is not None else None
                if target is None:
                    target = next((r.initial for _, r in seq.detached if r.initial.id == name), None)
            seq = enclosing_sequence(seq)
        self.target = target

    def on_enter(self, ctx: Context) -> None:
        target = self.target
        supervisor = supervisor_of(wiring(target)) if target is not None else None
        if target is not None and supervisor is not None and target.active:
            supervisor.reset_timeout(ctx)
        self.finish("succeeded")


class JoinParams(StateParams):
    sequences: list[str] = Field(min_length=1, description="Ids of non-blocking sequences to wait for.")


class Join(State[JoinParams]):
    """Waits until the named non-blocking sequences (started before, here or in an enclosing sequence) finished."""

    __slots__ = ("holders",)
    can_finish = True
    Params = JoinParams

    def __init__(self, id: str, params: JoinParams | None = None) -> None:
        super().__init__(id, params)
        #: (sequence that starts it, its id) per name, bound when the machine is built
        self.holders: list[tuple[Sequence, str]] = []

    def bind(self, machine: MachineView) -> None:
        """Each named non-blocking sequence's holder: the nearest enclosing sequence that starts it."""
        holders = []
        for name in self.params.sequences:
            holder = enclosing_sequence(self)
            while holder is not None and name not in [r.initial.id for _, r in holder.detached]:
                holder = enclosing_sequence(holder)
            if holder is not None:
                holders.append((holder, name))
        self.holders = holders

    def tick(self, ctx: Context) -> None:
        for holder, name in self.holders:
            if name not in holder.done:
                return
        self.finish("succeeded")


def enclosing_sequence(state: State[Any]) -> Sequence | None:
    """The nearest Sequence that contains ``state``."""
    region = wiring(state).region
    while region is not None and region.owner is not None:
        owner = region.owner
        if isinstance(owner, Sequence):
            return owner
        region = wiring(owner).region
    return None


class CallParams(StateParams):
    sequence: str = Field(min_length=1, description="The id of a sequence declared in 'sequences' of this Sequence "
                                                    "or an enclosing one.")


class Call(State[CallParams]):
    """A step that runs a declared sequence under its own id (the same sequence may be called several times).

    The parser puts the declared sequence in its place; a Call is never built, and one outside a Sequence's
    steps is a load error."""

    __slots__ = ()
    Params = CallParams


__all__ = ["Call", "Join", "ResetTimeout", "Sequence", "SetVar", "Step", "Wait", "enclosing_sequence"]
