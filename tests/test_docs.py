"""The documentation site: ``mkdocs build --strict`` passes (no broken link, no missing reference), the CLI
reference generated from the argument parsers covers every command and option, the Python examples of the
pages run and print what the pages say, and the README's links lead to files that exist."""

from __future__ import annotations

import argparse
import importlib
import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"


def load_hook():
    """docs/hooks/generate.py, imported from its file (it is not part of the installed package)."""
    spec = importlib.util.spec_from_file_location("docs_hooks_generate", DOCS / "hooks" / "generate.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("site")
    env = dict(os.environ, NO_MKDOCS_2_WARNING="1")  # Material's banner about its successor, not a warning of ours
    proc = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--config-file", str(ROOT / "mkdocs.yml"),
         "--site-dir", str(out)],
        cwd=ROOT, capture_output=True, text=True, timeout=300, env=env,
    )
    log = proc.stdout + proc.stderr
    assert proc.returncode == 0, f"mkdocs build --strict failed:\n{log}"
    warnings = [line for line in log.splitlines() if re.match(r"\s*(WARNING|ERROR)\b", line)]
    assert not warnings, "\n".join(warnings)
    return out


def test_site_builds_strictly_with_every_page(site: Path) -> None:
    pages = sorted(p.relative_to(DOCS).with_suffix("") for p in DOCS.rglob("*.md"))
    assert len(pages) >= 12
    for page in pages:
        html = site / ("index.html" if page.name == "index" else page / "index.html")
        assert html.is_file(), f"{page} was not built"


def test_site_has_the_drawings_made_by_fsmctl_graph(site: Path) -> None:
    hook = load_hook()
    for name in hook.GRAPHS:
        svg = (site / "img" / "graphs" / f"{name}.svg").read_text(encoding="utf-8")
        assert svg.startswith("<svg") and "</svg>" in svg
    used = set()
    for page in DOCS.rglob("*.md"):
        used |= set(re.findall(r"img/graphs/(\w+)\.svg", page.read_text(encoding="utf-8")))
    assert used and used <= set(hook.GRAPHS)


def test_site_has_the_api_reference(site: Path) -> None:
    text = (site / "api" / "running" / "index.html").read_text(encoding="utf-8")
    for name in ("fsm.loading.loader.load", "fsm.runtime.machine.Machine", "schedule_signal",
                 "fsm.runtime.context.Context"):
        assert name in text
    assert ":class:" not in text  # reStructuredText roles are turned into code by docs/hooks/rst_roles.py


def test_site_cli_page_is_the_generated_reference(site: Path) -> None:
    text = (site / "cli" / "index.html").read_text(encoding="utf-8")
    assert "fsmctl-reference" not in text  # the marker was replaced
    for name in ("validate", "run", "graph"):
        assert f'id="fsmctl-{name}"' in text


