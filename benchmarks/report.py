"""The core benchmark's report: ratios against tral-fsm, the targets of issue 2, and the printed tables."""

from __future__ import annotations

from typing import Any

from peers import rate_adapters
from peers.workloads import FAN, FLAT_N, LOAD_N

TARGET_FLAT = 1_000_000
TARGET_FLAT_RATIO = 7.0
TARGET_NESTED = 300_000
TARGET_LOAD_MS = 50.0


def ours(results: list[dict[str, Any]], workload: str) -> dict[str, Any] | None:
    for row in results:
        if row["workload"] == workload and row["key"] == "tral-fsm" and row.get("status") == "ok":
            return row
    return None


def add_ratios(results: list[dict[str, Any]]) -> None:
    """``tral_fsm_speedup``: rates best against best, load times median against median."""
    for row in results:
        base = ours(results, row["workload"])
        if row.get("status") != "ok" or base is None or row is base:
            continue
        if row["unit"] == "ms":
            row["tral_fsm_speedup"] = row["median"] / base["median"]
        else:
            row["tral_fsm_speedup"] = base["best"] / row["best"]


def targets(results: list[dict[str, Any]]) -> list[dict[str, Any]]:
    out = []
    flat = ours(results, "flat")
    if flat is not None:
        out.append({"target": "(a) flat >= 1,000,000 transitions/s", "value": f"{flat['best']:,.0f}/s",
                    "pass": flat["best"] >= TARGET_FLAT})
        peers = [r for r in results if r["workload"] == "flat" and r.get("status") == "ok" and r is not flat]
        all_peers = [c.library for c, w in rate_adapters() if w.name == "flat" and c.key != "tral-fsm"]
        missing = [lib for lib in all_peers if lib not in {r["library"] for r in peers}]
        if peers:
            fastest = max(peers, key=lambda r: r["best"])
            ratio = flat["best"] / fastest["best"]
            value = f"{ratio:.1f}x {fastest['library']} ({fastest['best']:,.0f}/s)"
            if missing:  # a PASS against a subset of the peers would claim too much
                value += f"; not measured: {', '.join(missing)}"
            out.append({"target": f"(a) flat >= {TARGET_FLAT_RATIO:g}x the fastest peer", "value": value,
                        "pass": (ratio >= TARGET_FLAT_RATIO) if not missing or ratio < TARGET_FLAT_RATIO else None})
        else:
            out.append({"target": f"(a) flat >= {TARGET_FLAT_RATIO:g}x the fastest peer",
                        "value": "no peer measured", "pass": None})
    nested = ours(results, "nested")
    if nested is not None:
        out.append({"target": "(b) nested >= 300,000 transitions/s", "value": f"{nested['best']:,.0f}/s",
                    "pass": nested["best"] >= TARGET_NESTED})
    load = ours(results, "load")
    if load is not None:
        out.append({"target": "(c) load+validate+build 1000 states < 50 ms", "value": f"{load['median']:.1f} ms median",
                    "pass": load["median"] < TARGET_LOAD_MS})
    for row in results:  # tral-fsm itself failed a workload: its targets are missed
        if row["key"] == "tral-fsm" and row.get("status") != "ok":
            out.append({"target": f"({'abc'[['flat', 'nested', 'load'].index(row['workload'])]}) {row['workload']}",
                        "value": row.get("status", "?"), "pass": False})
    return out


def print_table(results: list[dict[str, Any]], goals: list[dict[str, Any]], env: dict[str, Any]) -> None:
    titles = {"flat": f"(a) flat ring of {FLAT_N} states, transitions/s",
              "nested": f"(b) nested {FAN}x{FAN}x{FAN}, transitions/s (all levels)",
              "load": f"(c) load + validate + build, {LOAD_N}-state ring from disk, ms"}
    header = f"{'library':<44} {'version':<9} {'best':>13} {'median':>13}  {'tral-fsm x':>10}"
    print(f"\ntral-fsm core benchmark  |  Python {env['python']}  {env['machine']}  {env['cpus']} CPUs  "
          f"load avg {env['loadavg_start']} -> {env['loadavg_end']}")
    for workload in ("flat", "nested", "load"):
        rows = [r for r in results if r["workload"] == workload]
        if not rows:
            continue
        print(f"\n{titles[workload]}")
        print(header)
        print("-" * len(header))
        for r in rows:
            if r.get("status") != "ok":
                print(f"{r['library']:<44} {r['version']:<9} {r.get('status', '?')}")
                continue
            if r["unit"] == "ms":
                best, med = f"{r['best']:.1f} ms", f"{r['median']:.1f} ms"
            else:
                best, med = f"{r['best']:,.0f}", f"{r['median']:,.0f}"
            ratio = "-" if "tral_fsm_speedup" not in r else f"{r['tral_fsm_speedup']:.1f}x"
            print(f"{r['library']:<44} {r['version']:<9} {best:>13} {med:>13}  {ratio:>10}")
    print("\n'tral-fsm x' = how many times faster tral-fsm is (rates: best/best; load: median/median).")
    if goals:
        print("\nTargets (issue 2)")
        for g in goals:
            mark = "n/a " if g["pass"] is None else ("PASS" if g["pass"] else "MISS")
            print(f"  {mark}  {g['target']:<48} {g['value']}")
