"""Parameter overrides addressed by state path: ``lap/bottom.speed=0.8`` sets parameter ``speed`` of the state at
path ``lap/bottom`` on a checked machine, validated by that state type's parameters, before the machine is built.

Used by ``fsmctl sweep --set`` (several values: one run each) and ``fsmctl run --set`` (one value), so a run of
a sweep is reproduced alone. Only the state on the path changes: a machine included several times (a lap
included three times) is copied along the path, so ``lap1/bottom.speed`` leaves ``lap2`` alone.
"""

from __future__ import annotations

import copy
import json
from dataclasses import dataclass
from typing import Any

from pydantic import ValidationError

from fsm.model.document import MachineSpec, StateSpec, SubMachine
from fsm.model.params import StateParams

from .. import did_you_mean

#: Keys an override may not change: identity, layout, and what the loader compiled (conditions, assignments).
FIXED = {"id", "type", "layout", "description", "set", *StateParams.STEP_KEYS}


class OverrideError(ValueError):
    """A bad override: the message names it and says what would be right."""


@dataclass(frozen=True)
class Override:
    path: str
    param: str
    values: tuple[Any, ...]
    text: str

    def one(self, value: Any) -> tuple[str, str, Any]:
        return self.path, self.param, value


def parse_value(text: str) -> Any:
    """A JSON scalar (``0.8``, ``true``, ``"lane"``), or the text itself (``lane``)."""
    try:
        value = json.loads(text)
    except ValueError:
        return text
    return value if isinstance(value, (bool, int, float, str)) else text


def parse(text: str, several: bool = True) -> Override:
    """``PATH.PARAM=V1,V2`` (``several``) or ``PATH.PARAM=V``."""
    name, sep, rest = text.partition("=")
    path, dot, param = name.strip().rpartition(".")
    if not sep or not dot or not path or not param:
        raise OverrideError(f"--set {text!r}: write STATE_PATH.PARAMETER=VALUE" + ("[,VALUE...]" if several else "")
                            + ", e.g. home.speed=0.8" + (",1.0" if several else ""))
    parts = [p.strip() for p in rest.split(",")] if several else [rest.strip()]
    if any(p == "" for p in parts):
        raise OverrideError(f"--set {text!r}: an empty value")
    return Override(path.strip("/"), param.strip(), tuple(parse_value(p) for p in parts), text)


def paths(spec: MachineSpec) -> dict[str, StateSpec]:
    """Every state of a checked machine by path (ids joined by '/', region names included as in the runtime)."""
    out: dict[str, StateSpec] = {}

    def walk(level: MachineSpec, prefix: str) -> None:
        for st in level.states:
            path = f"{prefix}/{st.id}" if prefix else st.id
            out[path] = st
            for name, sub, _ in st.subs:
                if sub is not None:
                    walk(sub, f"{path}/{name}" if name else path)

    walk(spec, "")
    return out


def check(spec: MachineSpec, override: Override) -> None:
    """Raise :class:`OverrideError` when the override names no state or parameter, or a value is invalid."""
    by_path = paths(spec)
    st = by_path.get(override.path)
    if st is None:
        hint = did_you_mean(override.path, by_path, n=3) or f"states: {', '.join(list(by_path)[:10])}"
        raise OverrideError(f"--set {override.text}: no state at path '{override.path}'; {hint}")
    own = {f.alias or n for n, f in st.cls.Params.model_fields.items()} - FIXED
    if override.param not in own:
        hint = (did_you_mean(override.param, sorted(own), n=3)
                or f"its parameters: {', '.join(sorted(own)) or 'none that can be set'}")
        raise OverrideError(f"--set {override.text}: '{override.path}' ({st.params.type}) has no parameter "
                            f"'{override.param}'; {hint}")
    for value in override.values:
        _validated(st, override.param, value, override.text)


def _validated(st: StateSpec, param: str, value: Any, text: str) -> StateParams:
    data = st.params.model_dump(by_alias=True, exclude_unset=True)
    data[param] = value
    try:
        params: StateParams = st.cls.Params.model_validate(data)  # the registered class's own params model
        return params
    except ValidationError as err:
        first = err.errors()[0]
        raise OverrideError(f"--set {text}: {param}={json.dumps(value)} is not valid for '{st.id}' "
                            f"({st.params.type}): {first['msg']}") from None


def apply(spec: MachineSpec, changes: list[tuple[str, str, Any]]) -> MachineSpec:
    """A copy of ``spec`` with each ``(path, param, value)`` set; what the changes do not touch is shared."""
    for path, param, value in changes:
        spec = _set(spec, path.split("/"), param, value)
    return spec


def _set(level: MachineSpec, steps: list[str], param: str, value: Any) -> MachineSpec:
    """Copy ``level`` and, along ``steps``, the states and sub-machines down to the one that changes."""
    level = copy.copy(level)
    level.states = list(level.states)
    head, rest = steps[0], steps[1:]
    for i, st in enumerate(level.states):
        if st.id != head:
            continue
        st = copy.copy(st)
        level.states[i] = st
        if not rest:
            st.params = _validated(st, param, value, f"{'/'.join(steps)}.{param}")
            return level
        subs = list(st.subs)
        for k, (name, sub, ptr) in enumerate(subs):
            if sub is None:
                continue
            inner = rest[1:] if name and rest[0] == name else rest if not name else None
            if inner is None or not inner:
                continue
            if any(s.id == inner[0] for s in sub.states):
                subs[k] = SubMachine(name, _set(sub, inner, param, value), ptr)
                st.subs = subs
                return level
    raise OverrideError(f"no state at path '{'/'.join(steps)}'")
