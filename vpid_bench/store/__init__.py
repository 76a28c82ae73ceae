"""The store: one module per file format that more than one room reads, each holding its
schema string, its size caps, its reader and its checks (:mod:`.optimum`: the instance-optimum
file; :mod:`.archive`: an archive folder's manifest, checked files and optima).

It sits below ``analysis/``, ``targets.py`` and ``report/`` (docs/architecture.md): it
imports only the core's base modules (``errors``, ``fileio``, ``problem``, ``records``).
"""
