"""``python -m eval crosscheck``: the tandem interaction against a free-wake vortex-lattice
solver (docs/crosscheck.md). The subcommand is :mod:`eval.crosscheck.cli`; the cases and the
mapping :mod:`.case`, the solver runs and their records :mod:`.uvlm`, the table and
figure :mod:`.report`."""

from .cli import DESCRIPTION, EPILOG, HELP, NAME, add_arguments, main

__all__ = ["DESCRIPTION", "EPILOG", "HELP", "NAME", "add_arguments", "main"]
