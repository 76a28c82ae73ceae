"""Round five's report failures (issue 44), each named by its id: N16 (the built-in test
functions' first screen called them "a measured record" and reported profile-likelihood
failures on a clean run), N5 (links and images in records and plugin sections were real
ones), N6, N8 and N9 (a report folder is one report: planted links, two writers, SIGTERM and
a file-size limit once left it mixed, torn or missing)."""

from __future__ import annotations

import json
import os
import re
import resource
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest


@pytest.mark.parametrize("function", ["sphere", "rastrigin"])
def test_n16_test_functions_are_no_measured_record(function, tmp_path, registry):
    """A clean run of a test function whose minimiser has a zero coordinate (no truth is
    offered): no "measured record", no profile likelihood, no intervals and no fit diagnostics
    (there is no record to identify), and the first screen says why there is no truth."""
    from vpid_functions.plugin import FunctionsConfig

    from vpid_bench.experiment import run_from_config
    from vpid_bench.params import hydra_node
    from vpid_bench.report.build import build_report

    cfg = {"problem": hydra_node(FunctionsConfig, "functions") | {
               "function": function, "dim": 3, "iterations": 5, "ps": 8},
           "optimizer": {"name": "de1"}, "seed": 0, "runs": 3, "progress": False,
           "report": False}
    summary = run_from_config(cfg, tmp_path, registry=registry)
    recs = [json.loads(p.read_text()) for p in summary.record_paths]
    assert all(r["status"] == "ok" for r in recs)
    assert all(r["problem"]["info"]["fits_a_record"] is False for r in recs)
    assert all("intervals" not in r["result"] for r in recs)
    assert not (tmp_path / "profile.json").exists()
    assert not (tmp_path / "diagnostics.json").exists()
    build_report([tmp_path], tmp_path / "report", short=True)
    text = " ".join((tmp_path / "report" / "report.md").read_text().split())
    assert "measured record" not in text and "profile likelihood failed" not in text
    assert "No truth is offered by this problem (it fits no record)" in text
    assert "Fit diagnostics" not in text


def test_n16_a_record_fitting_problem_without_truth_keeps_its_wording():
    """The other side: a problem that fits a record (the default) keeps "a measured record"."""
    from vpid_bench.problem import Problem
    from vpid_bench.report.estimates import NO_TRUTH

    assert Problem.fits_a_record is True and "a measured record" in NO_TRUTH


def _report_synth():
    """tests/report/report_synth.py (synthetic records, the N5 sweep)."""
    sys.path.insert(0, str(Path(__file__).parents[1] / "report"))
    import report_synth

    return report_synth


#: An attribute that would make a browser load something from another host.
REMOTE = re.compile(r"""(?:href|src)\s*=\s*["']?\s*(?:[a-z][a-z0-9+.-]*:)?//""", re.IGNORECASE)


@pytest.mark.parametrize("short", [True, False])
def test_n5_links_and_images_in_records_and_plugin_sections_are_text(tmp_path, short):
    """A failed run's error message, an optimizer's name and a plugin's section (title, text,
    table, headline column) holding an image, a link, an autolink, a bare URL, a ``www.``
    address, a reference-style link and raw HTML: report.md, rendered as GitHub would (raw
    HTML allowed), and every HTML page hold no link or image to anything but the report's own
    files; the text is shown, as text; the section's emphasis and the report's own figures
    and links stay."""
    from markdown_it import MarkdownIt

    out = _report_synth().links_sweep(tmp_path / "s", short=short)
    md = (out / "report.md").read_text(encoding="utf-8")
    rendered = MarkdownIt("commonmark", {"html": True}).enable("table").render(md)
    assert not REMOTE.search(rendered), REMOTE.search(rendered)
    # no bare URL or www. address a renderer would make a link of (their ':' and '.' escaped)
    assert not re.search(r"(?i)(?:https?|ftp)://|www\.n5|mailto:", md)
    text_md = " ".join(rendered.split())
    for shown in ("n5-image.png", "n5-link", "n5-autolink", "n5-bare", "www.n5.invalid",
                  "n5-html.png", "[n5 ref][r]", "n5-title", "n5-name.png"):
        assert shown in text_md, shown  # shown, as text
    pages = sorted(out.glob("*.html"))
    assert len(pages) >= 4
    for page in pages:
        html = page.read_text(encoding="utf-8")
        assert not REMOTE.search(html), (page.name, REMOTE.search(html))
    problem = (out / "problem-vehicle.html").read_text(encoding="utf-8")
    assert "http://127.0.0.1:9/n5-image.png" in problem and "<em>kept</em>" in problem
    assert "http://127.0.0.1:9/n5-ref" in (out / "protocol.html").read_text(encoding="utf-8")
    if not short:  # the report's own images are still images
        assert re.search(r'<img[^>]+src="figures/[^"]+\.png"', problem)
        assert re.search(r"!\[[^\]]*\]\(figures/\S+\.png\)", md)


