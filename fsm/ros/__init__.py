"""The car over ROS 2, without ROS installed: an I/O profile binds the car interface to topics, Zenoh carries them.

- :mod:`fsm.ros.profile`: the I/O profile file (topics, message types, rates, QoS, how long an input may be silent);
  located errors before anything starts. Stdlib and pydantic only.
- :mod:`fsm.ros.messages`: ROS 2 message types (rosbags' typestore, ackermann_msgs registered from message text),
  CDR encoding and decoding.
- :mod:`fsm.ros.transport`: Zenoh sessions (peer mode, explicit endpoints), topic keys as rmw_zenoh or the
  Zenoh bridge name them.
- :mod:`fsm.ros.car`: :class:`~fsm.ros.car.RosCar`, the car interface (:class:`fsm.sim.io.CarIO`) whose readings
  come from subscribed topics; :mod:`fsm.ros.driver`: the session's driver (wall-clock or lock-step ticks,
  the safety stop, the status topic, the bag).
- :mod:`fsm.ros.robot`: the simulated car as a ROS 2 robot (``fsmctl sim --ros``); the only module here that loads
  the simulator (pymunk).
- :mod:`fsm.ros.bag`: runs recorded as rosbag2 (MCAP); :mod:`fsm.ros.replay`: a recorded drive fed to a machine.

Importing this package is cheap: rosbags and Zenoh (the ``ros2`` extra) load in the modules that need them.
"""

from __future__ import annotations
