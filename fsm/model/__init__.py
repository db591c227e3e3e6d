"""The model layer: data only. Errors and located problems, state paths, JSON positions, the expression language,
parameter base models, the machine document's specs and the compiled plan with its kinds. It imports nothing of
the other layers of ``fsm`` (docs/architecture.md, "Layering")."""
