"""The rooms of the house and what each may import (docs/architecture.md), checked on the
source: the core knows no problem, the shell is the only room that knows Hydra, the report
knows nothing of the shell, plugins use the public API only."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).parents[2]
CORE = ROOT / "vpid_bench"
PLUGINS = ROOT / "plugins"
CONF = ROOT / "conf"
#: What a plugin may import from vpid-bench: the one public import line.
PLUGIN_API = ("vpid_bench",)
#: The first-party plugin packages (each a folder of plugins/).
PLUGIN_PACKAGES = sorted(p.name for p in PLUGINS.iterdir() if p.is_dir()
                         and not p.name.startswith((".", "_")) and p.name != "__pycache__")


def _imports(path: Path) -> set[str]:
    """Every module a file imports (absolute, relative imports resolved)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    package = ".".join(path.relative_to(path.parents[len(path.relative_to(ROOT).parts) - 1])
                       .with_suffix("").parts[:-1])
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - node.level + 1]
                module = ".".join([*base, node.module] if node.module else base)
            else:
                module = node.module or ""
            out.add(module)
    return out


def _files(folder: Path) -> list[Path]:
    return sorted(p for p in folder.rglob("*.py") if "__pycache__" not in p.parts)


def test_the_core_names_no_problem_outside_the_hook_docs():
    """No word 'vehicle', 'paper' or 'NoRE' in vpid_bench/ but in the report hook's docstring
    (whole words: 'ignore' and 'NoRecordsError' are not meant)."""
    word = re.compile(r"\b(vehicles?|paper|nore)\b", re.IGNORECASE)
    hits = [f"{p.relative_to(ROOT)}:{i}" for p in CORE.rglob("*") if p.is_file()
            and p.suffix in (".py", ".yaml", ".csv") and "__pycache__" not in p.parts
            for i, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1)
            if word.search(line)]
    assert hits == ["vpid_bench/hookspecs.py:44"], hits


def test_the_import_reader_sees_relative_and_absolute_imports():
    """A control: the checks below would see a forbidden import."""
    seen = _imports(CORE / "shell" / "callbacks.py")
    assert "vpid_bench.report.build" in seen and "hydra.experimental.callback" in seen


def test_only_the_shell_imports_hydra():
    bad = [str(p.relative_to(ROOT)) for p in _files(CORE)
           if "shell" not in p.relative_to(CORE).parts
           and any(m == "hydra" or m.startswith("hydra.") for m in _imports(p))]
    assert bad == []


def test_the_report_imports_nothing_from_the_shell():
    bad = [str(p.relative_to(ROOT)) for p in _files(CORE / "report")
           if any(m.startswith("vpid_bench.shell") for m in _imports(p))]
    assert bad == []


@pytest.mark.parametrize("plugin", PLUGIN_PACKAGES)
def test_plugins_use_only_the_public_api(plugin):
    bad = {m for p in _files(PLUGINS / plugin) for m in _imports(p)
           if m.startswith("vpid_bench") and m not in PLUGIN_API}
    assert bad == set()


@pytest.mark.parametrize("plugin", PLUGIN_PACKAGES)
def test_plugins_import_no_other_plugin_package(plugin):
    """A helper two plugin packages need lives in the public API, or one plugin composes
    another's optimizer by name (``registered_optimizer``): no package imports another."""
    others = set(PLUGIN_PACKAGES) - {plugin}
    bad = {m for p in _files(PLUGINS / plugin) for m in _imports(p) if m.split(".")[0] in others}
    assert bad == set()


