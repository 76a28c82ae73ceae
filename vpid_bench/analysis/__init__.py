"""What a record allows, computed by the job (the report only reads files): instance optima,
bounds, intervals, floors, fit diagnostics, structures: all from residuals (architecture.md)."""
