"""Runs recorded as rosbag2 (MCAP storage, ROS 2 message types) through rosbags, for ``ros2 bag play``, Foxglove and
``fsmctl replay``.

What is recorded is what the machine saw and did: each input message at the tick that latched it, each command and
status message at the tick that published it. A message's log time is that tick's machine time in nanoseconds, the
times of the trace, so bag and trace line up exactly (``t_bag = round(t_trace * 1e9)``); the messages' own header
stamps are kept as the robot sent them.

The bag is written into a scratch folder beside the one named and renamed into place when the run ends, so a
half-written bag never carries the user's name.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Callable, Collection, Iterator
from pathlib import Path
from typing import Any

from fsm.model.errors import FsmError
from fsm.ros.messages import typestore
from fsm.ros.profile import Binding, Profile, normalise_type


def roles(profile: Profile) -> dict[str, Binding]:
    """Every topic a run records, by role (the inputs, ``command``, ``status``)."""
    out: dict[str, Binding] = dict(profile.inputs_bound())
    out["command"] = profile.outputs.command
    if profile.outputs.status is not None:
        out["status"] = profile.outputs.status
    return out


class BagError(FsmError):
    """The finished bag could not be put under the name given."""


class BagRecorder:
    """Writes a run's messages into a rosbag2 folder (MCAP); :meth:`commit` puts it in place."""

    def __init__(self, path: str | os.PathLike[str], profile: Profile) -> None:
        from rosbags.rosbag2 import StoragePlugin, Writer

        self.path = Path(path)
        self.profile = profile
        self._scratch = Path(tempfile.mkdtemp(prefix=f".{self.path.name}.", dir=self.path.parent))
        self._inner = self._scratch / "bag"
        self._writer = Writer(self._inner, version=9, storage_plugin=StoragePlugin.MCAP)
        self._writer.open()
        store = typestore()
        self._connections: dict[str, Any] = {}
        for role, binding in roles(profile).items():
            self._connections[role] = self._writer.add_connection(
                "/" + binding.topic.lstrip("/"), normalise_type(binding.type), typestore=store)
        self.messages = 0
        self._open = True

    def write(self, role: str, raw: bytes, time_s: float) -> None:
        """Record ``raw`` (CDR) on the topic of ``role`` at machine time ``time_s``."""
        self._writer.write(self._connections[role], round(time_s * 1e9), raw)
        self.messages += 1

    def close(self) -> None:
        if self._open:
            self._open = False
            self._writer.close()

    def commit(self) -> None:
        """Finish the bag and rename it to the name given, which must still not exist: should something have
        appeared there during the run, :class:`BagError` says where the finished bag was kept instead."""
        self.close()
        if os.path.lexists(self.path):
            kept = self._scratch.with_name(f"{self.path.name}.bag-{os.getpid()}")
            try:
                os.rename(self._inner, kept)
                shutil.rmtree(self._scratch, ignore_errors=True)
            except OSError:
                kept = self._inner
            raise BagError(f"--bag {self.path}: something was created there during the run; the bag was kept as "
                           f"{kept}")
        os.rename(self._inner, self.path)
        shutil.rmtree(self._scratch, ignore_errors=True)

    def discard(self) -> None:
        try:
            self.close()
        except Exception:  # a writer that failed half-way: the scratch folder goes anyway
            pass
        shutil.rmtree(self._scratch, ignore_errors=True)


def read_bag(path: str | os.PathLike[str]) -> list[tuple[str, str, int, bytes]]:
    """Every message of a rosbag2 folder: ``(topic, type, log time ns, CDR bytes)`` in log-time order (all in
    memory: for tests and small bags; :class:`BagSource` streams)."""
    with BagSource(path) as source:
        out = [(topic, source.topics[topic][0], ns, raw) for topic, ns, raw in source.messages()]
    out.sort(key=lambda m: m[2])
    return out


