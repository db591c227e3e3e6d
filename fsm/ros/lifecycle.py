"""The bridge as a ROS 2 managed node (REP 2000's lifecycle, ``rclpy.lifecycle``): ``fsmctl run --ros --via rclpy
--lifecycle``.

The node starts *unconfigured*. ``configure`` loads and checks the document and builds the session (publishers,
subscriptions, parameters); a document that does not load fails the transition with its located message logged,
and the node stays unconfigured. ``activate`` starts ticking (waiting for the robot first); ``deactivate`` pauses
the machine and sends the zero-speed command; ``cleanup`` releases the session; ``shutdown`` ends the run.

A transition that is not allowed in the current state gets ROS 2's standard refusal (``success: false`` and rcl's
warning). rclpy 7.1 itself raises from its service callback then, which ends the node's executor (the node stops
answering); :func:`lifecycle_node` answers such requests before rclpy sees them.

What the node calls is a :class:`Managed` (the command's side, :mod:`fsm.tools.ros.lifecycle`), on the executor's
thread: each call returns quickly; the ticking is done on the command's thread.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any, Protocol

from fsm.runtime.clock import RealTimeClock


class Managed(Protocol):
    """What the managed node's transitions do (each returns None when it succeeded, else why not)."""

    def configure(self) -> str | None: ...

    def activate(self) -> str | None: ...

    def deactivate(self) -> str | None: ...

    def cleanup(self) -> str | None: ...

    def shutdown(self) -> str | None: ...


class HoldableClock(RealTimeClock):
    """The wall clock of a run that may be paused (deactivated): the time paused does not count, so after an
    ``activate`` the machine goes on from where it was instead of catching up on the ticks it missed."""

    __slots__ = ("_held",)

    def __init__(self, dt: float) -> None:
        super().__init__(dt)
        self._held: float | None = None

    def hold(self) -> None:
        if self._held is None:
            self._held = time.monotonic()

    def resume(self) -> None:
        held, self._held = self._held, None
        if held is not None and self._t0 is not None:
            self._t0 += time.monotonic() - held


def logger_of(node: Any) -> Any:
    """The node's rclpy logger (its messages go to standard error and /rosout)."""
    return node.get_logger()


def lifecycle_node(name: str, managed: Managed, **kwargs: Any) -> Any:
    """An ``rclpy.lifecycle.LifecycleNode`` named ``name`` whose transitions call ``managed`` (``kwargs``: as
    ``rclpy.node.Node``'s: namespace, context, parameter_overrides)."""
    import importlib

    from rclpy.lifecycle import LifecycleNode, TransitionCallbackReturn

    change_state_type: Any = importlib.import_module("lifecycle_msgs.srv").ChangeState

    def outcome(node: Any, transition: str, step: Callable[[], str | None]) -> Any:
        try:
            why = step()
        except Exception as exc:  # rclpy would turn it into ERROR without a word
            why = f"{type(exc).__name__}: {exc}"
        if why is None:
            logger_of(node).info(f"{transition}: done")
            return TransitionCallbackReturn.SUCCESS
        logger_of(node).error(f"{transition} failed: {why}")
        return TransitionCallbackReturn.FAILURE

    class Node(LifecycleNode):
        def __init__(self, node_name: str, **options: Any) -> None:
            super().__init__(node_name, **options)
            service: Any = self._service_change_state
            self._allowed = service.callback
            service.callback = self._change_state

        def _change_state(self, request: Any, response: Any) -> Any:
            """rcl's refusal of a transition the current state does not have, answered here (see the module's
            docstring)."""
            machine: Any = self._state_machine
            current = machine.current_state
            transition = request.transition
            possible = {t[0]: t[1] for t in machine.available_transitions}
            if transition.label:
                wanted = [tid for tid, label in possible.items() if label == transition.label]
            else:
                wanted = [transition.id] if transition.id in possible else []
            if not wanted:
                shown = transition.label or str(transition.id)
                logger_of(self).warning(f"unable to start transition {shown} from the current state {current[1]} "
                               f"(it has {', '.join(sorted(possible.values())) or 'none'})")
                return change_state_type.Response(success=False)
            return self._allowed(request, response)

        def forget_parameter(self, name: str) -> None:
            """rclpy's ``undeclare_parameter``, for read-only parameters too: a cleanup releases everything its
            configure declared (rclpy refuses to undeclare a read-only one)."""
            self._parameters.pop(name, None)
            self._descriptors.pop(name, None)

        def on_configure(self, state: Any) -> Any:
            return outcome(self, "configure", managed.configure)

        def on_activate(self, state: Any) -> Any:
            return outcome(self, "activate", managed.activate)

        def on_deactivate(self, state: Any) -> Any:
            return outcome(self, "deactivate", managed.deactivate)

        def on_cleanup(self, state: Any) -> Any:
            return outcome(self, "cleanup", managed.cleanup)

        def on_shutdown(self, state: Any) -> Any:
            return outcome(self, "shutdown", managed.shutdown)

        def on_error(self, state: Any) -> Any:
            managed.deactivate()
            managed.cleanup()
            return TransitionCallbackReturn.SUCCESS  # back to unconfigured

    return Node(name, **kwargs)
