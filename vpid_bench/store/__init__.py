"""The store: one module per file format, each holding its schema string, its size caps, its
reader, its writer and its checks:

* :mod:`.records`: a run's record (``records/run-<index>-<run_id>.json``), with
  :mod:`.record_check` (the field rules every reader applies) and :mod:`.provenance` (which
  versions of what produced it);
* :mod:`.job_status`: a job folder's ``job.json``;
* :mod:`.artifacts`: the files a job leaves for the report (the best run's signals), with
  :mod:`.job_files` (its JSON files: names, size cap, reader, writer) and :mod:`.job_checks`
  (each JSON file's schema and content checks);
* :mod:`.optimum`: the instance-optimum file;
* :mod:`.archive`: an archive folder's manifest, checked files and optima, with
  :mod:`.archive_records` (its runs, each line checked, :mod:`.plausible` the values a run
  gives) and :mod:`.archive_pack` (its one writer);
* :mod:`.ioh`: the IOHprofiler export (a report's ``ioh/``, an archive's ``ioh.zip``);
* :mod:`.csv_table`: the one CSV writer (full precision); :mod:`.paths`: file names made
  from untrusted text and paths kept inside a folder;
* :mod:`.record_csv`: a user's CSV record (``problem.reference.file``), read for the problem
  plugins through the public API.

It sits below the job (``experiment.py``, ``assemble.py``, ``job_analysis.py``), ``analysis/``,
``targets.py`` and ``report/`` (docs/architecture.md), and imports only the core's base modules
(``errors``, ``fileio``, ``problem``, and ``estimators`` for the objectives' names).
"""
