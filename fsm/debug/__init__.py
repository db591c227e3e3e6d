"""The debug layer: the engine of the live debugger. A session run under commands from another thread
(control), breakpoints, and hot reload. Only the tools import it."""
