"""The shell: the only room of vpid-bench that knows Hydra.

* :mod:`.main`: the ``vpid-bench`` command (parse, pre-flight, hand over to Hydra, exit code);
* :mod:`.argv`: our reading of the command line (Hydra's flags and ours);
* :mod:`.preflight`: composes every point of a sweep and checks it before any job runs;
* :mod:`.compose`: Hydra's compose API for the pre-flight, each distinct point composed once;
* :mod:`.config_store`: Hydra config nodes built from the job spec and the plugins' dataclasses;
* :mod:`.callbacks`: Hydra callbacks that write their outcome to disk (sweep folder, report);
* :mod:`.resume`: finding an earlier sweep, the sweep lock, the jobs' statuses.
"""
