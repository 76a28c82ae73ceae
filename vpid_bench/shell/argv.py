"""The command line as vpid-bench reads it: Hydra's flags plus ``--resume``, ``--merge`` and
``--version``, mirrored with argparse so that the pre-flight knows what the command asks for
(run, sweep, information) and a command line Hydra would refuse is refused here, in one line.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
from collections.abc import Sequence

from ..errors import ConfigError

RESUME_FLAG = "--resume"
#: Add this command's jobs to an output folder that holds another command's jobs.
MERGE_FLAG = "--merge"
#: The shipped configs' place in Hydra's search path.
SHIPPED_CONFIGS = "pkg://vpid_bench.conf"


@dataclasses.dataclass(frozen=True)
class ConfigSource:
    """Where the primary config comes from (``-cp``/``-cn``/``-cd``): ``path`` its folder or
    ``pkg://`` package (None: the shipped one), ``name`` (None: ``config``), ``search`` one
    more search-path entry after it. The pre-flight and Hydra are both set up from it."""

    path: str | None = None
    name: str | None = None
    search: str | None = None

    def search_override(self) -> list[str]:
        """The override that puts :attr:`search` in ``hydra.searchpath``, or nothing."""
        if self.search is None:
            return []
        quoted = self.search.replace("\\", "\\\\").replace('"', '\\"')
        return [f'hydra.searchpath=["{quoted}"]']

    def hydra_flags(self) -> list[str]:
        """Hydra's flags for this source (folders absolute)."""
        return ([f"--config-path={self.path}"] * (self.path is not None)
                + [f"--config-name={self.name}"] * (self.name is not None))


@dataclasses.dataclass
class CommandLine:
    """What the command line asks for."""

    overrides: list[str]
    multirun: bool
    resume: str | None  # None: no --resume; "": find the folder; else the folder given
    version: bool
    info: str | None  # the information-only flag used (--help, --cfg, ...), else None
    hydra_args: list[str]  # the command line for Hydra (ours removed, folders made absolute)
    config: ConfigSource = dataclasses.field(default_factory=ConfigSource)
    merge: bool = False  # the output folder may hold another command's jobs

    @property
    def custom_config(self) -> bool:
        """A config we do not ship (--config-name, --config-path or --config-dir)."""
        return self.config != ConfigSource()


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # type: ignore[override]
        raise ConfigError("command line", " ".join(self._argv), f"Hydra's flags ({message}); "
                          "see vpid-bench --hydra-help")


def _parser(argv: Sequence[str]) -> _Parser:
    p = _Parser(add_help=False, prog="vpid-bench")
    p._argv = list(argv)  # type: ignore[attr-defined]
    p.add_argument("--help", "-h", action="store_true")
    p.add_argument("--hydra-help", action="store_true")
    p.add_argument("--version", action="store_true")
    p.add_argument("overrides", nargs="*")
    p.add_argument("--cfg", "-c", choices=["job", "hydra", "all"])
    p.add_argument("--resolve", action="store_true")
    p.add_argument("--package", "-p")
    p.add_argument("--run", "-r", action="store_true")
    p.add_argument("--multirun", "-m", action="store_true")
    p.add_argument("--shell-completion", "-sc", action="store_true")
    p.add_argument("--config-path", "-cp")
    p.add_argument("--config-name", "-cn")
    p.add_argument("--config-dir", "-cd")
    p.add_argument("--experimental-rerun")
    p.add_argument("--info", "-i", const="all", nargs="?",
                   choices=["all", "config", "defaults", "defaults-tree", "plugins",
                            "searchpath"])
    return p


