"""Recording runs outside the core: the recorder of a run's trace with its header (the machine document, includes
inlined, layout kept), and the MCAP export of a trace (:mod:`~fsm.tools.recording.mcap`, imported only when asked
for). The trace format and its recorder are :mod:`fsm.trace.recorder`, reading traces is :mod:`fsm.trace.replay`; the
HTML report
is :mod:`fsm.tools.report`."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from fsm.model.errors import printable
from fsm.trace.recorder import Recorder

from .document import header_document

if TYPE_CHECKING:
    from _typeshed import SupportsWrite

__all__ = ["end_lines", "header_document", "run_recorder"]


def run_recorder(stream: SupportsWrite[str] | None, file: str, car: Any = None, *, world_file: Any = None,
                 seed: int = 0, noise: bool = True, preloaded: dict[str, Any] | None = None,
                 overrides: list[str] | None = None, initial_vars: dict[str, Any] | None = None,
                 sample_rate: float = 20.0, document: dict[str, Any] | None = None) -> Any:
    """The recorder of a run as ``fsmctl run`` and ``fsmctl sweep`` write it: the header (the machine document
    with its layout, world, seed, overrides), the car's samples at ``sample_rate`` Hz and its camera frames; a
    bare :class:`~fsm.trace.recorder.Recorder` (summary only) when ``stream`` is ``None``. ``document``: the header's
    machine
    document when the caller already has it (else read again from ``file``)."""
    if stream is None:
        return Recorder()
    header: dict[str, Any] = {"source": file,
                              "machine": document if document is not None else header_document(file, preloaded)}
    if overrides:
        header["overrides"] = list(overrides)
    if initial_vars:
        header["initial_vars"] = dict(initial_vars)
    extra = sample = frames = fields = None
    if car is not None:
        from fsm.sim.loop import (
            CAR_SAMPLE_FIELDS,
            car_trace_fields,
            car_trace_frames,
            car_trace_header,
            car_trace_sample,
        )

        header.update(car_trace_header(car, world_file, seed, noise))
        extra = car_trace_fields(car)
        sample = car_trace_sample(car)
        frames = car_trace_frames(car)
        fields = CAR_SAMPLE_FIELDS
    return Recorder(stream, extra=extra, header=header, sample=sample, sample_period=1.0 / sample_rate, frames=frames,
                    sample_fields=fields)


def end_lines(file: str, machine: Any, recorder: Any, *, interrupted: bool = False, note: str = "",
              where: str = "") -> list[str]:
    """What a command says when a run ended (``fsmctl run``, with ``--live`` and ``--ros``): the outcome, the ticks,
    the time and the transitions (``where``: on what it ran, after the time; ``note``: said with "interrupted"), the
    states visited, and the active one when it did not finish. Terminal-safe (control characters escaped)."""
    status = f"outcome {machine.outcome}" if machine.finished else "not finished"
    if interrupted:
        status += f" (interrupted{note})"
    lines = [f"{file}: {status} after {machine.ticks} ticks ({machine.now:.3f} s){where}, "
             f"{machine.transition_count} transitions", "visited: " + " -> ".join(recorder.visited)]
    if not machine.finished:
        lines.append(f"active: {machine.active_path}")
    return [printable(line) for line in lines]
