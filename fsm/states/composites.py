"""Generic composite states: ``FSMState`` (a nested machine) and ``Parallel`` (regions ticked in order)."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import Field

from fsm.loading.registry import register_state
from fsm.model.document import MachineSpecField
from fsm.model.params import StateParams
from fsm.runtime.composite import Composite


class FSMStateParams(StateParams):
    machine: MachineSpecField = Field(
        description='The sub-machine: a machine document, or {"file": "path"} relative to this file.')


@register_state
class FSMState(Composite[FSMStateParams]):
    """A nested machine, inline or from a file; finishes with the outcome of the Final state it reaches."""

    __slots__ = ()
    Params = FSMStateParams

    @classmethod
    def submachines(cls, params: FSMStateParams) -> list[tuple[str | None, Any, str]]:
        return [(None, params.machine, "/machine")]


class ParallelParams(StateParams):
    regions: list[MachineSpecField] = Field(
        min_length=1,
        description="The regions: machine documents (or includes); a region's path step is its "
                    "machine's name, else region1, region2, ...")
    join: Literal["all", "any"] = Field(
        default="all", description="Finish when all regions are final, or when any is.")


@register_state
class Parallel(Composite[ParallelParams]):
    """Regions ticked in declaration order; finishes when all (join=all) or any (join=any) reach a Final state."""

    __slots__ = ()
    Params = ParallelParams

    @classmethod
    def submachines(cls, params: ParallelParams) -> list[tuple[str | None, Any, str]]:
        return [(f"region{i + 1}", doc, f"/regions/{i}") for i, doc in enumerate(params.regions)]