def _config_source(args: argparse.Namespace, overrides: Sequence[str]) -> ConfigSource:
    """The config source of ``-cp``/``-cn``/``-cd``, folders existing and read from the
    current folder (Hydra reads a relative ``-cp`` from inside the installed package).
    ``-cd DIR`` comes *before* the shipped configs: a ``DIR/<name>.yaml`` is the primary
    config (Hydra's own ``-cd`` searches DIR last: the shipped ``config.yaml`` silently won,
    ``runs: 3`` gave 30 runs); without one, DIR adds choices to the shipped config."""
    def folder(flag: str, value: str | None) -> str | None:
        if value is None or value.startswith("pkg://"):
            return value
        if not os.path.isdir(value):
            raise ConfigError(flag, value, "an existing folder")
        return os.path.abspath(value)

    path = folder("--config-path", args.config_path)
    config_dir = folder("--config-dir", args.config_dir)
    name = args.config_name
    if config_dir is None:
        return ConfigSource(path, name)
    if any(o.lstrip("+~").startswith("hydra.searchpath=") for o in overrides):
        raise ConfigError("hydra.searchpath", "", "not with -cd (vpid-bench sets it from -cd); "
                          "list your folders in your config's hydra.searchpath instead")
    if path is None and os.path.isfile(os.path.join(config_dir, f"{name or 'config'}.yaml")):
        return ConfigSource(config_dir, name, SHIPPED_CONFIGS)
    return ConfigSource(path, name, "file://" + config_dir)


def _without_config_flags(hydra_args: Sequence[str]) -> list[str]:
    """The command line without ``-cp``/``-cn``/``-cd`` and their values."""
    flags = ("--config-path", "-cp", "--config-name", "-cn", "--config-dir", "-cd")
    out, skip = [], False
    for arg in hydra_args:
        if skip:
            skip = False
        elif arg in flags:
            skip = True
        elif not arg.startswith(tuple(f + "=" for f in flags)):
            out.append(arg)
    return out


def _own_flags(argv: Sequence[str]) -> tuple[list[str], str | None, bool]:
    """``argv`` without vpid-bench's own flags, and their values: ``--resume`` (None: not
    given; "": find the folder; else the folder) and ``--merge``."""
    hydra_args, resume, merge = [], None, False
    for arg in argv:
        if arg == MERGE_FLAG:
            merge = True
        elif arg == RESUME_FLAG:
            resume = ""
        elif arg.startswith(RESUME_FLAG + "="):
            resume = arg.split("=", 1)[1]
            if not resume:
                raise ConfigError(RESUME_FLAG, resume, "a folder, or --resume alone to find it")
        else:
            hydra_args.append(arg)
    return hydra_args, resume, merge


def parse_command_line(argv: Sequence[str]) -> CommandLine:
    """Read ``argv``; :class:`ConfigError` for what Hydra would refuse or cannot honour."""
    hydra_args, resume, merge = _own_flags(argv)
    args = _parser(hydra_args).parse_args(hydra_args)
    info = next((flag for flag, given in (
        ("--help", args.help), ("--hydra-help", args.hydra_help), ("--cfg", args.cfg),
        ("--info", args.info), ("--shell-completion", args.shell_completion),
        ("--experimental-rerun", args.experimental_rerun)) if given), None)
    if args.multirun and info in ("--cfg", "--info", "--experimental-rerun"):
        raise ConfigError(info, args.cfg or args.info or args.experimental_rerun,
                          "a single run's config: drop -m (or use --help)")
    if args.run and args.multirun:
        raise ConfigError("--run", True, "either --run or --multirun, not both")
    if args.shell_completion:
        query = [o for o in args.overrides or [] if o.startswith("query=")]
        if query and "COMP_LINE" not in os.environ:
            raise ConfigError("-sc", query[0], "install=bash (or zsh, fish) to install "
                              "completion; query= is what the installed completion runs")
    if (resume is not None or merge) and (info or args.version):
        raise ConfigError(RESUME_FLAG if resume is not None else MERGE_FLAG,
                          resume or True, "a command that runs jobs")
    source = _config_source(args, args.overrides or [])
    hydra_args = [*source.hydra_flags(), *_without_config_flags(hydra_args),
                  *source.search_override()]
    return CommandLine(list(args.overrides or []), bool(args.multirun), resume,
                       bool(args.version), info, hydra_args, source, merge)
