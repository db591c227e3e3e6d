"""``fsmctl sweep``: many runs of one machine over seeds, worlds, parameter overrides and variables, on a local
process pool or a Ray cluster (``fsm.tools.sweep``).

Everything is checked before the first run (a located error and exit 1 for an override naming no state or
parameter, a value its type refuses, an empty grid or one of more than ``--max-runs`` runs, a glob matching
nothing, an unreachable Ray address; exit 2 for an output folder holding a symlink, a FIFO or an input where the
sweep writes). Exit 0 when every run ran (whatever its outcome), 1 when a run raised, 130 on Ctrl-C or SIGTERM
after writing what finished.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

from fsm.model.errors import DiagramError, Problem, UsageError

from ..sweep.limits import MAX_RUNS
from .common import (
    EXIT_FAIL,
    EXIT_INTERRUPTED,
    EXIT_OK,
    Interrupts,
    Subcommands,
    positive_float,
    registry_from,
    whole_number,
)


def register(sub: Subcommands) -> None:
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
    p.add_argument("--max-runs", type=whole_number(1), metavar="N", default=None,
                   help=f"run a sweep of up to N runs (default {MAX_RUNS:,}; every finished run's record, about 70 KB, "
                        "stays in memory until the report is written)")
    p.add_argument("-q", "--quiet", action="store_true", help="print nothing but errors")
    live = p.add_argument_group("the live page")
    live.add_argument("--live", action="store_true",
                      help="serve a page listing the runs with their status as they finish, and print its URL; a "
                           "click watches a running run or opens a finished one in the live debugger's page. Every run "
                           "then writes its trace "
                           "(runs/<id>/trace.jsonl); after the sweep the page stays until Ctrl-C (needs the 'live' "
                           "extra)")
    live.add_argument("--port", type=_port, default=None, metavar="N", help="port of the page (default 8765; 0: any)")
    live.add_argument("--host", default=None, metavar="HOST",
                      help="address to listen on (default 127.0.0.1; another address needs the URL's token)")
    live.add_argument("--no-token", action="store_true", help="no token in the URL (this machine only)")
    p.set_defaults(func=cmd_sweep)


def _port(text: str) -> int:
    from ..live.runner import parse_port

    return parse_port(text)


def cmd_sweep(args: argparse.Namespace) -> int:
    """Ctrl-C and SIGTERM are noted from the start (a second one while planning ends at once): the sweep stops at
    the next safe point, keeps what finished and exits 130."""
    with Interrupts() as interrupts:
        return _sweep(args, interrupts)


def _check_sweep_usage(args: argparse.Namespace) -> None:
    """The options that do not go together, refused before the sweep file is read."""
    from ..sweep.spec import check_duration

    if args.spec is None and args.machine is None:
        raise UsageError("give a sweep file or --machine FILE")
    if args.address and args.backend != "ray":
        raise UsageError("--address is for --backend ray")
    if not args.out:
        raise UsageError("-o: give the name of a folder")
    if args.duration is not None and (problem := check_duration(args.duration)) is not None:
        raise UsageError(f"--{problem}")
    _check_live(args)


def _sweep(args: argparse.Namespace, interrupts: Interrupts) -> int:
    from ..sweep.runner import usable_cpus

    _check_sweep_usage(args)
    spec, base, where, name, flags = _spec(args)
    out_dir = Path(args.out)
    if out_dir.exists() and not out_dir.is_dir():
        raise UsageError(f"-o {args.out}: not a folder")
    flag_plugins = _flag_plugins(args)
    jobs = args.jobs or usable_cpus()
    try:
        planned = _plan(args, interrupts, (spec, base, name, where), flags, flag_plugins, out_dir, jobs)
    except KeyboardInterrupt:
        print("fsmctl sweep: interrupted before any run started", file=sys.stderr)
        return EXIT_INTERRUPTED
    p, folder, resume, todo, pool, live = planned
    if not args.quiet:
        for warning in resume.warnings:
            print(warning, file=sys.stderr)
        print(f"{len(p.jobs)} run{'s' * (len(p.jobs) != 1)}: {len(todo)} to run ({jobs} at a time), "
              f"{len(resume.records)} finished before", flush=True)
    result = _execute(args, planned, where, jobs, interrupts)
    if live is None:
        return _report(args, p, result, out_dir)
    return _report_live(args, p, result, out_dir, live, interrupts)


def _execute(args: argparse.Namespace, planned: tuple[Any, Any, Any, list[dict[str, Any]], Any, Any], where: str,
             jobs: int, interrupts: Interrupts) -> Any:
    """The sweep's runs, on the pool started while planning (and shown on the live page, which closes on an
    error); a Ray head that cannot be reached is a located error."""
    from ..sweep.backends import BackendError
    from ..sweep.runner import execute

    p, folder, resume, todo, pool, live = planned
    show = args.progress if args.progress is not None else sys.stderr.isatty()
    try:
        if live is not None:
            live.board.start()
        return execute(p, folder, todo, resume, interrupts, backend=args.backend, jobs=jobs, address=args.address,
                       progress=show and not args.quiet, pool=pool,
                       on_record=live.board.record if live is not None else None)
    except BackendError as exc:
        raise DiagramError([Problem(str(exc), where, hint="check --address (host:port of the Ray head) or leave "
                                                          "it out to start Ray here")]) from None
    except BaseException:
        if live is not None:
            live.close()
        raise


def _plan(args: argparse.Namespace, interrupts: Interrupts, sweep: tuple[Any, Path, str, str], flags: set[str],
          flag_plugins: list[str], out_dir: Path, jobs: int) -> tuple[Any, Any, Any, list[dict[str, Any]], Any, Any]:
    """Before any run: the pool's processes started (they import while the sweep is planned), the plan, the
    output folder checked, the runs finished before, the runs to do and the live page (or ``None``); on any
    error or Ctrl-C the pool is stopped again."""
    from ..sweep.folder import Folder, read_records
    from ..sweep.runner import plan

    pool = None
    try:
        if args.backend == "process":
            from ..sweep.backends import local_pool

            pool = local_pool(jobs)
        p = plan(*sweep, out_dir.resolve(), flags=flags, flag_plugins=flag_plugins,
                 max_runs=args.max_runs or MAX_RUNS)
        folder = Folder(out_dir, p.inputs)
        folder.check()
        resume = read_records(out_dir / "sweep.jsonl", {job["key"] for job in p.jobs})
        todo = [job for job in p.jobs if job["key"] not in resume.records]
        folder.check_runs(job["id"] for job in todo)
        if interrupts.stop():
            raise KeyboardInterrupt
        live = _start_live(args, p, todo, resume, out_dir.resolve(), jobs) if args.live else None
    except BaseException:
        if pool is not None:
            pool.terminate()
            pool.join()
        raise
    return p, folder, resume, todo, pool, live


def _report_live(args: argparse.Namespace, p: Any, result: Any, out_dir: Path, live: Any,
                 interrupts: Interrupts) -> int:
    """``--live``: the report, then the runs served until Ctrl-C (unless the sweep was interrupted)."""
    live.board.end()
    try:
        code = _report(args, p, result, out_dir)
        if not result.interrupted:
            print("live: the sweep has ended; its runs are served until Ctrl-C here", flush=True)
            interrupts.writing = False
            while not interrupts.stop():
                time.sleep(0.1)
    finally:
        live.close()
    return code


def _check_live(args: argparse.Namespace) -> None:
    """The live options without ``--live``, and what ``--live`` needs (usage errors)."""
    if not args.live:
        given = [o for o, v in (("--port", args.port), ("--host", args.host), ("--no-token", args.no_token or None))
                 if v is not None]
        if given:
            raise UsageError(f"{given[0]} is an option of the live page: add --live")
        return
    from ..live.runner import check_page_options

    check_page_options(args)


def _start_live(args: argparse.Namespace, p: Any, todo: list[dict[str, Any]], resume: Any, out_dir: Path,
                jobs: int) -> Any:
    """Serve the sweep's page (a port in use is an error before any run starts) and print its URL; every run to
    run writes its trace (what the page opens), which leaves the runs' keys as they are: a sweep run again without
    --live skips them."""
    from ..live.runner import DEFAULT_PORT, announce, listen_error
    from ..live.server import new_token
    from ..live.sweep import Board, SweepServer

    for job in todo:
        job["trace"] = True
        if job["out"] is None:
            job["out"] = str(out_dir / "runs" / job["id"])
    board = Board(p.jobs, out_dir, jobs)
    for rec in resume.records.values():
        board.record(rec, before=True)
    host = args.host or "127.0.0.1"
    port = args.port if args.port is not None else DEFAULT_PORT
    token = None if args.no_token else new_token()
    server = SweepServer(board, p.name, token)
    try:
        bound = server.start(host, port)
    except OSError as exc:
        raise listen_error(exc, host, port) from None
    announce(host, bound, token, sys.stdout)
    return server


def _spec(args: argparse.Namespace) -> tuple[Any, Path, str, str, set[str]]:
    """The sweep: the file's keys overridden by the flags; where it came from (for messages) and which keys
    (as JSON pointers) the flags gave."""
    from pydantic import ValidationError

    from ..sweep.spec import SweepSpec

    data, base, where, name = _spec_file(args)
    flags: set[str] = set()
    for key, value in _flag_keys(args):
        data[key] = value
        flags.add("/" + key)
    data["set"] = _flag_sets(args, dict(data.get("set") or {}), flags)
    data["vars"] = _flag_vars(args, dict(data.get("vars") or {}), flags)
    if args.duration is not None:
        data["duration"] = args.duration
        flags.add("/duration")
    if args.no_noise:
        data["noise"] = False
    data["outputs"] = {**(data.get("outputs") or {}),
                       **{key: True for key in ("trace", "report", "plot", "video") if getattr(args, key)}}
    try:
        return SweepSpec.model_validate(data), base, where, name, flags
    except ValidationError as err:
        first = err.errors()[0]
        raise UsageError(f"{'.'.join(map(str, first['loc']))}: {first['msg']}") from None


def _spec_file(args: argparse.Namespace) -> tuple[dict[str, Any], Path, str, str]:
    """The sweep file's keys as given, the folder its paths are relative to, its name for messages and the
    sweep's name (without a file: none, the working folder, the command line and the machine's name)."""
    from ..sweep.runner import CLI
    from ..sweep.spec import read_spec_file

    if args.spec is None:
        return {}, Path.cwd(), CLI, Path(args.machine).stem if args.machine else "sweep"
    spec_path = Path(args.spec)
    spec = read_spec_file(spec_path)
    return (spec.model_dump(by_alias=True, exclude_unset=True), spec_path.resolve().parent, str(spec_path),
            spec.name or spec_path.stem)


def _flag_keys(args: argparse.Namespace) -> list[tuple[str, Any]]:
    """The sweep's keys given by --machine, --world and --seeds (paths made absolute; a pattern from here)."""
    keys: list[tuple[str, Any]] = []
    if args.machine:
        keys.append(("machine", str(Path(args.machine).resolve())))
    if args.world:
        keys.append(("worlds", [str(Path(w).resolve()) if not any(c in w for c in "*?[") else str(Path.cwd() / w)
                                for w in args.world]))
    if args.seeds:
        keys.append(("seeds", args.seeds))
    return keys


