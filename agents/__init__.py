"""Optimisers over the normalised box [-1, 1]^d and the harness that runs them on the tasks:
import from the modules (``agents.harness``, ``agents.jobs``, ``agents.methods``, ...;
docs/harness.md). The package itself imports nothing.
"""
