"""Benchmark: what the live debugger costs (issue 24). The hallway lap (16,176 ticks, trace recorded in memory as
``fsmctl run --live`` records it) at full speed:

- **plain**: the session run to its end, no controller, no server;
- **live, no page**: the same run under the controller (commands looked at between chunks of ticks, a snapshot
  after each) with the live server listening in the same process and no page connected (target: at most 5 %
  slower);
- **live, one page**: the same with one headless Chromium page connected and redrawing (target: at most 15 %
  slower; the page gets at most 30 messages a second, the server drops what a slow page cannot take);
- **rewind**: after the run, back to tick 10,000: from the nearest snapshot the controller took on the way
  (restored in place, the rest re-simulated; target under 0.2 s), and, for comparison, with snapshots off (a fresh
  session re-simulated from tick 0); what a snapshot costs (processor time of the run's thread, bytes it holds);
- **live, 10 watch expressions**: the live run, no page, with ten watch expressions evaluated after every tick
  (target: at most 10 % slower than plain); "why" and watches cost nothing while none is asked (the no-page row);
- **why**: after the rewind, the explanation of tick 10,000 (a re-simulation to it, the run untouched);
- **watch values on request** (``--range ROUNDS``): what a page's plot or cursor asks of a paused run, the ten
  watches' values at every tick of 10,000 ticks, re-simulated (from a snapshot, from the start, reduced per pixel
  column);
- **step to redrawn page**: with the run paused and the page connected, the time from a click on "Step 1" to the
  page showing the new tick (the page's own clock, ``performance.now``; target under 100 ms).

Speed lost is shown twice: from the ticks per second (wall clock: what the user sees, but on a shared machine as
noisy as its load) and from this process's processor time per tick (``time.process_time``: the run's thread, the
server's and the bench's polling; steadier under load, blind to what Chromium takes from the run's core). The
run's thread and the server's are also shown on their own (each thread's processor time per tick), and Chromium's
processes' processor time per 1,000 ticks.

``--no-server ROUNDS``: the lap plain against ``Controller.loop`` in the same thread (no server, no page), alone,
with snapshots off and with the ten watches, alternated round by round in one process: the live loop's own cost
per tick, by processor time.

Each run starts paused; the clock starts at "resume" and stops when the controller says the run has ended (looked
at every 20 ms from the main thread: at most 20 ms on a run of seconds). Two cores shared with Chromium: the page
figures include the browser's own work. Not a timed test: CI does not run it.

    .venv/bin/python benchmarks/bench_live.py [--repeat 3] [--steps 30] [--no-browser] [--json FILE]
    .venv/bin/python benchmarks/bench_live.py --no-server 7
    .venv/bin/python benchmarks/bench_live.py --instructions
    .venv/bin/python benchmarks/bench_live.py --range 5
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import sys
import threading
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
LAP = ROOT / "diagrams" / "hallway_lap.json"
WORLD = ROOT / "diagrams" / "worlds" / "hallway.json"


_PLAN: list[Any] = []
#: Ten watch expressions over the car's readings (what a person watching a lap would ask for).
WATCHES = ("car_front", "car_left", "car_right", "car_distance", "car_speed", "car_steering", "car_speed_command",
           "car_front < 0.9", "car_left + car_right", "car_distance * 2")


def make_session() -> tuple[Any, Any]:
    """The lap's session recording into a live line buffer, as ``fsmctl run --live`` builds it (the plan compiled
    once, as there)."""
    from fsm.loading.loader import compile as compile_plan
    from fsm.sim import simulate
    from fsm.tools.live.stream import LineBuffer
    from fsm.tools.recording import run_recorder
    from fsm.tools.recording.document import header_document

    if not _PLAN:
        _PLAN.extend([compile_plan(str(LAP)), header_document(str(LAP))])
    session = simulate(_PLAN[0], world=WORLD)
    buffer = LineBuffer()
    session.record(run_recorder(buffer, str(LAP), session.car, world_file=WORLD, document=_PLAN[1]))
    return session, buffer


def snapshot_figures(controller: Any) -> tuple[int, float, int, list[int]]:
    """How many snapshots the run took, what the last cost (s of the run thread's processor time), the bytes one
    holds (median), and their ticks."""
    from fsm.session.snapshot import sizeof

    snaps = controller.snapshots
    sizes = sorted(sizeof(snap) for snap in snaps) or [0]
    return len(snaps), controller._snap_cost, sizes[len(sizes) // 2], [snap.tick for snap in snaps]


def plain() -> tuple[float, float]:
    session, _ = make_session()
    c0, t0 = time.process_time(), time.perf_counter()
    session.run()
    return session.ticks / (time.perf_counter() - t0), (time.process_time() - c0) / session.ticks * 1e6


class LiveRun:
    """The lap under the controller, served on a free port from a thread of its own (as ``serve`` does)."""

    def __init__(self, watches: int = 0, snapshots: bool = True) -> None:
        import asyncio

        from fsm.debug.control import SNAPSHOT_PERIOD, Controller
        from fsm.tools.live.page import live_page
        from fsm.tools.live.server import LiveServer, Source

        session, buffer = make_session()
        session.start()
        source = Source(buffer)

        def factory() -> Any:  # a rewind's session, its trace the one the pages switch to
            fresh, source.buffer = make_session()
            return fresh

        def restored(session: Any) -> None:  # a snapshot restored: the pages switch to its trace
            source.buffer = session.recorder.out

        self.controller = Controller(session, factory=factory, speed=None, paused=True,
                                     fresh=lambda: make_session()[0], on_restore=restored,
                                     snapshot_period=SNAPSHOT_PERIOD if snapshots else None)
        source.controller = self.controller
        for text in WATCHES[:watches]:
            self.controller.send("watch", {"expr": text})
        header = json.loads(buffer.first_line())
        self.server = LiveServer(source, live_page(header, LAP.name), None)
        self.loop = asyncio.new_event_loop()
        started = threading.Event()
        self.port = 0

        def serve() -> None:
            asyncio.set_event_loop(self.loop)

            async def start() -> None:
                self.port = await self.server.start("127.0.0.1", 0)
                started.set()

            self.loop.run_until_complete(start())
            self.loop.run_forever()

        self.thread = threading.Thread(target=serve, daemon=True)
        self.thread.start()
        started.wait(10)
        self.runner = threading.Thread(target=self.controller.loop, daemon=True)
        self.runner.start()
        self.url = f"http://127.0.0.1:{self.port}/"

    def run(self) -> tuple[float, float]:
        """Resume, wait for the end: ticks per second, and this process's processor time per tick in us (the
        run's thread, the server's and this one's polling: what the run costs here, however busy the machine)."""
        controller = self.controller
        ticks0 = controller.session.ticks
        threads0 = self.thread_times()
        c0, t0 = time.process_time(), time.perf_counter()
        controller.send("resume")
        while controller.ended is None:
            time.sleep(0.02)
        ticks = controller.session.ticks - ticks0
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        #: the run's thread and the server's, processor time per tick in us
        self.threads = tuple((b - a) / ticks * 1e6 for a, b in zip(threads0, self.thread_times(), strict=True))
        return ticks / wall, cpu / ticks * 1e6

    def thread_times(self) -> tuple[float, float]:
        """Processor seconds used so far by the run's thread and by the server's (0 where the platform cannot
        tell)."""
        out = []
        for thread in (self.runner, self.thread):
            try:
                out.append(time.clock_gettime(time.pthread_getcpuclockid(thread.ident or 0)))
            except (AttributeError, OSError):
                out.append(0.0)
        return out[0], out[1]

    def rewind(self, tick: int) -> float:
        """Seconds from the rewind command to the controller's notice that it is there."""
        controller = self.controller
        t0 = time.perf_counter()
        controller.send("rewind", {"tick": tick})
        while controller.snapshot.get("tick") != tick or controller.session.ticks != tick:
            time.sleep(0.002)
        return time.perf_counter() - t0

    def why(self, tick: int) -> float:
        """Seconds from a ``why`` of ``tick`` to its answer."""
        controller = self.controller
        t0 = time.perf_counter()
        controller.send("why", {"tick": tick}, "why")
        while not any(m.get("id") == "why" for m in list(controller.messages)):
            time.sleep(0.002)
        answer = next(m for m in list(controller.messages) if m.get("id") == "why")
        assert answer["ok"], answer
        return time.perf_counter() - t0

    def close(self) -> None:
        self.controller.send("stop")
        self.runner.join(10)
        import asyncio

        asyncio.run_coroutine_threadsafe(self.server.close(), self.loop).result(60)
        self.loop.call_soon_threadsafe(self.loop.stop)
        self.thread.join(10)


def controller_round(watches: int, snapshots: bool = True) -> float:
    """The lap under :meth:`Controller.loop` in this thread (no server, no page), as ``fsmctl run --live`` runs it
    (with its per-chunk ``stop``): processor time per tick in us."""
    from fsm.debug.control import SNAPSHOT_PERIOD, Controller

    session, _ = make_session()
    session.start()
    controller = Controller(session, factory=lambda: make_session()[0], speed=None,
                            snapshot_period=SNAPSHOT_PERIOD if snapshots else None)
    for text in WATCHES[:watches]:
        controller.send("watch", {"expr": text})
    halt = threading.Event()
    c0 = time.process_time()
    controller.loop(stop=lambda: halt.is_set() or controller.ended is not None)
    return (time.process_time() - c0) / session.ticks * 1e6


def in_process(rounds: int) -> int:
    """``--no-server``: plain against the controller's loop, alone and with the ten watches, alternated in one
    process: what the live loop itself costs per tick, without the server's thread and the page."""
    cases = {"plain (session.run)": lambda: plain()[1], "Controller.loop": lambda: controller_round(0),
             "Controller.loop, snapshots off": lambda: controller_round(0, snapshots=False),
             "Controller.loop, 10 watches": lambda: controller_round(len(WATCHES))}
    times: dict[str, list[float]] = {name: [] for name in cases}
    for _ in range(rounds):
        for name, case in cases.items():
            times[name].append(case())
    best = min(times["plain (session.run)"])
    print("| the hallway lap, in one process | processor us/tick median | best | against plain (best) |")
    print("|---|---:|---:|---:|")
    for name, got in times.items():
        print(f"| {name} | {statistics.median(got):.2f} | {min(got):.2f} | {min(got) / best - 1:+.1%} |")
    return 0


def _reply(controller: Any, name: str, args: dict[str, Any]) -> dict[str, Any]:
    """Send a command to a controller looping in another thread and wait for its reply."""
    ident = f"{name}-{time.monotonic_ns()}"
    controller.send(name, args, ident)
    while True:
        for message in list(controller.messages):
            if message.get("id") == ident:
                if not message["ok"]:
                    raise SystemExit(f"{name}: {message['error']}")
                return message  # type: ignore[no-any-return]
        time.sleep(0.0005)


def range_request(rounds: int) -> int:
    """``--range ROUNDS``: the ten watches' values at every tick of 10,000 ticks, asked of a paused live run at tick
    16,000 of the lap (the controller's ``watch_values``, what the page's plot and cursor ask): re-simulated from the
    latest snapshot before the range, from the start, and reduced to 800 pixel columns; wall and processor time of
    the request (median of ``rounds``), and the instructions' worth of ticks (ticks re-simulated)."""
    from fsm.debug.control import Controller

    session, _ = make_session()
    controller = Controller(session, factory=lambda: make_session()[0], speed=None, paused=True)
    thread = threading.Thread(target=controller.loop, daemon=True)
    thread.start()
    try:
        for text in WATCHES:
            _reply(controller, "watch", {"expr": text})
        _reply(controller, "step", {"n": 16_000})
        while controller.snapshot.get("tick") != 16_000 or controller.snapshot.get("state") != "paused":
            time.sleep(0.005)
        snaps = [s.tick for s in controller.snapshots]
        cases = {"10,000 ticks (6,000-15,999), from a snapshot": {"from": 6_000, "to": 15_999},
                 "10,000 ticks (0-9,999), from the start": {"from": 0, "to": 9_999},
                 "10,000 ticks (6,000-15,999), reduced to 800 columns": {"from": 6_000, "to": 15_999, "width": 800},
                 "one tick (12,345): the cursor's cell": {"from": 12_345, "to": 12_345}}
        print(f"snapshots at ticks {snaps}")
        print("| watch_values request, 10 watches, lap paused at tick 16,000 | source | wall ms median | best | "
              "processor ms median |")
        print("|---|---|---:|---:|---:|")
        for name, args in cases.items():
            walls, cpus, source = [], [], ""
            for _ in range(rounds):
                w0, c0 = time.perf_counter(), time.process_time()
                answer = _reply(controller, "watch_values", args)
                walls.append((time.perf_counter() - w0) * 1e3)
                cpus.append((time.process_time() - c0) * 1e3)
                source = answer["source"]
            print(f"| {name} | {source} | {statistics.median(walls):.0f} | {min(walls):.0f} | "
                  f"{statistics.median(cpus):.0f} |")
    finally:
        controller.send("stop")
        thread.join(20)
    return 0


def browser_cpu() -> float:
    """Processor seconds used so far by the Chromium processes this benchmark started (its descendants on Linux;
    0 where /proc is missing): what the page costs the machine, however busy it is."""
    proc = Path("/proc")
    if not proc.is_dir():
        return 0.0
    parents: dict[int, int] = {}
    stats: dict[int, tuple[str, float]] = {}
    tick = os.sysconf("SC_CLK_TCK")
    for entry in proc.iterdir():
        if not entry.name.isdigit():
            continue
        try:
            text = (entry / "stat").read_text()
        except OSError:
            continue
        name, rest = text[text.index("(") + 1:text.rindex(")")], text[text.rindex(")") + 2:].split()
        parents[int(entry.name)] = int(rest[1])
        stats[int(entry.name)] = (name, (int(rest[11]) + int(rest[12])) / tick)
    me, total = os.getpid(), 0.0
    for pid, (name, cpu) in stats.items():
        up, seen = pid, 0
        while up in parents and up != me and seen < 64:
            up, seen = parents[up], seen + 1
        if up == me and "chrom" in name.lower():
            total += cpu
    return total


def step_latency(page: Any, steps: int) -> list[float]:
    """Milliseconds from a click on "Step 1" to the page showing the next tick, ``steps`` times."""
    out = []
    for _ in range(steps):
        ms = page.evaluate("""() => new Promise(done => {
            const want = String(window.tralLive.status().tick + 1), t0 = performance.now();
            document.getElementById('run-step').click();
            (function look() {
              if (document.body.dataset.tick === want) done(performance.now() - t0);
              else requestAnimationFrame(look);
            })();
        })""")
        out.append(float(ms))
        time.sleep(0.05)
    return out


def wait_drawn(page: Any, script: str, seconds: float = 30) -> None:
    """Poll ``script`` in the page (its CSP forbids Playwright's own polling, which evaluates strings)."""
    end = time.monotonic() + seconds
    while not page.evaluate(f"!!(window.tralLive && window.tralLive.drawn && window.tralLive.drawn() > 0 && "
                            f"window.tralLive.status() && ({script}))"):
        if time.monotonic() > end:
            raise SystemExit(f"the live page did not get to {script} within {seconds} s")
        time.sleep(0.05)


def count_instructions() -> int:
    """The lap's instructions, plain and under the controller with the server up and no page: each counted in a
    fresh process under callgrind with and without the run (``--probe MODE 0|1``), so that start-up, imports and
    the setup cancel out (``PYTHONHASHSEED=0``: string hashes move counts by about 1 % otherwise). The server's
    loop wakes on the wall clock, which valgrind slows about 50 times: its share is overcounted, not hidden."""
    from bench_instructions import callgrind

    if shutil.which("valgrind") is None:
        raise SystemExit("--instructions needs valgrind (apt install valgrind)")
    env = dict(os.environ, PYTHONHASHSEED="0")

    def count(mode: str, n: int) -> int:
        return callgrind([__file__, "--probe", mode, str(n)], env, ROOT, f"{mode} {n}")

    runs = {mode: count(mode, 1) - count(mode, 0) for mode in ("plain", "live", "nosnap", "watch")}
    print("| run of the hallway lap (16,176 ticks) | instructions | per tick |")
    print("|---|---:|---:|")
    for mode, label in (("plain", "plain (session.run)"), ("live", "live, no page"),
                        ("nosnap", "live, no page, snapshots off"), ("watch", "live, no page, 10 watch expressions")):
        print(f"| {label} | {runs[mode] / 1e6:,.0f}M | {runs[mode] / 16176:,.0f} |")
    print(f"\nunder the controller with the server up and no page: {runs['live'] / runs['plain'] - 1:+.1%} "
          "instructions (target: at most 5 % slower)")
    print(f"of which the snapshots for rewind: {runs['live'] / runs['nosnap'] - 1:+.1%} instructions")
    print(f"with 10 watch expressions: {runs['watch'] / runs['plain'] - 1:+.1%} instructions (target: at most 10 %)")
    return 0


def probe(mode: str, n: int) -> int:
    """One counted process: the lap plain or under the controller (``n`` 0: build only, to subtract)."""
    if mode == "plain":
        session, _ = make_session()
        if n:
            session.run()
    else:
        live = LiveRun(len(WATCHES) if mode == "watch" else 0, snapshots=mode != "nosnap")
        if n:
            live.run()
            if mode == "live":
                print(f"snapshots: {len(live.controller.snapshots)}", file=sys.stderr)
        live.close()
    return 0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--steps", type=int, default=30)
    ap.add_argument("--no-browser", action="store_true")
    ap.add_argument("--json", metavar="FILE")
    ap.add_argument("--instructions", action="store_true",
                    help="count instructions with valgrind instead (plain against live with no page): the same "
                         "figures however busy the machine is; a few minutes")
    ap.add_argument("--no-server", type=int, metavar="ROUNDS", default=0,
                    help="the live loop alone (no server, no page), alternated with the plain run in one process")
    ap.add_argument("--range", type=int, metavar="ROUNDS", default=0,
                    help="the time to answer a page's request for the watches' values at 10,000 ticks")
    ap.add_argument("--probe", nargs=2, metavar=("MODE", "N"), help=argparse.SUPPRESS)  # one counted process
    args = ap.parse_args()
    if args.probe:
        return probe(args.probe[0], int(args.probe[1]))
    if args.instructions:
        return count_instructions()
    if args.no_server:
        return in_process(args.no_server)
    if args.range:
        return range_request(args.range)
    results: dict[str, Any] = {"plain": [], "live_no_page": [], "live_one_page": [], "step_ms_tick0": [],
                               "step_ms_tick8000": []}
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    with_page = not args.no_browser and chromium is not None
    pw = browser = None
    if with_page:
        from playwright.sync_api import sync_playwright

        pw = sync_playwright().start()
        browser = pw.chromium.launch(executable_path=chromium, args=["--no-sandbox"])
    try:
        for k in range(args.repeat):  # interleaved: a loaded machine's drift falls on all three alike
            results["plain"].append(plain())
            live = LiveRun()
            try:
                results["live_no_page"].append(live.run())
                results.setdefault("threads_no_page", []).append(live.threads)
                results.setdefault("snapshots", []).append(snapshot_figures(live.controller))
                results.setdefault("rewind_10000_s", []).append(live.rewind(10_000))
                results.setdefault("why_10000_s", []).append(live.why(10_000))
            finally:
                live.close()
            live = LiveRun(snapshots=False)
            try:
                live.run()
                results.setdefault("rewind_resim_10000_s", []).append(live.rewind(10_000))
            finally:
                live.close()
            live = LiveRun(len(WATCHES))
            try:
                results.setdefault("live_watch10", []).append(live.run())
            finally:
                live.close()
            if browser is None:
                continue
            live = LiveRun()
            page = browser.new_page(viewport={"width": 1400, "height": 1000})
            try:
                page.goto(live.url)
                wait_drawn(page, "window.tralLive.status().tick === 0")
                time.sleep(1.0)  # the page settled (its first layout, fonts, plots): a page that follows the run
                if k == 0:
                    results["step_ms_tick0"] = step_latency(page, args.steps)
                    live.controller.send("step", {"n": 8000 - live.controller.session.ticks})
                    wait_drawn(page, "window.tralLive.status().tick === 8000 && document.body.dataset.tick === '8000'")
                    results["step_ms_tick8000"] = step_latency(page, args.steps)
                b0, t0 = browser_cpu(), live.controller.session.ticks
                results["live_one_page"].append(live.run())
                results.setdefault("threads_one_page", []).append(live.threads)
                results.setdefault("browser_ms_per_1000_ticks", []).append(
                    (browser_cpu() - b0) * 1e6 / max(1, live.controller.session.ticks - t0))
            finally:
                page.close()
                live.close()
    finally:
        if browser is not None and pw is not None:
            browser.close()
            pw.stop()
    base = results["plain"]
    alone = results["live_no_page"]

    def row(name: str, runs: list[list[float]]) -> None:
        speed, cpu = [r[0] for r in runs], [r[1] for r in runs]
        loss = 1 - statistics.median(speed) / statistics.median(s for s, _ in base)
        cpu_loss = 1 - min(c for _, c in base) / min(cpu)
        lost = "" if runs is base else f" {loss:.1%} | {cpu_loss:.1%}"
        print(f"| {name} | {statistics.median(speed):,.0f} | {max(speed):,.0f} | {statistics.median(cpu):.1f} | "
              f"{min(cpu):.1f} |{lost or ' | '} |")

    print("| run of the hallway lap, full speed | ticks/s median | best | processor us/tick median | best | "
          "speed lost (median ticks/s) | speed lost (best processor time) |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    row("plain (session.run)", base)
    row("live, no page", alone)
    row("live, no page, 10 watch expressions", results["live_watch10"])
    why = results["why_10000_s"]
    print(f"\nwhy of tick 10,000 (re-simulated to it): median {statistics.median(why):.2f} s, best {min(why):.2f} s")
    rw, full = results["rewind_10000_s"], results["rewind_resim_10000_s"]
    print(f"\nrewind from the end (16,176) to tick 10,000 from a snapshot: median {statistics.median(rw):.3f} s, best "
          f"{min(rw):.3f} s, worst {max(rw):.3f} s over {len(rw)}; re-simulated from tick 0 (snapshots off): median "
          f"{statistics.median(full):.3f} s, best {min(full):.3f} s")
    snaps = results["snapshots"]
    print(f"snapshots taken in a run of the lap: {', '.join(str(n) for n, _c, _b, _t in snaps)} (at ticks "
          f"{snaps[-1][3]}); each: {statistics.median(c for _n, c, _b, _t in snaps) * 1e3:.2f} ms of the run's "
          f"processor time (median of the runs' last), {statistics.median(b for _n, _c, b, _t in snaps) / 1e3:.0f} KB "
          f"held")
    if results["live_one_page"]:
        row("live, one Chromium page", results["live_one_page"])
        for key, what in (("threads_no_page", "no page"), ("threads_one_page", "one Chromium page")):
            runs = results[key]
            print(f"\nlive, {what}: the run's thread {statistics.median(r for r, _s in runs):.2f} us a tick (median), "
                  f"the server's thread {statistics.median(s for _r, s in runs):.3f} us a tick (median; processor "
                  "time of each thread)")
        bc = results["browser_ms_per_1000_ticks"]
        print(f"\nChromium's processor time while the page follows the run: median {statistics.median(bc):.0f} ms, "
              f"least {min(bc):.0f} ms per 1,000 ticks (the run itself: {min(c for _, c in base):.0f} ms per 1,000 "
              "ticks at its best)")
        for key, where in (("step_ms_tick0", "at tick 0"), ("step_ms_tick8000", "at tick 8,000 (half the lap shown)")):
            lat = sorted(results[key])
            p90 = lat[min(len(lat) - 1, int(0.9 * len(lat)))]
            print(f"\nclick on Step 1 to redrawn page {where}: median {statistics.median(lat):.1f} ms, "
                  f"p90 {p90:.1f} ms, max {lat[-1]:.1f} ms over {len(lat)} steps")
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=1) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))
    sys.exit(main())
