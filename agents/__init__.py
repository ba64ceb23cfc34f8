"""Optimisers over the normalised box [-1, 1]^d and the harness that runs them on the tasks.

Import from the modules: ``agents.harness`` (``run``, ``prepare``), ``agents.jobs`` (``Job``),
``agents.records`` (``Record``), ``agents.store`` (``RecordStore``), ``agents.methods``
(``register_method``, ``get_method``), ``agents.tasks``, and the optimisers ``agents.pso``,
``agents.cmaes_search`` and ``agents.random_search`` (docs/harness.md). The package itself
imports nothing.
"""
