"""An FMU is code from somewhere else (problem=fmu): one that crashes or hangs costs its runs,
not the sweep; one without a binary for this platform, of another FMI version, whose binary
refuses its description's GUID, or whose zip reaches outside its folder is one ``error:``
line."""

from __future__ import annotations

import json
import time
import zipfile
from pathlib import Path

import pytest
from hostile_helpers import CLI, error_lines, main_in_process, run_cli

pytest.importorskip("fmpy")

from vpid_fmu import example  # noqa: E402
from vpid_fmu.problem import FmuConfig, FmuProblem  # noqa: E402

from vpid_bench import ConfigError  # noqa: E402
from vpid_bench.params import build_dataclass  # noqa: E402

TRUTH = {"ms": 280.0, "mu": 33.0, "ks": 17000.0, "cs": 1300.0}


@pytest.fixture(scope="module")
def record(example_fmu, tmp_path_factory):
    out = tmp_path_factory.mktemp("fmu-record") / "record.csv"
    return example.write_record(example_fmu("fmi2"), out, TRUTH, duration=1.0)


def _config(fmu, record, **keys) -> FmuConfig:
    return build_dataclass(FmuConfig, {"fmu": str(fmu), "reference": {"file": str(record)},
                                       **keys}, "problem")


def _rezip(src: Path, out: Path, edit=None, extra=()) -> Path:
    """A copy of the FMU ``src`` with ``edit(name, data) -> (name, data) | None`` applied to
    each member and ``extra`` ``(ZipInfo or name, data)`` members added."""
    with zipfile.ZipFile(src) as z, zipfile.ZipFile(out, "w") as o:
        for info in z.infolist():
            got = (info.filename, z.read(info))
            got = edit(*got) if edit else got
            if got is not None:
                o.writestr(got[0], got[1])
        for info, data in extra:
            o.writestr(info, data)
    return out


def test_an_fmu_without_a_binary_for_this_platform_is_one_error_line(example_fmu, record,
                                                                     in_tmp, capsys):
    code, err = main_in_process(["problem=fmu", f"problem.fmu={example_fmu('nobinary')}",
                                 f"problem.reference.file={record}", "optimizer=lsq"], capsys)
    lines = error_lines(err)
    assert code == 2 and len(lines) == 1, err
    assert "problem.fmu" in lines[0] and "binaries/linux64/quarter_car.so" in lines[0]
    assert "it has none" in lines[0]


def test_another_fmi_version_and_a_doctype_are_refused(example_fmu, record, tmp_path):
    def version(name, data):
        return (name, data.replace(b'fmiVersion="2.0"', b'fmiVersion="1.0"')
                if name == "modelDescription.xml" else data)

    old = _rezip(example_fmu("fmi2"), tmp_path / "v1.fmu", version)
    with pytest.raises(ConfigError, match="problem.fmu.*FMI 2.0 or 3.0|problem.fmu.*valid"):
        _config(old, record)

    def doctype(name, data):
        return (name, b'<?xml version="1.0"?>\n<!DOCTYPE x [<!ENTITY e SYSTEM '
                b'"file:///etc/passwd">]>\n' + data.split(b"\n", 1)[1]
                if name == "modelDescription.xml" else data)

    bad = _rezip(example_fmu("fmi2"), tmp_path / "dtd.fmu", doctype)
    with pytest.raises(ConfigError, match="without a document type"):
        _config(bad, record)


@pytest.mark.parametrize("name, why", [
    ("../evil.so", "'..' part"), ("/etc/evil", "absolute path"),
    ("binaries\\linux64\\x.so", "backslash"), ("a/\x01b", "control character")])
def test_a_member_name_outside_the_folder_is_refused(example_fmu, record, tmp_path, name, why):
    fmu = _rezip(example_fmu("fmi2"), tmp_path / "evil.fmu", extra=[(name, b"x")])
    with pytest.raises(ConfigError, match=why):
        _config(fmu, record)


def test_a_symbolic_link_member_is_refused(example_fmu, record, tmp_path):
    link = zipfile.ZipInfo("resources/link")
    link.external_attr = (0o120777 << 16)
    fmu = _rezip(example_fmu("fmi2"), tmp_path / "link.fmu", extra=[(link, b"/etc/passwd")])
    with pytest.raises(ConfigError, match="symbolic link"):
        _config(fmu, record)


def test_a_guid_mismatch_is_one_line_naming_it(example_fmu, record):
    """The binary checks the token at instantiation (in the worker, where the binary runs):
    a ConfigError naming the GUID."""
    problem = FmuProblem(_config(example_fmu("guid"), record))
    with pytest.raises(ConfigError, match="GUID mismatch"):
        problem.evaluate(problem.bounds.lower[None])


