"""``fsmctl explain TRACE --tick N``: why tick N of a run did what it did, from its trace, by re-simulation.

The run is built again from what the trace's header holds (the machine's document, the world, the seed, the
noise, the tick), its recorded inputs scheduled at their ticks, and run to just before tick N, as the live
debugger's rewind does; then tick N is run with every check of the active states' transitions kept
(:mod:`fsm.debug.explain`). The re-simulation is compared with the trace: the states active before N and what
fired at N must be what the trace says, or the command says where they part (a type's code changed since, a run
of another version). The machine and the world come from the header, so the files they were read from may have
moved or changed.
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from fsm.model.errors import FsmError

from .common import EXIT_OK, Subcommands


def register(sub: Subcommands) -> None:
    p = sub.add_parser("explain", help="say why a tick of a run did what it did (each transition checked, what it "
                                       "read, fired or why not), by re-simulating its trace",
                       description="For tick N of a run's trace: every transition leaving each state active before "
                                   "it, in the order the tick checks them, with its guard or condition, the values "
                                   "it read at that tick and whether it fired, and if not, why not (guard false, "
                                   "condition false, a higher-priority transition fired, a paused subtree, a "
                                   "monitor took over). Computed by re-simulating the run from its trace, as the "
                                   "live debugger's rewind does; what the live page's Why panel shows.")
    p.add_argument("trace", metavar="TRACE.jsonl", help="the trace (fsmctl run --trace; '-' for standard input)")
    p.add_argument("--tick", type=int, required=True, metavar="N", help="the tick to explain (1 to the trace's last)")
    p.add_argument("--json", action="store_true", help="print the explanation as JSON")
    p.set_defaults(func=cmd_explain)


def rebuild(trace: Any) -> Any:
    """A fresh session of the run ``trace`` recorded, with its recorded inputs scheduled (not started)."""
    from fsm.session.inputs import recorded_inputs
    from fsm.session.session import Session

    header = trace.header
    document = header.get("machine")
    if not isinstance(document, dict):
        raise FsmError(f"{trace.name}: the trace's header holds no machine document: it cannot be re-simulated "
                       "(write it with fsmctl run --trace)")
    if trace.reloads:
        raise FsmError(f"{trace.name}: the run was hot-reloaded at tick {trace.reloads[0].get('tick')}: a trace is "
                       "re-simulated with one machine only; use the trace of a run without a reload")
    dt = header.get("dt")
    try:
        if header.get("world_file") or header.get("world"):
            from fsm.sim import simulate
            from fsm.sim.world import parse_world

            # the world as the run loaded it, from the header: a trace explains from any folder, and a world
            # file changed since does not change the run (a header without it names the world's file)
            world = header.get("world")
            world = (parse_world(world, f"{trace.name}: the header's world") if isinstance(world, dict)
                     else header.get("world_file"))
            session = simulate(document, world=world, seed=int(header.get("seed") or 0),
                               noise=bool(header.get("noise", True)), dt=float(dt) if dt else None)
        else:
            session = Session.open(document, dt=float(dt) if dt else None)
    except FsmError as exc:
        raise FsmError(f"{trace.name}: the run cannot be built again from its header: {exc}") from None
    inputs, warnings = recorded_inputs(trace.inputs)
    if warnings:
        raise FsmError(f"{trace.name}: {warnings[0]}")
    for tick, item in inputs:
        session.schedule_tick(tick, item)
    return session


def explain_trace(trace: Any, tick: int) -> Any:
    """The :class:`~fsm.debug.explain.Explanation` of ``tick`` of ``trace`` (checked against the trace)."""
    from fsm.debug.explain import explain_next
    from fsm.session.session import StopRules

    last = trace.last_tick
    if not 1 <= tick <= last:
        raise FsmError(f"--tick {tick}: the trace's ticks are 1 to {last}; choose one of them")
    session = rebuild(trace)
    session.start()
    if tick > 1:
        session.run(stop_rules=StopRules(max_ticks=tick - 1))
    if session.ticks != tick - 1:
        raise FsmError(f"{trace.name}: the re-simulated run ended at tick {session.ticks}, before tick {tick}: it "
                       "is not the run the trace recorded (a type's code or tral-fsm changed since?)")
    check_active(trace, session, tick - 1, "a type's code or tral-fsm changed since?")
    explanation = explain_next(session, signal_names(trace, session))
    fired = sorted(f"{t['from']} -> {t['to']}" for e in trace.events if e["tick"] == tick
                   for t in e.get("transitions", ()) if t.get("from"))
    if sorted(explanation.fired) != fired:
        raise FsmError(f"{trace.name}: at tick {tick} the re-simulated run fired {explanation.fired or 'nothing'}, "
                       f"the trace says {fired or 'nothing'}: it is not the run the trace recorded")
    return explanation


def check_active(trace: Any, session: Any, tick: int, why: str) -> None:
    """The re-simulated run must be in the states the trace recorded at ``tick``; an error naming both (and
    ``why`` they may part) otherwise."""
    active = session.machine.active_paths
    recorded = trace.at(tick)[0]
    if sorted(active) != sorted(recorded):
        raise FsmError(f"{trace.name}: at tick {tick} the re-simulated run is in {', '.join(active)}, the trace says "
                       f"{', '.join(recorded)}: it is not the run the trace recorded ({why})")


def signal_names(trace: Any, session: Any) -> list[str]:
    """The signals an expression over the re-simulated run may read: the machine's and those the trace set."""
    signals = {str(i["input"].get("name")) for i in trace.inputs if i.get("input", {}).get("kind") == "signal"}
    return sorted(signals | set(session.machine.ctx.signals))


def cmd_explain(args: argparse.Namespace) -> int:
    from fsm.model.errors import printable

    from ..runs.args import read_trace_arg

    trace = read_trace_arg(args.trace)
    for warning in trace.warnings:
        print(printable(f"fsmctl explain: warning: {warning}"), file=sys.stderr)
    explanation = explain_trace(trace, args.tick)
    if args.json:
        print(json.dumps(explanation.to_json(), indent=2, default=str))
    else:
        print("\n".join(printable(line) for line in explanation.text().splitlines()))
    return EXIT_OK
