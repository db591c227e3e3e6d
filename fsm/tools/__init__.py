"""What users run, installed as ``fsm.tools``; one subpackage per concern.

- :mod:`fsm.tools.cli`: ``fsmctl``, the entry point and one module per command.
- :mod:`fsm.tools.umlet`: the ``.uxf`` reader pipeline, the writer and the palette.
- :mod:`fsm.tools.graph`: the layered layout and the SVG, Mermaid and DOT drawings.
- :mod:`fsm.tools.files`: reading and writing the files users name, shared by all of them.
- :mod:`fsm.tools.runs`: what the commands that run a machine share (arguments, the end of a run), below the CLI,
  the live debugger and the ROS 2 bridge.

Only the CLI imports the other packages' commands; the UMLet and graph packages never import the CLI.
"""