@pytest.mark.parametrize("keys, match", [
    ({"known": {"nope": 1.0}}, "problem.known.nope"),
    ({"known": {"kt": "stiff"}}, "problem.known.kt.*finite number"),
    ({"known": {"ms": 250.0}}, "problem.known.ms.*not identified"),
    ({"bounds": {"h": [1, 2]}}, "problem.bounds.h.*identified"),
    ({"bounds": {"ms": [3, 2]}}, "problem.bounds.ms.*lower < upper"),
    ({"parameters": ["ms", "zz"]}, "problem.parameters='zz'"),
    ({"parameters": ["kt"]}, "problem.bounds.kt.*no min and max"),
    ({"reference": {"columns": {"road": "h"}}}, "problem.reference.columns.road"),
    ({"inputs": "derivatives", "interface": "me"}, "problem.inputs"),
    ({"interface": "xx"}, "problem.interface.*auto, cs, me"),
])
def test_a_bad_key_is_one_error_naming_it(example_fmu, record, keys, match):
    keys = dict(keys)
    ref = {"file": str(record), **keys.pop("reference", {})}
    with pytest.raises(ConfigError, match=match):
        build_dataclass(FmuConfig, {"fmu": str(example_fmu("fmi2")), "reference": ref, **keys},
                        "problem")


def test_record_columns_are_strict(example_fmu, record, tmp_path):
    """The one CSV record reader's rules (vpid_bench.CsvTable), in its words: an input's
    column under another name, an unused column, an input without a column, a unit that is
    not the FMU's."""
    text = Path(record).read_text()
    renamed = tmp_path / "road.csv"
    renamed.write_text(text.replace("t,h,", "t,road,", 1))
    with pytest.raises(ConfigError, match=r"column h is missing; found columns t, road, .*"
                       r"problem.reference.columns=\{h:<column>\}"):
        _config(example_fmu("fmi2"), renamed)
    extra = tmp_path / "extra.csv"
    extra.write_text("\n".join(line + (",temperature" if k == 0 else ",21.5")
                                for k, line in enumerate(text.splitlines())))
    with pytest.raises(ConfigError, match="column 'temperature' is not used"):
        _config(example_fmu("fmi2"), extra)
    _config(example_fmu("fmi2"), extra, reference={"file": str(extra),
                                                   "ignore": ["temperature"]})
    mapped = _config(example_fmu("fmi2"), renamed, reference={"file": str(renamed),
                                                              "columns": {"h": "road"}})
    assert FmuProblem(mapped).record.columns["h"] == "road"
    dropped = tmp_path / "noinput.csv"
    dropped.write_text("\n".join(",".join(c for i, c in enumerate(line.split(",")) if i != 1)
                                 for line in text.splitlines()))
    with pytest.raises(ConfigError, match="column h is missing"):
        _config(example_fmu("fmi2"), dropped)
    unit = tmp_path / "unit.csv"
    unit.write_text(text.replace("zsdd", "zsdd [g]", 1))
    with pytest.raises(ConfigError, match=r"column zsdd in its unit \[m/s2\] or without a unit"):
        _config(example_fmu("fmi2"), unit)


@pytest.mark.slow
def test_a_crashing_and_a_hanging_fmu_cost_their_runs_not_the_sweep(example_fmu, record,
                                                                     tmp_path):
    """A segfault in the FMU's step and a step that never returns: each run is recorded
    failed with how (SIGSEGV; killed past run_timeout_s), the sweep ends with its summary."""
    t0 = time.monotonic()
    done = run_cli(["-m", "problem=fmu",
                    f"problem.fmu={example_fmu('crash')},{example_fmu('hang')}",
                    f"problem.reference.file={record}", "optimizer=lsq", "runs=2",
                    "run_timeout_s=2", "progress=false", "report=false",
                    "hydra.sweep.dir=sweep"], tmp_path, timeout=300)
    assert time.monotonic() - t0 < 200
    assert done.returncode == 1, done.stderr[-3000:]
    assert "sweep: 2 job(s)" in done.stderr and "Traceback" not in done.stderr
    for name, why in (("crash", "signal SIGSEGV"), ("hang", "run_timeout_s=2")):
        (job,) = (tmp_path / "sweep").glob(f"*{name}.fmu*")
        records = [json.loads(p.read_text()) for p in sorted(job.glob("records/run-*.json"))]
        assert [r["status"] for r in records] == ["failed", "failed"], name
        assert all(why in r["error"]["message"] for r in records), records[0]["error"]
    assert CLI  # the command is the subject: run as a user runs it


