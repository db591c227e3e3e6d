"""MkDocs hook: the parts of the site generated at build time, so they never drift from the code.

- The CLI reference: ``<!-- fsmctl-reference -->`` in a page becomes the usage, description and
  options of ``fsmctl`` and every subcommand, rendered from ``fsm.tools.cli.build_parser()``.
- The drawings: ``img/graphs/NAME.svg`` for each diagram in :data:`GRAPHS`, drawn by ``fsmctl graph
  --format svg`` (run in-process) from the example diagrams.

:func:`cli_reference` and :func:`draw_graphs` are plain functions, so tests call them without MkDocs.
"""

from __future__ import annotations

import argparse
import functools
import html
import io
import tempfile
from contextlib import redirect_stderr
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

#: Marker a page writes where the generated CLI reference goes.
CLI_MARKER = "<!-- fsmctl-reference -->"

#: Site path (under ``img/graphs/``, without ``.svg``) -> diagram, relative to the repository.
GRAPHS = {
    "hallway_lap": "diagrams/hallway_lap.uxf",
    "turn_left": "diagrams/turn_left.uxf",
    "lane_change": "diagrams/lane_change.uxf",
    "corner_turn": "diagrams/corner_turn.uxf",
    "mission": "diagrams/examples/mission.json",
    "blinker": "diagrams/examples/blinker.uxf",
    "drive": "diagrams/examples/drive.uxf",
    "sorter": "diagrams/examples/sorter.json",
}

_WIDTH = 88  # columns of the usage lines, independent of the terminal that runs the build


# -- the CLI reference ------------------------------------------------------------------------------
def _subcommands(parser: argparse.ArgumentParser) -> list[tuple[str, str, argparse.ArgumentParser]]:
    """``(name, one-line help, parser)`` of each subcommand, in the order ``fsmctl --help`` lists them."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            helps = {a.dest: a.help or "" for a in action._choices_actions}
            return [(name, helps.get(name, ""), sub) for name, sub in action.choices.items()]
    return []


def _text(value: str) -> str:
    return html.escape(" ".join(value.split()), quote=False)


def _invocation(action: argparse.Action) -> str:
    """``--output OUT`` / ``-o OUT, --output OUT`` / ``FILE``, as argparse's help shows it."""
    if not action.option_strings:
        return action.metavar if isinstance(action.metavar, str) else action.dest
    if action.nargs == 0:
        return ", ".join(action.option_strings)
    metavar = action.metavar or action.dest.upper()
    if action.choices is not None and action.metavar is None:
        metavar = "{" + ",".join(str(c) for c in action.choices) + "}"
    return ", ".join(f"{opt} {metavar}" for opt in action.option_strings)


def _options(parser: argparse.ArgumentParser) -> str:
    formatter = parser._get_formatter()
    out: list[str] = []
    for group in parser._action_groups:
        actions = [a for a in group._group_actions
                   if not isinstance(a, (argparse._HelpAction, argparse._SubParsersAction))]
        if not actions:
            continue
        title = {"positional arguments": "Arguments", "options": "Options",
                 "optional arguments": "Options"}.get(group.title or "", group.title or "Options")
        out.append(f"**{_text(title[0].upper() + title[1:])}**\n")
        if group.description:
            out.append(_text(group.description) + "\n")
        out.append("| argument | meaning |\n|---|---|")
        for action in actions:
            meaning = _text(formatter._expand_help(action)) if action.help else ""
            if action.choices is not None and action.option_strings and action.metavar is not None:
                meaning += f" (one of {', '.join(f'`{c}`' for c in action.choices)})"
            if not action.option_strings and action.nargs in ("+", "*"):
                meaning = (meaning + " " if meaning else "") + "(one or more)" * (action.nargs == "+") \
                    + "(any number)" * (action.nargs == "*")
            cell = html.escape(_invocation(action), quote=False).replace("|", "&#124;")  # not a cell border
            out.append(f"| <code>{cell}</code> | {meaning or '&nbsp;'} |")
        out.append("")
    return "\n".join(out)


def _usage(parser: argparse.ArgumentParser) -> str:
    parser.formatter_class = functools.partial(argparse.HelpFormatter, width=_WIDTH)  # type: ignore[assignment]
    return parser.format_usage().strip()


def cli_reference(parser: argparse.ArgumentParser | None = None) -> str:
    """Markdown for ``fsmctl`` and each subcommand: one-line help, usage, description, arguments, options."""
    if parser is None:
        from fsm.tools.cli import build_parser

        parser = build_parser()
    out = [f"```text\n{_usage(parser)}\n```\n"]
    if parser.description:
        out.append(_text(parser.description) + "\n")
    out.append(_options(parser))
    subs = _subcommands(parser)
    out.append("| command | what it does |\n|---|---|")
    prog = parser.prog
    out.extend(f"| [`{name}`](#{prog}-{name}) | {_text(help_)} |" for name, help_, _ in subs)
    out.append("")
    for name, help_, sub in subs:
        out.append(f"## {prog} {name} {{#{prog}-{name}}}\n")
        if help_:
            out.append(_text(help_[0].upper() + help_[1:]) + ".\n")
        out.append(f"```text\n{_usage(sub)}\n```\n")
        if sub.description:
            out.append(_text(sub.description) + "\n")
        out.append(_options(sub))
    return "\n".join(out)


# -- the drawings -----------------------------------------------------------------------------------
def draw_graphs(graphs: dict[str, str] | None = None, root: Path = ROOT) -> dict[str, str]:
    """``{name: svg text}``, each drawn by ``fsmctl graph --format svg`` from its diagram."""
    from fsm.tools.cli import main

    drawings: dict[str, str] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name, diagram in (graphs or GRAPHS).items():
            out = Path(tmp) / f"{name}.svg"
            errors = io.StringIO()
            with redirect_stderr(errors):
                status = main(["graph", str(root / diagram), "--format", "svg", "-o", str(out)])
            if status != 0:
                raise RuntimeError(f"fsmctl graph {diagram} failed ({status}): {errors.getvalue().strip()}")
            drawings[name] = out.read_text(encoding="utf-8")
    return drawings


# -- MkDocs events ----------------------------------------------------------------------------------
def on_files(files, config):  # type: ignore[no-untyped-def]
    """Add the drawings to the site as ``img/graphs/NAME.svg`` (links to them are then checked)."""
    from mkdocs.structure.files import File

    for name, svg in draw_graphs().items():
        files.append(File.generated(config, f"img/graphs/{name}.svg", content=svg))
    return files


def on_page_markdown(markdown, page, config, files):  # type: ignore[no-untyped-def]
    """Put the CLI reference where a page has the marker."""
    if CLI_MARKER in markdown:
        markdown = markdown.replace(CLI_MARKER, cli_reference())
    return markdown
