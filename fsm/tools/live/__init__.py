"""The live debugger's tools: the page and its assets, the aiohttp server, the stream of trace lines, the runner
that drives a debugged session (:mod:`fsm.debug.control`) in its own thread, hot reload's file watcher, and the
sweep board. Imported only by ``fsmctl run --live`` and ``fsmctl sweep --live`` (aiohttp is the ``live`` extra)."""
