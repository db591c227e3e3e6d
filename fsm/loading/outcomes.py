"""Outcomes a parsed state or machine level can finish with, as the checks need them: a ``Finished`` transition
out of a state that can never finish, or on an outcome it never has, is refused when the document is loaded."""

from __future__ import annotations

from collections import deque
from typing import Any

from fsm.model.document import MachineSpec, StateSpec
from fsm.runtime.composite import Composite


def state_outcomes(st: StateSpec) -> set[str] | None:
    """The outcomes a state can finish with (empty: never finishes; ``None``: any)."""
    cls = st.cls
    if cls.is_composite:
        assert issubclass(cls, Composite)  # is_composite is Composite's flag
        regions = [None if sub.machine is None else machine_outcomes(sub.machine) for sub in st.subs]
        out = cls.composite_outcomes(st.params, regions)
        return None if out is None else out | step_outcomes(st.params) | caller_outcomes(st)
    out = cls.possible_outcomes(st.params)
    return None if out is None else out | step_outcomes(st.params)


def can_finish(st: StateSpec) -> bool:
    if st.cls.is_final:
        return True
    outcomes = state_outcomes(st)
    return outcomes is None or bool(outcomes)


def machine_outcomes(spec: MachineSpec) -> set[str] | None:
    """Outcomes of the ``Final`` states reachable in one machine level (``None``: unknown, the level is broken)."""
    if not spec.complete:
        return None
    by_id = {st.id: st for st in spec.states}
    if spec.initial not in by_id:
        return set()
    out: set[str] = set()
    for sid in reachable(spec):
        st = by_id.get(sid)
        if st is not None and st.cls.is_final:
            out.update(st.cls.possible_outcomes(st.params) or ())
    return out


def reachable(spec: MachineSpec) -> set[str]:
    """The ids reachable from the initial state along the transitions as drawn."""
    single = dict(spec.edges)
    if len(single) == len(spec.edges):  # at most one transition out of each state: its chain, followed
        seen = {spec.initial}
        node = single.get(spec.initial)
        while node is not None and node not in seen:
            seen.add(node)
            node = single.get(node)
        return seen
    edges: dict[str, list[str]] = {}
    for src, dst in spec.edges:
        edges.setdefault(src, []).append(dst)
    seen = {spec.initial}
    todo = deque([spec.initial])
    while todo:
        for nxt in edges.get(todo.popleft(), ()):
            if nxt not in seen:
                seen.add(nxt)
                todo.append(nxt)
    return seen


def step_outcomes(params: Any) -> set[str]:
    """Outcomes the step-common keys add to what a state's type can finish with."""
    out: set[str] = set()
    if getattr(params, "precondition", None) is not None:
        out.add("precondition_failed")
    if getattr(params, "until", None) is not None:
        out.add("succeeded")
    for m in getattr(params, "monitors", None) or ():
        if m.behavior == "abortOwner":
            out.add("aborted")
    if getattr(params, "timeout", None) is not None and params.timeout_behavior == "abortOwner":
        out.add("timeout")
    return out


def caller_outcomes(st: StateSpec) -> set[str]:
    """Outcomes a composite gets from its children's ``...CallerOfOwner`` aborts."""
    out: set[str] = set()
    for sub in st.subs:
        for child in sub.machine.states if sub.machine is not None else ():
            p = child.params
            if any(m.behavior == "abortCallerOfOwner" for m in p.monitors or ()):
                out.add("aborted")
            if p.timeout is not None and p.timeout_behavior == "abortCallerOfOwner":
                out.add("timeout")
    return out


__all__ = ["can_finish", "caller_outcomes", "machine_outcomes", "reachable", "state_outcomes", "step_outcomes"]
