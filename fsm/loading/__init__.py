"""The load layer: a document becomes a machine in stages. Reading (a reader per file suffix), the registry of
state and transition types, parsing into specs, checking, outcomes, compiling into a plan and building the
runtime objects; :mod:`fsm.load.loader` puts the stages together. It sits on the model and the runtime."""
