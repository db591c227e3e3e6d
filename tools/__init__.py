"""Command-line tools: ``fsmctl`` and, later, the UMLet reader and writer. Installed as ``fsm.tools``."""
