"""A small slice of a shipped archive (some members, the first instances, every optimizer),
written as an archive of its own: a report of it is the archive's report in miniature, built
in seconds rather than the minute or two the whole archive takes."""

from __future__ import annotations

import gzip
import hashlib
import json
import shutil
from collections.abc import Sequence
from pathlib import Path

from vpid_bench.store.archive import JOBS, MANIFEST, OPTIMA, RECORDS, located

#: archive/vpid1's slice of the default test run: a full car (D = 9) and a quarter car
#: (D = 4), the first 5 of their 15 instances, all 19 optimizers (190 runs).
VPID1_SLICE = ("vpid1_f_bmw_iso_c", "vpid1_q_golden_iso_c")


def _entry(path: Path) -> dict[str, object]:
    data = path.read_bytes()
    return {"bytes": len(data), "sha256": hashlib.sha256(data).hexdigest()}


def slice_archive(source: Path, dest: Path, problems: Sequence[str] = VPID1_SLICE,
                  instances: int = 5) -> Path:
    """Write into ``dest`` the archive ``source`` cut to ``problems`` and their first
    ``instances`` instances (records, their optima, the problems' job files), with a manifest
    of the new files' SHA-256; returns ``dest``."""
    manifest = json.loads((source / MANIFEST).read_text(encoding="utf-8"))
    dest.mkdir(parents=True)
    names = [p.encode() for p in problems]
    ids: set[tuple[str, str]] = set()
    with gzip.open(located(source, RECORDS), "rb") as fh, \
            gzip.open(dest / RECORDS, "wb") as out:
        for line in fh:
            if not any(n in line for n in names):  # most lines: no JSON parsed
                continue
            rec = json.loads(line)
            if rec["problem"]["name"] in problems and rec["instance"]["index"] < instances:
                ids.add((rec["problem"]["name"], rec["instance"]["id"]))
                out.write(line)
    with open(source / OPTIMA, encoding="utf-8") as fh, \
            open(dest / OPTIMA, "w", encoding="utf-8") as out:
        for line in fh:
            opt = json.loads(line)
            if (opt["problem"], opt["instance"]) in ids:
                out.write(line)
    files = {RECORDS: _entry(dest / RECORDS), OPTIMA: _entry(dest / OPTIMA)}
    for p in problems:
        for f in sorted((source / JOBS / p).glob("*.json")):
            target = dest / JOBS / p / f.name
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(f, target)
            files[f"{JOBS}/{p}/{f.name}"] = _entry(target)
    manifest.update(files=files, problems=list(problems))
    (dest / MANIFEST).write_text(json.dumps(manifest, indent=1), encoding="utf-8")
    return dest
