"""Drawing big machines: ``fsm.tools.graph.svg`` must grow about linearly with the machine (issue 8, item 9).

Target: 10,000 states drawn as SVG in under 5 s, and roughly linear: the time per state at 10,000 states is
close to that at 1,000 (ratio near 1). Machines: a flat ring, a ring with one more transition out of every
state to a random state, and 100-state rings nested in composites; each without and with stored ``layout``
boxes (a grid, as a drawn diagram has them). Prints a table (states, seconds, ms per state) and the ratio.

Run: ``.venv/bin/python benchmarks/bench_graph.py`` (``--quick``: up to 2,000 states; ``--cli``: also time
``fsmctl graph FILE --format svg`` and ``fsmctl export`` in a fresh process). Wall clocks on a shared machine are
noisy: ``--instructions random:500`` counts the instructions of ``svg()`` for one machine under callgrind instead
(the label-heavy case: random transitions), with ``--base COMMIT`` also on that commit, and prints the ratio.
Uniformly random transitions between far-apart states fill the drawing with crossing lines; their labels get
costlier as the machine grows (about n^1.5), which is why that kind stops at 2,000 states by default
(``--random-max``).
"""

from __future__ import annotations

import argparse
import copy
import json
import random
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from bench_instructions import REPO, base_checkout, callgrind, on_tree

SIZES = (500, 1_000, 2_000, 5_000, 10_000)
TARGET_S = 5.0


def ring(n: int, layout: bool = False) -> dict[str, Any]:
    """``s0 -> s1 -> ... -> s(n-1) -> s0``, each left by a Timeout."""
    states = [{"id": f"s{i}", "type": "Idle"} for i in range(n)]
    trs = [{"type": "Timeout", "from": f"s{i}", "to": f"s{(i + 1) % n}", "seconds": 0.5} for i in range(n)]
    doc = {"name": f"ring{n}", "initial": "s0", "states": states, "transitions": trs}
    return _grid(doc) if layout else doc


def random_graph(n: int, layout: bool = False, seed: int = 1) -> dict[str, Any]:
    """The ring plus one SensorLevel transition from every state to a random one."""
    doc = ring(n)
    rnd = random.Random(seed)
    doc["transitions"] += [{"type": "SensorLevel", "from": f"s{i}", "to": f"s{rnd.randrange(n)}", "sensor": "front",
                            "below": 0.5} for i in range(n)]
    doc["name"] = f"random{n}"
    return _grid(doc) if layout else doc


