"""The command-line side of the ROS 2 bridge: ``fsmctl run --ros``, ``fsmctl sim --ros`` and ``fsmctl replay``.

The car interface over topics, the driver, the simulated robot, bags and replay live in :mod:`fsm.ros`; this package
checks the options and outputs, opens the Zenoh session, runs the session with the safety rules around it (a zero
speed command first on Ctrl-C and on any exception), and writes trace, report, summary and bag.
"""

from __future__ import annotations
