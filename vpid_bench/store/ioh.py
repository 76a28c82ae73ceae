"""The runs' best-so-far traces in IOHprofiler's data format, for IOHanalyzer and iohinspector
(the layout and what each file holds: docs/report.md, the IOHprofiler export).

``ioh/<context>/<optimizer>/IOHprofiler_f<id>_<problem>.json`` (the meta-data the ``ioh``
package's Analyzer logger writes since 0.3.3) and ``data_f<id>_<problem>/
IOHprofiler_f<id>_DIM<d>.dat``, below the report's ``ioh/`` or in an archive's ``ioh.zip``
(:func:`write_zip`). No record text is put where a reader evaluates it.
"""

from __future__ import annotations

import json
import math
import tempfile
import zipfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from .paths import inside, slug

#: IOHprofiler's format version this export follows (the ``ioh`` package's JSON meta-data).
FORMAT_VERSION = "0.3.22"
#: The export's folder in a report (and in an archive's zip).
FOLDER = "ioh"
#: IOHprofiler's instance numbers are 16-bit.
MAX_INSTANCE = 65535


def _num(v: float) -> str:
    return f"{v:.10e}"


def run_lines(evaluations: Sequence[float], best: Sequence[float | None], used: float,
              offset: float) -> tuple[list[str], tuple[int, float] | None]:
    """The ``.dat`` block of one run and its (evaluation, value) of the best."""
    lines = ["evaluations raw_y"]
    last_y, last_e, best_at = math.inf, 0, None
    for e, b in zip(evaluations, best, strict=True):
        if b is None or not math.isfinite(float(b)):
            continue
        y = float(b) - offset
        e = 1 if not lines[1:] else int(e)
        if y < last_y and e > last_e:
            lines.append(f"{e} {_num(y)}")
            last_y, last_e, best_at = y, e, (e, y)
        elif y < last_y:  # same evaluation count: keep the better value
            lines[-1] = f"{e} {_num(y)}"
            last_y, best_at = y, (e, y)
    if best_at is None:
        return [], None
    if int(used) > last_e:
        lines.append(f"{int(used)} {_num(last_y)}")
    return lines, best_at


def export_ioh(root: Path, records: Sequence[Mapping[str, Any]],
               rows: Sequence[Mapping[str, Any]], out_dir: Path) -> list[Path]:
    """Write the export of every successful run with a trace below ``root`` (inside
    ``out_dir``); returns the files written."""
    by_id = {r["run_id"]: r for r in records}
    contexts = sorted({r["context"] for r in rows})
    groups: dict[tuple[str, str], list[Mapping[str, Any]]] = {}
    for r in rows:
        if r["status"] == "ok":
            groups.setdefault((r["context"], r["algorithm"]), []).append(r)
    gap_ok = {c: all(math.isfinite(float(r.get("f_opt", math.nan)))
                     for r in rows if r["context"] == c and r["status"] == "ok")
              for c in contexts}
    written: list[Path] = []
    for (context, algorithm), g in sorted(groups.items()):
        fid = contexts.index(context) + 1
        problem = slug(g[0]["problem"])
        folder = inside(out_dir, root / slug(context) / slug(algorithm))
        dims: dict[int, list[dict[str, Any]]] = {}
        blocks: dict[int, list[str]] = {}
        for r in g:
            rec = by_id[r["run_id"]]
            trace = rec.get("trace") or {}
            ev, best = trace.get("evaluations") or [], trace.get("best") or []
            if not ev or len(ev) != len(best):
                continue
            offset = float(r["f_opt"]) if gap_ok[context] else 0.0
            used = float(r["evaluations"]) if math.isfinite(float(r["evaluations"])) \
                else float(ev[-1])
            lines, best_at = run_lines(ev, best, used, offset)
            if best_at is None:
                continue
            x = (rec.get("result") or {}).get("x_best") or []
            x = [float(v) for v in x] if all(
                isinstance(v, (int, float)) and math.isfinite(v) for v in x) else []
            d = len(x) or len((rec.get("parameters") or {}).get("names") or []) or 1
            inst = (rec.get("instance") or {}).get("index", r["run_index"])
            inst = inst if isinstance(inst, int) and 0 <= inst <= MAX_INSTANCE else 0
            dims.setdefault(d, []).append({"instance": inst, "evals": int(used), "best": {
                "evals": best_at[0], "y": best_at[1], "x": x}})
            blocks.setdefault(d, []).extend(lines)
        if not dims:
            continue
        data_dir = f"data_f{fid}_{problem}"
        scenarios = []
        for d in sorted(dims):
            rel = f"{data_dir}/IOHprofiler_f{fid}_DIM{d}.dat"
            dat = inside(out_dir, folder / rel)
            dat.parent.mkdir(parents=True, exist_ok=True)
            dat.write_text("\n".join(blocks[d]) + "\n", encoding="utf-8")
            written.append(dat)
            scenarios.append({"dimension": d, "path": rel, "runs": dims[d]})
        meta = {"version": FORMAT_VERSION, "suite": "vpid-bench", "function_id": fid,
                "function_name": problem, "maximization": False,
                "algorithm": {"name": str(algorithm), "info": str(context)},
                "attributes": ["evaluations", "raw_y"], "scenarios": scenarios}
        js = inside(out_dir, folder / f"IOHprofiler_f{fid}_{problem}.json")
        js.write_text(json.dumps(meta, indent=1, allow_nan=False) + "\n", encoding="utf-8")
        written.append(js)
    return written


def write_zip(path: Path, records: Sequence[Mapping[str, Any]],
              rows: Sequence[Mapping[str, Any]]) -> None:
    """The export of ``records`` zipped into ``path`` (an archive's ``ioh.zip``) with fixed
    dates, so a rebuild of the same records gives the same bytes."""
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        files = export_ioh(root / FOLDER, records, rows, root)
        with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as zf:
            for f in sorted(files):
                info = zipfile.ZipInfo(str(f.relative_to(root)), date_time=(2026, 1, 1, 0, 0, 0))
                info.compress_type = zipfile.ZIP_DEFLATED
                zf.writestr(info, f.read_bytes())
