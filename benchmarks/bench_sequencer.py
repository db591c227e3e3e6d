"""Sequencer speed (issue 10), and what guards and ``set`` cost on the flat ring: a sequence of 1,000 steps, each
watched by 3 monitors of its callers, must run at >= 200,000 ticks per second; pausing and resuming a subtree must
cost the same whatever the size of the rest of the machine (O(1) in it).

Each step is a ``Step`` that finishes at its first tick, so every tick checks the three monitors (one per
enclosing sequence, expressions that stay false), ticks one step and fires one link to the next step.
Run: ``.venv/bin/python benchmarks/bench_sequencer.py`` (``--quick`` for fewer repeats).
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import fsm


def sequence_doc(steps: int) -> dict[str, Any]:
    chain = [{"id": f"s{i}", "type": "Step"} for i in range(steps)]
    inner = {"id": "c", "type": "Sequence", "steps": chain,
             "monitors": [{"condition": "stop > 2", "behavior": "abortOwner"}]}
    middle = {"id": "b", "type": "Sequence", "steps": [inner],
              "monitors": [{"condition": "stop > 1", "behavior": "abortOwner"}]}
    outer = {"id": "a", "type": "Sequence", "steps": [middle], "repeat": 0,
             "monitors": [{"condition": "stop > 0", "behavior": "abortOwner"}]}
    return {"name": "bench", "initial": "a", "vars": {"stop": 0}, "states": [outer]}


def rate(doc: dict[str, Any], ticks: int, repeat: int) -> float:
    """Ticks per second of the machine ``doc`` (best of ``repeat``), after its start."""

    best = float("inf")
    for _ in range(repeat):
        m = fsm.load(doc)
        m.start()
        tick = m.tick
        t0 = time.perf_counter()
        for _ in range(ticks):
            tick()
        best = min(best, time.perf_counter() - t0)
        assert not m.finished
    return ticks / best


def wide_doc(others: int) -> dict[str, Any]:
    """A Parallel with ``others`` busy regions beside the one sequence that gets paused."""
    target = {"name": "arm", "initial": "arm", "states": [
        {"id": "arm", "type": "Sequence", "repeat": 0,
         "steps": [{"id": "w", "type": "Wait", "seconds": 1},
                   {"id": "x", "type": "SetVar", "assign": {"n": "n + 1"}}]}]}
    rest = [{"name": f"r{i}", "initial": "i", "states": [{"id": "i", "type": "Idle"}]} for i in range(others)]
    return {"name": "wide", "initial": "p", "vars": {"n": 0},
            "states": [{"id": "p", "type": "Parallel", "regions": [target, *rest]}]}


def pause_resume_us(others: int, repeat: int) -> float:

    m = fsm.load(wide_doc(others))
    fsm.run(m, max_ticks=10)
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        for _ in range(1000):
            m.pause("p/arm/arm")
            m.resume("p/arm/arm")
        best = min(best, time.perf_counter() - t0)
    return best / 1000 * 1e6


def ring_doc(kind: str, n: int = 100) -> dict[str, Any]:
    """The flat ring of ``n`` Idle states linked by Always; with a guard, or a guard and a counter ``set``."""
    transitions = []
    for i in range(n):
        t: dict[str, Any] = {"type": "Always", "from": f"s{i}", "to": f"s{(i + 1) % n}"}
        if kind in ("guard", "guard+set"):
            t["guard"] = "n >= 0"
        if kind == "guard+set":
            t["set"] = {"n": "n + 1"}
        transitions.append(t)
    return {"initial": "s0", "vars": {"n": 0}, "states": [{"id": f"s{i}", "type": "Idle"} for i in range(n)],
            "transitions": transitions}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="fewer repeats")
    args = ap.parse_args()
    repeat = 2 if args.quick else 5
    print("| workload | figure | target |")
    print("|---|---|---|")
    steps = rate(sequence_doc(1000), 20000, repeat)
    print(f"| 1,000 steps, 3 monitors of callers each | {steps:,.0f} ticks/s | >= 200,000 ticks/s "
          f"{'(pass)' if steps >= 200_000 else '(MISS)'} |")
    plain = rate(ring_doc("plain"), 200_000, repeat)
    for kind in ("guard", "guard+set"):
        r = rate(ring_doc(kind), 200_000, repeat)
        cost = 1 - r / plain
        print(f"| flat ring of 100, {kind} on every transition | {r:,.0f} transitions/s ({cost:.0%} below plain "
              f"{plain:,.0f}) | at most 20 % {'(pass)' if cost <= 0.2 else '(MISS)'} |")
    base = None
    for others in (10, 100, 1000):
        us = pause_resume_us(others, repeat)
        base = base or us
        print(f"| pause + resume of one sequence, {others} other regions | {us:.1f} us ({us / base:.2f}x of 10) | "
              "flat in the size of the rest |")


if __name__ == "__main__":
    main()
