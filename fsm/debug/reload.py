"""Hot reload: a running machine replaced, between two ticks, by one built from its edited document.

The new machine shares the old one's context (variables, signals, car, plants) and clock, and takes over the active
configuration by state path: each level's active state is the state at the same path in the new machine
(:meth:`StateWiring.take_over <fsm.runtime.region.StateWiring.take_over>`: its entry time, pause and finishing carried
over, its transitions armed afresh, the type's ``on_enter`` run with the new parameters; no document ``set`` action
runs, so the variables stay as they are). A level whose active state no longer exists enters its initial state (a
transition from nowhere in the trace, as at the start) and is listed in :attr:`Swap.missing`: a debugger pauses
there and says so. A level new in the document (a parallel region added to an active composite) starts at its
initial state. The old active states' ``on_exit`` run first (the type's own, innermost first: resources
released), their document ``set.on_exit`` does not.

Not while a monitor's exception sequence runs (its steps belong to the old machine): :class:`ReloadRefused`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from fsm.loading.building import build
from fsm.model.errors import StateRuntimeError
from fsm.model.plan import MachinePlan
from fsm.runtime.machine import Machine
from fsm.runtime.region import Region, wiring
from fsm.runtime.state import State


class ReloadRefused(Exception):
    """The machine cannot be replaced now (the message says why and when it can)."""


@dataclass
class Swap:
    """What a hot reload did: the new machine, the active states carried over (paths), the active states that no
    longer exist with the state entered instead, and the levels new in the document with the state they started at."""

    machine: Machine
    kept: list[str] = field(default_factory=list)
    missing: list[tuple[str, str]] = field(default_factory=list)
    started: list[tuple[str, str]] = field(default_factory=list)

    def describe(self) -> str:
        """One line for a person: what was kept and what was not."""
        parts = [f"kept {', '.join(self.kept) if self.kept else 'no active state'}"]
        parts += [f"{old} no longer exists: entered {new} instead" for old, new in self.missing]
        parts += [f"new level {level}: entered {new}" for level, new in self.started]
        return "; ".join(parts)


def running_exception(machine: Machine) -> str | None:
    """The path of an active state whose monitor's exception sequence is running, or None."""
    for region in machine.regions:
        if region.started:
            supervisor = region.current.supervisor
            if supervisor is not None and supervisor.level is not None:
                return region.active.path
    return None


def swap_machine(old: Machine, plan: MachinePlan) -> Swap:
    """A machine built from ``plan`` that takes over ``old``'s context and active configuration (see the module
    docstring); ``old`` must not be used afterwards. Raises :class:`ReloadRefused` while an exception sequence
    runs, :class:`~fsm.model.errors.DiagramError` if the plan cannot be built here (it drives a car and there is none),
    :class:`~fsm.model.errors.StateRuntimeError` if a state's ``on_exit`` or ``on_enter`` fails."""
    owner = running_exception(old)
    if owner is not None:
        raise ReloadRefused(f"an exception sequence of {owner} is running; the reload waits until it has ended "
                            "(save the file again then)")
    ctx = old.ctx
    try:
        new = build(plan, clock=old.clock, context=ctx)
    except BaseException:
        ctx.machine = old
        raise
    swap = Swap(new)
    if not old.started:
        return swap
    old_regions = {region.path: region for region in old.regions}
    active: dict[str, State[Any]] = {r.active.path: r.active for r in old.regions if r.started}
    for state in sorted(active.values(), key=lambda s: -s.path.count("/")):  # innermost first
        try:
            state.on_exit(ctx)
        except StateRuntimeError:
            raise
        except Exception as exc:
            raise StateRuntimeError.of(state, "on_exit (hot reload)", ctx, exc) from exc
    new.started = True
    _place(new.root, old_regions, active, ctx, swap)
    return swap


def _place(region: Region, old_regions: dict[str, Region], active: dict[str, State[Any]], ctx: Any,
           swap: Swap) -> None:
    before = old_regions.get(region.path)
    if before is not None:
        region.fired = before.fired
    target = next((s for s in region.states.values() if s.path in active), None)
    if target is None:
        region.start(ctx)
        if before is not None and before.started:
            swap.missing.append((before.active.path, region.active.path))
        else:
            swap.started.append((region.path, region.active.path))
        return
    region.active = target
    region.started = True
    wiring(target).take_over(ctx, wiring(active[target.path]))
    swap.kept.append(target.path)
    for sub in wiring(target).regions:
        was = old_regions.get(sub.path)
        if was is None or was.started:  # a level the old machine had stopped (a halted composite) stays stopped
            _place(sub, old_regions, active, ctx, swap)


__all__ = ["ReloadRefused", "Swap", "running_exception", "swap_machine"]
