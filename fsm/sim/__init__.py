"""The simulated TRAL car: world files, a pymunk car with ultrasonic and hall sensors, the closed loop, the renderer.

Importing this package is cheap: pymunk and OpenCV load only in the modules that need them
(``car``, ``loop``, ``render``). States and transitions see the car only through the
:class:`fsm.sim.io.CarIO` protocol, so a hardware bridge can implement the same interface.
"""

from __future__ import annotations

from .io import SENSORS, CarIO

#: The world a machine that drives runs in when none is given (``fsm.sim.world.default_world`` finds it).
DEFAULT_WORLD = "hallway.json"

__all__ = ["DEFAULT_WORLD", "SENSORS", "CarIO"]
