"""Huge inputs: validation time must grow in proportion to the size (issue 2: a 20 MB document; issue 3: a
50 MB .uxf). Each file carries one planted mistake near its end, so the error locator scans nearly all of it.

Prints, for a quarter-size and a full-size file of each kind, the wall time and the time per MB; a ratio
of the per-MB times near 1 means linear. Run: ``.venv/bin/python benchmarks/bench_big.py``.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path


def json_document(n: int) -> str:
    """A ring of ``n`` states with a misspelt type near the end."""
    bad = n - 17
    states = ",\n".join(
        f'    {{"id": "s{i}", "type": "{"Idel" if i == bad else "Idle"}", "description": "state number {i}"}}'
        for i in range(n))
    transitions = ",\n".join(
        f'    {{"type": "Timeout", "from": "s{i}", "to": "s{(i + 1) % n}", "seconds": 0.5}}' for i in range(n))
    return f'{{\n  "initial": "s0",\n  "states": [\n{states}\n  ],\n  "transitions": [\n{transitions}\n  ]\n}}\n'


def uxf_document(n: int) -> str:
    """``n`` state boxes in a row and no initial marker (one located error)."""
    from fsm.tools.umlet.writer import diagram, element

    return diagram([element("UMLState", i * 200, 0, 100, 40, f"S{i}\n--\nentry / do something {i}")
                    for i in range(n)])


def measure(path: Path, repeat: int) -> tuple[float, int]:
    import fsm

    best = float("inf")
    problems = 0
    for _ in range(repeat):
        t0 = time.perf_counter()
        _spec, found = fsm.check(path)
        best = min(best, time.perf_counter() - t0)
        problems = sum(1 for p in found if p.severity == "error")
    return best, problems


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="a tenth of the sizes")
    parser.add_argument("--repeat", type=int, default=2)
    args = parser.parse_args()
    scale = 0.1 if args.quick else 1.0
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for kind, make, full_n, suffix in (("JSON", json_document, 135_000, ".json"),
                                           ("UMLet", uxf_document, 200_000, ".uxf")):
            per_mb = []
            for n in (int(full_n * scale / 4), int(full_n * scale)):
                path = Path(tmp) / f"big{suffix}"
                path.write_text(make(n), encoding="utf-8")
                mb = path.stat().st_size / 1e6
                seconds, errors = measure(path, args.repeat)
                per_mb.append(seconds / mb)
                rows.append((kind, n, mb, seconds, seconds / mb * 1000, errors))
            rows.append((kind, None, None, None, per_mb[1] / per_mb[0], None))
    print(f"{'input':6} {'elements':>9} {'MB':>7} {'seconds':>8} {'ms/MB':>7} {'errors':>6}")
    for kind, n, mb, seconds, value, errors in rows:
        if n is None:
            print(f"{kind:6} per-MB time, full size / quarter size: {value:.2f} (1.0 = linear)")
        else:
            print(f"{kind:6} {n:9,d} {mb:7.1f} {seconds:8.2f} {value:7.1f} {errors:6d}")
    return 0


if __name__ == "__main__":
    sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != Path(__file__).resolve().parents[1]]
    sys.exit(main())
