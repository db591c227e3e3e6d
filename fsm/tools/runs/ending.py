"""The end of a run, as ``fsmctl run`` (simulated car, or none) and ``fsmctl run --ros`` share it: the summary with
the run's error and interruption, the trace's ``end`` line, and the HTML report of the trace kept in memory."""

from __future__ import annotations

import io
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from fsm.model.errors import StateRuntimeError

if TYPE_CHECKING:
    from _typeshed import SupportsWrite

    from fsm.session.session import Session
    from fsm.trace.recorder import Recorder

    from ..files import Output
    from .args import Interrupts


def run_guarded(session: Session, recorder: Recorder, interrupts: Interrupts, run: Callable[[], None],
                halt: Callable[[], None] = lambda: None) -> StateRuntimeError | None:
    """``run()`` the session until a stop rule, the machine's end or Ctrl-C: a state's exception is returned (the
    trace flushed by ``recorder``); a second Ctrl-C while a state did not return ends the run as interrupted.
    ``halt()`` runs first on any exception (the car must not drive on); signals then only wait for the outputs."""
    try:
        run()
    except StateRuntimeError as exc:
        halt()
        recorder.flush(session.machine)
        return exc
    except KeyboardInterrupt:
        halt()
        interrupts.received = interrupts.received or 2
        recorder.flush(session.machine)
    except BaseException:
        halt()
        raise
    finally:
        interrupts.writing = True
    return None


class Tee:
    """The trace written to the user's file and kept in memory for the report."""

    def __init__(self, *streams: SupportsWrite[str] | None) -> None:
        self.memory = io.StringIO()
        self.streams: list[SupportsWrite[str]] = [st for st in streams if st is not None] + [self.memory]

    def write(self, text: str) -> None:
        for st in self.streams:
            st.write(text)


def trace_stream(trace_out: Output | None, report_out: Output | None) -> SupportsWrite[str] | None:
    """Where a run's recorder writes: the --trace file, and with --report a :class:`Tee` that keeps the trace in
    memory for it too."""
    stream = trace_out.stream() if trace_out is not None else None
    return Tee(stream) if report_out is not None else stream


def error_fields(error: StateRuntimeError) -> dict[str, Any]:
    """A state's exception as the summary and the trace's ``end`` line give it."""
    return {"state": error.path, "phase": error.phase, "tick": error.tick, "time": error.time,
            "message": f"{type(error.cause).__name__}: {error.cause}"}


def end_run(session: Session, error: StateRuntimeError | None, interrupted: bool, *, report_out: Output | None,
            report_name: str, result: dict[str, Any] | None = None, end: dict[str, Any] | None = None
            ) -> dict[str, Any]:
    """End a run that has stopped: the summary (with ``result``'s fields, then the error and the interruption),
    the trace's ``end`` line (``end``'s fields, then the same two) and, with ``report_out``, the HTML report of the
    trace (named ``report_name``) its recorder kept in memory. Returns the summary."""
    summary = session.summary()
    summary.update(result or {})
    if error is not None:
        summary["error"] = error_fields(error)
    if interrupted:
        summary["interrupted"] = True
    fields = dict(end or {})
    if interrupted:
        fields["interrupted"] = True
    if "error" in summary:
        fields["error"] = summary["error"]
    session.finish(**fields)
    if report_out is not None:
        assert session.recorder is not None  # a report asks for a recorder (run_recorder with a Tee)
        write_report(session.recorder.out, report_out, report_name)
    return summary


def write_report(stream: SupportsWrite[str] | None, report_out: Output, name: str) -> None:
    """Write the HTML report of the trace a :class:`Tee` kept in memory to ``report_out``."""
    from fsm.trace.replay import parse_trace

    from ..report import report_html

    if not isinstance(stream, Tee):
        raise TypeError("the report is made from the trace a Tee keeps in memory: record the run into a Tee")
    trace = parse_trace(stream.memory.getvalue().encode("utf-8"), name)
    report_out.write(report_html(trace))
