"""The session layer: one run of a machine. The tick loop every runner uses, its Driver protocol, inputs that
steer a run from outside, and stop rules. It sits on the runtime and the trace's recorder."""