def _budget_formulas(path: Path) -> list[str]:
    """Code (not docstrings) of a file that adds 1 to something named ``iterations``."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    return [f"{path.relative_to(ROOT)}:{node.lineno}" for node in ast.walk(tree)
            if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Add)
            and "iterations" in ast.unparse(node.left) and ast.unparse(node.right) == "1"]


def test_no_plugin_computes_its_own_budget():
    """The job hands every optimizer its run's budget (``self.budget``); ``ps * (iterations
    + 1)`` is code once, in ``vpid_bench.problem.default_budget``."""
    assert _budget_formulas(CORE / "problem.py") != []  # the control: the one home is seen
    assert [h for p in _files(PLUGINS) for h in _budget_formulas(p)] == []
    core = [h for p in _files(CORE) for h in _budget_formulas(p)]
    assert {h.split(":")[0] for h in core} == {"vpid_bench/problem.py"}, core


def test_the_primary_config_names_no_paper():
    """The framework's primary config (shipped as ``vpid_bench.conf``) is generic: the paper
    lives in the vehicle plugin and its docs; the default selection is one line each."""
    word = re.compile(r"\b(paper|gokdag|gökdağ|nore)\b", re.IGNORECASE)
    hits = [f"config.yaml:{i}" for i, line in
            enumerate((CONF / "config.yaml").read_text(encoding="utf-8").splitlines(), 1)
            if word.search(line)]
    assert hits == []


def _module_name(path: Path) -> str:
    return ".".join(path.relative_to(ROOT).with_suffix("").parts).removesuffix(".__init__")


def _package_imports(path: Path, modules: set[str], anywhere: bool = False) -> set[str]:
    """The package modules a file imports: when it is imported (module body, not functions
    nor ``if TYPE_CHECKING``), or with ``anywhere`` also inside functions (a deferred import
    is still a dependency: two modules that import each other, even lazily, cannot be read
    or moved one without the other). ``from . import x`` counts submodule ``x``."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    me = _module_name(path)
    package = me if path.name == "__init__.py" else me.rpartition(".")[0]
    out = set()
    for node in ast.walk(tree) if anywhere else tree.body:
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names if a.name in modules)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                module = ".".join([*base, node.module] if node.module else base)
            else:
                module = node.module or ""
            for alias in node.names:
                if f"{module}.{alias.name}" in modules:
                    out.add(f"{module}.{alias.name}")
            if module in modules:
                out.add(module)
    # a parent package is always imported before its children: not an edge of the graph
    ancestors = {".".join(me.split(".")[:i]) for i in range(1, me.count(".") + 1)}
    return out - {me} - ancestors


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Every import circle of ``graph`` found by a depth-first search (each as a path that
    ends where it starts)."""
    state: dict[str, int] = {}
    cycles = []

    def visit(node: str, stack: list[str]) -> None:
        state[node] = 1
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                cycles.append(stack[stack.index(nxt):] + [nxt] if nxt in stack else [node, nxt])
            elif nxt not in state:
                visit(nxt, [*stack, nxt])
        state[node] = 2

    for module in sorted(graph):
        if module not in state:
            visit(module, [module])
    return cycles


def _graph(anywhere: bool) -> dict[str, set[str]]:
    files = _files(CORE)
    modules = {_module_name(p) for p in files}
    return {_module_name(p): _package_imports(p, modules, anywhere) for p in files}


def test_the_core_has_no_import_circle():
    """Import graph of vpid_bench/ (module bodies): no cycle, so every room can be read from
    the bottom up (the api facade imports the small modules, never the reverse)."""
    graph = _graph(anywhere=False)
    assert "vpid_bench.api" in graph["vpid_bench"]
    assert _cycles(graph) == []


def test_no_import_circle_even_through_deferred_imports():
    """The same with the imports inside functions counted: the report once held one
    (report.archive packed an archive with report.compute, which reads archives); making an
    archive now lives in report.pack, above both."""
    graph = _graph(anywhere=True)
    assert "vpid_bench.report.archive" in graph["vpid_bench.report.compute"]  # a lazy edge
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == [["a", "b", "c", "a"]]  # control
    assert _cycles(graph) == []


def test_no_complexity_exception_under_the_core():
    """ruff's complexity rules (C901, PLR0912, PLR0915) hold for every file of vpid_bench/."""
    pyproject = (ROOT / "pyproject.toml").read_text(encoding="utf-8")
    assert 'max-complexity = 15' in pyproject
    ignores = pyproject.split("[tool.ruff.lint.per-file-ignores]", 1)[1].split("\n[", 1)[0]
    assert not re.search(r'^"vpid_bench', ignores, re.M), ignores


