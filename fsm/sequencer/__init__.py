"""The EEROS sequencer on the runtime: its state types (:mod:`~fsm.sequencer.steps`), a Sequence's steps laid out
as regions while parsing (:mod:`~fsm.sequencer.parsing`), the checks that need the enclosing sequences
(:mod:`~fsm.sequencer.checking`), and at run time each state's supervisor: monitors, timeouts, preconditions and
the exception sequences they run (:mod:`~fsm.sequencer.supervisor`)."""
