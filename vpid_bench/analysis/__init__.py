"""What a record allows, computed by the job (the report only reads files): instance optima,
Cramér–Rao bounds, intervals and profiles without a truth, floors per estimator, fit
diagnostics and candidate structures (docs/architecture.md). All need residuals."""
