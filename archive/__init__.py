"""The archives of built-in results (data only; read by :mod:`vpid_bench.store.archive`)."""
