"""The EEROS sequencer compiled onto the runtime: :mod:`~fsm.sequencer.compile` (Sequence documents to regions) and
:mod:`~fsm.sequencer.watch` (monitors, timeouts, exception sequences)."""
