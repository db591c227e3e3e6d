"""Benchmark: sensor message in -> command out over Zenoh or rclpy with Fast DDS on localhost (issues 25 and 32: p99
under 5 ms at 80 ticks/s over 10,000 ticks), the in-process simulator's speed, which the bridge must not change, and
the replay of a 13-minute drive of about 300 MB (issue 32: under 20 s, RSS under 200 MB).

Two processes; over Zenoh peer mode on a free tcp/127.0.0.1 port, no router, no multicast; over rclpy (``--via
rclpy``) Fast DDS in a ROS domain of the benchmark's own with ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` and the
command as ``TwistStamped`` (ackermann_msgs has no wheel):

- the **source** (this file with ``--source``) plays the robot: every 12.5 ms of wall time it publishes what the TRAL
  profile binds (three ``sensor_msgs/Range`` at 20 Hz, ``nav_msgs/Odometry`` and the hall counter at 80 Hz) and the
  clock of that tick, and notes when it sent them;
- the **machine** (``fsmctl run --ros --lockstep``'s session: ``RosDriver`` with ``diagrams/lap.json``) ticks when the
  tick's clock arrives and publishes the tick's command (``AckermannDriveStamped``, stamped with the tick's time).

The latency of a tick is the time from the source's first ``put`` of the tick's sensor messages to the command
with that tick's stamp arriving back at the source: decode, latch, the machine's tick, encode and both network
hops (one clock, both processes on the same machine). Not a timed test: CI does not run it.

    .venv/bin/python benchmarks/bench_ros.py [--ticks 10000] [--rate 80] [--via zenoh|rclpy] [--json FILE]
                                             [--sim-repeat 3]
    .venv/bin/python benchmarks/bench_ros.py --replay-minutes 13 [--json FILE]

The replay: a sensors-only drive (three ``Range`` at 20 Hz, ``Odometry`` at 80 Hz) with a camera the profile does
not bind (``CompressedImage``, 30 KB at 10 Hz), written with rosbags as MCAP, then ``fsmctl replay`` in a process of
its own: its wall time and its maximum RSS (``getrusage`` of the child).
"""

from __future__ import annotations

import argparse
import gc
import json
import math
import os
import socket
import statistics
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
PROFILE = ROOT / "fsm" / "ros" / "tral.profile.json"
MACHINE = ROOT / "diagrams" / "lap.json"


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


#: How long an input may be silent in the benchmark's profile: the TRAL profile's 0.1-0.25 s would end the
#: lock-step run at the first stall of a loaded machine (the safety rule); the benchmark measures the stall instead.
BENCH_SILENCE = 5.0


#: rclpy's ROS domain for the benchmark (not 0, everyone's default).
BENCH_DOMAIN = 91


def bench_profile(via: str = "zenoh") -> Any:
    """The TRAL profile with every input's ``max_silence`` at :data:`BENCH_SILENCE`; over rclpy with a
    ``TwistStamped`` command, in :data:`BENCH_DOMAIN`."""
    from fsm.ros.profile import parse_profile

    data = json.loads(PROFILE.read_text(encoding="utf-8"))
    for binding in data["inputs"].values():
        binding["max_silence"] = BENCH_SILENCE
    data["transport"]["via"] = via
    if via == "rclpy":
        data["outputs"]["command"]["type"] = "geometry_msgs/msg/TwistStamped"
        data["transport"]["domain"] = BENCH_DOMAIN
        os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    return parse_profile(data, str(PROFILE), base_dir=str(PROFILE.parent))


def open_link(profile: Any, listen: list[str], connect: list[str], node: str) -> Any:
    from fsm.ros.transport import open_bus

    if profile.transport.via == "rclpy":
        return open_bus(profile, node=node).open()
    return open_bus(profile, connect=connect, listen=listen, via="zenoh", sim_time=True).open()  # lock-step


