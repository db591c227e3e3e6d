"""Benchmark: accuracy of the camera pipeline against ground truth, and its cost per frame.

The issue-9 sweep: 640x480, fx = fy = 600, DICT_4X4_50, 0.15 m
markers, a gate of two markers 0.5 m apart (0.24 m at 0.5 m, so both fit) straight ahead at 0.5-4 m,
turned by 0/30/60 degrees; per cell ``--frames`` rendered frames (seeded noise). Columns: detection
rate, marker position error (3-D, median / p95, cm), gate heading error from the two marker positions
(median / p95, degrees), false positives, and render / detect milliseconds per frame. Then a drive
towards a gate at 20 Hz: ms per frame for full-frame detection and for region-of-interest tracking.
Not a timed test: CI does not run it.

    .venv/bin/python benchmarks/bench_vision.py [--frames 50] [--seed 0]
"""

from __future__ import annotations

import argparse
import math
import time
from types import SimpleNamespace

import cv2
import numpy as np


def pct(values: list[float], q: float) -> float:
    return float(np.percentile(values, q)) if values else float("nan")


def sweep(frames: int, seed: int) -> list[dict]:
    from fsm.sim.camera import SimCamera, markers_from_gates
    from fsm.vision import CameraMount, GateRule, MarkerDetector, find_gates

    mount = CameraMount(height=0.18)
    rows = []
    for d in (0.5, 1.0, 2.0, 3.0, 4.0):
        for yaw in (0, 30, 60):
            width = 0.24 if d == 0.5 else 0.5
            gate = SimpleNamespace(markers=(1, 2), center=(d, 0.0), heading=float(yaw), width=width, marker_size=0.15,
                                   height=0.18)
            specs = markers_from_gates([gate])
            cam = SimCamera(specs, mount=mount, seed=seed + int(d * 100) + yaw)
            det = MarkerDetector(cam.camera, mount=mount)
            truth = {m.id: cam.truth(m, 0, 0, 0)[0] for m in specs}
            found = fp = 0
            dt: list[float] = []
            gate_err: list[float] = []
            t_render = t_detect = 0.0
            px = float(np.ptp(cam.project(0, 0, 0)[0].corners[:, 0]))
            for _ in range(frames):
                t0 = time.perf_counter()
                frame = cam.render(0, 0, 0)
                t1 = time.perf_counter()
                ds = det.detect(frame)
                t2 = time.perf_counter()
                t_render += t1 - t0
                t_detect += t2 - t1
                for x in ds:
                    if x.id in truth:
                        found += 1
                        dt.append(100 * float(np.linalg.norm(np.array(x.position) - truth[x.id])))
                    else:
                        fp += 1
                gates = find_gates(ds, GateRule(pairs=[(1, 2)]))
                if gates:
                    err = math.degrees(gates[0].heading) - yaw
                    gate_err.append(abs((err + 180) % 360 - 180))
            rows.append({"d": d, "yaw": yaw, "px": px, "det": 100 * found / (2 * frames), "fp": fp,
                         "dt_med": pct(dt, 50), "dt_p95": pct(dt, 95), "gate_med": pct(gate_err, 50),
                         "gate_p95": pct(gate_err, 95), "gates": 100 * len(gate_err) / frames,
                         "render": 1000 * t_render / frames, "detect": 1000 * t_detect / frames})
    return rows


def drive(seed: int, track: bool, full_every: int = 10) -> dict:
    """The car drives at 1 m/s from 5 m to 0.7 m in front of a gate 25 degrees off its axis, weaving a little,
    with the camera at 20 Hz; what a frame costs, and how often the gate is seen."""
    from fsm.sim.camera import SimCamera, markers_from_gates
    from fsm.vision import MarkerDetector, find_gates

    gate = SimpleNamespace(markers=(12, 31), center=(5.5, 0.3), heading=25.0, width=0.8, marker_size=0.15, height=0.15)
    cam = SimCamera(markers_from_gates([gate]), seed=seed)
    det = MarkerDetector(cam.camera, mount=cam.mount, track=track, full_every=full_every)
    n = 0
    seen = 0
    t_render = t_detect = 0.0
    for k in range(87):  # 4.3 s at 20 Hz
        x = 0.05 * k
        y = 0.05 * math.sin(k / 8)
        th = 0.08 * math.sin(k / 6)
        t0 = time.perf_counter()
        frame = cam.render(x, y, th)
        t1 = time.perf_counter()
        gates = find_gates(det.detect(frame))
        t2 = time.perf_counter()
        t_render += t1 - t0
        t_detect += t2 - t1
        n += 1
        seen += bool(gates)
    return {"render": 1000 * t_render / n, "detect": 1000 * t_detect / n, "seen": 100 * seen / n,
            "full": det.full_searches, "roi": det.roi_searches, "frames": n}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=50)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    cv2.setNumThreads(1)
    print(f"OpenCV {cv2.__version__}, numpy {np.__version__}, one thread; {args.frames} frames per cell\n")
    print("| d [m] | yaw | marker px | det % | dt med / p95 [cm] | gate seen % | gate heading med / p95 [deg] "
          "| fp | render / detect [ms] |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in sweep(args.frames, args.seed):
        print(f"| {r['d']:g} | {r['yaw']} | {r['px']:.0f} | {r['det']:.0f} | {r['dt_med']:.2f} / {r['dt_p95']:.2f} "
              f"| {r['gates']:.0f} | {r['gate_med']:.2f} / {r['gate_p95']:.2f} | {r['fp']} "
              f"| {r['render']:.2f} / {r['detect']:.2f} |")
    print("\nDriving towards a gate at 20 Hz (87 frames, 640x480):\n")
    print("| detection | render ms | detect ms | total ms / frame | camera cost per simulated s | gate seen % "
          "| full / ROI searches |")
    print("|---|---|---|---|---|---|---|")
    for label, track in (("full frame every frame", False), ("ROI tracking, full frame every 10th", True)):
        runs = [drive(args.seed, track) for _ in range(3)]
        r = min(runs, key=lambda r: r["render"] + r["detect"])
        total = r["render"] + r["detect"]
        print(f"| {label} | {r['render']:.2f} | {r['detect']:.2f} | {total:.2f} | {20 * total:.0f} ms "
              f"| {r['seen']:.0f} | {r['full']} / {r['roi']} |")


if __name__ == "__main__":
    main()
