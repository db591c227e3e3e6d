"""``fsmctl replay``: a machine open loop on a recorded drive; trace, report, summary and the first divergence."""

from __future__ import annotations

import argparse
import json
import sys
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from _typeshed import SupportsWrite

from fsm.model.errors import UsageError, printable

from ..runs.args import EXIT_FAIL, EXIT_OK, checked, input_name, read_inputs, registry_from
from .common import car_recorder, load, require_extra


def run_replay(args: argparse.Namespace) -> int:
    from fsm.loading.loader import compile as compile_spec
    from fsm.loading.loader import machine_files
    from fsm.ros.replay import ReplayDriver, load_drive, replay_session

    from ..runs.ending import trace_stream, write_report
    from ..runs.outputs import run_outputs

    outs = run_outputs(args)
    outputs, trace_out, report_out, summary_out = outs.all, outs.trace, outs.report, outs.summary
    pre = read_inputs([args.machine])
    file = input_name(args.machine)
    spec = _checked_spec(args, pre, file)
    profile = load(args.profile)
    require_extra("fsmctl replay")
    if args.start is not None and args.stop is not None and args.stop <= args.start:
        raise UsageError(f"--to {args.stop:g} must be after --from {args.start:g}")
    drive = load_drive(args.bag, profile, start=args.start, stop=args.stop,
                       warn=lambda text: print(printable(f"fsmctl replay: warning: {text}"), file=sys.stderr))
    outputs.open(machine_files(spec) + [args.profile])
    try:
        session = replay_session(drive, compile_spec(spec), profile)
        driver = session.driver
        assert isinstance(driver, ReplayDriver)
        header = {"replay_of": args.bag, "overrides": args.overrides}
        recorder = session.record(car_recorder(trace_stream(trace_out, report_out), file, driver.car, profile,
                                               preloaded=pre, sample_rate=args.sample_rate, extra_header=header))
        driver.prime()
        session.run()
        result = _summary(args, session, driver, drive)
        session.finish()
        if report_out is not None:
            write_report(recorder.out, report_out, args.trace if args.trace not in (None, "-") else file)
        if summary_out is not None:
            summary_out.write(json.dumps(result, indent=2) + "\n")
        outputs.commit()
    finally:
        outputs.discard()
        drive.source.close()
    if not args.quiet:
        _tell(args, file, session.machine, driver, drive, profile, sys.stderr if outputs.to_stdout else sys.stdout)
    return EXIT_FAIL if args.expect_same and driver.divergence is not None else EXIT_OK


def _checked_spec(args: argparse.Namespace, pre: dict[str, bytes], file: str) -> Any:
    """The machine document, checked (a located error otherwise), ``--set`` applied."""
    from fsm.loading.loader import check
    from fsm.loading.reading import preloaded

    from ..runs.args import apply_overrides

    with preloaded(pre):
        spec, problems = check(file, registry=registry_from(args))
    return apply_overrides(checked(problems, spec), args.overrides, file)


def _summary(args: argparse.Namespace, session: Any, driver: Any, drive: Any) -> dict[str, Any]:
    """The session's summary with what the replay compared and where it first diverged."""
    divergence = driver.divergence
    result: dict[str, Any] = session.summary()
    result["replay"] = {"bag": args.bag, "ticks": session.machine.ticks + 1, "commands_recorded": drive.commanded,
                        "from": args.start, "to": args.stop, "compared": driver.compared,
                        "divergence": None if divergence is None else {
                            "tick": divergence.tick, "time": divergence.time,
                            "recorded": divergence.recorded, "replayed": divergence.replayed}}
    return result


def _tell(args: argparse.Namespace, file: str, machine: Any, driver: Any, drive: Any, profile: Any,
          report: SupportsWrite[str]) -> None:
    """The outcome and the comparison, in a sentence each."""
    status = f"outcome {machine.outcome}" if machine.finished else "not finished"
    print(printable(f"{file} on {args.bag}: {status} after {machine.ticks} ticks ({machine.now:.3f} s)"),
          file=report)
    if not drive.commanded:
        print(f"the bag has no commands on {profile.outputs.command.topic}: ticked at {profile.rate:g} Hz on "
              "its clock, nothing to compare", file=report)
    elif driver.divergence is None:
        print(f"the same decisions as the recorded drive at all {driver.compared} ticks compared", file=report)
    else:
        print(printable(driver.divergence.describe()), file=report)
