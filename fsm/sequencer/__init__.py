"""The EEROS sequencer on the runtime: its state types (:mod:`~fsm.sequencer.steps`), a Sequence's steps laid out
as regions while parsing (:mod:`~fsm.sequencer.layout`), the checks that need the enclosing sequences
(:mod:`~fsm.sequencer.checks`), and at run time each state's supervisor: monitors, timeouts, preconditions and
the exception sequences they run (:mod:`~fsm.runtime.supervisor`)."""
