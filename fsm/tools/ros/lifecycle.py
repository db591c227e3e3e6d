"""``fsmctl run MACHINE --ros PROFILE --via rclpy --lifecycle``: the bridge as a ROS 2 managed node.

The node (:mod:`fsm.ros.lifecycle`) calls the transitions here on its executor's thread; the ticking happens on
the command's thread. ``deactivate`` and ``shutdown`` send the zero-speed command at once and make the command of
the tick in progress zero too, so the last command the robot gets has zero speed. ``configure`` reads the document
again (its file as it is now, ``--set`` applied), so a document fixed after a failed ``configure`` is taken by the
next one.

What is written at the end (trace, summary, report, bag) is the run of the configured machine: paused and resumed
as the node was deactivated and activated. A run that records (``--trace``, ``--summary``, ``--report``, ``--bag``)
keeps one machine: after ``cleanup`` it cannot be configured again (the outputs would mix two runs); without
outputs it can, as often as wanted. The process ends at ``shutdown`` or Ctrl-C (exit 130).
"""

from __future__ import annotations

import argparse
import sys
import threading
from typing import Any

from fsm.model.errors import FsmError, StateRuntimeError, UsageError, printable

from ..runs.args import EXIT_INTERRUPTED, EXIT_OK, Interrupts

#: How long cleanup waits for the tick in progress to end, s (a tick takes milliseconds).
TICK_WAIT = 2.0


def load_plan(args: argparse.Namespace, file: str) -> tuple[Any, Any]:
    """The document as it is now, checked, ``--set`` applied: (spec, compiled plan); a located
    :class:`~fsm.model.errors.DiagramError` otherwise."""
    from fsm.loading.loader import analyse, compile_checked
    from fsm.loading.loader import compile as compile_spec

    from ..runs.args import apply_overrides, checked, registry_from

    spec, analysis, problems = analyse(file, registry=registry_from(args))
    spec, analysis = checked(problems, spec), checked(problems, analysis)
    changed = apply_overrides(spec, args.overrides, file)
    return changed, compile_checked(spec, analysis) if changed is spec else compile_spec(changed)