def test_n5_only_the_reports_own_files_are_links():
    """The rule the HTML renderer and the link check apply (:func:`.safe.local_link`), and
    the Markdown parser of the pages refusing anything else even when given a real link."""
    from vpid_bench.report.safe import local_link
    from vpid_bench.report.site import markdown_html

    for url in ("figures/a.png", "tables/t.csv", "problem-x.html#c-1", "report.md"):
        assert local_link(url), url
    for url in ("https://x", "http://x", "//x/y.png", "data:image/png;base64,AA", "file:///e",
                "/etc/passwd", "javascript:alert(1)", "../x.png", "a\\b", " HTTPS://x", ""):
        assert not local_link(url), url
    html = str(markdown_html("[a](https://x/a) ![b](http://x/b.png) ![c](figures/c.png) "
                             "[d](tables/d.csv)"))
    assert 'src="figures/c.png"' in html and 'href="tables/d.csv"' in html
    assert not REMOTE.search(html) and "https://x/a" in html


# --- N6, N8, N9: a report folder is one report ----------------------------------------------

#: A report's build time, to the minute (report.md, the pages): not part of what it says.
_STAMP = re.compile(rb"\d{4}-\d{2}-\d{2} \d{2}:\d{2} UTC")


def _sweep(root: Path, algos: tuple[str, ...]) -> Path:
    """Synthetic ``vehicle`` runs of ``algos`` (4 each): each set of optimizers makes a report
    with pages of its own names."""
    synth = _report_synth()
    for k, algo in enumerate(algos):
        recs = [synth.record(problem="vehicle", optimizer=algo, ps=20, run_index=i,
                             x=synth.OV * (1 + 0.01 * (k + 1) * (i - 1.5)),
                             f=0.01 * (k + 1) * (i + 1), names=synth.PAPER_NAMES,
                             true=synth.OV, units=["kg"] * 9)
                for i in range(4)]
        synth.write_job(root / f"job-{algo}", recs)
    return root


def _files(folder: Path) -> dict[str, bytes]:
    """Every file below ``folder`` (links as ``-> target``), its build time blanked."""
    out = {}
    for p in sorted(folder.rglob("*")):
        rel = p.relative_to(folder).as_posix()
        if p.is_symlink():
            out[rel] = b"-> " + os.fsencode(os.readlink(p))
        elif p.is_file():
            out[rel] = _STAMP.sub(b"<built>", p.read_bytes())
    return out


def _leftovers(out: Path) -> list[str]:
    """Hidden folders a report left beside ``out`` (its new or old copy)."""
    return sorted(p.name for p in out.parent.glob(f".{out.name}.*"))


def _report(paths, out: Path, short: bool = True, **kwargs):
    from vpid_bench.report.build import build_report

    return build_report([*paths], out, short=short, archive=False, **kwargs)


@pytest.fixture(scope="module")
def two_sweeps(tmp_path_factory) -> tuple[Path, Path]:
    root = tmp_path_factory.mktemp("n8")
    return _sweep(root / "a", ("alpha", "beta")), _sweep(root / "b", ("gamma", "delta", "eps"))


