"""The command line as vpid-bench reads it: Hydra's flags plus ``--resume`` and ``--version``.

Hydra parses the command line again when it runs; this module only learns what the command
asks for (run, sweep, show information), so that the pre-flight can check it first. It mirrors
Hydra 1.3's flags with the standard library's argparse; a command line Hydra's parser would
refuse is refused here, in one line.
"""

from __future__ import annotations

import argparse
import dataclasses
from collections.abc import Sequence

from ..errors import ConfigError

RESUME_FLAG = "--resume"


@dataclasses.dataclass
class CommandLine:
    """What the command line asks for."""

    overrides: list[str]
    multirun: bool
    resume: str | None  # None: no --resume; "": find the folder; else the folder given
    version: bool
    custom_config: bool  # --config-name/--config-path/--config-dir: a config we do not ship
    info: str | None  # the information-only flag used (--help, --cfg, ...), else None
    hydra_args: list[str]  # the command line for Hydra (ours removed)


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


def _check_config_dir(config_dir: str | None, name: str | None, path: str | None) -> None:
    """``-cd DIR`` adds DIR to Hydra's search path *after* the shipped configs, so a
    ``config.yaml`` there (the name asked for when ``-cn`` is not given) is silently shadowed
    by the shipped one: once the user's ``runs: 3`` gave 30 runs. Refused in one line."""
    import os

    if config_dir is None or path is not None:
        return
    if not os.path.isdir(config_dir):
        raise ConfigError("--config-dir", config_dir, "an existing folder")
    wanted = f"{name or 'config'}.yaml"
    if wanted == "config.yaml" and os.path.isfile(os.path.join(config_dir, wanted)):
        raise ConfigError("--config-dir", config_dir,
                          "a folder whose config.yaml the shipped config.yaml would shadow "
                          "(Hydra looks there last): rename yours and pass -cn <its name>, "
                          "or use -cp <folder>")


def parse_command_line(argv: Sequence[str]) -> CommandLine:
    """Read ``argv`` (without the program name). Raises :class:`ConfigError` for a command
    line Hydra would refuse, and for flag combinations Hydra cannot honour."""
    hydra_args, resume = [], None
    for arg in argv:
        if arg == RESUME_FLAG:
            resume = ""
        elif arg.startswith(RESUME_FLAG + "="):
            resume = arg.split("=", 1)[1]
            if not resume:
                raise ConfigError(RESUME_FLAG, resume, "a folder, or --resume alone to find it")
        else:
            hydra_args.append(arg)
    args = _parser(hydra_args).parse_args(hydra_args)
    info = None
    for flag, given in (("--help", args.help), ("--hydra-help", args.hydra_help),
                        ("--cfg", args.cfg), ("--info", args.info),
                        ("--shell-completion", args.shell_completion),
                        ("--experimental-rerun", args.experimental_rerun)):
        if given:
            info = flag
            break
    if args.multirun and info in ("--cfg", "--info", "--experimental-rerun"):
        raise ConfigError(info, args.cfg or args.info or args.experimental_rerun,
                          "a single run's config: drop -m (or use --help)")
    if args.run and args.multirun:
        raise ConfigError("--run", True, "either --run or --multirun, not both")
    if args.shell_completion:
        import os

        query = [o for o in args.overrides or [] if o.startswith("query=")]
        if query and "COMP_LINE" not in os.environ:
            raise ConfigError("-sc", query[0], "install=bash (or zsh, fish) to install "
                              "completion; query= is what the installed completion runs")
    if resume is not None and (info or args.version):
        raise ConfigError(RESUME_FLAG, resume or True, "a command that runs jobs")
    _check_config_dir(args.config_dir, args.config_name, args.config_path)
    return CommandLine(
        overrides=list(args.overrides or []),
        multirun=bool(args.multirun),
        resume=resume,
        version=bool(args.version),
        custom_config=bool(args.config_name or args.config_path or args.config_dir),
        info=info,
        hydra_args=hydra_args,
    )
