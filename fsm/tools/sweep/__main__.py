"""``python -m fsm.tools.sweep --schema [FILE]``: print or write the sweep JSON Schema (regenerates the committed
``fsm/schema/sweep.schema.json``)."""

from __future__ import annotations

import sys
from pathlib import Path

from .spec import sweep_schema_text


def main(argv: list[str]) -> int:
    if argv[:1] != ["--schema"] or len(argv) > 2:
        print("usage: python -m fsm.tools.sweep --schema [FILE]", file=sys.stderr)
        return 2
    if len(argv) == 2:
        Path(argv[1]).write_text(sweep_schema_text(), encoding="utf-8")
    else:
        sys.stdout.write(sweep_schema_text())
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
