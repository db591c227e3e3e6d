"""UMLet benchmarks: convert a generated diagram of 1,000 states and 2,000 relations (target < 300 ms), and
``fsmctl validate`` on a small diagram, process start included (target < 0.5 s wall).

Run: ``.venv/bin/python benchmarks/bench_uxf.py``
"""

from __future__ import annotations

import statistics
import subprocess
import sys
import time
from pathlib import Path

from fsm.tools.umlet.reader import convert_bytes
from fsm.tools.umlet.writer import diagram, element, relation


def big_diagram(n_states: int = 1000, cols: int = 40) -> bytes:
    """A grid of states; each has a relation to its right neighbour and one to the state below (wrapping)."""
    els = [element("UMLSpecialState", 60, 0, 20, 20, "type=initial"), relation([[70, 20], [70, 60]], "lt=->")]
    pos = {}
    for i in range(n_states):
        x, y = 20 + (i % cols) * 200, 60 + (i // cols) * 120
        pos[i] = (x, y)
        els.append(element("UMLState", x, y, 100, 40, f"s{i}\n--\ntype=Idle"))
    rel = 0
    for i in range(n_states):
        x, y = pos[i]
        j = i + 1 if (i + 1) % cols else i - cols + 1
        jx, jy = pos[j]
        if jx > x:
            els.append(relation([[x + 100, y + 20], [jx, jy + 20]], "lt=->\ntype=Timeout\nseconds=1"))
        else:  # back to the row's start: around below
            els.append(relation([[x + 50, y + 40], [x + 50, y + 60], [jx + 50, jy + 60], [jx + 50, jy + 40]],
                                "lt=->\nnext"))
        rel += 1
        k = (i + cols) % n_states
        kx, ky = pos[k]
        if ky > y:
            els.append(relation([[x + 20, y + 40], [kx + 20, ky]], "lt=->\ntick [ok] / go = 1"))
        else:
            els.append(relation([[x + 80, y], [x + 80, y - 10], [kx + 80, ky - 10], [kx + 80, ky]], "lt=<-\nback"))
        rel += 1
    assert rel == 2 * n_states
    return diagram(els).encode()


def bench_convert(repeat: int = 7) -> float:
    raw = big_diagram()
    conv = convert_bytes(raw, "big.uxf")
    doc = conv.machines[0]
    assert len(doc["states"]) == 1000 and len(doc["transitions"]) == 2000
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        convert_bytes(raw, "big.uxf")
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def bench_validate(repeat: int = 5) -> float:
    small = Path(__file__).resolve().parents[1] / "diagrams" / "examples" / "drive.uxf"
    fsmctl = Path(sys.executable).with_name("fsmctl")
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        subprocess.run([str(fsmctl), "validate", "-q", str(small)], check=True, capture_output=True)
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def main() -> None:
    c = bench_convert()
    print(f"convert 1,000 states + 2,000 relations: {c * 1000:.0f} ms (median of 7; target < 300 ms)")
    v = bench_validate()
    print(f"fsmctl validate small .uxf (process start included): {v * 1000:.0f} ms (median of 5; target < 500 ms)")


if __name__ == "__main__":
    main()
