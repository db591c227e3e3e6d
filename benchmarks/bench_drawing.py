"""How legible the SVG drawings are (issue 24, item 7): overlaps and crossings counted on each picture.

For every diagram in ``diagrams/`` (the ``.uxf`` where there is one, else the ``.json``) and every file of the
real UMLet corpus that converts (found where ``tests/helpers.py`` finds it, or in ``$TRAL_UXF_CORPUS``), draws it
with ``fsmctl graph --format svg`` and counts what :mod:`fsm.tools.graph.quality` counts: box/box overlaps, arrows
through boxes (not their ends nor a composite they are drawn in) or along them, labels over boxes, labels over
labels or closer than ``LABEL_GAP``, labels over arrows, arrow crossings, arrows running on top of each other or side
by side closer than ``SPACING``. Prints a Markdown table and the totals.

Run: ``.venv/bin/python benchmarks/bench_drawing.py`` (``--fsmctl PATH``: draw with another checkout's
``fsmctl``, e.g. to measure before a change; the counting is always this checkout's).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from dataclasses import fields
from pathlib import Path

from fsm.tools.graph.quality import Quality, measure, table

ROOT = Path(__file__).resolve().parents[1]


def corpus() -> Path:
    given = os.environ.get("TRAL_UXF_CORPUS")
    return Path(given) if given else ROOT.parent / "shared" / "corpus" / "uxf"


def files() -> list[Path]:
    ours = sorted((ROOT / "diagrams").rglob("*.uxf"))
    ours += [p for p in sorted((ROOT / "diagrams").rglob("*.json"))
             if not p.with_suffix(".uxf").exists() and ".scenario" not in p.name and "worlds" not in p.parts]
    return sorted(ours) + sorted(corpus().glob("*.uxf"))


def draw(fsmctl: str, path: Path, out: Path) -> str | None:
    plugin = ["--plugin", str(ROOT / "examples" / "eeros" / "eeros_plant.py")] if "eeros" in path.parts else []
    got = subprocess.run([fsmctl, *plugin, "graph", str(path), "--format", "svg", "-o", str(out)], capture_output=True,
                         text=True, check=False)
    if got.returncode != 0:
        return None
    return out.read_text(encoding="utf-8")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--fsmctl", default=str(Path(sys.executable).with_name("fsmctl")))
    args = ap.parse_args()
    rows: list[tuple[str, Quality | str]] = []
    total = Quality()
    with tempfile.TemporaryDirectory() as tmp:
        for path in files():
            name = str(path.relative_to(ROOT)) if path.is_relative_to(ROOT) else f"corpus/{path.name}"
            text = draw(args.fsmctl, path, Path(tmp) / "out.svg")
            if text is None:
                continue  # a corpus file the converter refuses: nothing drawn
            q = measure(text)
            rows.append((name, q))
            for f in fields(Quality):
                setattr(total, f.name, getattr(total, f.name) + getattr(q, f.name))
    rows.append(("**total**", total))
    print(table(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
