"""Rewrite calls of the removed ``Machine.run`` into ``fsm.run`` (issue 31): ``m.run(ARGS)`` becomes
``fsm.run(m, ARGS).outcome`` (``fsm.run(m, ARGS)`` where the call is a statement of its own), and ``import fsm``
is added where missing (``ruff check --fix`` sorts it in). For code written against the old API (a branch merged
after the change, a user's scripts).

Usage: ``python scripts/migrate_machine_run.py [--names m,machine] FILE...``; ``--names`` are the variable names
that hold machines (default: m, m2, machine). Prints each file and the number of calls rewritten.
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path


def rewrite(text: str, names: list[str]) -> tuple[str, int]:
    """``text`` with each ``NAME.run(...)`` rewritten, and how many there were."""
    call = re.compile(r"(?<![\w.])(%s)\.run\(" % "|".join(map(re.escape, names)))
    out: list[str] = []
    i = count = 0
    while (found := call.search(text, i)) is not None:
        out.append(text[i:found.start()])
        j, depth = found.end(), 1
        while depth:
            depth += {"(": 1, ")": -1}.get(text[j], 0)
            j += 1
        args = text[found.end():j - 1].strip()
        line_start = text.rfind("\n", 0, found.start()) + 1
        line_end = text.find("\n", j)
        alone = not text[line_start:found.start()].strip() and not text[j:line_end if line_end >= 0 else None].strip()
        out.append(f"fsm.run({found.group(1)}{', ' + args if args else ''})" + ("" if alone else ".outcome"))
        i, count = j, count + 1
    out.append(text[i:])
    new = "".join(out)
    if count and not re.search(r"^import fsm$", new, re.M):
        future = re.search(r"^from __future__ import annotations\n", new, re.M)
        imports = re.search(r"^(import |from )", new, re.M)
        first = future.end() if future else imports.start() if imports else 0
        new = new[:first] + ("\nimport fsm\n" if future else "import fsm\n") + new[first:]
    return new, count


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--names", default="m,m2,machine")
    parser.add_argument("files", nargs="+", type=Path)
    args = parser.parse_args(argv)
    for path in args.files:
        text, count = rewrite(path.read_text(encoding="utf-8"), args.names.split(","))
        if count:
            path.write_text(text, encoding="utf-8")
        print(f"{path}: {count}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
