#!/usr/bin/env python
"""Soak: a car that runs all day (issue 37). The machine of the issue follows the right-hand wall of the hallway and
never finishes; does the process's memory stay flat while it runs?

- **curve**: the machine for ``--hours`` simulated hours (default 8: 2,304,000 ticks) in the simulator, in a fresh
  process that reads its resident set size (VmRSS) every 600 simulated seconds; the slope in bytes per tick is the
  least-squares line through the points after the first 600 s.
- **cli**: ``fsmctl run forever.json --duration D --summary s.json`` for D = 600, 2400 and 9600 s, each in a fresh
  process, its max RSS (the issue's table; the target: max RSS after 9,600 s within 5 MB of the one after 600 s).
- **ros**: ``fsmctl sim --ros --lockstep`` and ``fsmctl run --ros --lockstep`` over Zenoh on 127.0.0.1 for
  ``--ros-hours`` simulated hours (default 1; 0 leaves it out), the run's RSS every few seconds of wall time and its
  max RSS at the end. Lock-step ticks run at an even pace, so the ticks at a sample are taken in proportion to the
  wall time (the run's total is exact).
- **live** (``--live-hours``, default 2; 0 leaves it out): ``fsmctl run --live`` as it runs with no page connected
  and no pace (as fast as possible): the controller, its snapshots for rewind and the trace streamed to the run's
  temporary file, with a rewind horizon of ``--live-horizon`` simulated seconds (default 600, so that the horizon
  is passed early), RSS every 600 simulated seconds and the slope in bytes per tick beyond the horizon.
- **instructions** (``--instructions``): the cost of one tick of the car loop counted with valgrind, as
  ``bench_instructions.py`` counts the core's (3,000 ticks and the summary, minus 1,000 ticks and the summary, over
  2,000: the base computed its figures from its lists at the summary, this checkout at each sample).

With ``--base REF`` the curve, the cli runs and the instruction count also run on an earlier commit, checked out into
a temporary git worktree (as ``bench_baseline.py`` does). Memory is memory: the machine's load does not change it,
only the wall times printed beside it.

    .venv/bin/python benchmarks/bench_soak.py [--hours 8] [--ros-hours 1] [--base REF] [--instructions] [--json F]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from bench_baseline import REPO, base_tree

BENCH = Path(__file__).resolve().parent
WORLD = REPO / "diagrams" / "worlds" / "hallway.json"
PROFILE = REPO / "fsm" / "ros" / "tral.profile.json"
#: The machine of issue 37.
FOREVER = {"name": "forever", "initial": "follow", "states": [
    {"id": "follow", "type": "FollowWall", "side": "right", "distance": 0.4, "speed": 1.0}]}
CLI_DURATIONS = (600.0, 2400.0, 9600.0)
#: simulated seconds between two points of the curve
EVERY = 600.0
#: how long an input may be silent in the lock-step run: a loaded machine stalls for longer than the TRAL profile's
#: 0.1-0.25 s, which would end the run (the safety rule), as in bench_ros.py
SILENCE = 5.0

#: What both child scripts measure with: the process's resident set, bytes.
RSS = r'''
from pathlib import Path


def rss():
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) * 1024
    return 0
'''

CURVE = r'''
import json, resource, sys, time
from pathlib import Path
if len(sys.argv) > 5:  # an earlier commit's fsm (PYTHONPATH) must win over this checkout's editable install
    sys.meta_path[:] = [f for f in sys.meta_path if 'editable' not in type(f).__module__.lower()]
from fsm.session.session import StopRules
from fsm.sim import simulate

machine, world, duration, every = json.loads(sys.argv[1]), sys.argv[2], float(sys.argv[3]), float(sys.argv[4])



session = simulate(machine, world=world, stop=StopRules(duration))
points = []
session.every(every, lambda s: points.append((s.ticks, rss())))
t0 = time.perf_counter()
session.run()
summary = session.summary()
wall = time.perf_counter() - t0
if not points or points[-1][0] != session.ticks:
    points.append((session.ticks, rss()))
print(json.dumps({"points": points, "max_rss": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024,
                  "wall_s": wall, "ticks": session.ticks, "laps": summary.get("lap_totals", {}).get("laps",
                  len(summary.get("laps", [])))}))
'''

LIVE = r'''
import json, resource, sys, time
from pathlib import Path
from fsm.debug.control import Controller
from fsm.session.session import StopRules
from fsm.sim import simulate
from fsm.tools.live.stream import TraceFile
from fsm.tools.recording import run_recorder

machine, world, duration, every, horizon = (json.loads(sys.argv[1]), sys.argv[2], float(sys.argv[3]),
                                            float(sys.argv[4]), float(sys.argv[5]))



session = simulate(machine, world=world, stop=StopRules(duration))
session.record(run_recorder(TraceFile(), "forever.json", session.car, world_file=world, document=machine))
points = []
session.every(every, lambda s: points.append((s.ticks, rss())))
controller = Controller(session, speed=None, horizon=horizon)
t0 = time.perf_counter()
controller.loop(stop=lambda: controller.ended is not None)
wall = time.perf_counter() - t0
if not points or points[-1][0] != session.ticks:
    points.append((session.ticks, rss()))
print(json.dumps({"points": points, "max_rss": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024,
                  "wall_s": wall, "ticks": session.ticks, "snapshots": len(controller.snapshots),
                  "earliest": controller.earliest, "trace_bytes": session.recorder.out.mark()}))
'''

TICKS = r'''
import json, sys
if len(sys.argv) > 4:
    sys.meta_path[:] = [f for f in sys.meta_path if 'editable' not in type(f).__module__.lower()]
from fsm.session.session import StopRules
from fsm.sim import simulate

session = simulate(json.loads(sys.argv[1]), world=sys.argv[2], stop=StopRules())
session.step(int(sys.argv[3]))
session.summary()  # what every run reports at its end: the base computed its figures here
'''


def python_env(tree: Path | None) -> dict[str, str]:
    env = dict(os.environ, PYTHONHASHSEED="0")
    if tree is not None:
        env["PYTHONPATH"] = str(tree)
    else:
        env.pop("PYTHONPATH", None)
    return env


def curve(hours: float, tree: Path | None) -> dict[str, Any]:
    """The machine for ``hours`` simulated hours in a fresh process: RSS every :data:`EVERY` simulated seconds."""
    args = [sys.executable, "-c", RSS + CURVE, json.dumps(FOREVER), str(WORLD), str(hours * 3600), str(EVERY)]
    if tree is not None:
        args.append("base")
    done = subprocess.run(args, env=python_env(tree), capture_output=True, text=True, cwd=str(tree or REPO),
                          timeout=6 * 3600)
    if done.returncode != 0:
        raise RuntimeError(f"the curve on {'base' if tree else 'this checkout'} failed:\n{done.stderr[-2000:]}")
    result: dict[str, Any] = json.loads(done.stdout.strip().splitlines()[-1])
    result["slope"] = slope([p for p in result["points"] if p[0] >= round(EVERY / 0.0125)])
    return result


def live_curve(hours: float, horizon: float) -> dict[str, Any]:
    """``fsmctl run --live`` with no page and no pace, for ``hours`` simulated hours in a fresh process: RSS every
    :data:`EVERY` simulated seconds, and the slope beyond the horizon (and beyond the first 600 s)."""
    args = [sys.executable, "-c", RSS + LIVE, json.dumps(FOREVER), str(WORLD), str(hours * 3600), str(EVERY),
            str(horizon)]
    done = subprocess.run(args, env=python_env(None), capture_output=True, text=True, cwd=str(REPO),
                          timeout=6 * 3600)
    if done.returncode != 0:
        raise RuntimeError(f"the live run failed:\n{done.stderr[-2000:]}")
    result: dict[str, Any] = json.loads(done.stdout.strip().splitlines()[-1])
    result["horizon"] = horizon
    past = round(max(horizon, EVERY) / 0.0125)
    result["slope"] = slope([p for p in result["points"] if p[0] > past])
    return result


def slope(points: list[list[int]]) -> float | None:
    """The least-squares slope of RSS against ticks, bytes per tick."""
    if len(points) < 2:
        return None
    n = len(points)
    mx = sum(p[0] for p in points) / n
    my = sum(p[1] for p in points) / n
    sxx = sum((p[0] - mx) ** 2 for p in points)
    return sum((p[0] - mx) * (p[1] - my) for p in points) / sxx if sxx else None


def fsmctl(tree: Path | None) -> list[str]:
    if tree is None:
        return [sys.executable, "-m", "fsm.tools.cli"]
    code = ("import sys\nsys.meta_path[:] = [f for f in sys.meta_path if 'editable' not in "
            "type(f).__module__.lower()]\nfrom fsm.tools.cli import main\nsys.exit(main())")
    return [sys.executable, "-c", code]


def max_rss_of(argv: list[str], env: dict[str, str], cwd: Path) -> tuple[int, float]:
    """Run ``argv``; its max RSS in bytes (from wait4) and its wall time. RuntimeError when it fails."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(argv, env=env, cwd=str(cwd), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _pid, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    err = proc.stderr.read().decode(errors="replace") if proc.stderr else ""
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(argv[-6:])} exited {proc.returncode}:\n{err[-2000:]}")
    return usage.ru_maxrss * 1024, wall