def test_n8_a_new_report_replaces_the_old_folder_whole(two_sweeps, tmp_path):
    """Stale pages of an earlier report were never removed: a report of other optimizers
    left their pages beside the new ones. Now the folder is the new report and nothing else,
    the same as the report written into an empty folder."""
    a, b = two_sweeps
    out = tmp_path / "report"
    _report([a], out)
    assert (out / "optimizer-alpha.html").is_file()
    _report([b], out)
    _report([b], tmp_path / "fresh")
    assert _files(out) == _files(tmp_path / "fresh")
    assert not (out / "optimizer-alpha.html").exists() and _leftovers(out) == []


@pytest.mark.parametrize("exchange", [True, False], ids=["renameat2", "two-renames"])
def test_n8_a_report_that_fails_mid_build_leaves_the_old_one_whole(two_sweeps, tmp_path,
                                                                   monkeypatch, exchange):
    """The build fails after runs.csv and a few tables are written (the third CSV): the old
    report is there, byte for byte, and no hidden copy is left beside it; the same where the
    one-step exchange of two folders is not available (two renames, signals held back)."""
    from vpid_bench import fileio
    from vpid_bench.store import csv_table

    a, b = two_sweeps
    out = tmp_path / "report"
    _report([a], out)
    before = _files(out)
    if not exchange:
        monkeypatch.setattr(fileio, "_exchange", lambda *_: False)
    real, calls = csv_table.write_csv, []

    def failing(path, *args, **kwargs):
        calls.append(path)
        if len(calls) == 3:
            raise RuntimeError("mid-build failure")
        return real(path, *args, **kwargs)

    monkeypatch.setattr(csv_table, "write_csv", failing)
    with pytest.raises(RuntimeError, match="mid-build"):
        _report([b], out)
    assert len(calls) == 3 and _files(out) == before and _leftovers(out) == []
    monkeypatch.setattr(csv_table, "write_csv", real)
    _report([b], out)  # and the swap itself, either way
    assert (out / "optimizer-gamma.html").is_file() and not (out / "optimizer-alpha.html").exists()
    assert _leftovers(out) == []


def _report_process(sweep: Path, out: Path, *extra: str) -> subprocess.Popen:
    from hostile_helpers import REPORT_CLI, cli_env

    return subprocess.Popen([*REPORT_CLI, str(sweep), "-o", str(out), "--no-archive", *extra],
                            env=cli_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)


def test_n8_a_report_stopped_by_sigterm_leaves_the_old_one_whole(two_sweeps, tmp_path):
    """SIGTERM while the new report is being written (runs.csv and tables written, figures
    being drawn) over an older one: the old report is there, byte for byte; one line, status
    143, and no hidden copy left. It once left the new runs.csv beside the old pages."""
    from extras import limit

    a, b = two_sweeps
    out = tmp_path / "report"
    _report([a], out, short=False)
    before = _files(out)
    proc = _report_process(b, out)
    deadline = time.monotonic() + limit(120)
    try:
        while time.monotonic() < deadline and proc.poll() is None:
            started = [p for p in tmp_path.glob(".report.new-*") if (p / "runs.csv").exists()]
            if started or (out / "runs.csv").read_bytes() != before["runs.csv"]:
                break
            time.sleep(0.01)
        assert proc.poll() is None, "the report ended before it could be stopped"
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=limit(60))
    finally:
        proc.kill()
    assert proc.returncode == 128 + signal.SIGTERM, err
    assert _without_progress(err) == [
        "interrupted: no report written (its folder keeps the previous one, if any); run the "
        "same command again"]
    assert _files(out) == before and _leftovers(out) == []


