"""``fsmctl``: validate, run and inspect machine documents.

Exit status: 0 success, 1 a document or run failed (one located message per problem, no traceback),
2 command-line usage error, 130 a run stopped by Ctrl-C or SIGTERM (its outputs are still written). Each
command lives in its own module of this package with a ``register`` function; heavy modules load only inside
the commands that need them.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence
from typing import Any

from fsm.model.errors import DiagramError, FsmError, RegistrationError, UsageError, printable

from .common import EXIT_FAIL, EXIT_INTERRUPTED, EXIT_OK, EXIT_USAGE, version

#: The command modules, in the order ``fsmctl --help`` lists them.
COMMANDS = ("validate", "run", "test", "sweep", "report", "types", "schema", "convert", "export", "palette", "graph",
            "detect", "sim", "replay", "explain", "watch", "new")


#: ``fsmctl --help`` ends with this (docs/cli.md says the same).
EPILOG = """exit status:
  0    success
  1    a document is invalid or a run failed (one located message per problem, no traceback)
  2    command-line usage error
  130  a run stopped by Ctrl-C or SIGTERM (its outputs are still written)

Options before COMMAND are fsmctl's own (--plugin, --traceback, --no-cache); those after it are the command's
(fsmctl COMMAND --help). --traceback or FSM_TRACEBACK=1 prints the whole traceback of any failure. --no-cache
(before or after COMMAND) or FSM_NO_CACHE=1 loads every machine from its files, neither reading nor writing the
plan cache (~/.cache/tral-fsm, or FSM_CACHE_DIR)."""

#: fsmctl's own options, given before the command; the value says whether one takes a value.
TOP_OPTIONS = {"--plugin": True, "--traceback": False, "--no-cache": False, "--version": False, "-h": False,
               "--help": False}


class _Parser(argparse.ArgumentParser):
    #: ``fsmctl``'s command parsers by name (on the top-level parser; empty on a command's)
    commands: dict[str, argparse.ArgumentParser] = {}

    def error(self, message: str) -> Any:  # argparse's usage errors: exit status 2, no traceback
        self.print_usage(sys.stderr)
        self.exit(EXIT_USAGE, f"{self.prog}: error: {_did_you_mean_choice(message)}\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="fsmctl", description="Validate, run and inspect tral-fsm machine documents.",
                     epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--plugin", action="append", default=[], metavar="MODULE|FILE.py",
                        help="import MODULE (installed, or in the current folder) or load FILE.py to register its "
                             "state/transition types (repeatable)")
    parser.add_argument("--traceback", action="store_true",
                        help="print the whole traceback of any failure (as FSM_TRACEBACK=1 does)")
    parser.add_argument("--no-cache", action="store_true",
                        help="load machines from their files only: neither read nor write the plan cache (as "
                             "FSM_NO_CACHE=1 does); also accepted after the command")
    parser.add_argument("--version", action="version", version="%(prog)s " + version())
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    for name in COMMANDS:
        importlib.import_module(f"{__package__}.{name}").register(sub)
    parser.commands = dict(sub.choices)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    argv = list(sys.argv[1:] if argv is None else argv)
    try:
        _check_placement(parser, argv)
        args, extra = parser.parse_known_args(argv)
        if "--no-cache" in extra:  # fsmctl's own, but at home after any command that loads a machine too
            extra = [token for token in extra if token != "--no-cache"]
            args.no_cache = True
        if extra:
            _unrecognized(parser, args.command, extra)
    except KeyboardInterrupt:
        return _interrupted()
    if args.command is None:
        parser.print_help(sys.stderr)
        return EXIT_USAGE
    import os

    if args.traceback:
        from fsm.model.errors import TRACEBACK_ENV

        os.environ[TRACEBACK_ENV] = "1"  # for every path that prints a failure, and for worker processes
    before = os.environ.get("FSM_NO_CACHE")
    if args.no_cache:  # for every load of the command, and for its worker processes (a sweep's)
        os.environ["FSM_NO_CACHE"] = "1"
    try:
        return int(args.func(args) or 0)
    except BaseException as exc:
        return _failed(exc)
    finally:
        if args.no_cache and before is None:  # main may be called in a process that goes on
            del os.environ["FSM_NO_CACHE"]
        elif args.no_cache and before is not None:
            os.environ["FSM_NO_CACHE"] = before


def _failed(exc: BaseException) -> int:
    """Say why the command failed, in one located message (with the whole traceback first when asked for)."""
    from fsm.model.errors import print_traceback, traceback_wanted

    if traceback_wanted() and not isinstance(exc, (KeyboardInterrupt, BrokenPipeError, SystemExit)):
        print_traceback(exc)
    try:
        raise exc
    except UsageError:
        print(f"fsmctl: error: {_one_line(exc)}", file=sys.stderr)
        return EXIT_USAGE
    except DiagramError as err:
        for problem in err.problems:
            print(problem, file=sys.stderr)
        return EXIT_USAGE if getattr(err, "usage", False) else EXIT_FAIL  # a sweep's flag is a usage error
    except RegistrationError:
        from fsm.loading.registry import PluginError

        print(printable(exc.located()) if isinstance(exc, PluginError) else f"fsmctl: plugin error: {_one_line(exc)}",
              file=sys.stderr)
        return EXIT_FAIL
    except FsmError:
        print(f"fsmctl: error: {_one_line(exc)}", file=sys.stderr)
        return EXIT_FAIL
    except BrokenPipeError:
        _quiet_stdout()
        return EXIT_OK
    except KeyboardInterrupt:
        return _interrupted()
    except OSError as err:  # the system refused something the checks could not foresee (a disk that filled up)
        from ..files import os_reason

        where = f" {err.filename}" if getattr(err, "filename", None) else ""
        print(printable(f"fsmctl: error:{where} {os_reason(err)}"), file=sys.stderr)
        return EXIT_FAIL
    except MemoryError:
        print("fsmctl: error: out of memory", file=sys.stderr)
        return EXIT_FAIL


# -- usage errors that say what to type ------------------------------------------------------------------------------
def _subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    return parser.commands if isinstance(parser, _Parser) else {}


def _options(parser: argparse.ArgumentParser) -> list[str]:
    """The option strings a parser takes, as its help lists them at the start of a line (``  -q, --quiet``); read
    only on an error's path."""
    import re

    heads = [ln.strip().split("  ")[0] for ln in parser.format_help().splitlines() if re.match(r"  +-", ln)]
    return sorted({opt for head in heads for opt in re.findall(r"(?<![\w-])(--?[A-Za-z][\w-]*)", head)})


