"""A sweep's limits, in a module of their own so that ``fsmctl``'s parser names them in its help without importing
the sweep file's models (:mod:`fsm.tools.sweep.spec`, pydantic)."""

from __future__ import annotations

#: A sweep of more runs is refused unless ``--max-runs`` allows it: every finished run's record (about 70 KB with
#: its trajectory) is kept in memory until sweep.csv and sweep.html are written, and planning holds every run.
MAX_RUNS = 10_000
#: The most ticks ``fsmctl run`` runs without ``--max-ticks`` (``MAX_TICKS`` of fsm/tools/cli/run.py, which this package
#: may not import): a sweep's duration must be one its printed ``fsmctl run`` command accepts.
MAX_TICKS = 10_000_000