# -- the source: the robot's side ----------------------------------------------------------------------------
def source(endpoint: str, ticks: int, rate: float, via: str) -> dict[str, Any]:
    from fsm.ros import messages as M

    profile = bench_profile(via)
    link = open_link(profile, [endpoint], [], "bench_source")
    pubs = {name: link.publisher(b) for name, b in profile.inputs_bound().items()}
    clock = link.publisher(profile.clock)
    sent: dict[int, float] = {}
    got: dict[int, float] = {}
    done = threading.Event()
    dt = 1.0 / rate

    def on_command(raw: bytes) -> None:
        now = time.perf_counter()
        message = M.decode(raw, profile.outputs.command.type)
        n = round(M.stamp_seconds(message) / dt)
        if n not in got:
            got[n] = now
            if n >= ticks:
                done.set()

    link.subscribe(profile.outputs.command, on_command)
    link.wait_for_peer(30)
    while not (clock.matched() and all(p.matched() for p in pubs.values())):
        time.sleep(0.01)
    hall_type = profile.inputs.hall.type if profile.inputs.hall is not None else "std_msgs/msg/Int32"
    t0 = time.perf_counter()
    cpu0 = time.process_time()
    for n in range(ticks + 1):
        if n == 1:  # tick 0 waits for the machine to start (its command of tick 0); the timing starts then
            while 0 not in got:
                time.sleep(0.001)
            t0 = time.perf_counter() - dt
            cpu0 = time.process_time()
        due = t0 + n * dt
        delay = due - time.perf_counter()
        if delay > 0:
            time.sleep(delay)
        t = n * dt
        batch = []
        if n % 4 == 0:  # the ultrasonic sensors at 20 Hz
            batch += [("left", M.range_message(t, "us_left", 1.5, 4.0)),
                      ("right", M.range_message(t, "us_right", 0.4, 4.0)),
                      ("front", M.range_message(t, "us_front", 3.0, 4.0))]
        batch.append(("odometry", M.odometry_message(t, n * 0.01, 0.0, 0.0, 0.8, 0.0)))
        batch.append(("hall", M.counter_message(hall_type, n * 7)))
        raws = [(name, M.encode(message)) for name, message in batch]
        clock_raw = M.encode(M.clock_message(t))
        sent[n] = time.perf_counter()
        for name, raw in raws:
            pubs[name].put(raw)
        clock.put(clock_raw)
    done.wait(10)
    cpu = time.process_time() - cpu0
    link.close()
    lat = [(got[n] - sent[n]) * 1000 for n in range(1, ticks + 1) if n in got]
    return {"ticks": ticks, "received": len(lat), "latency_ms": lat, "wall_s": time.perf_counter() - t0,
            "cpu_s": cpu}


# -- the machine's side ----------------------------------------------------------------------------------------
def machine_side(endpoint: str, ticks: int, via: str) -> dict[str, Any]:
    from fsm.loading.loader import compile as compile_plan
    from fsm.ros.driver import ros_session
    from fsm.session.session import StopRules

    profile = bench_profile(via)
    link = open_link(profile, [], [endpoint], "fsmctl")
    session = ros_session(compile_plan(MACHINE), profile, link, lockstep=True, stop=StopRules(max_ticks=ticks),
                          log=lambda text: None)
    session.driver.prime(30)
    pauses: list[float] = []
    started: list[float] = []

    def on_gc(phase: str, info: dict[str, Any]) -> None:
        if phase == "start":
            started.append(time.perf_counter())
        elif started:
            pauses.append((time.perf_counter() - started.pop()) * 1000)

    gc.callbacks.append(on_gc)
    t0, cpu0 = time.perf_counter(), time.process_time()
    session.run()
    wall, cpu = time.perf_counter() - t0, time.process_time() - cpu0
    gc.callbacks.remove(on_gc)
    time.sleep(0.5)
    link.close()
    stopped = session.result.stopped if session.result is not None else "not started"
    return {"ticks": session.ticks, "wall_s": wall, "cpu_s": cpu, "ros": session.driver.metrics()["ros"],
            "stopped": stopped, "gc_pauses_ms": pauses}


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, max(0, math.ceil(q * len(ordered)) - 1))]


