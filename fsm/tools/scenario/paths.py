"""How a scenario names states: by id or the end of a path (``state_matches``), and active states by a path prefix
(``active_matches``). Below both the scenario model and the temporal language, which use them."""

from __future__ import annotations


def state_matches(item: str, path: str) -> bool:
    """A state id or path written in a scenario names the state at ``path``: equal, or its last segments."""
    item = item.strip("/")
    return path == item or path.endswith("/" + item)


def active_matches(prefix: str, path: str) -> bool:
    """An ``active`` entry matches an active leaf path: equal, or a prefix ending at a '/'."""
    prefix = prefix.strip("/")
    return path == prefix or path.startswith(prefix + "/")
