"""Scenario tests: ``*.scenario.json`` files that run a machine on a timeline of inputs and check what it did.

- :mod:`.model`: the scenario document (pydantic models, the committed ``scenario.schema.json``) and its
  loading with located problems;
- :mod:`.timeline`: inputs as exact level changes on the simulated clock (pulses, levels, presses with
  contact bounce, variable changes);
- :mod:`.runner`: one deterministic run with a recording listener, then the expectations checked against it;
- :mod:`.junit`: the JUnit XML report.

May import the core (``fsm``) and, lazily, the simulated car (``fsm.sim``) for scenarios with a world;
never the CLI (``fsm.tools.cli`` imports this package, not the other way round).
"""

from __future__ import annotations

from .model import Scenario, load_scenario
from .runner import ScenarioResult, run_scenario

__all__ = ["Scenario", "ScenarioResult", "load_scenario", "run_scenario"]
