"""The runtime layer: what ticks. States, transitions, conditions, composites, regions, the machine, each state's
supervisor (monitors, timeouts, exception sequences), the context, clocks and debouncing. It reads the model and
never calls up into loading or the session."""
