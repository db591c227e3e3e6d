"""Many runs at once (``fsmctl sweep``): one machine over worlds x seeds x parameter overrides x variables.

- :mod:`.spec`: the sweep file (pydantic model, the committed ``sweep.schema.json``), the grid, the seeds
  (``numpy.random.SeedSequence``) and the keys that let a second run skip finished runs;
- :mod:`.overrides`: ``PATH.PARAM=VALUE`` overrides checked against the machine (also ``fsmctl run --set``);
- :mod:`.worker`: one run, a plain dict in and out, the same code on a process pool and on Ray;
- :mod:`.backends`: the local spawn pool and ``ray.util.multiprocessing.Pool`` (Ray imported only there);
- :mod:`.runner`: planning (every mistake before the first run), running, resuming, Ctrl-C;
- :mod:`.folder`: the output folder checked before any run, ``sweep.jsonl`` read back and appended safely;
- :mod:`.results`: ``sweep.jsonl``, ``sweep.csv`` and the self-contained ``sweep.html``.
"""

from __future__ import annotations
