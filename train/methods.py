"""Registers the harness methods ``ppo``, ``sac`` and ``policy:RUN_DIR`` (see train/policies.py).

:mod:`agents.methods` imports this module the first time one of those names is asked for.
"""

from __future__ import annotations

from train.policies import register

register()
