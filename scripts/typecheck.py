"""Type-check the package with mypy in strict mode (the configuration is ``[tool.mypy]`` in pyproject.toml).

Every subpackage lives under ``fsm/`` in the checkout as it is installed, so this is plain ``python -m mypy`` run
from the checkout's root; the script stays so that tests and docs have one command to name.

Usage: ``python scripts/typecheck.py [mypy options]``; the exit status is mypy's.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def main(argv: list[str]) -> int:
    """Run mypy with ``argv`` (none: the configuration's packages) from the checkout and print what it says."""
    done = subprocess.run([sys.executable, "-m", "mypy", *argv], cwd=ROOT, capture_output=True, text=True)
    sys.stdout.write(done.stdout)
    sys.stderr.write(done.stderr)
    return done.returncode


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
