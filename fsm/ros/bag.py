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
    """Every message of a rosbag2 folder: ``(topic, type, log time ns, CDR bytes)`` in log-time order."""
    from rosbags.rosbag2 import Reader

    out: list[tuple[str, str, int, bytes]] = []
    with Reader(Path(path)) as reader:
        for connection, timestamp, raw in reader.messages():
            out.append((connection.topic, connection.msgtype, int(timestamp), bytes(raw)))
    out.sort(key=lambda m: m[2])
    return out