def _importers_of(prefix: str, allowed: tuple[str, ...]) -> list[str]:
    """Files of vpid_bench/ outside the folders ``allowed`` that import a module starting
    with ``prefix`` (imports inside functions counted: :func:`_imports` walks the whole
    file)."""
    return [f"{p.relative_to(ROOT)} -> {m}" for p in _files(CORE)
            if p.relative_to(CORE).parts[0] not in allowed
            for m in sorted(_imports(p)) if m == prefix or m.startswith(prefix + ".")]


def test_nothing_but_the_report_and_the_shell_imports_the_report():
    """docs/architecture.md: the core never imports the report, not even inside a function
    (``targets.py`` once read archives through it; it reads them through ``store/`` now)."""
    assert _importers_of("vpid_bench.report", ("report", "shell")) == []
    control = [m for m in _imports(CORE / "shell" / "main.py") if m.startswith("vpid_bench.")]
    assert control  # the reader sees the shell's imports of the rooms below it


def test_nothing_but_the_shell_imports_the_shell():
    assert _importers_of("vpid_bench.shell", ("shell",)) == []


def test_the_store_sits_below_analysis_targets_and_the_report():
    """store/ (one module per file format) imports only the core's base modules, never a
    room that reads or writes through it (the job's side: assemble, job_analysis,
    experiment; the runner; the plugin registry)."""
    above = ("vpid_bench.analysis", "vpid_bench.report", "vpid_bench.shell",
             "vpid_bench.targets", "vpid_bench.experiment", "vpid_bench.build",
             "vpid_bench.spec", "vpid_bench.workers", "vpid_bench.job_runs",
             "vpid_bench.assemble", "vpid_bench.job_analysis", "vpid_bench.runner",
             "vpid_bench.plugins", "vpid_bench.worker_loop")
    facade = ("vpid_bench", "vpid_bench.api")  # they import the registry (the archive's
    # writer once took vpid-bench's version from the package: an arrow back up)
    bad = [f"{p.name} -> {m}" for p in _files(CORE / "store") for m in _imports(p)
           if m.startswith(above) or m in facade]
    assert bad == []


def test_one_schema_string_per_file_format():
    """Each format's schema string and file names are written once, in its module under
    store/ (the optimum file's was once in analysis/optimum.py and report/optima.py; the
    archive's writer and the IOHprofiler export once lived in report/)."""
    from vpid_bench.store import archive, ioh, job_checks, optimum, records

    for schema, home in ((optimum.SCHEMA, "store/optimum.py"),
                         (archive.SCHEMA, "store/archive.py"),
                         (records.SCHEMA, "store/records.py"),
                         (ioh.FORMAT_VERSION, "store/ioh.py"),
                         *((s, "store/job_checks.py") for s in (
                             job_checks.DIAGNOSTICS_SCHEMA, job_checks.PROFILE_SCHEMA,
                             job_checks.COMPARISONS_SCHEMA)),
                         *((name, "store/archive.py") for name in (
                             archive.MANIFEST, archive.RECORDS, archive.OPTIMA, archive.SUMMARY,
                             archive.IOH))):
        holders = [str(p.relative_to(CORE)) for p in _files(CORE)
                   if f'"{schema}"' in p.read_text(encoding="utf-8")]
        assert holders == [home], (schema, holders)


def test_the_store_names_the_job_files_the_rooms_write():
    from vpid_bench.analysis.estimator_floors import FILE as ESTIMATORS
    from vpid_bench.report.identifiability import FILE as IDENTIFIABILITY
    from vpid_bench.store.archive import JOB_FILES

    assert set(JOB_FILES) == {IDENTIFIABILITY, ESTIMATORS}


