"""Watching a running machine with the Listener API: a log of transitions and the dwell time per state.

A ``fsm.Listener`` gets ``on_transition`` for every state entered (initial entries too, with ``source`` and
``transition`` set to ``None``) and ``on_tick`` at the end of every tick. The machine calls nothing when no
listener is attached, so watching costs nothing unless you ask for it. ``Listener`` is a Protocol: any object with
these two methods is a listener; subclassing it gives the ones you do not write (they do nothing). The
``transition`` is a ``Fired``: the ``fsm.Transition`` that fired, or the ``Restart`` record of a monitor that
restarted the state; both have ``type_name``. mypy --strict accepts this file.
Run it: ``python examples/listener.py`` (it runs ``diagrams/examples/mission.json``).
"""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path
from typing import Any

import fsm
from fsm.runtime.machine import Fired

MISSION = Path(__file__).resolve().parent.parent / "diagrams" / "examples" / "mission.json"


class DwellTimes(fsm.Listener):
    """Prints each transition with its time and sums how long each state path was active."""

    def __init__(self) -> None:
        self.entered: dict[str, float] = {}
        self.dwell: dict[str, float] = defaultdict(float)

    def on_transition(self, ctx: fsm.Context, source: fsm.State[Any] | None, target: fsm.State[Any],
                      transition: Fired | None) -> None:
        if source is not None and transition is not None:
            print(f"{ctx.now:7.3f} s  {source.path} -> {target.path}  ({transition.type_name})")
        self.entered.setdefault(target.path, ctx.now)  # left: seen at the end of the tick, in on_tick

    def on_tick(self, machine: fsm.Machine) -> None:
        active = self._active(machine)
        for path in list(self.entered):
            if path not in active:
                self.dwell[path] += machine.ctx.now - self.entered.pop(path)

    @staticmethod
    def _active(machine: fsm.Machine) -> set[str]:
        """Every active state path, its ancestors included."""
        paths: set[str] = set()
        for leaf in machine.active_paths:
            parts = leaf.split("/")
            paths.update("/".join(parts[:i]) for i in range(1, len(parts) + 1))
        return paths

    def close(self, now: float) -> None:
        for path, since in self.entered.items():
            self.dwell[path] += now - since
        self.entered.clear()


def main() -> None:
    machine = fsm.load(MISSION)
    watcher = DwellTimes()
    machine.add_listener(watcher)
    machine.schedule_signal("start", 0.5)
    machine.schedule_signal("gripped", 3.0)
    outcome = fsm.run(machine, duration=30.0).outcome
    watcher.close(machine.ctx.now)
    print(f"outcome: {outcome} at {machine.ctx.now:.3f} s")
    print("dwell time per state:")
    for path, seconds in sorted(watcher.dwell.items()):
        print(f"  {path:<28} {seconds:7.3f} s")


if __name__ == "__main__":
    main()
