"""The one reader of a user's CSV record (``vpid_bench.CsvTable``, issue 45: one home per file
format): a unit table given as data converts, without one a stated unit must be the
column's own; the strict column rule; and no plugin reads a record's CSV of its own."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from vpid_bench import ColumnMap, ConfigError, CsvTable, RecordColumn

ROOT = Path(__file__).parents[2]
UNITS = {"s": ("time", 1.0), "ms": ("time", 1e-3), "m": ("length", 1.0),
         "mm": ("length", 1e-3)}


def _write(path: Path, header: str, rows: int = 20) -> Path:
    path.write_text(header + "\n" + "".join(f"{0.5 * k!r},{float(np.sin(k)) + 2!r},"
                                            f"{float(np.cos(k))!r}\n" for k in range(rows)))
    return path


def test_a_unit_table_given_as_data_converts_each_column(tmp_path):
    """``t [ms]`` and ``x [mm]`` read in s and m: the values times the table's factors."""
    path = _write(tmp_path / "r.csv", "t [ms],x [mm],u")
    table = CsvTable(path, [RecordColumn("x", "m")], [RecordColumn("u")], units=UNITS)
    t, x, u = table.read(table.required, [table.find(RecordColumn("u"))])
    k = np.arange(20)
    np.testing.assert_allclose(t, 0.5e-3 * k, rtol=1e-15)
    np.testing.assert_allclose(x[0], 1e-3 * (np.sin(k) + 2), rtol=1e-15)
    np.testing.assert_allclose(u[:, 0], np.cos(k), rtol=1e-15)


def test_without_a_table_a_stated_unit_must_be_the_columns_own(tmp_path):
    path = _write(tmp_path / "r.csv", "t [s],x [mm],u")
    with pytest.raises(ConfigError, match=r"column x in its unit \[m\] or without a unit "
                       r"\(found \[mm\]\)"):
        CsvTable(path, [RecordColumn("x", "m")], [RecordColumn("u")])
    table = CsvTable(path, [RecordColumn("x", "mm")], [RecordColumn("u")])
    assert table.required[0].factor == 1.0


def test_a_mapped_column_its_unit_and_the_strict_rule(tmp_path):
    """A mapping names the column and may give its unit; an unused column is refused naming
    it and the names allowed, unless ignored; a time column named ``time`` is ``t``."""
    path = _write(tmp_path / "r.csv", "time,pos,temperature")
    table = CsvTable(path, [RecordColumn("x", "m")], mapping=ColumnMap({"x": "pos [mm]"}),
                     units=UNITS)
    assert (table.time.name, table.required[0].name) == ("time", "pos")
    assert table.required[0].factor == pytest.approx(1e-3)
    with pytest.raises(ConfigError, match=r"only the columns the problem uses, t, x; column "
                       r"'temperature' is not used"):
        table.read(table.required, [])
    ignored = CsvTable(path, [RecordColumn("x", "m")],
                       mapping=ColumnMap({"x": "pos"}, ("temperature",)))
    assert ignored.read(ignored.required, [])[1].shape == (1, 20)


def test_a_value_beyond_the_limit_says_si_only_when_a_table_converts(tmp_path):
    path = tmp_path / "r.csv"
    path.write_text("t,x [mm]\n" + "".join(f"{k},{1e300 if k == 3 else 1}\n"
                                           for k in range(20)))
    with pytest.raises(ConfigError, match=r"at most 1e\+100 in SI units; row 5 column x is "
                       r"1e\+300 \(x 0.001 in SI units\)"):
        table = CsvTable(path, [RecordColumn("x", "m")], units=UNITS)
        table.read(table.required, [])
    table = CsvTable(path, [RecordColumn("x", "mm")])
    with pytest.raises(ConfigError, match=r"at most 1e\+100; row 5 column x is 1e\+300$"):
        table.read(table.required, [])


def test_no_plugin_reads_a_record_csv_of_its_own():
    """The plugins' record readers go through CsvTable: none parses CSV rows itself (the
    paper's shipped table, read with DictReader, is data of the plugin, not a record)."""
    hits = [f"{p.relative_to(ROOT)}" for p in (ROOT / "plugins").rglob("*.py")
            if re.search(r"\bcsv\.reader\(|_HEADER = re\.compile|float\(row\[",
                         p.read_text(encoding="utf-8"))]
    assert hits == []
    assert "csv.reader(" in (ROOT / "vpid_bench/store/record_csv.py").read_text()  # control
