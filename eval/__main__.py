"""``python -m eval SUBCOMMAND ...``: the evaluation command line.

Subcommands are modules listed in :data:`SUBCOMMANDS`. Each defines

* ``NAME``: the subcommand's name, and ``HELP``: one line for the overview;
* ``add_arguments(parser)``: its arguments, on the ``argparse`` sub-parser;
* ``main(args, parser) -> int``: run it (``parser.error`` for bad input, exit status 2).

Adding a subcommand (e.g. ``study``) is one module with these four names and one entry here.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence
from types import ModuleType

from tandem_env.io.progress_bar import warnings_as_lines

#: Modules providing the subcommands, in the order ``--help`` lists them.
SUBCOMMANDS: tuple[str, ...] = (
    "eval.optimize",
    "eval.compare",
    "eval.study",
    "eval.measured",
    "eval.speed_change",
)


def _load(names: Sequence[str]) -> list[ModuleType]:
    return [importlib.import_module(name) for name in names]


def build_parser(modules: Sequence[ModuleType] | None = None) -> argparse.ArgumentParser:
    """The top-level parser with one sub-parser per subcommand module."""
    modules = _load(SUBCOMMANDS) if modules is None else modules
    parser = argparse.ArgumentParser(
        prog="python -m eval",
        description=(
            "Optimise strokes of the tandem-wing model with PSO, random search or RL agents, "
            "and compare the recorded results."
        ),
    )
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for module in modules:
        # A module whose help depends on what is registered builds it now: description().
        describe = getattr(module, "description", None)
        sub = subparsers.add_parser(
            module.NAME,
            help=module.HELP,
            description=describe() if describe else getattr(module, "DESCRIPTION", module.HELP),
            epilog=getattr(module, "EPILOG", None),
            formatter_class=argparse.RawDescriptionHelpFormatter,
        )
        module.add_arguments(sub)
        sub.set_defaults(_main=module.main, _parser=sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Parse ``argv`` (default ``sys.argv[1:]``) and run the subcommand; its exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    with warnings_as_lines():
        return int(args._main(args, args._parser) or 0)


if __name__ == "__main__":
    sys.exit(main())
