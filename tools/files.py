"""Writing files atomically: a temporary file in the same folder, renamed over the target when complete."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import IO, Any


def write_atomic(path: str | os.PathLike[str], data: str | bytes) -> None:
    """Write ``data`` to ``path`` so that readers see the old file or the whole new one, never a half."""
    with AtomicFile(path, "wb" if isinstance(data, bytes) else "w") as fh:
        fh.write(data)


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


class AtomicFile:
    """``with AtomicFile(path) as fh:`` writes to a temporary file; it replaces ``path`` only on success."""

    def __init__(self, path: str | os.PathLike[str], mode: str = "w") -> None:
        self.path = Path(path)
        self.mode = mode
        self._tmp: str | None = None
        self._fh: IO[Any] | None = None

    def __enter__(self) -> IO[Any]:
        directory = self.path.parent if str(self.path.parent) else Path(".")
        fd, self._tmp = tempfile.mkstemp(prefix=f".{self.path.name}.", suffix=".tmp", dir=directory)
        os.chmod(self._tmp, 0o666 & ~_umask())  # mkstemp makes 0600; a written file should look like any other
        kwargs = {} if "b" in self.mode else {"encoding": "utf-8", "newline": "\n"}
        self._fh = os.fdopen(fd, self.mode, **kwargs)
        return self._fh

    def __exit__(self, exc_type: Any, exc: Any, tb: Any) -> None:
        assert self._fh is not None and self._tmp is not None
        self._fh.close()
        if exc_type is None:
            os.replace(self._tmp, self.path)
        else:
            self.discard()

    def discard(self) -> None:
        if self._tmp is not None and os.path.exists(self._tmp):
            os.unlink(self._tmp)
