"""Trace, report and export costs (issue 11), on the 200 s hallway lap:

- writing the trace costs at most 10 % of the closed loop's speed without video (the same lap run with and without
  a trace to a file, alternated, best of N each);
- ``fsmctl report`` for the lap in under 2 s (the command's wall time, process start included), the HTML at most
  2 MB;
- scrubbing redraws in under 50 ms (the report in headless Chromium: ``tralReport.setTime`` at 200 cursor
  positions spread over the run, the mean and the worst, layout included);
- ``fsmctl export --mcap``: time and size.

Run: ``.venv/bin/python benchmarks/bench_report.py`` (``--repeat N``, default 3). The scrub figure needs Chromium
and Playwright (the test extra); without them that row says so.
"""

from __future__ import annotations

import argparse
import io
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
FSMCTL = str(Path(sys.executable).parent / "fsmctl")
LAP = REPO / "diagrams" / "hallway_lap.uxf"


def closed_loop(trace: Path | None) -> float:
    """Wall time of the lap's closed loop (machine, car, physics), with the trace written to ``trace`` or none."""
    import fsm
    from fsm.sim.car import SimCar
    from fsm.sim.loop import Simulation
    from fsm.sim.world import default_world, load_world
    from fsm.tools.recording import run_recorder

    car = SimCar(load_world(default_world(str(LAP))), seed=0)
    m = fsm.load(LAP, car=car)
    stream = open(trace, "w", encoding="utf-8") if trace is not None else None
    rec = m.add_listener(run_recorder(stream, str(LAP), car, world_file="hallway.json"))
    t0 = time.perf_counter()
    m.start()
    rec.flush(m)
    Simulation(m, car).run(duration=600)
    rec.finish(m)
    if stream is not None:
        stream.close()
    return time.perf_counter() - t0


def scrub(html: Path) -> str:
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        return "n/a (no playwright)"
    if chromium is None:
        return "n/a (no Chromium)"
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=chromium, args=["--no-sandbox"])
        page = browser.new_context(offline=True, viewport={"width": 1400, "height": 1000}).new_page()
        page.goto(html.as_uri())
        page.wait_for_function("window.tralReport !== undefined")
        times = page.evaluate("""() => {
            const r = window.tralReport, out = [];
            for (let i = 0; i < 200; i++) {
                const t0 = performance.now();
                r.setTime(r.duration * ((i * 0.618034) % 1));
                document.body.offsetHeight;  // force the layout the redraw caused
                out.push(performance.now() - t0);
            }
            return out;
        }""")
        browser.close()
    return f"mean {sum(times) / len(times):.1f} ms, worst {max(times):.1f} ms"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    print(f"load: {os.getloadavg()[0]:.2f} (1 min) on {os.cpu_count()} CPUs")
    with tempfile.TemporaryDirectory() as tmp:
        trace = Path(tmp) / "lap.jsonl"
        plain, traced = [], []
        closed_loop(None)  # warm up imports and caches
        for _ in range(args.repeat):
            plain.append(closed_loop(None))
            traced.append(closed_loop(trace))
        cost = min(traced) / min(plain) - 1
        html = Path(tmp) / "lap.html"
        t0 = time.perf_counter()
        subprocess.run([FSMCTL, "report", str(trace), "-o", str(html)], check=True)
        report_s = time.perf_counter() - t0
        mcap = Path(tmp) / "lap.mcap"
        t0 = time.perf_counter()
        subprocess.run([FSMCTL, "export", str(trace), "--mcap", str(mcap)], check=True)
        mcap_s = time.perf_counter() - t0
        scrubbed = scrub(html)
        size_trace, size_html, size_mcap = trace.stat().st_size, html.stat().st_size, mcap.stat().st_size
    print("| workload | measured | target |")
    print("|---|---:|---|")
    print(f"| lap closed loop, no trace / with trace (best of {args.repeat}) | "
          f"{min(plain):.2f} s / {min(traced):.2f} s (+{cost * 100:.1f} %) | trace costs at most 10 % |")
    print(f"| trace of the 200 s lap | {size_trace / 1e6:.2f} MB | |")
    print(f"| `fsmctl report` of the lap (wall, process start included) | {report_s:.2f} s | under 2 s |")
    print(f"| report HTML | {size_html / 1e6:.2f} MB | at most 2 MB |")
    print(f"| scrubbing: one cursor move redrawn (200 moves, Chromium) | {scrubbed} | under 50 ms |")
    print(f"| `fsmctl export --mcap` of the lap | {mcap_s:.2f} s, {size_mcap / 1e6:.2f} MB | |")


if __name__ == "__main__":
    sys.stdout = io.TextIOWrapper(sys.stdout.buffer, line_buffering=True)
    main()
