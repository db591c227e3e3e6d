"""Hot reload of a live run: the machine's files watched on disk; an edit is checked as ``fsmctl check`` would, and
either shown in the page as located errors (the run goes on with the machine it has) or handed to the controller,
which swaps the machine at the next tick boundary (:mod:`fsm.debug.reload`).

Watching is polling the files' size and modification time a few times a second (a handful of files: no
dependency, and it works the same on every system and file system); a change is taken once two looks agree, so a
file caught half-written by an editor is read when it is whole."""

from __future__ import annotations

import asyncio
import os
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

#: Seconds between two looks at the files.
POLL = 0.25


@dataclass
class Loaded:
    """An edited document: its plan (``None`` when it has errors), its errors (located, one a line) and what the
    reload's trace line and the controller need (``file``, ``document``, ``signals``, ``files``)."""

    plan: Any
    errors: list[str] = field(default_factory=list)
    info: dict[str, Any] = field(default_factory=dict)


def _stamp(name: str) -> tuple[int, int] | None:
    try:
        st = os.stat(name)
    except OSError:
        return None
    return st.st_mtime_ns, st.st_size


class Watcher:
    """The files of a machine (its own and its includes), and how to load it again (``load``, run in a worker
    thread: it reads and compiles)."""

    def __init__(self, files: list[str], load: Callable[[], Loaded]) -> None:
        self.load = load
        self.files: list[str] = []
        self.stamps: dict[str, tuple[int, int] | None] = {}
        self.watch(files)

    def watch(self, files: list[str]) -> None:
        """Watch ``files`` from now on (a reload may add or drop includes)."""
        self.files = list(dict.fromkeys(files))
        self.stamps = {name: _stamp(name) for name in self.files}

    def changed(self) -> bool:
        """Whether a file changed since the last look (and remember what it looks like now)."""
        now = {name: _stamp(name) for name in self.files}
        moved = now != self.stamps
        self.stamps = now
        return moved

    async def run(self, controller: Any, on_valid: Callable[[Loaded], None]) -> None:
        """Until cancelled: on a change that has settled, load the machine again; tell the pages its errors, or
        queue the reload (``on_valid`` is told first: the page served from now on draws the new machine)."""
        loop = asyncio.get_running_loop()
        while True:
            await asyncio.sleep(POLL)
            if not self.changed():
                continue
            while True:  # settled: two looks in a row agree
                await asyncio.sleep(POLL)
                if not self.changed():
                    break
            loaded = await loop.run_in_executor(None, self.load)
            if loaded.errors:
                controller.messages.append({"kind": "reload", "ok": False, "file": loaded.info.get("file"),
                                            "errors": loaded.errors})
                notify = controller.notify
                if notify is not None:
                    notify()
                continue
            self.watch(list(loaded.info.get("files") or self.files))
            on_valid(loaded)
            controller.send("reload", {"plan": loaded.plan, "info": loaded.info,
                                       "signals": loaded.info.get("signals") or []})


def loader(file: str, check: Callable[[], tuple[Any, list[Any]]], finish: Callable[[Any], Any],
           describe: Callable[[Any], dict[str, Any]]) -> Callable[[], Loaded]:
    """How ``fsmctl run --live`` loads ``file`` again: ``check()`` gives the spec and its problems (read from
    disk), ``finish(spec)`` the plan (with the run's ``--set`` overrides), ``describe(spec)`` the trace line's and
    the controller's details. A problem of the document, or of an override it no longer fits, is an error."""
    from fsm.model.errors import DiagramError, FsmError, printable

    def load() -> Loaded:
        try:
            spec, problems = check()
            errors = [p for p in problems if p.severity == "error"]
            if spec is None or errors:
                return Loaded(None, [printable(p.text) for p in errors or problems] or
                              [f"{file}: the document cannot be used"], {"file": file})
            return Loaded(finish(spec), [], {"file": file, **describe(spec)})
        except DiagramError as exc:
            return Loaded(None, [printable(p.text) for p in exc.problems] or [printable(str(exc))], {"file": file})
        except (FsmError, OSError, ValueError) as exc:
            return Loaded(None, [printable(f"{file}: {exc}")], {"file": file})

    return load
