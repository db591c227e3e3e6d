"""The files a run writes (``--trace``, ``--report``, ``--summary``, and with the simulated car ``--video`` and
``--plot``), as one argument object: checked together before anything is read, committed together at the end."""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from ..files import Output, Outputs


@dataclass
class RunOutputs:
    """A run's outputs; each is ``None`` when its option was not given. ``all`` opens, commits and discards them."""

    all: Outputs
    trace: Output | None
    report: Output | None
    summary: Output | None
    video: Output | None = None
    plot: Output | None = None


def run_outputs(args: argparse.Namespace, *, video_suffixes: tuple[str, ...] = ()) -> RunOutputs:
    """``--trace``, ``--report`` and ``--summary`` (with ``video_suffixes``, also ``--video``, its container by
    suffix, and ``--plot``), each classified (a folder, a missing folder: a usage error before anything is read) and
    told apart from the others."""
    from ..files import Outputs  # start-up: every command line is parsed without the writer

    outputs = Outputs()
    trace = outputs.add(args.trace, "--trace")
    report = outputs.add(args.report, "--report", suffix=".html")
    summary = outputs.add(args.summary, "--summary")
    video = plot = None
    if video_suffixes:
        suffix = Path(args.video).suffix.lower() if args.video else ""
        video = outputs.add(args.video, "--video", binary=True,
                            suffix=suffix if suffix in video_suffixes else video_suffixes[0])
        plot = outputs.add(args.plot, "--plot", binary=True, suffix=".png")
    outputs.check()
    return RunOutputs(outputs, trace, report, summary, video, plot)
