"""Data only: ``<suite>/records.jsonl.gz`` and ``<suite>/ioh.zip`` of each archive that
vpid-bench ships (``vpid_bench.archive``), read through :mod:`vpid_bench.store.archive`."""