@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")  # expected
def test_n8_a_sigterm_a_fork_callback_swallowed_still_ends_the_report(two_sweeps, tmp_path):
    """The command's SIGTERM landing in a fork's callback (logging's lock release, while the
    figures are drawn in forked processes) raises there, and Python only prints "Exception
    ignored": the report once went on and exited 0. Here the signal is sent from that very
    callback: the build ends with ``KeyboardInterrupt`` and the old report is whole."""
    import psutil
    from extras import every_core

    from vpid_bench import interrupts
    from vpid_bench.report.build import build_report

    if (os.cpu_count() or 1) < 2:
        pytest.skip("the report forks its figures only on two cores or more")
    a, b = two_sweeps
    out = tmp_path / "report"
    _report([a], out, short=True)
    before = _files(out)
    armed = {"on": False}
    children = {c.pid for c in psutil.Process().children()}

    def kill_in_callback() -> None:
        if armed.pop("on", False):
            os.kill(os.getpid(), signal.SIGTERM)

    os.register_at_fork(after_in_parent=kill_in_callback)
    saved = {sig: signal.getsignal(sig) for sig in interrupts.SIGNALS}
    watch = (interrupts._Watch.installed, interrupts._Watch.signalled, interrupts._Watch.signum)
    try:
        interrupts.install()
        armed["on"] = True
        with pytest.raises(KeyboardInterrupt), every_core():  # the figures forked on 2+ cores
            build_report([b], out, short=False, archive=False)
        assert interrupts.exit_status() == 128 + signal.SIGTERM
    finally:
        armed.clear()
        for sig, handler in saved.items():
            signal.signal(sig, handler)
        (interrupts._Watch.installed, interrupts._Watch.signalled,
         interrupts._Watch.signum) = watch
    assert _files(out) == before and _leftovers(out) == []
    assert not {c.pid for c in psutil.Process().children()} - children  # none left behind


def test_n8_two_reports_written_at_once_leave_one_whole(two_sweeps, tmp_path):
    """Two ``vpid-bench-report`` commands writing into one folder at once (over an older
    report): the folder is then one of the two reports, whole (as each alone writes it),
    never pages of one beside runs.csv of the other."""
    from extras import limit

    a, b = two_sweeps
    out = tmp_path / "report"
    alone = {}
    for sweep in (a, b):
        _report([sweep], tmp_path / f"alone-{sweep.name}")
        alone[sweep] = _files(tmp_path / f"alone-{sweep.name}")
    assert alone[a] != alone[b]
    _report([a.parent], out)  # an older report, of both sweeps
    procs = [_report_process(sweep, out, "--short") for sweep in (a, b)]
    for proc in procs:
        _, err = proc.communicate(timeout=limit(300))
        assert proc.returncode == 0, err
    assert _files(out) in (alone[a], alone[b])
    assert _leftovers(out) == []


def test_n8_the_folder_swap_keeps_the_old_folder_until_the_new_one_is_whole(tmp_path):
    """:class:`WholeFolder` alone: an exception in the block leaves the old folder; the new
    folder is a real one with the usual permissions (not mkdtemp's 0700), where a planted
    link stood."""
    from vpid_bench.fileio import WholeFolder

    out = tmp_path / "out"
    out.mkdir()
    (out / "old.txt").write_text("old")
    with pytest.raises(ValueError), WholeFolder(out) as new:
        (new / "new.txt").write_text("new")
        raise ValueError("stop")
    assert os.listdir(out) == ["old.txt"] and _leftovers(out) == []
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    out.rename(tmp_path / "was")
    out.symlink_to(elsewhere, target_is_directory=True)
    whole = WholeFolder(out)
    with whole as new:
        (new / "new.txt").write_text("new")
    assert not out.is_symlink() and os.listdir(out) == ["new.txt"]
    assert os.listdir(elsewhere) == [] and whole.links == [out]
    mask = os.umask(0)
    os.umask(mask)
    assert out.stat().st_mode & 0o777 == 0o777 & ~mask


