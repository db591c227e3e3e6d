"""``--tunable PATH.PARAM``: the parameters of the machine's states as ROS 2 parameters of the bridge's node.

Every parameter the document (or ``--set``) gives a state is declared as ``states.<path, '/' as '.'>.<param>``
with its type and a description; read-only, except those ``--tunable`` names (checked against the machine like
``--set``), which a ROS 2 client may set: the value is validated as the document's would be (a value that is not
valid is refused with the reason) and the state takes it between two ticks."""

from __future__ import annotations

import json
import re
from typing import Any

from fsm.model.errors import UsageError
from fsm.ros.parameters import Tunable

#: The parts of a ROS 2 parameter name.
NAME_PART = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


def tunables(spec: Any, writable: list[str], overridden: list[str]) -> list[Tunable]:
    """The states' parameters of ``spec`` as :class:`Tunable` (``writable``: the ``--tunable`` texts; ``overridden``:
    the ``--set`` texts, for the descriptions)."""
    from ..sweep.overrides import FIXED, paths

    by_path = paths(spec)
    wanted = {_checked(spec, by_path, text) for text in writable}
    changed = {text.partition("=")[0].strip().strip("/") for text in overridden}
    out: list[Tunable] = []
    for path, st in by_path.items():
        given = st.params.model_dump(mode="json", by_alias=True, exclude_unset=True)
        every = st.params.model_dump(mode="json", by_alias=True)
        for param in sorted(set(given) | {p for q, p in wanted if q == path}):
            name = ".".join(["states", *path.split("/"), param])
            if (param in FIXED or param in ("id", "type") or every.get(param) is None
                    or not all(NAME_PART.fullmatch(part) for part in name.split("."))):
                continue
            out.append(_tunable(name, path, st, param, every[param], (path, param) in wanted,
                                f"{path}.{param}" in changed))
    return out


def _tunable(name: str, path: str, st: Any, param: str, value: Any, writable: bool, overridden: bool) -> Tunable:
    """One parameter of the state ``st`` at ``path`` as a ROS 2 parameter ``name``, its description saying where
    its value is from and whether a client may set it."""
    kind = "set with --set" if overridden else "from the document"
    note = ("writable (--tunable): the state takes a valid value between two ticks, from its next entry"
            if writable else "read-only (name it with --tunable to set it from outside)")
    return Tunable(name, path, param, value if isinstance(value, (bool, int, float, str))
                   else json.dumps(value, separators=(",", ":")),
                   f"parameter {param} of state {path} ({st.params.type}), {kind}; {note}",
                   writable, _validator(st, param, value))


def _checked(spec: Any, by_path: dict[str, Any], text: str) -> tuple[str, str]:
    """``--tunable PATH.PARAM``: a state and one of its parameters (a usage error otherwise, as ``--set``)."""
    from ..sweep.overrides import Override, OverrideError, check

    path, dot, param = text.strip().rpartition(".")
    path = path.strip("/")
    if not dot or not path or not param:
        raise UsageError(f"--tunable {text!r}: write STATE_PATH.PARAMETER, e.g. home.speed")
    st = by_path.get(path)
    current = st.params.model_dump(mode="json", by_alias=True).get(param) if st is not None else None
    try:
        check(spec, Override(path, param, (current,), text))
    except OverrideError as exc:
        raise UsageError(str(exc).replace("--set", "--tunable", 1)) from None
    return path, param


def _validator(st: Any, param: str, start: Any) -> Any:
    """The state's parameters with ``param`` set to a value from outside (JSON text for a list or an object);
    ValueError saying why the value is not valid."""
    from pydantic import ValidationError

    as_text = not isinstance(start, (bool, int, float, str))

    def validate(value: Any) -> Any:
        if as_text:
            try:
                value = json.loads(value)
            except ValueError:
                raise ValueError(f"not JSON: {value!r}") from None
        data = st.params.model_dump(by_alias=True, exclude_unset=True)
        data[param] = value
        try:
            return st.cls.Params.model_validate(data)
        except ValidationError as err:
            raise ValueError(f"{json.dumps(value)} is not valid for state {st.id} ({st.params.type}): "
                             f"{err.errors()[0]['msg']}") from None

    return validate
