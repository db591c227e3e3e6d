"""The ``fsmctl`` console script. A Ctrl-C while Python still imports tral-fsm and builds the parser (the first
few tenths of a second of every command) ends it quietly with exit status 130, as one does once the command runs
(fsm/tools/cli/app.py); nothing of the package is imported before that guard is in place. Once the command has
returned, a late Ctrl-C no longer interrupts the interpreter's exit."""

from __future__ import annotations

import signal
import sys

#: The exit status of a command stopped by Ctrl-C (``EXIT_INTERRUPTED`` of fsm/tools/cli/common.py).
EXIT_INTERRUPTED = 130


def main() -> int:
    if sys.argv[1:] == ["--version"]:  # the installed version, without importing the package (pydantic, the loader)
        from importlib.metadata import version

        sys.stdout.write(f"fsmctl {version('tral-fsm')}\n")
        return 0
    try:
        from fsm.tools.cli.app import main as fsmctl

        return fsmctl()
    except KeyboardInterrupt:  # while importing, or building the parser before the command runs
        sys.stderr.write("fsmctl: interrupted\n")
        return EXIT_INTERRUPTED
    finally:
        signal.signal(signal.SIGINT, signal.SIG_IGN)  # the outcome is decided: exit without a traceback


if __name__ == "__main__":
    sys.exit(main())
