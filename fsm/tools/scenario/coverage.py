"""Coverage over scenario runs: which states were entered (and ran), which transitions and which monitors (and
timeouts) fired, per machine, over every scenario run with the same :class:`Coverage`.

``fsmctl test --coverage`` and the pytest plugin (``--fsm-coverage``) print :meth:`Coverage.text`, write
:meth:`Coverage.to_json` and compare :meth:`Coverage.percent` with ``--fail-under``. A state counts when a run
entered it and ran it: a step only ever skipped by its precondition is listed as "only skipped".
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from fsm.runtime.region import transition_wiring, wiring
from fsm.runtime.supervisor import supervisor_of

if TYPE_CHECKING:
    from fsm.runtime.machine import Machine

    from .runner import Recording


@dataclass
class MachineCoverage:
    """One machine's elements and which of them the runs reached."""

    name: str
    #: state path -> entered and ran / only skipped / never entered
    states: dict[str, str] = field(default_factory=dict)
    #: transition label -> fired
    transitions: dict[str, bool] = field(default_factory=dict)
    #: monitor label -> fired
    monitors: dict[str, bool] = field(default_factory=dict)
    scenarios: int = 0

    def reached(self, path: str, status: str) -> None:
        """State ``path`` reached as ``status`` by one more run: the most a run did counts (ran over skipped over
        never entered)."""
        self.states[path] = max(self.states.get(path, "never"), status, key=_RANK.__getitem__)

    def fired(self, transitions: dict[str, bool], monitors: dict[str, bool]) -> None:
        """Transitions and monitors (label -> fired) of one more run: fired once is fired."""
        for label, hit in transitions.items():
            self.transitions[label] = self.transitions.get(label, False) or hit
        for label, hit in monitors.items():
            self.monitors[label] = self.monitors.get(label, False) or hit

    def counts(self) -> dict[str, tuple[int, int]]:
        """(covered, total) of states, transitions and monitors."""
        return {"states": (sum(1 for v in self.states.values() if v == "ran"), len(self.states)),
                "transitions": (sum(self.transitions.values()), len(self.transitions)),
                "monitors": (sum(self.monitors.values()), len(self.monitors))}


    def missed(self) -> list[tuple[str, list[str]]]:
        """What the runs did not reach, by kind: (title, items), in the report's order."""
        return [("never entered", [p for p, v in self.states.items() if v == "never"]),
                ("only skipped", [p for p, v in self.states.items() if v == "skipped"]),
                ("never fired", [t for t, v in self.transitions.items() if not v]),
                ("monitors never fired", [m for m, v in self.monitors.items() if not v])]


#: How much of a state a run reached, least first.
_RANK = {"never": 0, "skipped": 1, "ran": 2}


def _transition_label(tr: Any) -> str:
    return f"{tr.source.path} -> {tr.target.path} ({tr.type_name} #{transition_wiring(tr).index})"


class Coverage:
    """What the scenario runs reached, per machine (by the machine's file, or its name)."""

    def __init__(self) -> None:
        self.machines: dict[str, MachineCoverage] = {}

    def add(self, machine: Machine, rec: Recording, key: str | None = None) -> None:
        """Add one run of ``machine`` whose record is ``rec``."""
        ran = {e.path for k, e in enumerate(rec.entries) if k not in rec.skipped}
        skipped = {rec.entries[k].path for k in rec.skipped}
        self.add_reached(machine, ran, skipped, rec.fired, {(f.owner, f.label, f.kind) for f in rec.monitors}, key)

    def add_reached(self, machine: Machine, ran: set[str], skipped: set[str], fired: set[tuple[str, int]],
                    fired_monitors: set[tuple[str, str, str]], key: str | None = None) -> None:
        """Add one run of ``machine`` that entered and ran the states ``ran``, skipped ``skipped``, fired the
        transitions ``fired`` ((source path, index)) and the monitors ``fired_monitors`` ((owner, label, kind))."""
        cov = self._of(key or machine.name or "machine")
        cov.scenarios += 1
        for path, state in machine.states_by_path.items():
            cov.reached(path, "ran" if path in ran else "skipped" if path in skipped else "never")
            supervisor = supervisor_of(state)
            out = wiring(state).transitions
            cov.fired({_transition_label(tr): (path, transition_wiring(tr).index) in fired for tr in out},
                      {f"{path}: {m.kind} {m.label} ({m.behavior})": (path, m.label, m.kind) in fired_monitors
                       for m in (supervisor.monitors if supervisor is not None else ())})

    def _of(self, key: str) -> MachineCoverage:
        """The coverage of the machine ``key`` (new when no run of it was added yet)."""
        cov = self.machines.get(key)
        if cov is None:
            cov = self.machines[key] = MachineCoverage(key)
        return cov

    def merge_json(self, data: dict[str, Any]) -> None:
        """Add the coverage another process reported (:meth:`to_json`; a pytest-xdist worker's): a state counts as
        reached when either reached it, a transition or monitor as fired when either fired it."""
        for m in data.get("machines", []):
            cov = self._of(m["machine"])
            cov.scenarios += m["runs"]
            for s in m["states"]:
                cov.reached(s["path"], s["status"])
            cov.fired({t["transition"]: t["fired"] for t in m["transitions"]},
                      {mon["monitor"]: mon["fired"] for mon in m["monitors"]})

    def totals(self) -> dict[str, tuple[int, int]]:
        out = {"states": (0, 0), "transitions": (0, 0), "monitors": (0, 0)}
        for cov in self.machines.values():
            for kind, (hit, total) in cov.counts().items():
                out[kind] = (out[kind][0] + hit, out[kind][1] + total)
        return out

    def percent(self) -> float:
        """Covered elements (states, transitions, monitors together) in percent of all; 100 when there are none."""
        hit = sum(h for h, _t in self.totals().values())
        total = sum(t for _h, t in self.totals().values())
        return 100.0 * hit / total if total else 100.0

    def text(self) -> list[str]:
        """The report: per machine, the counts and what was never entered or never fired."""
        lines = []
        for cov in self.machines.values():
            lines.append(f"coverage of {cov.name} ({cov.scenarios} run(s)): " + _counts_text(cov.counts()))
            lines += [f"  {title}: " + ", ".join(items) for title, items in cov.missed() if items]
        lines.append(f"coverage: {self.percent():.1f}% (" + _counts_text(self.totals()) + ")")
        return lines

    def to_json(self) -> dict[str, Any]:
        return {
            "percent": round(self.percent(), 3),
            "totals": {k: {"covered": h, "total": t} for k, (h, t) in self.totals().items()},
            "machines": [{
                "machine": cov.name, "runs": cov.scenarios,
                "states": [{"path": p, "status": v} for p, v in cov.states.items()],
                "transitions": [{"transition": t, "fired": v} for t, v in cov.transitions.items()],
                "monitors": [{"monitor": m, "fired": v} for m, v in cov.monitors.items()],
            } for cov in self.machines.values()],
        }


def _counts_text(counts: dict[str, tuple[int, int]]) -> str:
    """``states 3/4, transitions 2/5, ...``"""
    return ", ".join(f"{kind} {hit}/{total}" for kind, (hit, total) in counts.items())
