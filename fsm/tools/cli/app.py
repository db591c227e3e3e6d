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
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any, cast

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


def build_parser(argv: Sequence[str] | None = None) -> argparse.ArgumentParser:
    """fsmctl's parser with every command; given the command line ``argv`` that names a command plainly (after
    fsmctl's own options only), with that command alone: each command's module imports what its options need (a
    run's, the live page's and the robot's modules), which a ``validate`` should not wait for. Anything else (no
    command, an unknown word, an option fsmctl does not know before it) gets every command, for its messages."""
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
    named = _command_named(argv)
    for name in COMMANDS if named is None else (named,):
        importlib.import_module(f"{__package__}.{name}").register(sub)
    parser.commands = dict(sub.choices)
    return parser


def _command_named(argv: Sequence[str] | None) -> str | None:
    """The command ``argv`` names after fsmctl's own options (and nothing else before it), or None."""
    tokens = iter(argv if argv is not None else ())
    for token in tokens:
        name = token.split("=", 1)[0]
        if name in ("-h", "--help", "--version"):
            return None
        if name in TOP_OPTIONS:
            if TOP_OPTIONS[name] and "=" not in token:
                next(tokens, None)
            continue
        return token if token in COMMANDS else None
    return None


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser(argv)
    try:
        args = _parse(parser, argv)
    except KeyboardInterrupt:
        return _interrupted()
    if args.command is None:
        parser.print_help(sys.stderr)
        return EXIT_USAGE
    with _environment(args):
        try:
            return int(args.func(args) or 0)
        except BaseException as exc:
            return _failed(exc)


def _parse(parser: argparse.ArgumentParser, argv: list[str]) -> argparse.Namespace:
    """The command line, or a usage error that says what to type (exit 2)."""
    misplaced, rest = _misplaced(parser, argv, _check_placement(parser, argv))
    args, extra = parser.parse_known_args(rest)
    if "--no-cache" in extra:  # fsmctl's own, but at home after any command that loads a machine too
        extra = [token for token in extra if token != "--no-cache"]
        args.no_cache = True
    if misplaced or extra:
        _unrecognized(parser, args.command, misplaced + extra)
    return args


@contextmanager
def _environment(args: argparse.Namespace) -> Iterator[None]:
    """--traceback and --no-cache said to every path that prints a failure or loads a machine, and to worker
    processes (a sweep's); FSM_NO_CACHE as it was afterwards (main may be called in a process that goes on)."""
    import os

    if args.traceback:
        from fsm.model.errors import TRACEBACK_ENV

        os.environ[TRACEBACK_ENV] = "1"
    before = os.environ.get("FSM_NO_CACHE")
    if args.no_cache:
        os.environ["FSM_NO_CACHE"] = "1"
    try:
        yield
    finally:
        if args.no_cache and before is None:
            del os.environ["FSM_NO_CACHE"]
        elif args.no_cache and before is not None:
            os.environ["FSM_NO_CACHE"] = before


def _failed(exc: BaseException) -> int:
    """Say why the command failed, in one located message (with the whole traceback first when asked for)."""
    from fsm.model.errors import print_traceback, traceback_wanted

    if traceback_wanted() and not isinstance(exc, (KeyboardInterrupt, BrokenPipeError, SystemExit)):
        print_traceback(exc)
    said = next((say for kind, say in _SAID if isinstance(exc, kind)), None)
    if said is None:
        raise exc
    return said(exc)


def _problems(exc: BaseException) -> int:
    for problem in getattr(exc, "problems", ()):
        print(problem, file=sys.stderr)
    return EXIT_USAGE if getattr(exc, "usage", False) else EXIT_FAIL  # a sweep's flag is a usage error


def _plugin_error(exc: BaseException) -> int:
    from fsm.loading.registry import PluginError

    print(printable(exc.located()) if isinstance(exc, PluginError) else f"fsmctl: plugin error: {_one_line(exc)}",
          file=sys.stderr)
    return EXIT_FAIL


def _error(exc: BaseException, status: int = EXIT_FAIL) -> int:
    print(f"fsmctl: error: {_one_line(exc)}", file=sys.stderr)
    return status


