"""Building: the runtime objects (states, regions, transitions with their guards and actions, the Machine) from
a spec the loader has checked. Nothing here reports a document problem except a machine that drives a car
built without one."""

from __future__ import annotations

from typing import Any

from .context import Context
from .document import MachineSpec, StateSpec
from .errors import DiagramError, Problem
from .machine import Machine
from .region import Region
from .state import State


def build(spec: MachineSpec, *, clock: Any = None, car: Any = None, context: Context | None = None) -> Machine:
    """Objects from a checked spec: states, regions, transitions with precomputed lists, the Machine."""
    by_path: dict[str, State] = {}
    regions: list[Region] = []
    variables: dict[str, Any] = {}
    specs: dict[str, StateSpec] = {}
    root = _build_region(spec, spec.name or "", "", None, by_path, regions, variables, specs)
    ctx = context if context is not None else Context(car=car)
    for key, value in variables.items():
        ctx.vars.setdefault(key, value)
    if ctx.car is None:
        needy = [f"'{s.path}' ({s.type_name})" for s in by_path.values() if s.needs_car]
        needy += [f"{t.source.path} -> {t.target.path} ({t.type_name})" for s in by_path.values()
                  for t in s.transitions if t.needs_car]
        if needy:
            names = ", ".join(needy[:5]) + (" ..." if len(needy) > 5 else "")
            raise DiagramError([Problem(f"this machine drives a car ({names}) but no car was given",
                                        spec.source.name, hint="run it with `fsmctl run FILE --world WORLD`, "
                                        "or pass car= to fsm.load")])
    machine = Machine(root, name=spec.name or "", clock=clock, context=ctx, all_regions=regions,
                      states_by_path=by_path)
    for region in regions:
        for state in region.states.values():
            for tr in state.transitions:
                tr.bind(machine)
                if tr.conditions:
                    tr._bind_conditions(machine)
    from .sequencer.compile import bind

    bind(machine, specs)
    return machine


def _build_region(spec: MachineSpec, name: str, prefix: str, owner: State | None, by_path: dict[str, State],
                  regions: list[Region], variables: dict[str, Any], specs: dict[str, StateSpec]) -> Region:
    from .sequencer.compile import build_state

    states: dict[str, State] = {}
    for key, value in spec.vars.items():
        variables.setdefault(key, value)
    for st in spec.states:
        obj = st.cls(st.id, st.params)
        obj.path = f"{prefix}/{st.id}" if prefix else st.id
        by_path[obj.path] = obj
        specs[obj.path] = st
        if st.subs:
            subs = []
            for rname, sub, _ in st.subs:
                assert sub is not None
                sub_prefix = f"{obj.path}/{rname}" if rname else obj.path
                subs.append(_build_region(sub, rname or st.id, sub_prefix, obj, by_path, regions, variables, specs))
            obj.regions = tuple(subs)
        build_state(obj, st, regions)
        states[st.id] = obj
    region = Region(name, prefix, states, states[spec.initial])
    region.owner = owner
    regions.append(region)
    for obj in states.values():
        obj.region = region
    for index, tr in enumerate(spec.transitions):
        p = tr.params
        t = tr.cls(p, states[p.from_], states[p.to], index)
        if tr.guard is not None or tr.assign is not None or tr.conditions:
            conditions = {key: cs.build() for key, cs in tr.conditions.items()}
            guard = tr.guard
            if "guard" in conditions:
                guard = conditions["guard"].holds
            t.attach(guard, tr.assign, conditions)
        states[p.from_].transitions.append(t)
    for st in spec.states:
        if st.actions != (None, None):
            states[st.id]._set_enter, states[st.id]._set_exit = st.actions
    for obj in states.values():
        ordered = sorted(obj.transitions, key=lambda t: -t.params.priority)
        obj.preempt = tuple(t for t in ordered if t.params.preempt)
        obj.regular = tuple(t for t in ordered if not t.params.preempt)
        obj._prepare()
    return region
