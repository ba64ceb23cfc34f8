"""``python -m eval crosscheck``: the tandem interaction against a free-wake vortex-lattice
solver (docs/crosscheck.md). The subcommand is :mod:`eval.crosscheck.cli`; the cases and the
mapping :mod:`.case`, the solver runs and their records :mod:`.uvlm`, the table and
figure :mod:`.report`."""