def _flag_sets(args: argparse.Namespace, sets: dict[str, Any], flags: set[str]) -> dict[str, Any]:
    """The file's ``set`` with each ``--set PATH.PARAM=V1,V2`` added (a malformed one is a usage error)."""
    from ..sweep import overrides as O
    from ..sweep.spec import escape_pointer

    for text in args.overrides:
        try:
            o = O.parse(text)
        except O.OverrideError as exc:
            raise UsageError(str(exc)) from None
        sets[f"{o.path}.{o.param}"] = list(o.values)
        flags.add(f"/set/{escape_pointer(f'{o.path}.{o.param}')}")
    return sets


def _flag_vars(args: argparse.Namespace, variables: dict[str, Any], flags: set[str]) -> dict[str, Any]:
    """The file's ``vars`` with each ``--var NAME=V1,V2`` added (a malformed one is a usage error)."""
    from ..sweep import overrides as O

    for text in args.variables:
        key, sep, values = text.partition("=")
        if not sep or not key.strip().isidentifier() or not values.strip():
            raise UsageError(f"--var {text!r}: write NAME=V1[,V2...], e.g. --var limit=1,2")
        variables[key.strip()] = [O.parse_value(v.strip()) for v in values.split(",")]
        flags.add(f"/vars/{key.strip()}")
    return variables


