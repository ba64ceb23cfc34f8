"""A toy optimiser in ONE file, as a plug-in would add one: a hill climber with a shrinking step.

Its frozen config (the settings are its fields) and its ask/tell class, registered by the one
``register_optimiser`` line at the end when this module is imported: by a test
(tests/agents/test_toy_optimiser.py) or by the ``tandem_env.optimisers`` entry point of an
installed plug-in. Nothing in ``agents`` or ``eval`` names it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from agents.methods import register_optimiser
from agents.optimiser import (
    AskTellOptimiser,
    FloatArray,
    OptimiserConfig,
    SeedLike,
    integer_setting,
)
from tandem_env.envs.base import ACTION_HIGH, ACTION_LOW


@dataclass(frozen=True, kw_only=True)
class HillClimbConfig(OptimiserConfig):
    """A (1, λ) hill climber: ``batch_size`` Gaussian steps of size ``step`` around the best point
    so far; the step halves after a batch that found nothing better. Its checks, record
    (``to_dict``) and ``build`` come from its fields (``OptimiserConfig``)."""

    algorithm = "hill-climb"
    citation = "toy hill climber (tests/agents/toy_optimiser.py)"

    max_evaluations: int = integer_setting(1)
    batch_size: int = integer_setting(1, default=16)
    step: float = 0.5


class HillClimb(AskTellOptimiser, settings=HillClimbConfig):
    def __init__(self, dim: int, config: HillClimbConfig, seed: SeedLike = None) -> None:
        super().__init__(dim, config.batch_size, config, seed)
        self._centre = np.zeros(dim)
        self._step = config.step

    def _propose(self, n: int) -> FloatArray:
        steps = self._rng.normal(0.0, self._step, (n, self.dim))
        return np.clip(self._centre + steps, ACTION_LOW, ACTION_HIGH)

    def _observe(self, X: FloatArray, fitness: FloatArray) -> None:
        if fitness.max() > self.best_fitness:  # the base class counts the batch after this
            self._centre = X[np.argmax(fitness)]
        else:
            self._step /= 2.0


register_optimiser("hill-climb", HillClimbConfig, batch="batch_size")  # the one line