def subcommands(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    (action,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    return dict(action.choices)


def option_strings(parser: argparse.ArgumentParser) -> list[str]:
    return [opt for a in parser._actions if not isinstance(a, argparse._HelpAction) for opt in a.option_strings]


def test_cli_reference_lists_every_subcommand_and_option() -> None:
    from fsm.tools.cli import build_parser

    text = load_hook().cli_reference()
    parser = build_parser()
    subs = subcommands(parser)
    assert {"validate", "run", "types", "schema", "convert", "export", "palette", "graph"} <= set(subs)
    sections = re.split(r"^## ", text, flags=re.M)
    by_name = {s.split()[1]: s for s in sections[1:]}
    assert set(by_name) == set(subs), "one section per subcommand"
    for opt in option_strings(parser):
        assert re.search(rf"<code>[^<]*{re.escape(opt)}\b", sections[0]), f"fsmctl {opt}"
    for name, sub in subs.items():
        section = by_name[name]
        assert f"usage: fsmctl {name}" in section
        for opt in option_strings(sub):
            assert re.search(rf"<code>[^<]*(?<![\w-]){re.escape(opt)}(?![\w-])", section), f"fsmctl {name} {opt}"
        for action in sub._actions:
            if action.help and not isinstance(action, argparse._HelpAction):
                first_words = " ".join(action.help.split()[:3])
                assert first_words.replace("'", "&#x27;") in section or first_words in section, (name, action.help)


def test_cli_reference_renders_groups_choices_and_pipes_as_table_cells() -> None:
    parser = argparse.ArgumentParser(prog="tool", description="A tool.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    p = sub.add_parser("go", help="go somewhere", description="Goes <far>.")
    p.add_argument("where", metavar="PLACE", nargs="+")
    p.add_argument("--signal", metavar="NAME[=0|1]@T", help="a signal (default %(default)s)", default="x")
    group = p.add_argument_group("the car", "only with a car")
    group.add_argument("--mode", choices=("a", "b"), help="which mode")
    text = load_hook().cli_reference(parser)
    assert "| [`go`](#tool-go) | go somewhere |" in text
    section = text.split("\n## ", 1)[1]
    assert section.startswith("tool go {#tool-go}")
    assert "| <code>--signal NAME[=0&#124;1]@T</code> | a signal (default x) |" in section
    assert "Goes &lt;far&gt;." in section
    assert "**The car**" in section and "only with a car" in section
    assert "| <code>--mode {a,b}</code> | which mode |" in section
    assert "| <code>PLACE</code> | (one or more) |" in section


def python_blocks(page: Path) -> str:
    return "\n".join(re.findall(r"^```python\n(.*?)^```", page.read_text(encoding="utf-8"), flags=re.M | re.S))


def test_extending_page_examples_run_and_print_what_the_page_says(tmp_path: Path) -> None:
    page = DOCS / "extending.md"
    script = tmp_path / "example.py"
    script.write_text(python_blocks(page), encoding="utf-8")
    proc = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    printed = proc.stdout.strip()
    assert printed and f"`{printed}`" in page.read_text(encoding="utf-8")


def in_a_folder_with_the_diagrams(tmp_path: Path, code: str) -> subprocess.CompletedProcess[str]:
    """``code`` run as a user would, in a folder of theirs where ``diagrams/`` is the repository's."""
    (tmp_path / "diagrams").symlink_to(ROOT / "diagrams")
    return subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=120)


def test_getting_started_python_example_runs(tmp_path: Path) -> None:
    """The page's examples print what its comments say, and the trace they write ends as the run did."""
    import json

    page = DOCS / "getting-started.md"
    proc = in_a_folder_with_the_diagrams(tmp_path, python_blocks(page))
    assert proc.returncode == 0, proc.stderr
    first = proc.stdout.splitlines()[0]
    assert first.split()[0] == "succeeded" and f"# {first}\n" in page.read_text(encoding="utf-8")
    lines = [json.loads(line) for line in (tmp_path / "sorter.jsonl").read_text(encoding="utf-8").splitlines()]
    assert lines[0]["type"] == "header" and lines[-1]["type"] == "end"
    assert (lines[-1]["outcome"], lines[-1]["tick"]) == ("succeeded", int(first.split()[2]))


def docstring_example(module: str) -> str:
    """The example (the indented block after ``::``) of ``module``'s docstring."""
    doc = importlib.import_module(module).__doc__ or ""
    block = re.search(r"::\n\n((?:    .*\n|\n)+)", doc)
    assert block, module
    return "\n".join(line[4:] for line in block.group(1).splitlines())


@pytest.mark.parametrize("module", ["fsm.session.run", "fsm"])
def test_the_python_apis_docstring_example_runs_as_written(tmp_path: Path, module: str) -> None:
    code = docstring_example(module)
    proc = in_a_folder_with_the_diagrams(tmp_path, code)
    assert proc.returncode == 0, proc.stderr
    said = re.search(r"# (.+)$", code, flags=re.M)
    assert proc.stdout.strip() == (said.group(1) if said else proc.stdout.strip()) and proc.stdout.strip()


def test_readme_links_lead_to_existing_files() -> None:
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    links = [t for t in re.findall(r"\]\(([^)\s]+)\)", readme) if not re.match(r"[a-z]+:", t)]
    assert len(links) >= 8
    for target in links:
        path = target.split("#")[0]
        assert (ROOT / path).exists(), f"README links to {target}, which does not exist"
    for page in ("docs/getting-started.md", "docs/cli.md", "docs/architecture.md"):
        assert f"({page}" in readme