def test_n8_a_mount_point_is_swapped_entry_by_entry(two_sweeps, tmp_path, monkeypatch):
    """A folder that is a mount point cannot be renamed: its entries are swapped (the new
    ones built in a hidden folder inside it), a failed build leaves them as they were, and
    nothing hidden is left in it."""
    from vpid_bench.store import csv_table

    a, b = two_sweeps
    out = tmp_path / "mnt"
    out.mkdir()
    real_ismount = os.path.ismount
    monkeypatch.setattr(os.path, "ismount", lambda p: Path(p) == out or real_ismount(p))
    _report([a], out)
    before = _files(out)
    _report([a], tmp_path / "fresh")
    assert before == _files(tmp_path / "fresh")
    monkeypatch.setattr(csv_table, "write_csv", lambda *_: 1 / 0)
    with pytest.raises(ZeroDivisionError):
        _report([b], out)
    assert _files(out) == before
    monkeypatch.undo()
    monkeypatch.setattr(os.path, "ismount", lambda p: Path(p) == out or real_ismount(p))
    _report([b], out)
    _report([b], tmp_path / "fresh-b")
    assert _files(out) == _files(tmp_path / "fresh-b")
    assert [p.name for p in out.iterdir() if p.name.startswith(".")] == []


def _plant_links(out: Path, outside: Path) -> None:
    """Links where a report writes: report.md to a file outside, tables/ to a folder outside,
    and a figure to a file outside."""
    outside.mkdir()
    (outside / "secret.txt").write_text("secret\n")
    (out / "report.md").unlink()
    (out / "report.md").symlink_to(outside / "secret.txt")
    shutil.rmtree(out / "tables")
    (out / "tables").symlink_to(outside, target_is_directory=True)
    (out / "figures").mkdir(exist_ok=True)
    (out / "figures" / "convergence.png").unlink(missing_ok=True)
    (out / "figures" / "convergence.png").symlink_to(outside / "secret.txt")


def test_n6_links_planted_in_a_report_folder_are_one_warning_line(two_sweeps, tmp_path):
    """``vpid-bench-report`` over a report folder with links planted where it writes: once a
    20-line UnsafePathError traceback and no report. Now the report is written, one
    ``warning:`` line names the links, and what they point to is untouched."""
    from hostile_helpers import run_cli

    a, b = two_sweeps
    out, outside = tmp_path / "report", tmp_path / "outside"
    _report([a], out)
    _plant_links(out, outside)
    done = run_cli([str(b), "-o", str(out), "--no-archive", "--short"], tmp_path, report=True)
    assert done.returncode == 0, done.stderr
    assert "Traceback" not in done.stderr
    (line,) = [x for x in done.stderr.splitlines() if x.startswith(("warning:", "error:"))]
    assert line.startswith(f"warning: {out} held 3 symbolic link(s)")
    assert str(out / "report.md") in line and str(out / "tables") in line
    assert sorted(os.listdir(outside)) == ["secret.txt"]
    assert (outside / "secret.txt").read_text() == "secret\n"
    assert not any(p.is_symlink() for p in out.rglob("*"))
    assert (out / "report.md").is_file() and (out / "optimizer-gamma.html").is_file()


def test_n6_a_sweep_with_links_planted_in_its_report_folder_still_writes_its_report(
        two_sweeps, tmp_path, capsys):
    """In a sweep one planted link meant no report at all ("report: not written ...
    UnsafePathError"). Now the sweep's report is written, its status ok, one warning line."""
    from vpid_bench.shell.callbacks import write_report

    a, _ = two_sweeps
    sweep = tmp_path / "sweep"
    shutil.copytree(a, sweep)
    _report([sweep], sweep / "report")
    _plant_links(sweep / "report", tmp_path / "outside")
    capsys.readouterr()
    assert write_report(sweep, short=True, archive=False) is True
    err = capsys.readouterr().err
    assert [x for x in err.splitlines() if x.startswith("warning:")] == [
        x for x in err.splitlines() if "symbolic link" in x]
    assert err.count("symbolic link") == 1 and str(sweep / "report" / "tables") in err
    assert (tmp_path / "outside" / "secret.txt").read_text() == "secret\n"
    status = json.loads((sweep / "report" / "status.json").read_text())
    assert status["status"] == "ok" and (sweep / "report" / "report.md").is_file()


