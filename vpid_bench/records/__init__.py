"""Run records: the schema, atomic JSON on disk, record assembly, provenance, job status.

A record says everything needed to repeat a run (settings, seeds, versions) and to judge it
(best vector in physical units, objective, metrics, trace, time). It is plain JSON (no
pickle); non-finite floats are written as ``null``. Two runs of the same job and seed give
records identical except for their ``timing`` section (:func:`fingerprint` drops it).

File name: ``records/run-<index>-<run_id>.json`` inside the job's folder. The ``run_id`` is a
hash of what determines the result (settings, seed, budget, run index, the plugins' versions,
the content of data files), so a re-run of the same job recognises its records and a changed
plugin or data file does not reuse them.
"""

from ..fileio import _umask, write_text_atomic
from .assemble import make_record
from .check import check_record
from .io import (
    OLD_SCHEMAS,
    RECORDS_DIR,
    REQUIRED_KEYS,
    SCHEMA,
    CorruptRecordError,
    OldRecordError,
    _jsonable,
    canonical_json,
    fingerprint,
    iter_record_files,
    job_key,
    parse_record,
    parse_record_name,
    read_record,
    record_path,
    run_id,
    stable_hash,
    write_json_atomic,
    write_record,
)
from .provenance import distribution_provenance, package_versions
from .status import JOB_STATUS_FILE, read_job_status, write_job_status

__all__ = [
    "OLD_SCHEMAS", "RECORDS_DIR", "REQUIRED_KEYS", "SCHEMA", "CorruptRecordError",
    "OldRecordError", "_jsonable", "_umask", "canonical_json", "check_record",
    "distribution_provenance",
    "fingerprint", "iter_record_files", "job_key", "make_record", "package_versions",
    "parse_record", "parse_record_name", "read_record", "record_path", "run_id", "stable_hash",
    "write_json_atomic", "write_record",
    "write_text_atomic",
    "JOB_STATUS_FILE", "read_job_status", "write_job_status",
]
