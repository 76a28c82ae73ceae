"""The store: one module per file format, each with its schema string, size caps, reader,
writer and checks (docs/architecture.md lists them). It sits below the job, ``analysis/``,
``targets.py`` and ``report/``, and imports only ``errors``, ``fileio``, ``problem`` and
``estimators`` (the objectives' names)."""
