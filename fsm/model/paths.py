"""State paths: ids joined by ``/``, resolved relative to a machine level and then its enclosing levels."""

from __future__ import annotations

from collections.abc import Container


def resolve_path(path: str, scope: str, paths: Container[str]) -> str | None:
    """The full path ``path`` means when written in the level at ``scope``, or ``None``.

    ``"/a/b"`` is absolute; ``"b/c"`` is tried in ``scope``, then in each enclosing level up to the
    root, like names in nested code blocks, so a parallel region can name its sibling region's states.
    """
    if path.startswith("/"):
        full = path.strip("/")
        return full if full in paths else None
    path = path.strip("/")
    parts = scope.split("/") if scope else []
    for k in range(len(parts), -1, -1):
        prefix = "/".join(parts[:k])
        candidate = f"{prefix}/{path}" if prefix else path
        if candidate in paths:
            return candidate
    return None