def cli_runs(tree: Path | None, machine: Path, out: Path) -> dict[float, tuple[int, float]]:
    rows = {}
    for duration in CLI_DURATIONS:
        rows[duration] = max_rss_of([*fsmctl(tree), "run", str(machine), "--world", str(WORLD), "--duration",
                                     f"{duration:g}", "--summary", str(out / "s.json"), "-q", "--no-progress"],
                                    python_env(tree), tree or REPO)
        print(f"  cli {'base' if tree else 'this'} {duration:g} s: {rows[duration][0] / 1e6:.1f} MB", file=sys.stderr,
              flush=True)
    return rows


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def ros_run(hours: float, machine: Path, out: Path) -> dict[str, Any]:
    """The machine over ROS 2 (Zenoh, lock-step) against ``fsmctl sim --ros``: the run's RSS over its wall time."""
    profile = json.loads(PROFILE.read_text(encoding="utf-8"))
    for binding in profile["inputs"].values():
        binding["max_silence"] = SILENCE
    profile.pop("$schema", None)  # a relative path, and only for editors
    profile_file = out / "soak.profile.json"
    profile_file.write_text(json.dumps(profile), encoding="utf-8")
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    duration = f"{hours * 3600:g}"
    env = python_env(None)
    sim = subprocess.Popen([*fsmctl(None), "sim", "--ros", str(profile_file), "--lockstep", "--listen", endpoint,
                            "--world", str(WORLD), "--duration", duration, "--wait", "60", "-q"],
                           env=env, cwd=str(REPO), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    t0 = time.perf_counter()
    run = subprocess.Popen([*fsmctl(None), "run", str(machine), "--ros", str(profile_file), "--lockstep", "--connect",
                            endpoint, "--duration", duration, "--summary", str(out / "ros.json"), "-q",
                            "--no-progress"], env=env, cwd=str(REPO), stdout=subprocess.DEVNULL,
                           stderr=subprocess.PIPE)
    samples: list[tuple[float, int]] = []
    status_file = Path(f"/proc/{run.pid}/status")
    try:
        while run.poll() is None:
            try:
                for line in status_file.read_text().splitlines():
                    if line.startswith("VmRSS:"):
                        samples.append((time.perf_counter() - t0, int(line.split()[1]) * 1024))
            except OSError:
                pass
            time.sleep(5.0)
    finally:
        for proc in (run, sim):
            if proc.poll() is None:
                proc.terminate()
        for proc in (run, sim):
            try:
                proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                proc.kill()
    wall = time.perf_counter() - t0
    err = run.stderr.read().decode(errors="replace") if run.stderr else ""
    if run.returncode != 0 or not (out / "ros.json").exists():
        sim_err = sim.stderr.read().decode(errors="replace") if sim.stderr else ""
        raise RuntimeError(f"fsmctl run --ros exited {run.returncode}:\n{err[-1500:]}\nsim:\n{sim_err[-1500:]}")
    summary = json.loads((out / "ros.json").read_text())
    ticks = int(summary["ticks"])
    points = [[round(ticks * t / wall), rss] for t, rss in samples]
    return {"ticks": ticks, "wall_s": wall, "points": points, "max_rss": max((p[1] for p in points), default=0),
            "slope": slope([p for p in points if p[0] >= round(EVERY / 0.0125)])}


def instructions(tree: Path | None, ticks: int) -> int:
    from bench_instructions import callgrind

    args = ["-c", TICKS, json.dumps(FOREVER), str(WORLD), str(ticks)]
    if tree is not None:
        args.append("base")
    return callgrind(args, python_env(tree), tree or REPO, f"{ticks} ticks on {'base' if tree else 'this checkout'}")


def per_tick(tree: Path | None) -> float:
    return (instructions(tree, 3000) - instructions(tree, 1000)) / 2000


def mb(value: float | None) -> str:
    return "" if value is None else f"{value / 1e6:.1f}"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--hours", type=float, default=8.0, help="simulated hours of the curve (default 8)")
    ap.add_argument("--ros-hours", type=float, default=1.0, help="simulated hours over ROS 2 (default 1; 0: none)")
    ap.add_argument("--base", help="also measure this earlier commit (curve, cli runs, instructions)")
    ap.add_argument("--live-hours", type=float, default=2.0,
                    help="simulated hours of a live run with no page (default 2; 0: none)")
    ap.add_argument("--live-horizon", type=float, default=600.0,
                    help="its rewind horizon, simulated seconds (default 600)")
    ap.add_argument("--no-cli", action="store_true", help="leave the fsmctl runs of 600/2400/9600 s out")
    ap.add_argument("--instructions", action="store_true", help="count the instructions of a tick (valgrind)")
    ap.add_argument("--json", metavar="FILE", help="also write every figure as JSON")
    args = ap.parse_args(argv)
    where = Path(tempfile.mkdtemp(prefix="tral-soak-"))
    machine = where / "forever.json"
    machine.write_text(json.dumps(FOREVER), encoding="utf-8")
    result: dict[str, Any] = {"hours": args.hours, "ros_hours": args.ros_hours, "base": args.base,
                              "load": os.getloadavg()}
    tree = None
    try:
        if args.base:
            tree = base_tree(args.base, where)
        sides: list[tuple[str, Path | None]] = [("this", None)] + ([("base", tree)] if tree is not None else [])
        for name, side in sides:
            print(f"curve on {name}: {args.hours:g} simulated hours ...", file=sys.stderr, flush=True)
            result.setdefault("curve", {})[name] = curve(args.hours, side)
            if not args.no_cli:
                result.setdefault("cli", {})[name] = {f"{d:g}": v for d, v in cli_runs(side, machine, where).items()}
            if args.instructions:
                result.setdefault("instructions", {})[name] = per_tick(side)
        if args.live_hours > 0:
            print(f"live, no page: {args.live_hours:g} simulated hours ...", file=sys.stderr, flush=True)
            result["live"] = live_curve(args.live_hours, args.live_horizon)
        if args.ros_hours > 0:
            print(f"ROS 2 lock-step: {args.ros_hours:g} simulated hours ...", file=sys.stderr, flush=True)
            result["ros"] = ros_run(args.ros_hours, machine, where)
    finally:
        if tree is not None:
            subprocess.run(["git", "-C", str(REPO), "worktree", "remove", "--force", str(tree)], capture_output=True)
        shutil.rmtree(where, ignore_errors=True)
    result["load_after"] = os.getloadavg()
    report(result)
    if args.json:
        Path(args.json).write_text(json.dumps(result, indent=1) + "\n", encoding="utf-8")
    return 0


def report(result: dict[str, Any]) -> None:
    curves = result["curve"]
    names = list(curves)
    print(f"## {result['hours']:g} simulated hours of the forever machine in the simulator\n")
    print("| simulated time | ticks | " + " | ".join(f"RSS {n}, MB" for n in names) + " |")
    print("|---:|---:|" + "---:|" * len(names))
    by_ticks = {n: dict((p[0], p[1]) for p in curves[n]["points"]) for n in names}
    every = max(1, round(3600 / EVERY))
    ticks = [p[0] for p in curves[names[0]]["points"]]
    for i, tick in enumerate(ticks):
        if i in (0, 1) or i % every == 0 or i == len(ticks) - 1:
            print(f"| {tick * 0.0125:,.0f} s | {tick:,} | " + " | ".join(mb(by_ticks[n].get(tick)) for n in names)
                  + " |")
    print()
    for n in names:
        c = curves[n]
        s = c["slope"]
        print(f"{n}: {c['ticks']:,} ticks in {c['wall_s']:.0f} s of wall time ({c['ticks'] / c['wall_s']:,.0f} "
              f"ticks/s), {c['laps']} laps, max RSS {mb(c['max_rss'])} MB, slope after 600 s "
              + (f"{s:.3f} bytes per tick" if s is not None else "n/a"))
    if "cli" in result:
        print("\n## fsmctl run forever.json --duration D --summary s.json, max RSS\n")
        print("| D | ticks | " + " | ".join(f"{n}, MB" for n in result["cli"]) + " |")
        print("|---:|---:|" + "---:|" * len(result["cli"]))
        for d in CLI_DURATIONS:
            key = f"{d:g}"
            print(f"| {d:,.0f} s | {round(d / 0.0125):,} | "
                  + " | ".join(mb(result["cli"][n][key][0]) for n in result["cli"]) + " |")
        for n, rows in result["cli"].items():
            growth = rows["9600"][0] - rows["600"][0]
            print(f"{n}: max RSS after 9,600 s minus after 600 s: {growth / 1e6:+.2f} MB (target: within 5 MB)")
    if "live" in result:
        live = result["live"]
        print(f"\n## a live run (fsmctl run --live), no page, as fast as possible, rewind horizon {live['horizon']:g} "
              "s\n")
        print("| simulated time | ticks | RSS, MB |\n|---:|---:|---:|")
        pts = live["points"]
        every = max(1, round(1800 / EVERY))
        for i, p in enumerate(pts):
            if i in (0, 1) or i % every == 0 or i == len(pts) - 1:
                print(f"| {p[0] * 0.0125:,.0f} s | {p[0]:,} | {mb(p[1])} |")
        s = live["slope"]
        print(f"\n{live['ticks']:,} ticks in {live['wall_s']:.0f} s of wall time "
              f"({live['ticks'] / live['wall_s']:,.0f} ticks/s); max RSS {mb(live['max_rss'])} MB; "
              f"{live['snapshots']} snapshots kept, rewind reaches back to "
              f"tick {live['earliest']:,}; trace on disk {live['trace_bytes'] / 1e6:.1f} MB; slope beyond the horizon "
              + (f"{s:.3f} bytes per tick" if s is not None else "n/a"))
    if "ros" in result:
        r = result["ros"]
        print(f"\n## {result['ros_hours']:g} simulated hour(s) over ROS 2 (Zenoh, lock-step)\n")
        pts = r["points"]
        step = max(1, len(pts) // 8)
        print("| ticks (about) | RSS, MB |\n|---:|---:|")
        for p in pts[::step] + ([pts[-1]] if pts and (len(pts) - 1) % step else []):
            print(f"| {p[0]:,} | {mb(p[1])} |")
        s = r["slope"]
        print(f"\n{r['ticks']:,} ticks in {r['wall_s']:.0f} s of wall time; max RSS {mb(r['max_rss'])} MB; slope after "
              "600 s " + (f"{s:.3f} bytes per tick" if s is not None else "n/a"))
    if "instructions" in result:
        ins = result["instructions"]
        line = ", ".join(f"{n} {v:,.0f}" for n, v in ins.items())
        print(f"\ninstructions per tick of the car loop (valgrind): {line}"
              + (f"; ratio {ins['this'] / ins['base']:.3f}" if "base" in ins else ""))
    print(f"\nload average {result['load'][0]:.1f} before, {result['load_after'][0]:.1f} after")


if __name__ == "__main__":
    sys.exit(main())
