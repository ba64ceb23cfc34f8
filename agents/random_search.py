"""Uniform random search over [-1, 1]^d: the baseline every optimiser should beat."""

from __future__ import annotations

from dataclasses import dataclass

from agents.methods import register_optimiser
from agents.optimiser import (
    MAX_BATCH,
    AskTellOptimiser,
    FloatArray,
    OptimiserConfig,
    SeedLike,
    integer_setting,
)
from tandem_env.envs.base import ACTION_HIGH, ACTION_LOW


@dataclass(frozen=True, kw_only=True)
class RandomSearchConfig(OptimiserConfig):
    """Configuration of :class:`RandomSearch`."""

    algorithm = "random-search"
    citation = "uniform random search over [-1, 1]^d (i.i.d. samples, no adaptation; baseline)"

    batch_size: int = integer_setting(1, MAX_BATCH, default=40)
    """Points per ask (>= 1); 40 matches the default PSO swarm so per-iteration costs compare."""


class RandomSearch(AskTellOptimiser, settings=RandomSearchConfig):
    """Random-search maximiser over [-1, 1]^dim (ask/tell:
    :class:`~agents.optimiser.AskTellOptimiser`)."""

    def __init__(self, dim: int, config: RandomSearchConfig, seed: SeedLike = None) -> None:
        super().__init__(dim, config.batch_size, config, seed)

    def _propose(self, n: int) -> FloatArray:
        return self._rng.uniform(ACTION_LOW, ACTION_HIGH, (n, self.dim))

    def _observe(self, X: FloatArray, fitness: FloatArray) -> None:
        """Nothing to learn: the base class tracks the best point and the history."""


register_optimiser("random", RandomSearchConfig, batch="batch_size")
