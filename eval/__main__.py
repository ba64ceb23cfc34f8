"""``python -m eval SUBCOMMAND ...``: the evaluation command line.

A subcommand is a module listed in :data:`SUBCOMMANDS` that defines ``NAME``, ``HELP`` (one
line for the overview), ``add_arguments(parser)`` and ``main(args, parser) -> int``
(``parser.error`` for bad input, exit status 2).
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from types import ModuleType

from train.entry import exit_on_bad_environment

# importing tandem_env checks numba's environment: a bad setting is one line and status 2
with exit_on_bad_environment("python -m eval"):
    from tandem_env.io.command import command_line
from tandem_env.io.progress_bar import warnings_as_lines

#: Modules providing the subcommands, in the order ``--help`` lists them.
SUBCOMMANDS: tuple[str, ...] = (
    "eval.optimize",
    "eval.compare",
    "eval.study",
    "eval.measured",
    "eval.speed_change",
    "eval.reference",
    "eval.numbers",
    "eval.show",
    "eval.crosscheck.cli",
)


def _texts(module: ModuleType) -> dict[str, object]:
    """The description and epilog of a subcommand's parser (the same under either program)."""
    # A module whose help depends on what is registered builds it now: description().
    describe = getattr(module, "description", None)
    return {
        "description": describe() if describe else getattr(module, "DESCRIPTION", module.HELP),
        "epilog": getattr(module, "EPILOG", None),
        "formatter_class": argparse.RawDescriptionHelpFormatter,
    }


def _prog(default: str) -> str:
    """The program name for usage lines: a console script's own (``tandem-study``) when run as
    one, else ``default``."""
    name = Path(sys.argv[0]).name
    return name if name.startswith("tandem-") else default


def build_parser(
    modules: Sequence[ModuleType] | None = None, prog: str = "python -m eval"
) -> argparse.ArgumentParser:
    """The top-level parser with one sub-parser per subcommand module."""
    if modules is None:
        modules = [importlib.import_module(name) for name in SUBCOMMANDS]
    text = (
        "Optimise strokes of the tandem-wing model with CMA-ES (the default), PSO, random "
        "search or RL agents, and compare the recorded results."
    )
    parser = argparse.ArgumentParser(prog=prog, description=text)
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for module in modules:
        sub = subparsers.add_parser(module.NAME, help=module.HELP, **_texts(module))
        module.add_arguments(sub)
        sub.set_defaults(_main=module.main, _parser=sub)
    return parser


@command_line
def main(argv: Sequence[str] | None = None) -> int:
    """Parse ``argv`` (default ``sys.argv[1:]``) and run the subcommand; its exit status."""
    parser = build_parser(prog=_prog("python -m eval") if argv is None else "python -m eval")
    args = parser.parse_args(argv)
    with warnings_as_lines():
        return int(args._main(args, args._parser) or 0)


def _script(module_name: str) -> Callable[[], int]:
    """The console script of one subcommand: ``tandem-<name> ARGS`` is ``python -m eval <name>
    ARGS``, with its own name in the usage line."""

    @command_line
    def script() -> int:
        module = importlib.import_module(module_name)
        prog = _prog(f"python -m eval {module.NAME}")
        parser = argparse.ArgumentParser(prog=prog, **_texts(module))
        module.add_arguments(parser)
        args = parser.parse_args(sys.argv[1:])
        with warnings_as_lines():
            return int(module.main(args, parser) or 0)

    script.__doc__ = f"The console script of :mod:`{module_name}` (``[project.scripts]``)."
    return script


# The console scripts of pyproject.toml's [project.scripts] (README, "Console scripts").
optimize = _script("eval.optimize")
compare = _script("eval.compare")
study = _script("eval.study")
measured = _script("eval.measured")
speed_change = _script("eval.speed_change")


if __name__ == "__main__":
    sys.exit(main())
