"""Composite: a state that owns sub-machines (regions) and finishes when they reach final states."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, ClassVar, TypeVar

from fsm.model.params import StateParams
from fsm.runtime.region import Region, wiring
from fsm.runtime.state import State

if TYPE_CHECKING:
    from fsm.model.plan import StatePlan
    from fsm.runtime.context import Context
    from fsm.runtime.state import Hook

P = TypeVar("P", bound=StateParams)


class Composite(State[P]):
    """Base of ``FSMState`` (one region), ``Parallel`` (several) and the sequencer's states.

    Ticking a composite steps each region in declaration order, then applies the join rule: with one
    region, the composite finishes with the outcome of the ``Final`` state its region reached; with
    several, ``join = "all"`` finishes when every region is final (outcome ``succeeded``, or the first
    other outcome in region order), ``join = "any"`` when the first region is final (its outcome).
    """

    __slots__ = ("join",)

    can_finish = True
    outcomes = None
    #: Sub-machines of this type are its regions: the loader asks ``submachines`` for their documents.
    is_composite: ClassVar[bool] = True

    def __init__(self, id: str, params: P | None = None) -> None:
        super().__init__(id, params)
        self.join = getattr(self.params, "join", "all")

    @classmethod
    def submachines(cls, params: P) -> list[tuple[str | None, Any, str]]:
        """The sub-machine documents of an element: ``(region name or None, document or include, pointer)``.

        The pointer is relative to the element (``"/machine"``, ``"/regions/1"``). ``None`` as name
        means the region's states sit directly under the composite in paths (``FSMState``).
        """
        raise NotImplementedError

    def attach_regions(self, regions: list[Region], plan: StatePlan) -> None:
        """Take the built regions (in the order of ``plan.regions``) as this state's sub-machines."""
        wiring(self).regions = tuple(regions)

    @classmethod
    def composite_outcomes(cls, params: P, regions: list[set[str] | None]) -> set[str] | None:
        """Outcomes this composite can finish with, from the outcomes each region's machine can reach."""
        if any(r is None for r in regions):
            return None  # a region failed to load: do not guess
        sets = [r for r in regions if r is not None]
        if not sets:
            return set()
        if len(sets) == 1:
            return set(sets[0])
        if getattr(params, "join", "all") == "any":
            return set().union(*sets)  # whichever region is final first (in region order, on a tie)
        if any(not s for s in sets):
            return set()  # some region never finishes, so "all" never joins
        # join=all (see _join): "succeeded" when every region succeeded, else the first other outcome in region
        # order, so region i's other outcomes count only when every region before it can succeed
        out: set[str] = set()
        for s in sets:
            out |= s - {"succeeded"}
            if "succeeded" not in s:
                return out
        out.add("succeeded")
        return out

    def tick(self, ctx: Context) -> None:
        regions = wiring(self).regions
        for region in regions:
            region.tick(ctx)
        if not self.finished:
            self._join(regions)

    def _tick_method(self) -> Hook | None:
        """A composite that keeps the base's tick ticks its regions, bound once (an ``FSMState``, of one region,
        finishes with its Final state's outcome without the general join); others tick as their class says."""
        if type(self).tick is not Composite.tick:
            return super()._tick_method()
        regions = wiring(self).regions
        if len(regions) != 1:
            def tick_all(ctx: Context) -> None:
                for level in regions:
                    level.tick(ctx)
                if not self.finished:
                    self._join(regions)
            return tick_all
        region = regions[0]

        def tick_one(ctx: Context) -> None:
            region.tick(ctx)
            if not self.finished:
                active = region.current
                if active.is_final:
                    self.finish(active.state.outcome or "succeeded")
        return tick_one

    def _join(self, regions: tuple[Region, ...]) -> None:
        if len(regions) == 1:
            active = regions[0].active
            if active.is_final:
                self.finish(active.outcome or "succeeded")
            return
        if self.join == "any":
            for region in regions:
                active = region.active
                if active.is_final:
                    self.finish(active.outcome or "succeeded")
                    return
            return
        outcome = None
        for region in regions:
            active = region.active
            if not active.is_final:
                return
            if outcome is None and active.outcome != "succeeded":
                outcome = active.outcome
        self.finish(outcome or "succeeded")
