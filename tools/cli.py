"""``fsmctl``: validate, run and inspect machine documents.

Exit status: 0 success, 1 a document or run failed (one located message per problem, no traceback),
2 command-line usage error. Heavy modules load only in the commands that need them.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from fsm.errors import DiagramError, FsmError, Problem, RegistrationError, StateRuntimeError, UsageError

EXIT_OK, EXIT_FAIL, EXIT_USAGE = 0, 1, 2
DEFAULT_MAX_DURATION = 600.0


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> Any:  # argparse's usage errors: exit status 2, no traceback
        self.print_usage(sys.stderr)
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="fsmctl", description="Validate, run and inspect tral-fsm machine documents.")
    parser.add_argument("--plugin", action="append", default=[], metavar="MODULE",
                        help="import MODULE to register its state/transition types (repeatable)")
    parser.add_argument("--version", action="version", version="%(prog)s " + _version())
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)

    p = sub.add_parser("validate", help="check machine documents (exit 1 if any is invalid)")
    p.add_argument("files", nargs="+", metavar="FILE")
    p.add_argument("--format", choices=("text", "json", "github"), default="text",
                   help="text (default), json, or github (GitHub Actions ::error annotations)")
    p.add_argument("--strict", action="store_true", help="treat warnings (unreachable states) as errors")
    p.add_argument("-q", "--quiet", action="store_true", help="print problems only")
    p.set_defaults(func=cmd_validate)

    p = sub.add_parser("schema", help="print the JSON Schema of machine documents")
    p.add_argument("-o", "--output", metavar="FILE", help="write it to FILE instead of standard output")
    p.add_argument("--check", metavar="FILE", help="exit 1 if FILE differs from the generated schema")
    p.set_defaults(func=cmd_schema)

    p = sub.add_parser("types", help="list the registered state and transition types with their parameters")
    p.add_argument("names", nargs="*", metavar="TYPE", help="only these types")
    p.add_argument("--format", choices=("text", "json"), default="text")
    p.set_defaults(func=cmd_types)

    p = sub.add_parser("run", help="run a machine until it finishes (or a limit) and print what it did")
    p.add_argument("file", metavar="FILE")
    p.add_argument("--max-ticks", type=_positive_int, metavar="N", help="stop after N ticks")
    p.add_argument("--duration", type=_positive_float, metavar="SECONDS",
                   help=f"stop after this much machine time (default: at most {DEFAULT_MAX_DURATION:g} s "
                        "when no --max-ticks is given)")
    p.add_argument("--dt", type=_positive_float, metavar="SECONDS", default=None,
                   help="tick period (default 0.0125 s = 80 Hz, the TRAL car's)")
    p.add_argument("--signal", action="append", default=[], metavar="NAME[=0|1]@T", type=_signal_arg,
                   help="set input signal NAME high (or to the value given) at machine time T (repeatable)")
    p.add_argument("--trace", metavar="OUT.jsonl", help="write a JSONL trace: one line per tick with a transition")
    p.add_argument("--summary", metavar="OUT.json", help="write a JSON summary of the run")
    p.add_argument("--expect", metavar="OUTCOME", help="exit 1 unless the machine finishes with OUTCOME")
    p.add_argument("-q", "--quiet", action="store_true", help="print nothing but errors")
    p.set_defaults(func=cmd_run)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help(sys.stderr)
        return EXIT_USAGE
    try:
        return int(args.func(args) or 0)
    except UsageError as exc:
        print(f"fsmctl: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except DiagramError as exc:
        for problem in exc.problems:
            print(problem, file=sys.stderr)
        return EXIT_FAIL
    except RegistrationError as exc:
        print(f"fsmctl: plugin error: {exc}", file=sys.stderr)
        return EXIT_FAIL
    except FsmError as exc:
        print(f"fsmctl: error: {exc}", file=sys.stderr)
        return EXIT_FAIL
    except BrokenPipeError:
        return EXIT_OK


# -- argument types -----------------------------------------------------------------------------------
def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {value}")
    return value


def _positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not (value > 0 and value != float("inf")):
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text}")
    return value


def _signal_arg(text: str) -> tuple[str, bool, float]:
    """``NAME@T`` or ``NAME=0@T`` -> (name, value, time)."""
    name_value, sep, when = text.rpartition("@")
    if not sep or not name_value:
        raise argparse.ArgumentTypeError(f"expected NAME@T or NAME=0@T, got {text!r}")
    name, eq, value_text = name_value.partition("=")
    values = {"1": True, "true": True, "on": True, "high": True, "0": False, "false": False, "off": False, "low": False}
    if eq and value_text.lower() not in values:
        raise argparse.ArgumentTypeError(f"signal value must be 1/0/true/false, got {value_text!r}")
    try:
        at = float(when)
    except ValueError:
        raise argparse.ArgumentTypeError(f"signal time must be a number of seconds, got {when!r}") from None
    if not (at >= 0 and at != float("inf")) or not name:
        raise argparse.ArgumentTypeError(f"expected NAME@T with T >= 0, got {text!r}")
    return name, values[value_text.lower()] if eq else True, at


def _version() -> str:
    from fsm import __version__

    return __version__


def _registry(args: argparse.Namespace) -> Any:
    from fsm.registry import default_registry

    try:
        return default_registry(tuple(args.plugin))
    except ModuleNotFoundError as exc:
        raise UsageError(f"--plugin: no module named {exc.name!r}") from None
    except RegistrationError:
        raise
    except Exception as exc:  # a plugin that fails to import is the plugin's error, reported in one line
        raise FsmError(f"--plugin: importing failed: {type(exc).__name__}: {exc}") from None


# -- validate -----------------------------------------------------------------------------------------
def cmd_validate(args: argparse.Namespace) -> int:
    from fsm.loader import check

    registry = _registry(args)
    results = []
    for file in args.files:
        _spec, problems = check(file, registry=registry)
        if args.strict:
            for p in problems:
                p.severity = "error"
        valid = not any(p.severity == "error" for p in problems)
        results.append((file, valid, problems))
    invalid = sum(1 for _, valid, _ in results if not valid)
    if args.format == "json":
        print(json.dumps([{"file": f, "valid": v, "problems": [p.to_dict() for p in ps]} for f, v, ps in results],
                         indent=2))
    elif args.format == "github":
        for _, _, problems in results:
            for p in problems:
                print(github_annotation(p))
    else:
        for file, valid, problems in results:
            for p in problems:
                print(p, file=sys.stderr if p.severity == "error" else sys.stdout)
            if not args.quiet:
                errors = sum(1 for p in problems if p.severity == "error")
                warnings = len(problems) - errors
                state = "ok" if valid else f"{errors} error{'s' * (errors != 1)}"
                if warnings:
                    state += f", {warnings} warning{'s' * (warnings != 1)}"
                print(f"{file}: {state}")
    return EXIT_FAIL if invalid else EXIT_OK


def github_annotation(p: Problem) -> str:
    """A GitHub Actions workflow command (``::error file=...,line=...::message``)."""

    def prop(text: str) -> str:
        return text.replace("%", "%25").replace("\r", "%0D").replace("\n", "%0A").replace(":", "%3A").replace(",", "%2C")

    def data(text: str) -> str:
        return text.replace("%", "%25").replace("\r", "%0D").replace("\n", "%0A")

    props = [f"file={prop(p.file or '')}"]
    if p.line is not None:
        props.append(f"line={p.line}")
        if p.column is not None:
            props.append(f"col={p.column}")
    props.append("title=" + prop("fsmctl validate"))
    message = (f"{p.element}: " if p.element else "") + p.message
    if p.pointer:
        message += f" (at {p.pointer})"
    if p.hint:
        message += f"; {p.hint}"
    level = "error" if p.severity == "error" else "warning"
    return f"::{level} {','.join(props)}::{data(message)}"


# -- schema -------------------------------------------------------------------------------------------
def schema_text(registry: Any) -> str:
    from fsm.document import json_schema

    return json.dumps(json_schema(registry), indent=2, ensure_ascii=False) + "\n"


def cmd_schema(args: argparse.Namespace) -> int:
    text = schema_text(_registry(args))
    if args.check:
        try:
            current = Path(args.check).read_text(encoding="utf-8")
        except OSError as exc:
            print(f"fsmctl: {args.check}: cannot read: {exc.strerror}", file=sys.stderr)
            return EXIT_FAIL
        if current != text:
            print(f"{args.check}: stale; regenerate it with `fsmctl schema -o {args.check}`", file=sys.stderr)
            return EXIT_FAIL
        return EXIT_OK
    if args.output:
        from .files import write_atomic

        _check_writable(args.output)
        write_atomic(args.output, text)
    else:
        sys.stdout.write(text)
    return EXIT_OK


# -- types --------------------------------------------------------------------------------------------
def cmd_types(args: argparse.Namespace) -> int:
    from fsm.document import param_info

    registry = _registry(args)
    rows = []
    for kind, name, cls in registry:
        if args.names and name not in args.names:
            continue
        doc = (cls.__doc__ or "").strip().splitlines()
        row = {"kind": kind, "name": name, "doc": doc[0] if doc else "", "params": param_info(cls.Params)}
        if kind == "state":
            row["can_finish"] = bool(cls.can_finish)
        rows.append(row)
    unknown = [n for n in args.names if n not in {r["name"] for r in rows}]
    if unknown:
        hints = []
        for n in unknown:
            close = registry.suggest(n, "state") + registry.suggest(n, "transition")
            hints.append(f"{n!r}" + (f" (did you mean {', '.join(close)}?)" if close else ""))
        print("fsmctl types: unknown type " + ", ".join(hints), file=sys.stderr)
        return EXIT_FAIL
    if args.format == "json":
        print(json.dumps(rows, indent=2))
        return EXIT_OK
    for heading, kind in (("States", "state"), ("Transitions", "transition")):
        group = [r for r in rows if r["kind"] == kind]
        if not group:
            continue
        print(heading)
        for r in group:
            finish = " [finishes]" if r.get("can_finish") else ""
            print(f"  {r['name']}{finish}: {r['doc']}")
            for prm in r["params"]:
                default = "required" if prm["required"] else f"default {json.dumps(prm.get('default'))}"
                desc = f"  {prm['description']}" if prm["description"] else ""
                print(f"      {prm['name']}: {prm['type']} ({default}){desc}")
        print()
    if not args.names:
        print("Every transition also takes: from, to, priority (default 0), preempt (default false).")
        print("Every element may carry: description, layout.")
    return EXIT_OK


# -- run ----------------------------------------------------------------------------------------------
def _check_writable(path: str) -> None:
    directory = Path(path).parent
    if str(directory) and not directory.is_dir():
        raise UsageError(f"cannot write {path}: folder {directory} does not exist")


def cmd_run(args: argparse.Namespace) -> int:
    from fsm.clock import SimulatedClock
    from fsm.loader import load
    from fsm.trace import Recorder, summary

    from .files import AtomicFile, write_atomic

    for out in (args.trace, args.summary):
        if out:
            _check_writable(out)
    registry = _registry(args)
    clock = SimulatedClock(args.dt) if args.dt else None
    machine = load(args.file, registry=registry, clock=clock)
    for name, value, at in args.signal:
        machine.schedule_signal(name, at, value)
    duration = args.duration
    if duration is None and args.max_ticks is None:
        duration = DEFAULT_MAX_DURATION

    trace_file = AtomicFile(args.trace) if args.trace else None
    out = trace_file.__enter__() if trace_file else None
    recorder = machine.add_listener(Recorder(out))
    error: StateRuntimeError | None = None
    interrupted = False
    try:
        machine.start()
        recorder.flush(machine)
        machine.run(max_ticks=args.max_ticks, duration=duration)
    except StateRuntimeError as exc:
        error = exc
        recorder.flush(machine)
    except KeyboardInterrupt:
        interrupted = True
        recorder.flush(machine)
    finally:
        if trace_file is not None:
            trace_file.__exit__(None, None, None)
    result = summary(machine, recorder)
    if error is not None:
        result["error"] = {"state": error.path, "phase": error.phase, "tick": error.tick, "message": str(error.cause)}
    if interrupted:
        result["interrupted"] = True
    if args.summary:
        write_atomic(args.summary, json.dumps(result, indent=2) + "\n")
    if error is not None:
        print(f"fsmctl run: {args.file}: {error}", file=sys.stderr)
        return EXIT_FAIL
    if not args.quiet:
        status = f"outcome {machine.outcome}" if machine.finished else "not finished"
        if interrupted:
            status += " (interrupted)"
        print(f"{args.file}: {status} after {machine.ticks} ticks ({machine.now:.3f} s), "
              f"{machine.transition_count} transitions")
        print("visited: " + " -> ".join(recorder.visited))
        if not machine.finished:
            print(f"active: {machine.active_path}")
    if interrupted:
        return 130
    if args.expect is not None and machine.outcome != args.expect:
        print(f"fsmctl run: expected outcome {args.expect!r}, got {machine.outcome!r}", file=sys.stderr)
        return EXIT_FAIL
    return EXIT_OK


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
