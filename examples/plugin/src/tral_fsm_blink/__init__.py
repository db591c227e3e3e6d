"""Example tral-fsm plugin: the ``Blink`` state and the ``Counted`` transition (see ``states`` and
``transitions``); the entry points in ``pyproject.toml`` make them known to ``fsmctl`` once installed."""
