"""UMLet diagrams (``.uxf``): the reader that turns a drawing into machine documents, the writer that draws a
document back so that it converts to the same document, and the palette generated from the registry.

The reader is a pipeline, one module per step: :mod:`~fsm.tools.umlet.source` (XML or TRAL's xml2json JSON to
raw elements with their line:column), :mod:`~fsm.tools.umlet.text` (what the texts in boxes and labels say),
:mod:`~fsm.tools.umlet.geometry` (UMLet's attachment rule, nesting by containment),
:mod:`~fsm.tools.umlet.scene` (boxes and machine levels), :mod:`~fsm.tools.umlet.relations` (arrows to
transitions), :mod:`~fsm.tools.umlet.documents` (the documents); :mod:`~fsm.tools.umlet.reader` runs it and is
the ``fsm.readers`` entry point for ``.uxf``. :mod:`~fsm.tools.umlet.convert` adds the loader's checks located
in the diagram. :mod:`~fsm.tools.umlet.writer` and :mod:`~fsm.tools.umlet.palette` write. May import the
``fsm`` core, lxml and :mod:`fsm.tools.graph.layout`; never the CLI or the car.
"""