def test_the_report_is_served_by_name_only_through_the_plugin_api():
    """An import by name (``importlib.import_module(".report....")``) is a deferred import
    too: outside report/ and shell/ only the package's facade holds one (``vpid_bench``
    serves ``ReportContext``, ``Section``, ... to report-section plugins on first use, so
    that plugins keep their one import line)."""
    holders = []
    for p in _files(CORE):
        if p.relative_to(CORE).parts[0] in ("report", "shell"):
            continue
        for node in ast.walk(ast.parse(p.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Constant) and isinstance(node.value, str) and \
                    re.fullmatch(r"(vpid_bench)?\.report(\.\w+)*", node.value):
                holders.append(str(p.relative_to(CORE)))
    assert sorted(set(holders)) == ["__init__.py"]


def test_json_files_are_parsed_only_in_the_store():
    """One reader per file format: outside store/ (and fileio's safe parser) nothing in the
    core parses a JSON file of its own; the shell reads back only the report status it wrote."""
    parses = re.compile(r"\b(loads_json|json\.loads?)\(")
    bad = [str(p.relative_to(ROOT)) for p in _files(CORE)
           if p.relative_to(CORE).parts[0] not in ("store", "fileio.py")
           and parses.search(p.read_text(encoding="utf-8"))]
    assert bad == ["vpid_bench/shell/main.py"], bad


#: Modules that read or write a data format (compressed, archived, pickled): the store's.
FORMAT_MODULES = ("gzip", "zipfile", "tarfile", "pickle")
#: Calls that parse or write a JSON data file.
JSON_CALLS = ("json.dump", "json.dumps", "json.load", "json.loads", "loads_json")


def _format_io(path: Path) -> list[str]:
    """Where a file imports a data-format module or calls a JSON reader or writer."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    hits = [f"{path.name}:{n.lineno} imports {m}" for n in ast.walk(tree)
            for m in ([a.name for a in n.names] if isinstance(n, ast.Import) else
                      [n.module or ""] if isinstance(n, ast.ImportFrom) else [])
            if m.split(".")[0] in FORMAT_MODULES]
    hits += [f"{path.name}:{n.lineno} calls {ast.unparse(n.func)}" for n in ast.walk(tree)
             if isinstance(n, ast.Call) and ast.unparse(n.func) in JSON_CALLS]
    return hits


def test_the_report_reads_and_writes_data_formats_only_through_the_store():
    """report/ holds no reader or writer of a data format of its own (issue 45): an archive
    (records.jsonl.gz, optima, manifest, ioh.zip), the IOHprofiler export and every JSON file
    a job writes are read and written through ``vpid_bench.store``. The report's own output
    (report.md, the HTML pages, figures, its CSV and LaTeX tables) is not a data format."""
    assert _format_io(CORE / "store" / "archive_pack.py")  # the control: the check sees them
    assert [h for p in _files(CORE / "report") for h in _format_io(p)] == []


def test_every_name_of_the_plugin_api_resolves():
    """``from vpid_bench import <name>`` works for every name the package lists, the ones
    served on first use included (a module moved once left two of them pointing nowhere)."""
    import vpid_bench

    missing = []
    for name in vpid_bench.__all__:
        try:
            getattr(vpid_bench, name)
        except (AttributeError, ImportError) as exc:
            missing.append(f"{name}: {exc}")
    assert missing == []


def test_the_plugin_api_names_are_written_once():
    """api.py's ``__all__`` is the one list of the plugin API's names: the package's
    ``__all__`` is made from it (issue 45: it was once written in both files),
    with no name twice."""
    import vpid_bench
    from vpid_bench import api

    init = ast.parse((CORE / "__init__.py").read_text(encoding="utf-8"))
    texts = {n.value for n in ast.walk(init)
             if isinstance(n, ast.Constant) and isinstance(n.value, str)}
    assert "Problem" in api.__all__ and texts & set(api.__all__) == set()
    assert vpid_bench.__all__[:len(api.__all__)] == api.__all__
    assert len(set(vpid_bench.__all__)) == len(vpid_bench.__all__)