class BagSource:
    """A recorded drive's messages, read as they are needed (never the whole bag in memory): a rosbag2 folder in
    any storage rosbags reads (MCAP, sqlite3), chunk by chunk; or, when its MCAP file is cut off (a recorder that
    was killed) or the folder has no ``metadata.yaml``, the MCAP files scanned from the start up to their last whole
    chunk, with a warning that names where the file stops.

    ``topics``: every recorded topic, ``(message type, layout)``; the layout (:data:`fsm.ros.messages.LAYOUTS`) is
    the one the bag's type hash names, None where the bag has no hash (then each layout is tried)."""

    def __init__(self, path: str | os.PathLike[str], warn: Callable[[str], None] | None = None) -> None:
        self.path = Path(path)
        self.warn = warn or (lambda text: None)
        self.topics: dict[str, tuple[str, str | None]] = {}
        #: messages per topic where the bag says (None: a scanned file, not known before reading)
        self.counts: dict[str, int | None] = {}
        self._reader: Any = None
        self._files: list[Path] = []
        self._open()

    def _open(self) -> None:
        from rosbags.rosbag2 import Reader

        from fsm.ros.messages import layout_of_hash

        folder = self.path
        if (folder / "metadata.yaml").is_file():
            try:
                reader = Reader(folder)
                reader.open()
            except Exception as exc:  # rosbags' ReaderError and what a damaged file makes it raise
                self._files = sorted(folder.glob("*.mcap"))
                if not self._files:
                    raise BagReadError(" ".join(str(exc).split())) from None
                self._scan_channels(first_error=" ".join(str(exc).split()))
                return
            self._reader = reader
            for c in reader.connections:
                digest = str(c.digest or "")
                layout = layout_of_hash(c.msgtype, digest) if digest.startswith("RIHS01_") else None
                self.topics[c.topic] = (c.msgtype, layout)
                self.counts[c.topic] = (self.counts.get(c.topic) or 0) + int(c.msgcount)
            return
        self._files = [folder] if folder.is_file() else sorted(folder.glob("*.mcap"))
        if not self._files:
            raise BagReadError("not a rosbag2 folder (no metadata.yaml and no .mcap file in it)")
        self._scan_channels()

    def _scan_channels(self, first_error: str | None = None) -> None:
        """The topics of MCAP files without their index: the channels declared up to where each file stops."""
        for _topic, _ns, _raw in self._scan(channels_only=True):
            pass
        if not self.topics:
            raise BagReadError(first_error or "no channel in the MCAP file(s): is it an MCAP file of ROS 2 messages?")

    def messages(self, topics: Collection[str] | None = None, start_ns: int | None = None,
                 stop_ns: int | None = None) -> Iterator[tuple[str, int, bytes]]:
        """``(topic, log time ns, CDR bytes)`` of ``topics`` (every topic: None) in log-time order, from
        ``start_ns`` up to (not including) ``stop_ns``."""
        if self._reader is not None:
            wanted = [c for c in self._reader.connections if topics is None or c.topic in topics]
            for connection, ns, raw in self._reader.messages(connections=wanted, start=start_ns, stop=stop_ns):
                yield connection.topic, int(ns), bytes(raw)
            return
        for topic, ns, raw in self._scan(topics=topics):
            if (start_ns is None or ns >= start_ns) and (stop_ns is None or ns < stop_ns):
                yield topic, ns, raw

    def _scan(self, topics: Collection[str] | None = None, channels_only: bool = False
              ) -> Iterator[tuple[str, int, bytes]]:
        """Each file's records in order, a chunk at a time (its messages sorted by log time), up to the last whole
        chunk of a file that is cut off (warned once, naming the file, the byte and the log time it stops at)."""
        from mcap.records import Channel, Chunk, DataEnd, Footer, Message, Schema
        from mcap.stream_reader import StreamReader, breakup_chunk

        for file in self._files:
            schemas: dict[int, str] = {}
            channels: dict[int, str] = {}
            last_ns: int | None = None
            chunks = 0
            with open(file, "rb") as stream:
                try:
                    for record in StreamReader(stream, emit_chunks=True).records:
                        if isinstance(record, (DataEnd, Footer)):
                            break
                        inner = breakup_chunk(record) if isinstance(record, Chunk) else [record]
                        batch: list[tuple[str, int, bytes]] = []
                        for r in inner:
                            if isinstance(r, Schema):
                                schemas[r.id] = r.name
                            elif isinstance(r, Channel):
                                channels[r.id] = r.topic
                                self.topics.setdefault(r.topic, (schemas.get(r.schema_id, ""), None))
                                self.counts[r.topic] = None
                            elif isinstance(r, Message) and not channels_only:
                                topic = channels.get(r.channel_id)
                                if topic is not None and (topics is None or topic in topics):
                                    batch.append((topic, int(r.log_time), bytes(r.data)))
                        if isinstance(record, Chunk):
                            chunks += 1
                            last_ns = record.message_end_time
                        batch.sort(key=lambda m: m[1])
                        yield from batch
                except Exception as exc:  # mcap's EndOfFile, McapError, a CRC or length that does not hold
                    if not channels_only:
                        where = f"log time {last_ns * 1e-9:.3f} s" if last_ns is not None else "its start"
                        self.warn(f"{file}: cut off at byte {stream.tell()} ({type(exc).__name__}): replayed up to "
                                  f"the last whole chunk ({chunks} chunks, up to {where})")

    def close(self) -> None:
        reader, self._reader = self._reader, None
        if reader is not None:
            reader.close()

    def __enter__(self) -> BagSource:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class BagReadError(FsmError):
    """A bag that cannot be read at all."""
