"""What the commands that run a machine share, below the CLI, the live debugger and the ROS 2 bridge: the
arguments of a run (:mod:`~fsm.tools.runs.args`: exit statuses, the registry, inputs read by the reading rule,
``--set`` overrides, Ctrl-C), its outputs as one argument object (:mod:`~fsm.tools.runs.outputs`) and its end
(:mod:`~fsm.tools.runs.ending`: the summary, the trace's ``end`` line and the report). It imports nothing of
:mod:`fsm.tools.cli`, :mod:`fsm.tools.live` or :mod:`fsm.tools.ros`."""