def _flag_plugins(args: argparse.Namespace) -> list[str]:
    """``fsmctl --plugin`` for a sweep: loaded here (a missing one is blamed on the flag) and by every worker
    (.py files by their absolute path, since a worker may run elsewhere)."""
    registry_from(args)
    return [str(Path(p).resolve()) if p.endswith(".py") else p for p in args.plugin]


def _report(args: argparse.Namespace, p: Any, result: Any, out_dir: Path) -> int:
    """The closing lines, and the exit status: 130 interrupted, 1 when a run raised, else 0."""
    failed = [r for r in result.records if not r.get("ok")]
    if not args.quiet:
        ok = sum(1 for r in result.records if r.get("ok") and (r.get("summary") or {}).get("outcome") == "succeeded")
        print(f"{len(result.records)} of {len(p.jobs)} runs in {out_dir} ({result.ran} ran, {result.skipped} "
              f"finished before) in {result.seconds:.1f} s; {ok} succeeded, {len(failed)} raised; "
              f"{out_dir / 'sweep.html'}")
        for r in failed[:5]:
            print(f"run {r['id']} raised {r.get('error')}; reproduce: {r['command']}", file=sys.stderr)
    elif failed:  # one line even with -q: exit status 1 is not left unexplained
        first = " ".join(str(failed[0].get("error")).split())[:300]
        print(f"fsmctl sweep: {len(failed)} of {len(result.records)} runs raised (run {failed[0]['id']}: {first}); "
              f"see {out_dir / 'sweep.html'}", file=sys.stderr)
    if result.interrupted:
        print(f"fsmctl sweep: interrupted; the {len(result.records)} finished runs are kept in "
              f"{out_dir / 'sweep.jsonl'} (the same command goes on from there)", file=sys.stderr)
        return EXIT_INTERRUPTED
    return EXIT_FAIL if failed else EXIT_OK
