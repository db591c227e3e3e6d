"""The live stream: the trace as the run writes it, kept for whoever connects (a page that joins late reads it from
the start), and what a page is told besides (status, replies): one format, the trace's lines.

:class:`LineBuffer` keeps the trace in memory (a finished trace served again, a sweep's run); :class:`TraceFile`,
what a live run records into, keeps it in a temporary file the run owns (deleted when it ends), so a run of hours
holds none of it in memory. Both can be cut where a snapshot of the run was taken (:meth:`mark`, :meth:`fork`): a
rewind restores the snapshot and goes on from a copy of the trace up to there.
"""

from __future__ import annotations

import io
import os
import tempfile
import threading


class LineBuffer(io.TextIOBase):
    """The trace's text as the run's thread writes it (one chunk per write), read by the server's thread from any
    chunk on. Appending to and slicing a list are atomic in CPython, so neither side locks."""

    def __init__(self) -> None:
        super().__init__()
        self.chunks: list[str] = []

    def write(self, text: str) -> int:
        self.chunks.append(text)
        return len(text)

    def writable(self) -> bool:
        return True

    def since(self, start: int) -> tuple[str, int]:
        """The text written from chunk ``start`` on, and the chunk to read from next time."""
        end = len(self.chunks)
        return "".join(self.chunks[start:end]), end

    def text(self) -> str:
        return "".join(self.chunks)

    def first_line(self) -> str:
        """The first line written (the trace's header), or ``""``."""
        return self.chunks[0].split("\n", 1)[0] if self.chunks else ""

    def mark(self) -> int:
        """Where the text ends now (for :meth:`fork`)."""
        return len(self.chunks)

    def fork(self, mark: int) -> LineBuffer:
        """A new buffer holding the text up to ``mark`` (this one unchanged: a page may still be reading it)."""
        out = LineBuffer()
        out.chunks = self.chunks[:mark]
        return out


#: A :class:`TraceFile` writes to its file once this much text waits (bytes), or when it is read.
PENDING = 1 << 16


class TraceFile(LineBuffer):
    """The trace in a temporary file (unlinked at once: nothing is left behind, whatever ends the process). The run's
    thread writes; the server's thread reads from a byte offset (:meth:`since`); a lock orders the two."""

    def __init__(self) -> None:
        super().__init__()
        self._file = tempfile.TemporaryFile(prefix="fsm-live-", suffix=".jsonl")
        self._fd = self._file.fileno()
        self._lock = threading.Lock()
        self._pending: list[bytes] = []
        self._waiting = 0
        self._size = 0  # bytes in the file
        self._first = ""

    def write(self, text: str) -> int:
        data = text.encode("utf-8")
        with self._lock:
            if not self._first and not self._size and not self._pending:
                self._first = text.split("\n", 1)[0]
            self._pending.append(data)
            self._waiting += len(data)
            if self._waiting >= PENDING:
                self._flush()
        return len(text)

    def _flush(self) -> None:
        if self._pending:
            data = b"".join(self._pending)
            self._pending = []
            self._waiting = 0
            view = memoryview(data)
            while view:
                done = os.pwrite(self._fd, view, self._size)
                self._size += done
                view = view[done:]

    def since(self, start: int) -> tuple[str, int]:
        """The text written from byte ``start`` on, and the byte to read from next time."""
        with self._lock:
            self._flush()
            end = self._size
        return _read(self._fd, start, end).decode("utf-8"), end

    def text(self) -> str:
        return self.since(0)[0]

    def first_line(self) -> str:
        return self._first

    def mark(self) -> int:
        with self._lock:
            return self._size + self._waiting

    def fork(self, mark: int) -> TraceFile:
        """A new file holding the first ``mark`` bytes of this one (copied by the kernel)."""
        out = TraceFile()
        with self._lock:
            self._flush()
        offset = 0
        while offset < mark:
            done = os.copy_file_range(self._fd, out._fd, mark - offset, offset, offset) if hasattr(
                os, "copy_file_range") else os.pwrite(out._fd, _read(self._fd, offset, mark), offset)
            if not done:
                break
            offset += done
        out._size = offset
        out._first = self._first
        return out

    def close(self) -> None:
        self._file.close()
        super().close()


def _read(fd: int, start: int, end: int) -> bytes:
    parts = []
    while start < end:
        got = os.pread(fd, min(end - start, 1 << 24), start)
        if not got:
            break
        parts.append(got)
        start += len(got)
    return b"".join(parts)