def _close(word: str, candidates: list[str]) -> str | None:
    import difflib

    found = difflib.get_close_matches(word, candidates, n=1, cutoff=0.6)
    return found[0] if found else None


def _check_placement(parser: argparse.ArgumentParser, argv: list[str]) -> None:
    """A command's option given before the command: name it as such (argparse would take its value for the
    command's name)."""
    commands = _subparsers(parser)
    i = 0
    while i < len(argv):
        token = argv[i]
        if token == "--" or not token.startswith("-"):
            return  # the command (or what argparse will call an invalid one)
        name = token.split("=", 1)[0]
        if name in TOP_OPTIONS:
            i += 2 if TOP_OPTIONS[name] and "=" not in token else 1
            continue
        command = next((t for t in argv[i + 1:] if t in commands), None)
        if command is not None and name in _options(commands[command]):
            commands[command].error(f"{name} is an option of `fsmctl {command}`: put it after the command "
                                    f"(fsmctl {command} ... {name} ...)")
        close = _close(name, list(TOP_OPTIONS) + (_options(commands[command]) if command else []))
        parser.error(f"unrecognized option {name}" + (f"; did you mean {close}?" if close else
                                                      f"; fsmctl's own options are {', '.join(TOP_OPTIONS)}"))
        return


def _unrecognized(parser: argparse.ArgumentParser, command: str | None, extra: list[str]) -> None:
    """Arguments the command does not take: said with the command's usage, with the option meant (or where an
    option of fsmctl's own goes)."""
    target = _subparsers(parser).get(command or "", parser)
    options = _options(target)
    hints = []
    flags = [token for token in extra if token.startswith("-")]
    for k, token in enumerate(extra):
        name, eq, value = token.partition("=")
        if not name.startswith("-"):
            continue
        if name in TOP_OPTIONS and name not in options:
            if TOP_OPTIONS[name] and not eq:
                value = extra[k + 1] if k + 1 < len(extra) else "VALUE"
            shown = f"{name} {value}" if TOP_OPTIONS[name] else name
            hints.append(f"{name} is an option of fsmctl itself: put it before the command "
                         f"(fsmctl {shown} {command} ...)")
            continue
        close = _close(name, options)
        if close is not None:
            hints.append(f"did you mean {close}?" if len(flags) == 1 else f"{name}: did you mean {close}?")
    target.error(f"unrecognized arguments: {' '.join(extra)}" + "".join(f"; {h}" for h in hints))


def _did_you_mean_choice(message: str) -> str:
    """argparse's "invalid choice: 'rn' (choose from 'run', ...)" with the choice meant, when one is close."""
    import re

    m = re.search(r"invalid choice: '([^']*)' \(choose from (.*)\)$", message)
    if m is None:
        return message
    choices = re.findall(r"'([^']*)'", m.group(2))
    close = _close(m.group(1), choices)
    return message + (f"; did you mean '{close}'?" if close else "")


def _one_line(exc: BaseException) -> str:
    """The error's message on one line, safe for a terminal (a file name or id cannot drive it)."""
    return printable(" ".join(str(exc).split()))


def _interrupted() -> int:
    print("fsmctl: interrupted", file=sys.stderr)
    return EXIT_INTERRUPTED


def _quiet_stdout() -> None:
    """After a reader closed the pipe: point standard output at /dev/null so exiting flushes nothing into it."""
    import os

    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError, AttributeError):
        pass