class LifecycleRun:
    """One ``fsmctl run --lifecycle`` (see the module's docstring)."""

    def __init__(self, args: argparse.Namespace, file: str, profile: Any, link: Any, outputs: Any,
                 files: dict[str, Any], stop_rules: Any, interrupts: Interrupts) -> None:
        self.args, self.file, self.profile, self.link = args, file, profile, link
        self.outputs = outputs
        #: trace_out, summary_out, report_out: the named outputs (or None)
        self.files = files
        self.stop_rules = stop_rules
        self.interrupts = interrupts
        self.ticking = threading.Lock()
        self.active = threading.Event()
        self.done = threading.Event()
        self.session: Any = None
        self.recorder: Any = None
        self.bag: Any = None
        self.primed = False
        #: why the machine no longer ticks while active (finished, a limit, silence, an error), or None
        self.over: str | None = None
        self.error: StateRuntimeError | None = None
        self.cleaned = False

    @property
    def records(self) -> bool:
        return bool(self.args.bag) or any(out is not None for out in self.files.values())

    def say(self, text: str) -> None:
        if not self.args.quiet:
            print(printable(f"fsmctl run: {text}"), file=sys.stderr, flush=True)

    # -- the node's transitions (the executor's thread) ------------------------------------------------------------
    def configure(self) -> str | None:
        if self.cleaned and self.records:
            return ("this run records (--trace, --summary, --report or --bag) the machine it configured first; "
                    "after cleanup start fsmctl again to configure another")
        try:
            spec, plan = load_plan(self.args, self.file)
            self._build(spec, plan)
        except FsmError as exc:
            return str(exc)
        return None

    def _build(self, spec: Any, plan: Any) -> None:
        from fsm.ros.bag import BagRecorder
        from fsm.ros.driver import ros_session
        from fsm.ros.lifecycle import HoldableClock
        from fsm.session.session import SetSignal

        from .ends import start_recording, state_parameters

        args = self.args
        if args.bag and self.bag is None:
            self.bag = BagRecorder(args.bag, self.profile)
        clock = None if args.lockstep else HoldableClock(self.profile.dt)
        session = ros_session(plan, self.profile, self.link, lockstep=args.lockstep, bag=self.bag,
                              variables=args.initial_vars, stop=self.stop_rules, clock=clock,
                              signals=list(getattr(spec, "inputs", None) or []),
                              tunables=state_parameters(args, spec, "rclpy"))
        for name, value, at in args.signal:
            session.schedule(at, SetSignal(name, value))
        self.recorder = start_recording(args, session, self.profile, self.file, self.files["trace"],
                                        self.files["report"])
        self.session, self.primed, self.over, self.error = session, False, None, None

    def activate(self) -> str | None:
        if self.session is not None:
            self.session.driver.inactive = False
        self.active.set()
        return None

    def deactivate(self) -> str | None:
        """Every command from now has zero speed (the tick in progress's too), one is sent now, and the ticking
        stops after the tick in progress. Nothing here waits for that tick: it may be waiting for a message this
        thread delivers (the simulator's clock in lock-step)."""
        self.active.clear()
        if self.session is not None:
            self.session.driver.inactive = True
            self.session.driver.stop()
        return None

    def cleanup(self) -> str | None:
        if not self.ticking.acquire(timeout=TICK_WAIT):
            return (f"the machine is still in its last tick after {TICK_WAIT:g} s (waiting for the robot); "
                    "try cleanup again")
        try:
            self.link.release()
            self.cleaned = True
            if not self.records:
                self.session = self.recorder = None
        finally:
            self.ticking.release()
        return None

    def shutdown(self) -> str | None:
        self.done.set()
        return self.deactivate()

    # -- the command's thread -----------------------------------------------------------------------------------
    def serve(self) -> int:
        """Tick while active, until shutdown or Ctrl-C; then write the outputs. The exit status."""
        name = f"{self.link.namespace.rstrip('/')}/{self.link.node_name}"
        self.say(f"{self.link.describe()}: a managed node, unconfigured (ros2 lifecycle set {name} configure)")
        interrupts = self.interrupts
        try:
            while not (self.done.is_set() or interrupts.stop()):
                if not self.active.wait(0.05):
                    continue
                with self.ticking:
                    if self.active.is_set() and self.session is not None and self.over is None:
                        self._tick_while_active()
                if self.over is not None:
                    self.done.wait(0.05)  # active but the machine is over: the car is held at zero
        finally:
            interrupts.writing = True
        return self._end()

    def _halt(self) -> bool:
        return not self.active.is_set() or self.done.is_set() or self.interrupts.stop()

    def _tick_while_active(self) -> None:
        session = self.session
        driver = session.driver
        if not self.primed:
            self.primed = driver.prime(stop=self._halt)
            if not self.primed:
                return
            self.say(f"{self.profile.name} answered ({self.link.describe()}); driving")
        clock = session.machine.clock
        resume = getattr(clock, "resume", None)
        if resume is not None:
            resume()
        try:
            result = session.run(stop=self._halt)
            if result.stopped != "stopped":
                self.over = result.stopped
        except StateRuntimeError as exc:
            self.error, self.over = exc, "error"
            self.recorder.flush(session.machine)
        finally:
            if resume is not None:
                clock.hold()
        if self.over is not None:
            driver.stop()
            self.say(f"the machine is over ({self.over}); the car is held at zero speed until shutdown")

    def _end(self) -> int:
        from .ends import finish_run

        if self.session is None:
            interrupted = self.interrupts.interrupted
            self.say(f"{'interrupted' if interrupted else 'shut down'} with no machine configured: nothing to write")
            return EXIT_INTERRUPTED if interrupted else EXIT_OK
        code = finish_run(self.args, self.session, self.file, self.outputs, self.files["summary"],
                       self.files["report"], self.recorder, self.error, self.interrupts.interrupted)
        if self.bag is not None:
            self.bag.commit()
            self.bag = None
        return code

    def discard(self) -> None:
        if self.bag is not None:
            self.bag.discard()
            self.bag = None


def check_usage(args: argparse.Namespace, via: str) -> None:
    """--lifecycle: rclpy's managed node, the document read at each configure (a file, not standard input)."""
    if via != "rclpy":
        raise UsageError("--lifecycle makes the bridge a ROS 2 managed node, which rclpy provides: add --via rclpy")
    if args.file == "-":
        raise UsageError("--lifecycle reads the document at each configure: name its file instead of '-'")
