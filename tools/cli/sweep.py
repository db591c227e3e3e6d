"""``fsmctl sweep``: many runs of one machine over seeds, worlds, parameter overrides and variables, on a local
process pool or a Ray cluster (``fsm.tools.sweep``).

Everything is checked before the first run (a located error and exit 1 for an override naming no state or
parameter, a value its type refuses, an empty grid, a glob matching nothing, an unreachable Ray address). Exit 0
when every run ran (whatever its outcome), 1 when a run raised, 130 on Ctrl-C after writing what finished.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from .common import EXIT_FAIL, EXIT_INTERRUPTED, EXIT_OK, positive_float, whole_number


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("sweep", help="run a machine over seeds, worlds and parameter values (process pool or Ray)",
                       description="Run one machine many times: the product of worlds x seeds x the values of each "
                                   "--set and --var. Writes OUT/sweep.jsonl (one record per run, as runs finish), "
                                   "OUT/sweep.csv, OUT/sweep.html and OUT/runs/<id>/summary.json. Running the same "
                                   "sweep again skips the runs that finished.")
    p.add_argument("spec", nargs="?", metavar="SPEC.json", help="a sweep file (flags override its keys)")
    p.add_argument("--machine", metavar="FILE", help="the machine (.json or .uxf)")
    p.add_argument("--world", action="append", default=[], metavar="WORLD|GLOB",
                   help="a world file or a glob of them (repeatable; default: the machine's default world)")
    p.add_argument("--seeds", metavar="START:STOP", help='seeds, e.g. 0:16 (16 seeds; default "0:1")')
    p.add_argument("--set", action="append", default=[], metavar="PATH.PARAM=V1,V2", dest="overrides",
                   help="values of a state's parameter, e.g. home.speed=0.8,1.0 or lap1/bottom.speed=0.8,1.0 "
                        "(repeatable; each adds a dimension to the grid)")
    p.add_argument("--var", action="append", default=[], metavar="NAME=V1,V2", dest="variables",
                   help="initial values of a blackboard variable (repeatable; each adds a dimension)")
    p.add_argument("--duration", type=positive_float, metavar="SECONDS", help="stop each run after this much "
                                                                              "simulated time (default 600 s)")
    p.add_argument("--no-noise", action="store_true", help="sensor noise off")
    p.add_argument("-o", "--out", metavar="DIR", default="sweep-out", help="output folder (default sweep-out)")
    p.add_argument("-j", "--jobs", type=whole_number(1, 512), metavar="N", default=None,
                   help="runs at a time (default: the number of CPUs)")
    p.add_argument("--backend", choices=("process", "ray"), default="process",
                   help="a local process pool (default) or a Ray cluster (pip install 'tral-fsm[ray]')")
    p.add_argument("--address", metavar="ADDR", help="the Ray cluster to use (default: start one on this machine)")
    p.add_argument("--trace", action="store_true", help="write each run's trace.jsonl")
    p.add_argument("--report", action="store_true", help="write each run's report.html (linked from sweep.html)")
    p.add_argument("--plot", action="store_true", help="write each run's plot.png")
    p.add_argument("--video", action="store_true", help="write each run's video.mp4 (slow)")
    p.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                   help="a progress bar with the time left (default: on a terminal)")
    p.add_argument("-q", "--quiet", action="store_true", help="print nothing but errors")
    p.set_defaults(func=cmd_sweep)


def cmd_sweep(args: argparse.Namespace) -> int:
    import os

    from fsm.errors import DiagramError, Problem, UsageError

    from ..sweep import overrides as O
    from ..sweep.backends import BackendError
    from ..sweep.runner import PlanError, execute, load_spec_file, plan
    from ..sweep.spec import SweepSpec

    if args.spec is None and args.machine is None:
        raise UsageError("give a sweep file or --machine FILE")
    if args.address and args.backend != "ray":
        raise UsageError("--address is for --backend ray")
    data: dict[str, Any] = {}
    base = Path.cwd()
    where = "the command line"
    name = Path(args.machine).stem if args.machine else "sweep"
    if args.spec is not None:
        spec_path = Path(args.spec)
        spec, problems = load_spec_file(spec_path)
        if problems:
            raise DiagramError(problems)
        data = spec.model_dump(by_alias=True, exclude_unset=True)
        base = spec_path.resolve().parent
        where = str(spec_path)
        name = spec.name or spec_path.stem
    if args.machine:
        data["machine"] = str(Path(args.machine).resolve())
    if args.world:
        data["worlds"] = [str(Path(w).resolve()) if not any(c in w for c in "*?[") else str(Path.cwd() / w)
                          for w in args.world]
    if args.seeds:
        data["seeds"] = args.seeds
    sets = dict(data.get("set") or {})
    for text in args.overrides:
        try:
            o = O.parse(text)
        except O.OverrideError as exc:
            raise UsageError(str(exc)) from None
        sets[f"{o.path}.{o.param}"] = list(o.values)
    data["set"] = sets
    variables = dict(data.get("vars") or {})
    for text in args.variables:
        key, sep, values = text.partition("=")
        if not sep or not key.strip().isidentifier() or not values.strip():
            raise UsageError(f"--var {text!r}: write NAME=V1[,V2...], e.g. --var limit=1,2")
        variables[key.strip()] = [O.parse_value(v.strip()) for v in values.split(",")]
    data["vars"] = variables
    if args.duration is not None:
        data["duration"] = args.duration
    if args.no_noise:
        data["noise"] = False
    outputs = dict(data.get("outputs") or {})
    for key in ("trace", "report", "plot", "video"):
        if getattr(args, key):
            outputs[key] = True
    data["outputs"] = outputs
    spec = SweepSpec.model_validate(data)
    out_dir = Path(args.out)
    if out_dir.exists() and not out_dir.is_dir():
        raise UsageError(f"-o {args.out}: not a folder")
    jobs = args.jobs or (len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1)
    pool = None
    if args.backend == "process":
        from ..sweep.backends import local_pool

        pool = local_pool(jobs)  # its processes start (and import) while the sweep is planned
    try:
        p = plan(spec, base, name, where, out_dir.resolve())
    except PlanError as exc:
        if pool is not None:
            pool.terminate()
            pool.join()
        raise DiagramError(exc.problems) from None
    show = args.progress if args.progress is not None else sys.stderr.isatty()
    try:
        result = execute(p, out_dir, backend=args.backend, jobs=jobs, address=args.address,
                         progress=show and not args.quiet, pool=pool)
    except BackendError as exc:
        raise DiagramError([Problem(str(exc), where, hint="check --address (host:port of the Ray head) or leave "
                                                          "it out to start Ray here")]) from None
    failed = [r for r in result.records if not r.get("ok")]
    if not args.quiet:
        ok = sum(1 for r in result.records if r.get("ok") and (r.get("summary") or {}).get("outcome") == "succeeded")
        print(f"{len(result.records)} of {len(p.jobs)} runs in {out_dir} ({result.ran} ran, {result.skipped} "
              f"finished before) in {result.seconds:.1f} s; {ok} succeeded, {len(failed)} raised; "
              f"{out_dir / 'sweep.html'}")
        for r in failed[:5]:
            print(f"run {r['id']} raised {r.get('error')}; reproduce: {r['command']}", file=sys.stderr)
    if result.interrupted:
        return EXIT_INTERRUPTED
    return EXIT_FAIL if failed else EXIT_OK
