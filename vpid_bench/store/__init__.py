"""The store: one module per file format, each with its schema string, size caps, reader,
writer and checks (what each holds and may import: docs/architecture.md)."""
