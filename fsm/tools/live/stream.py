"""The live stream: the trace as the run writes it, kept for whoever connects (a page that joins late reads it from
the start), and what a page is told besides (status, replies): one format, the trace's lines."""

from __future__ import annotations

import io


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

