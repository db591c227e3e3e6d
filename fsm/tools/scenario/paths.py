"""How a scenario names states: by id or the end of a path (``state_matches``), and active states by a path prefix
(``active_matches``); how its messages list states and times (``first_few``). Below both the scenario model and the
temporal language, which use them."""

from __future__ import annotations

from collections.abc import Iterable


def state_matches(item: str, path: str) -> bool:
    """A state id or path written in a scenario names the state at ``path``: equal, or its last segments."""
    item = item.strip("/")
    return path == item or path.endswith("/" + item)


def active_matches(prefix: str, path: str) -> bool:
    """An ``active`` entry matches an active leaf path: equal, or a prefix ending at a '/'."""
    prefix = prefix.strip("/")
    return path == prefix or path.startswith(prefix + "/")


def prefixes(paths: Iterable[str]) -> frozenset[str]:
    """Every state path on the way to these paths, themselves included (the active states of active leaves)."""
    return frozenset("/".join(p.split("/")[:k]) for p in paths for k in range(1, p.count("/") + 2))


def first_few(items: list[str], shown: int) -> str:
    """The first ``shown`` items joined by commas, ``, ...`` after them when there are more."""
    return ", ".join(items[:shown]) + (", ..." if len(items) > shown else "")