def _closed_pipe(exc: BaseException) -> int:
    _quiet_stdout()
    return EXIT_OK


def _refused(exc: BaseException) -> int:
    """The system refused something the checks could not foresee (a disk that filled up)."""
    from ..files import os_reason

    name = getattr(exc, "filename", None)
    print(printable(f"fsmctl: error:{f' {name}' if name else ''} {os_reason(cast(OSError, exc))}"), file=sys.stderr)
    return EXIT_FAIL


def _out_of_memory(exc: BaseException) -> int:
    print("fsmctl: error: out of memory", file=sys.stderr)
    return EXIT_FAIL


#: How each kind of failure is said, the first that matches (anything else is a bug: its traceback is printed).
_SAID: tuple[tuple[type[BaseException], Callable[[BaseException], int]], ...] = (
    (UsageError, lambda exc: _error(exc, EXIT_USAGE)), (DiagramError, _problems), (RegistrationError, _plugin_error),
    (FsmError, _error), (BrokenPipeError, _closed_pipe), (KeyboardInterrupt, lambda exc: _interrupted()),
    (OSError, _refused), (MemoryError, _out_of_memory))


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


def _check_placement(parser: argparse.ArgumentParser, argv: list[str]) -> int | None:
    """Where the command is in ``argv`` (``None`` without one); a command's option given before the command is
    named as such (argparse would take its value for the command's name)."""
    commands = _subparsers(parser)
    i = 0
    while i < len(argv):
        token = argv[i]
        if token == "--" or not token.startswith("-"):
            return i if token in commands else None  # the command (or what argparse will call an invalid one)
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
    return None


def _misplaced(parser: argparse.ArgumentParser, argv: list[str], at: int | None) -> tuple[list[str], list[str]]:
    """fsmctl's own options given after the command at ``argv[at]`` (which does not take them), each with its
    value, and the rest of ``argv``. Left in, argparse would read ``run --plugin P FILE`` as the file P and the
    option ``--plugin FILE``."""
    own = set(TOP_OPTIONS) - {"--no-cache"}  # also at home after the command (see _parse)
    if at is None or not own & {token.split("=", 1)[0] for token in argv[at + 1:]}:
        return [], argv
    own -= set(_options(_subparsers(parser)[argv[at]]))
    misplaced, rest = [], argv[:at + 1]
    tokens = iter(argv[at + 1:])
    for token in tokens:
        name = token.split("=", 1)[0]
        if token == "--" or name not in own:
            rest += [token, *tokens] if token == "--" else [token]
            continue
        value = next(tokens, None) if TOP_OPTIONS[name] and "=" not in token else None
        misplaced += [token] + ([value] if value is not None else [])
    return misplaced, rest


def _unrecognized(parser: argparse.ArgumentParser, command: str | None, extra: list[str]) -> None:
    """Arguments the command does not take: said with the command's usage, with the option meant (or where an
    option of fsmctl's own goes)."""
    target = _subparsers(parser).get(command or "", parser)
    options = _options(target)
    alone = sum(token.startswith("-") for token in extra) == 1
    hints = [hint for k, token in enumerate(extra) if token.startswith("-")
             if (hint := _hint(token, extra[k + 1:k + 2], options, command, alone))]
    target.error(f"unrecognized arguments: {' '.join(extra)}" + "".join(f"; {h}" for h in hints))


def _hint(token: str, after: list[str], options: list[str], command: str | None, alone: bool) -> str | None:
    """What to type instead of the option ``token`` (followed by ``after``): the option of the command meant, or
    the place of an option of fsmctl's own (with its value)."""
    name, eq, value = token.partition("=")
    if name in TOP_OPTIONS and name not in options:
        shown = f"{name} {value if eq else (after or ['VALUE'])[0]}" if TOP_OPTIONS[name] else name
        return f"{name} is an option of fsmctl itself: put it before the command (fsmctl {shown} {command} ...)"
    close = _close(name, options)
    if close is None:
        return None
    return f"did you mean {close}?" if alone else f"{name}: did you mean {close}?"


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
