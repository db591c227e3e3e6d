"""Starting ``fsmctl run --live`` for a test: the process, the URL it printed, and stopping it (the live tests)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
#: A machine whose variable decides its outcome: 'done' when n reaches 20 (one a tenth of a second), 'over' if
#: n ever exceeds 50 (an injection), and a state whose id is markup.
COUNTER = """{"name": "counter", "initial": "count", "vars": {"n": 0},
 "states": [{"id": "count", "type": "Idle"}, {"id": "done", "type": "Final", "outcome": "done"},
            {"id": "<img src=x onerror=alert(1)>", "type": "Final", "outcome": "over"}],
 "transitions": [{"type": "Always", "from": "count", "to": "<img src=x onerror=alert(1)>", "guard": "n > 50"},
                 {"type": "Always", "from": "count", "to": "done", "guard": "n >= 20"},
                 {"type": "Timeout", "from": "count", "to": "count", "seconds": 0.1, "set": {"n": "n + 1"}}]}
"""


class Live:
    """``fsmctl COMMAND ARGS --live --port 0`` (``run``, or ``report`` for a finished trace) in a process of its own;
    ``url`` is what it printed."""

    def __init__(self, *args: str, command: str = "run", cwd: Path = REPO) -> None:
        exe = Path(sys.executable).with_name("fsmctl")
        self.proc = subprocess.Popen([str(exe), command, *args, "--live", "--port", "0"], cwd=cwd,
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                     env={**os.environ, "PYTHONUNBUFFERED": "1"})
        assert self.proc.stdout is not None
        line = self.proc.stdout.readline()
        if not line.startswith("live: "):
            self.proc.kill()
            raise AssertionError(f"no URL: {line!r} {self.proc.stderr.read() if self.proc.stderr else ''}")
        self.url = line.split(" ", 1)[1].strip()
        self.base = self.url.split("?")[0].rstrip("/")
        self.token = self.url.split("token=")[1] if "token=" in self.url else ""

    def wait(self, seconds: float = 30) -> tuple[int, str, str]:
        out, err = self.proc.communicate(timeout=seconds)
        return self.proc.returncode, out, err

    def interrupt(self) -> tuple[int, str, str]:
        time.sleep(0.2)
        self.proc.send_signal(signal.SIGINT)
        return self.wait()

    def close(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.communicate()