# -- the in-process simulator ---------------------------------------------------------------------------------------
def simulator(repeat: int) -> dict[str, Any]:
    """The hallway lap in-process (no bridge involved): its realtime factor, best and median of ``repeat``."""
    from fsm.sim import simulate

    factors = []
    for _ in range(repeat):
        session = simulate(ROOT / "diagrams" / "hallway_lap.json")
        session.run()
        m = session.summary()
        factors.append(m["sim_time"] / session.wall_time)
    return {"realtime_factor_best": round(max(factors), 1),
            "realtime_factor_median": round(statistics.median(factors), 1)}


# -- the replay of a long drive ---------------------------------------------------------------------------------
#: The machine of the replay: drives on for ever (the front range never comes under 1 m).
ENDLESS = {"name": "endless", "initial": "go",
           "states": [{"id": "go", "type": "Motor", "speed": 1.0, "steering": 0, "distance": 1000},
                      {"id": "halt", "type": "Stop"}],
           "transitions": [{"type": "SensorLevel", "from": "go", "to": "halt", "sensor": "front", "below": 1.0}]}


def write_long_drive(folder: Path, minutes: float) -> Path:
    """A sensors-only drive with an unbound camera topic, as MCAP (see the module's docstring)."""
    import numpy as np
    from rosbags.rosbag2 import StoragePlugin, Writer

    from fsm.ros import messages as M

    store = M.typestore()
    bag = folder / "drive"
    rng = np.random.default_rng(0)
    jpeg = rng.integers(0, 255, 30_000, dtype=np.uint8).tobytes()  # noise does not compress: 30 KB a frame
    epoch = 1_790_000_000.0
    with Writer(bag, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        conns = {side: writer.add_connection(f"/tral/ultrasonic/{side}", "sensor_msgs/msg/Range", typestore=store)
                 for side in ("left", "right", "front")}
        odom = writer.add_connection("/tral/odom", "nav_msgs/msg/Odometry", typestore=store)
        camera = writer.add_connection("/tral/camera/compressed", "sensor_msgs/msg/CompressedImage", typestore=store)
        for k in range(round(minutes * 60 * 80)):
            t = epoch + k / 80
            ns = round(t * 1e9)
            if k % 4 == 0:
                for side, conn in conns.items():
                    writer.write(conn, ns, M.encode(M.range_message(t, f"us_{side}", 3.0 if side == "front" else 0.5,
                                                                    4.0)))
            if k % 8 == 0:
                writer.write(camera, ns, M.encode(M.compressed_image_message(t, jpeg)))
            writer.write(odom, ns, M.encode(M.odometry_message(t, k / 80 / 2, 0.0, 0.0, 0.5, 0.0)))
    return bag


def replay_bench(minutes: float, json_out: str | None) -> int:
    import resource
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        t0 = time.perf_counter()
        bag = write_long_drive(folder, minutes)
        size = sum(f.stat().st_size for f in bag.iterdir())
        written = time.perf_counter() - t0
        data = json.loads(PROFILE.read_text(encoding="utf-8"))
        data.pop("$schema")
        del data["inputs"]["hall"]
        (folder / "profile.json").write_text(json.dumps(data), encoding="utf-8")
        (folder / "endless.json").write_text(json.dumps(ENDLESS), encoding="utf-8")
        t0 = time.perf_counter()
        proc = subprocess.run([sys.executable, "-m", "fsm.tools.cli", "replay", str(bag), "--machine",
                               str(folder / "endless.json"), "--profile", str(folder / "profile.json"), "--summary",
                               str(folder / "summary.json")], capture_output=True, text=True, cwd=ROOT)
        wall = time.perf_counter() - t0
        usage = resource.getrusage(resource.RUSAGE_CHILDREN)
        rss_mb = usage.ru_maxrss / 1024
        cpu = usage.ru_utime + usage.ru_stime  # the replay's CPU time: what a shared machine does not inflate
        if proc.returncode != 0:
            print(proc.stderr)
            return 1
        summary = json.loads((folder / "summary.json").read_text())
    report = {"minutes": minutes, "bag_mb": round(size / 1e6, 1), "write_s": round(written, 1),
              "ticks": summary["replay"]["ticks"], "replay_wall_s": round(wall, 2), "replay_cpu_s": round(cpu, 2),
              "max_rss_mb": round(rss_mb, 1), "load_average": os.getloadavg()[0]}
    print(f"replay of a {minutes:g}-minute drive, {report['bag_mb']} MB of MCAP (written in {written:.1f} s): "
          f"{report['ticks']} ticks in {wall:.2f} s ({cpu:.2f} s of CPU), max RSS {rss_mb:.1f} MB "
          f"(load average {report['load_average']:.1f})")
    verdict = "met" if wall < 20 and rss_mb < 200 else "NOT met"
    print(f"  target < 20 s and RSS < 200 MB: {verdict}")
    if json_out:
        Path(json_out).write_text(json.dumps(report, indent=2) + "\n", encoding="utf-8")
    return 0 if verdict == "met" else 1


#: Which executor spins rclpy's node (fsm.ros.rclpy_link.EXECUTOR_ENV); both processes read it.
EXECUTOR_ENV = "FSM_RCLPY_EXECUTOR"


def latency_run(ticks: int, rate: float, via: str, executor: str) -> dict[str, Any]:
    """One pair of processes (see the module's docstring), rclpy's node spun by ``executor``."""
    os.environ[EXECUTOR_ENV] = executor
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    load0 = os.getloadavg()[0]
    proc = subprocess.Popen([sys.executable, __file__, "--source", endpoint, "--ticks", str(ticks), "--rate",
                             str(rate), "--via", via], stdout=subprocess.PIPE, text=True)
    side = machine_side(endpoint, ticks, via)
    out, _ = proc.communicate(timeout=ticks / rate + 120)
    src = json.loads(out.strip().splitlines()[-1])
    lat = src.pop("latency_ms")
    pauses = side["gc_pauses_ms"]
    report = {"ticks": ticks, "rate_hz": rate, "via": via, "executor": executor, "commands_back": len(lat),
              "latency_ms": {"p50": round(percentile(lat, 0.50), 3), "p90": round(percentile(lat, 0.90), 3),
                             "p99": round(percentile(lat, 0.99), 3), "max": round(max(lat), 3),
                             "mean": round(statistics.fmean(lat), 3)},
              "machine_cpu_us_per_tick": round(side["cpu_s"] / max(1, side["ticks"]) * 1e6, 1),
              "source_cpu_us_per_tick": round(src["cpu_s"] / ticks * 1e6, 1),
              "machine_gc": {"collections": len(pauses), "total_ms": round(sum(pauses), 2),
                             "max_ms": round(max(pauses, default=0.0), 3)},
              "load_average": [round(load0, 1), round(os.getloadavg()[0], 1)],
              "machine_wall_s": round(side["wall_s"], 2), "decode_failures": side["ros"]["decode_failures"],
              "machine_stopped": side["stopped"], "machine_ticks": side["ticks"]}
    over = "Zenoh (localhost, peer mode)" if via == "zenoh" else f"rclpy with Fast DDS (localhost), {executor} executor"
    print(f"sensor in -> command out over {over}, {len(lat)} of {ticks} ticks at {rate:g} ticks/s:")
    for k, v in report["latency_ms"].items():
        print(f"  {k:>4}: {v:7.3f} ms")
    print(f"  CPU per tick: machine {report['machine_cpu_us_per_tick']} us, source {report['source_cpu_us_per_tick']}"
          f" us; the machine's GC: {report['machine_gc']}; load average {load0:.1f} -> {os.getloadavg()[0]:.1f}")
    if side["stopped"] != "limit":
        print(f"  the machine stopped after {side['ticks']} ticks: {side['stopped']} (in lock-step a clock that "
              f"stalls longer than {BENCH_SILENCE:g} s stops it: the machine was too loaded)")
    return report


def print_comparison(runs: dict[str, dict[str, Any]]) -> None:
    """The executors side by side, measured in one invocation: the new one's figures as ratios of the old's."""
    old, new = runs["single"], runs["events"]
    print("\n| executor | commands back | p50 | p90 | p99 | max | machine CPU/tick | source CPU/tick | load |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for kind, r in runs.items():
        q = r["latency_ms"]
        print(f"| {kind} | {r['commands_back']:,} | {q['p50']:.2f} ms | {q['p90']:.2f} ms | {q['p99']:.2f} ms | "
              f"{q['max']:.1f} ms | {r['machine_cpu_us_per_tick']:.0f} us | {r['source_cpu_us_per_tick']:.0f} us | "
              f"{r['load_average'][0]}-{r['load_average'][1]} |")
    ratios = {k: round(new["latency_ms"][k] / old["latency_ms"][k], 2) for k in ("p50", "p90", "p99")}
    cpu = round(new["machine_cpu_us_per_tick"] / old["machine_cpu_us_per_tick"], 2)
    print(f"events / single: p50 {ratios['p50']}, p90 {ratios['p90']}, p99 {ratios['p99']}, machine CPU {cpu}")


def main() -> int:
    sys.setswitchinterval(float(os.environ.get("SWITCH", "0.005")))
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--ticks", type=int, default=10_000)
    ap.add_argument("--rate", type=float, default=80.0)
    ap.add_argument("--json", metavar="FILE")
    ap.add_argument("--sim-repeat", type=int, default=3, help="in-process hallway laps to time (0: none)")
    ap.add_argument("--via", choices=("zenoh", "rclpy"), default="zenoh", help="the transport (default zenoh)")
    ap.add_argument("--compare-executors", action="store_true",
                    help="rclpy: the SingleThreadedExecutor, then the EventsExecutor, in one invocation")
    ap.add_argument("--replay-minutes", type=float, metavar="MIN",
                    help="instead: write a drive of MIN minutes (about 23 MB a minute) and time its replay")
    ap.add_argument("--source", metavar="ENDPOINT", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.replay_minutes:
        return replay_bench(args.replay_minutes, args.json)
    if args.source:
        result = source(args.source, args.ticks, args.rate, args.via)
        print(json.dumps(result))
        return 0
    if args.compare_executors and args.via != "rclpy":
        ap.error("--compare-executors is for --via rclpy")
    kinds = ["single", "events"] if args.compare_executors else [os.environ.get(EXECUTOR_ENV, "events")]
    runs = {kind: latency_run(args.ticks, args.rate, args.via, kind) for kind in kinds}
    report = dict(runs[kinds[-1]])
    if args.compare_executors:
        report["executors"] = runs
        print_comparison(runs)
    verdict = "met" if report["latency_ms"]["p99"] < 5.0 and report["commands_back"] == args.ticks else "NOT met"
    print(f"  target p99 < 5 ms over {args.ticks} ticks: {verdict} (load average {os.getloadavg()[0]:.1f})")
    if args.sim_repeat:
        report["in_process_simulator"] = simulator(args.sim_repeat)
        print(f"in-process hallway lap: {report['in_process_simulator']['realtime_factor_best']}x real time (best of "
              f"{args.sim_repeat}; median {report['in_process_simulator']['realtime_factor_median']}x)")
    if args.json:
        Path(args.json).write_text(json.dumps(report, indent=2) + "\n", encoding="utf-8")
    return 0 if verdict == "met" else 1


if __name__ == "__main__":
    sys.exit(main())