def test_members_over_the_size_limits_are_refused(example_fmu, record, monkeypatch):
    """The declared sizes are checked before anything is read (the limits made small here:
    the binary is some 16 KiB)."""
    from vpid_fmu import archive, problem

    problem._setup.cache_clear()  # a config checked before is not read again
    monkeypatch.setattr(problem, "_setup", problem._setup.__wrapped__)
    monkeypatch.setattr(archive, "MAX_MEMBER_BYTES", 1024)
    archive._inspect.cache_clear()
    with pytest.raises(ConfigError, match="members of at most"):
        _config(example_fmu("fmi2"), record)
    monkeypatch.setattr(archive, "MAX_MEMBER_BYTES", 512 * 1024**2)
    monkeypatch.setattr(archive, "MAX_TOTAL_BYTES", 2048)
    archive._inspect.cache_clear()
    with pytest.raises(ConfigError, match="unpacked"):
        _config(example_fmu("fmi2"), record)
    monkeypatch.setattr(archive, "MAX_MEMBERS", 2)
    archive._inspect.cache_clear()
    with pytest.raises(ConfigError, match="at most 2 members"):
        _config(example_fmu("fmi2"), record)
    archive._inspect.cache_clear()


# --- issue 44's hostile records (N12, N14, N15, N18) reach an FMU too: one reader (issue 45) --
def _cell(record: Path, out: Path, row: int, column: str, text: str | None = None,
          every: bool = False) -> Path:
    """A copy of ``record`` with data row ``row`` (0-based; every row with ``every``) of
    ``column`` written ``text``."""
    lines = Path(record).read_text().splitlines()
    j = lines[0].split(",").index(column)
    for k in range(1, len(lines)):
        if every or k == row + 1:
            cells = lines[k].split(",")
            cells[j] = text
            lines[k] = ",".join(cells)
    out.write_text("\n".join(lines) + "\n")
    return out


@pytest.mark.parametrize("text", ["1_000", "\uff11\uff12", "\u0661\u0662"],
                         ids=["underscore", "full-width", "arabic-indic"])
def test_n15_fmu_record_with_underscore_or_fullwidth_digits_refused(example_fmu, record,
                                                                    tmp_path, text):
    """``float`` reads ``1_000`` and full-width digits; an FMU's record cell must be ASCII
    digits, as a vehicle's (the FMU's own reader once used ``float`` alone)."""
    assert float(text) in (1000.0, 12.0)  # what float() alone would have accepted
    bad = _cell(record, tmp_path / "digits.csv", 3, "zsdd", text)
    with pytest.raises(ConfigError, match=r"a number in column zsdd of every row; row 5 has "
                       r"none \(ASCII digits"):
        _config(example_fmu("fmi2"), bad)


def test_n18_fmu_record_value_beyond_1e100_refused(example_fmu, record, tmp_path):
    """1e300 is finite, but its square (the channel's norm) is not: refused naming row and
    column, in the FMU's own units (no SI conversion is claimed)."""
    bad = _cell(record, tmp_path / "huge.csv", 50, "zudd", "1e300")
    with pytest.raises(ConfigError, match=r"values of magnitude at most 1e\+100; row 52 "
                       r"column zudd is 1e\+300$"):
        _config(example_fmu("fmi2"), bad)


def test_n12_fmu_record_sample_dominating_a_channel_refused(example_fmu, record, tmp_path):
    """A finite spike making up most of a compared output's sum of squares is named (the
    FMU's reader once weighted the channel by it)."""
    bad = _cell(record, tmp_path / "spike.csv", 80, "zsdd", "1e6")
    with pytest.raises(ConfigError, match=r"row 82 column zsdd \(1e\+06\) makes up 100 % of "
                       "its sum of squares"):
        _config(example_fmu("fmi2"), bad)


@pytest.mark.parametrize(("value", "word"), [("0", "zero"), ("1e-310", "denormal")])
def test_n14_fmu_record_output_zero_or_denormal_refused(example_fmu, record, tmp_path, value,
                                                        word):
    """A denormal output passed the FMU's reader (its norm was > 0, its weight was not
    finite); zero and denormal are named alike."""
    bad = _cell(record, tmp_path / "flat.csv", 0, "zudd", value, every=True)
    with pytest.raises(ConfigError, match=f"column zudd is {word} throughout"):
        _config(example_fmu("fmi2"), bad)


def test_n15_fmu_record_is_one_error_line_before_any_job(example_fmu, record, tmp_path, in_tmp,
                                                         capsys):
    """The command itself: exit 2, one ``error:`` line, no job folder."""
    bad = _cell(record, tmp_path / "digits.csv", 3, "h", "\uff11")
    code, err = main_in_process(["problem=fmu", f"problem.fmu={example_fmu('fmi2')}",
                                 f"problem.reference.file={bad}", "optimizer=lsq", "runs=1",
                                 "progress=false", "report=false"], capsys)
    assert code == 2 and err.count("\n") == 1 and err.startswith("error: "), err
    assert "a number in column h of every row; row 5 has none" in err
    assert not list(in_tmp.rglob("records"))
