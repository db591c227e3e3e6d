"""``python -m fsm.tools.scenario --schema [FILE]``: print or write the scenario JSON Schema (regenerates the
committed ``fsm/schema/scenario.schema.json``)."""

from __future__ import annotations

import sys
from pathlib import Path

from .model import scenario_schema_text


def main(argv: list[str]) -> int:
    if argv[:1] != ["--schema"] or len(argv) > 2:
        print("usage: python -m fsm.tools.scenario --schema [FILE]", file=sys.stderr)
        return 2
    if len(argv) == 2:
        Path(argv[1]).write_text(scenario_schema_text(), encoding="utf-8")
    else:
        sys.stdout.write(scenario_schema_text())
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
