"""Timing for the core benchmark: the same garbage-collector policy, calibration and error handling for
every library; rate repeats go round-robin over the libraries so that outside load spreads over all."""

from __future__ import annotations

import argparse
import gc
import importlib
import statistics
import sys
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from importlib.metadata import PackageNotFoundError
from importlib.metadata import version as dist_version
from pathlib import Path
from typing import Any

from peers import Adapter, Loader, rate_adapters
from peers.workloads import FAN, Unsupported, WorkloadError

REPO = Path(__file__).resolve().parents[1]


def availability(cls: type[Adapter] | type[Loader]) -> str | None:
    """None if usable, else why not ("not installed", "shadowed by ...")."""
    try:
        mod = importlib.import_module(cls.module)
    except ImportError:
        return "not installed"
    if cls.key != "tral-fsm":
        origin = Path(getattr(mod, "__file__", "") or "").resolve()
        if REPO in origin.parents and ".venv" not in origin.parts:
            return f"shadowed by {origin}"
    return None


def new_row(cls: type[Adapter] | type[Loader], workload: str, unit: str, note: str) -> dict[str, Any]:
    """A result row, with the status "not installed" (or "shadowed ...") when the library is unusable."""
    try:
        version = dist_version(cls.dist)
    except PackageNotFoundError:
        version = "?"
    row: dict[str, Any] = {"workload": workload, "library": cls.library, "key": cls.key, "version": version,
                           "unit": unit, "note": note}
    why = availability(cls)
    if why is not None:
        row["status"] = why
        if why == "not installed":
            row["version"] = "-"
    return row


@contextmanager
def guarded(row: dict[str, Any]) -> Iterator[None]:
    """Record a library's failure in its row instead of stopping the run (one peer must not hide the others)."""
    try:
        yield
    except Unsupported as exc:
        row["status"] = f"unsupported: {exc}"
    except WorkloadError as exc:
        row["status"] = f"BROKEN: {exc}"
    except Exception as exc:  # noqa: BLE001
        row["status"] = f"ERROR: {type(exc).__name__}: {exc}"


class Timer:
    """Same gc policy for everyone: collect before each timed repeat; keep gc on (or off with --no-gc)."""

    def __init__(self, gc_off: bool) -> None:
        self.gc_off = gc_off

    def __enter__(self) -> Timer:
        gc.collect()
        if self.gc_off:
            gc.disable()
        return self

    def __exit__(self, *exc: Any) -> None:
        if self.gc_off:
            gc.enable()


def calibrate(adapter: Adapter, seconds: float, timer: Timer) -> int:
    """Steps per repeat so that one repeat lasts about ``seconds`` (also serves as the warm-up)."""
    n = 16
    while True:
        with timer:
            dt, _ = adapter.run(n)
        if dt >= 0.02 or n >= 1 << 24:
            break
        n *= 4
    return max(FAN, int(n * seconds / dt))


def measure_rates(args: argparse.Namespace, chosen: Any, results: list[dict[str, Any]]) -> None:
    """(a) and (b): rows in ``results`` with the rates of every repeat, best and median."""
    timer = Timer(args.no_gc)
    pairs = [(cls, w) for cls, w in rate_adapters() if chosen(w.name, cls.key)]
    for workload in dict.fromkeys(w for _, w in pairs):
        live: list[tuple[Adapter, dict[str, Any], int]] = []
        for cls, _ in (p for p in pairs if p[1] is workload):
            adapter = cls(workload)
            row = new_row(cls, workload.name, "transitions/s", adapter.note)
            results.append(row)
            if "status" in row:
                continue
            with guarded(row):
                t0 = time.perf_counter()
                adapter.setup()
                row["build_s"] = time.perf_counter() - t0
                adapter.precheck()
                n = args.n or calibrate(adapter, args.seconds, timer)
                adapter.check("after warm-up")
                row.update(status="ok", steps_per_repeat=n, runs=[])
                live.append((adapter, row, n))
                print(f"  [{workload.name}] {cls.library}: {n} steps per repeat", file=sys.stderr, flush=True)
        for r in range(args.repeat):
            for adapter, row, n in live:
                if row["status"] != "ok":
                    continue
                with guarded(row):
                    with timer:
                        dt, fired = adapter.run(n)
                    adapter.check(f"after repeat {r + 1}")
                    row["runs"].append(fired / dt)
        for _, row, _ in live:
            if row["status"] == "ok":
                row["best"] = max(row["runs"])
                row["median"] = statistics.median(row["runs"])


def measure_loads(args: argparse.Namespace, selected: list[type[Loader]], results: list[dict[str, Any]]) -> None:
    """(c): rows with the wall time of every load, median and best; the first load is ``first_ms``."""
    timer = Timer(args.no_gc)
    with tempfile.TemporaryDirectory(prefix="tral-bench-") as tmp:
        live: list[tuple[Loader, dict[str, Any]]] = []
        for cls in selected:
            loader = cls(Path(tmp))
            row = new_row(cls, "load", "ms", cls.note)
            results.append(row)
            if "status" in row:
                continue
            with guarded(row):
                loader.prepare()
                with timer:
                    t0 = time.perf_counter()
                    built = loader.once()   # first load in the process: imports, registries, caches
                    row["first_ms"] = (time.perf_counter() - t0) * 1e3
                loader.verify(built)
                del built
                row.update(status="ok", runs=[])
                live.append((loader, row))
                print(f"  [load] {cls.library}: first load {row['first_ms']:.1f} ms", file=sys.stderr, flush=True)
        for _ in range(args.load_repeat):
            for loader, row in live:
                with timer:
                    t0 = time.perf_counter()
                    built = loader.once()
                    dt = time.perf_counter() - t0
                row["runs"].append(dt * 1e3)
                del built
        for _, row in live:
            row["median"] = statistics.median(row["runs"])
            row["best"] = min(row["runs"])