def nested(n: int, layout: bool = False, per: int = 100) -> dict[str, Any]:
    """``n // per`` composites in a ring (left by Finished), each holding a ring of ``per - 1`` states and a Final
    state reached from its last one."""
    comps = []
    for c in range(max(1, n // per)):
        sub = ring(per - 1)
        sub.pop("name")
        sub["states"].append({"id": "end", "type": "Final"})
        sub["transitions"].append({"type": "SensorLevel", "from": f"s{per - 2}", "to": "end", "sensor": "front",
                                   "below": 0.3})
        comps.append({"id": f"c{c}", "type": "FSMState", "machine": sub})
    k = len(comps)
    doc = {"name": f"nested{n}", "initial": "c0", "states": comps,
           "transitions": [{"type": "Finished", "from": f"c{c}", "to": f"c{(c + 1) % k}"} for c in range(k)]}
    if layout:  # store what the layered layout gives, as a converted diagram would have it
        from fsm.tools.graph.labels import state_label
        from fsm.tools.graph.layout import LevelLayout, lay_out

        def store(level: LevelLayout) -> None:
            for node in level.nodes:
                node.doc["layout"] = {"x": node.x, "y": node.y, "w": node.w, "h": node.h}
                for part in node.parts:
                    store(part.level)

        store(lay_out(doc, lambda st: [state_label(st)]))
    return doc


def _grid(doc: dict[str, Any]) -> dict[str, Any]:
    cols = max(1, int(len(doc["states"]) ** 0.5))
    for i, st in enumerate(doc["states"]):
        st["layout"] = {"x": 20 + (i % cols) * 200, "y": 80 + (i // cols) * 120, "w": 120, "h": 40}
    return doc


KINDS = {"ring": ring, "random": random_graph, "nested": nested}

#: A process that builds one machine and draws it (``1``) or not (``0``): the difference is ``svg()``'s.
PROBE = r'''
import sys
sys.path.insert(0, BENCH)
from bench_graph import KINDS
kind, n, draw = sys.argv[1], int(sys.argv[2]), sys.argv[3] == "1"
doc = KINDS[kind](n)
from fsm.tools.graph import drawing, svg
if draw:
    svg(doc)
'''


def instructions(kind: str, n: int, tree: Path | None) -> int:
    """The instructions ``svg()`` takes for the machine ``kind`` of ``n`` states on ``tree`` (None: this checkout),
    counted by callgrind: a run that draws it minus one that only builds it."""
    env, code = on_tree(f"BENCH = {str(Path(__file__).resolve().parent)!r}\n" + PROBE, tree)
    cwd = tree or REPO
    drawn, built = (callgrind(["-c", code, kind, str(n), draw], env, cwd, f"svg of {kind} {n} ({draw})")
                    for draw in ("1", "0"))
    return drawn - built


def count(spec: str, base: str | None) -> int:
    """``--instructions KIND:N``: a table of svg()'s instructions on this checkout (and on ``base``)."""
    kind, _, size = spec.partition(":")
    if kind not in KINDS or not size.isdigit():
        print(f"--instructions wants KIND:N with KIND one of {', '.join(KINDS)}, e.g. random:500", file=sys.stderr)
        return 2
    with base_checkout(base) as tree:
        here = instructions(kind, int(size), None)
        there = instructions(kind, int(size), tree) if tree is not None else None
    print(f"| svg() of {spec} | instructions |\n|---|---:|\n| this checkout | {here:,} |")
    if there is not None:
        print(f"| {base} | {there:,} |\n| ratio | {here / there:.3f} |")
    return 0


def time_svg(doc: dict[str, Any], repeat: int) -> float:
    from fsm.tools.graph import svg

    best = float("inf")
    for _ in range(repeat):
        d = copy.deepcopy(doc)
        t0 = time.perf_counter()
        svg(d)
        best = min(best, time.perf_counter() - t0)
    return best


def time_cli(args: list[str]) -> float:
    fsmctl = Path(sys.executable).with_name("fsmctl")
    t0 = time.perf_counter()
    subprocess.run([str(fsmctl), *args], check=True, stdout=subprocess.DEVNULL)
    return time.perf_counter() - t0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="sizes up to 2,000 states")
    parser.add_argument("--cli", action="store_true", help="also time fsmctl graph --format svg and fsmctl export")
    parser.add_argument("--repeat", type=int, default=1, help="timed runs per row (the best counts)")
    parser.add_argument("--random-max", type=int, default=2_000, help="largest machine of the random kind")
    parser.add_argument("--only", help="comma-separated kinds: ring, random, nested")
    parser.add_argument("--instructions", metavar="KIND:N", help="count svg()'s instructions for one machine")
    parser.add_argument("--base", metavar="COMMIT", help="with --instructions: also on this commit")
    args = parser.parse_args()
    if args.instructions:
        return count(args.instructions, args.base)
    sizes = [n for n in SIZES if not args.quick or n <= 2_000]
    kinds = args.only.split(",") if args.only else list(KINDS)
    print(f"{'machine':<18} {'states':>7} {'svg s':>8} {'ms/state':>9}"
          + ("   cli svg s  export s" if args.cli else ""))
    verdicts = []
    with tempfile.TemporaryDirectory() as tmp:
        for kind in kinds:
            for layout in (False, True):
                per_state: dict[int, float] = {}
                for n in sizes:
                    if kind == "random" and n > args.random_max:
                        continue
                    doc = KINDS[kind](n, layout)
                    states = _count(doc)
                    secs = time_svg(doc, args.repeat)
                    per_state[n] = secs / states * 1000
                    name = f"{kind}{' +layout' if layout else ''}"
                    line = f"{name:<18} {states:>7,} {secs:>8.2f} {per_state[n]:>9.3f}"
                    if args.cli:
                        path = Path(tmp) / f"{kind}{n}{layout}.json"
                        path.write_text(json.dumps(doc))
                        svg = ['graph', str(path), '--format', 'svg', '-o', str(path.with_suffix('.svg'))]
                        line += f"   {time_cli(svg):>9.2f}"
                        line += f"  {time_cli(['export', str(path), '-o', str(path.with_suffix('.uxf'))]):>8.2f}"
                    print(line, flush=True)
                    if n == 10_000:
                        verdicts.append((name, secs, per_state[n] / per_state[1_000] if 1_000 in per_state else None))
    print(f"\nTarget: 10,000 states in under {TARGET_S:.0f} s, roughly linear (ms/state at 10k / at 1k near 1).")
    for name, secs, ratio in verdicts:
        ok = "PASS" if secs < TARGET_S else "MISS"
        print(f"  {name:<18} {secs:6.2f} s  {ok}   ratio 10k/1k per state: {ratio:.2f}" if ratio is not None
              else f"  {name:<18} {secs:6.2f} s  {ok}")
    return 0


def _count(doc: dict[str, Any]) -> int:
    total = 0
    for st in doc.get("states", []):
        total += 1
        machine = st.get("machine")
        if isinstance(machine, dict):
            total += _count(machine)
    return total


if __name__ == "__main__":
    sys.exit(main())