def test_n6_n8_a_folder_that_is_no_report_is_refused_in_one_line(two_sweeps, tmp_path):
    """A report replaces its folder whole, so ``-o`` naming a folder that holds other files
    (a planted link among them), or the records read, is refused: one ``error:`` line naming
    what is in the way, status 2, nothing touched."""
    from hostile_helpers import error_lines, run_cli

    a, _ = two_sweeps
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("mine\n")
    (mine / "evil").symlink_to(tmp_path)
    for out, named in ((mine, "evil, notes.txt"), (a, str(a)), (a.parent, str(a))):
        done = run_cli([str(a), "-o", str(out), "--no-archive", "--short"], tmp_path,
                       report=True)
        assert done.returncode == 2, done.stderr
        (line,) = error_lines(done.stderr)
        assert line.startswith(f"error: -o {out} is not allowed") and named in line, line
        assert "Traceback" not in done.stderr
    assert sorted(os.listdir(mine)) == ["evil", "notes.txt"]


def _limited(lim: int) -> Callable[[], None]:
    """A ``preexec_fn``: files of at most ``lim`` bytes, and SIGXFSZ ignored so that a write
    past it fails with EFBIG instead of killing the process."""

    def apply() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (lim, lim))

    return apply


def _without_progress(stderr: str) -> list[str]:
    """``stderr``'s lines but the progress lines of the report's stages (``report: figures
    3/69, 12 s elapsed``, vpid_bench/progress.py)."""
    return [x for x in stderr.strip().splitlines()
            if not (x.startswith("report: ") and x.endswith(" elapsed"))]


#: Files of at most 40 kB: the records are read, runs.csv, the tables and pages fit, the PNG
#: figures do not (the report once exited 0 without them, torn ones left, saying nothing).
FSIZE = 40_000


def test_n9_a_report_under_a_file_size_limit_fails_loudly_and_keeps_the_old_one(
        two_sweeps, tmp_path):
    from extras import limit
    from hostile_helpers import REPORT_CLI, cli_env, error_lines

    a, b = two_sweeps
    out = tmp_path / "report"
    _report([a], out, short=False)
    before = _files(out)
    done = subprocess.run([*REPORT_CLI, str(b), "-o", str(out), "--no-archive"],
                          env=cli_env(), capture_output=True, text=True, timeout=limit(300),
                          preexec_fn=_limited(FSIZE), check=False)
    assert done.returncode == 1, done.stderr
    assert error_lines(done.stderr) == [
        f"error: the report could not be written into {out} (File too large); it keeps the "
        "previous report, if any"], done.stderr
    assert "Traceback" not in done.stderr and "report:" not in done.stdout
    assert _files(out) == before and _leftovers(out) == []


def test_n9_a_sweeps_report_under_a_file_size_limit_is_a_warning_and_no_torn_report(
        two_sweeps, tmp_path):
    """A sweep's report under the limit once left a torn report.md: now one ``warning:``
    line, the previous report whole, and the failure in report/status.json."""
    from extras import limit
    from hostile_helpers import cli_env

    a, _ = two_sweeps
    sweep = tmp_path / "sweep"
    shutil.copytree(a, sweep)
    _report([sweep], sweep / "report", short=False)
    before = _files(sweep / "report")
    code = ("import sys; from pathlib import Path; from vpid_bench.shell.callbacks import "
            "write_report; sys.exit(0 if write_report(Path(sys.argv[1]), short=False, "
            "archive=False) else 3)")
    done = subprocess.run([sys.executable, "-c", code, str(sweep)], env=cli_env(),
                          capture_output=True, text=True, timeout=limit(300),
                          preexec_fn=_limited(FSIZE), check=False)
    assert done.returncode == 3, done.stderr
    (line,) = [x for x in _without_progress(done.stderr) if "report" in x]
    assert line.startswith(f"warning: the report was not written for {sweep}")
    assert "File too large" in line and "Traceback" not in done.stderr
    status = json.loads((sweep / "report" / "status.json").read_text())
    assert status["status"] == "failed" and "File too large" in status["problems"][0]
    del status
    after = _files(sweep / "report")
    assert after.pop("status.json") and after == before
    assert _leftovers(sweep / "report") == []
