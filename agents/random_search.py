"""Uniform random search over [-1, 1]^d: the baseline every optimiser should beat."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from agents.optimiser import (
    MAX_BATCH,
    AskTellOptimiser,
    FloatArray,
    SeedLike,
    check_settings,
    integer_setting,
)
from tandem_env.envs.base import ACTION_HIGH, ACTION_LOW

__all__ = ["RandomSearch", "RandomSearchConfig"]


@dataclass(frozen=True, kw_only=True)
class RandomSearchConfig:
    """Configuration of :class:`RandomSearch`."""

    max_evaluations: int = integer_setting(1)
    """Points evaluated (>= 1); the last batch is truncated to fit."""
    batch_size: int = integer_setting(1, MAX_BATCH, default=40)
    """Points per ask (>= 1); 40 matches the default PSO swarm so per-iteration costs compare."""

    def __post_init__(self) -> None:
        check_settings(self)

    @property
    def citation(self) -> str:
        """What the baseline is."""
        return "uniform random search over [-1, 1]^d (i.i.d. samples, no adaptation; baseline)"

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready record of every setting and the citation."""
        return {
            "algorithm": "random-search",
            "batch_size": self.batch_size,
            "max_evaluations": self.max_evaluations,
            "citation": self.citation,
        }

    def build(self, dim: int, seed: SeedLike = None) -> RandomSearch:
        """A fresh :class:`RandomSearch` for this configuration."""
        return RandomSearch(dim, self, seed)


class RandomSearch(AskTellOptimiser):
    """Random-search maximiser over [-1, 1]^dim (ask/tell:
    :class:`~agents.optimiser.AskTellOptimiser`)."""

    def __init__(self, dim: int, config: RandomSearchConfig, seed: SeedLike = None) -> None:
        if not isinstance(config, RandomSearchConfig):
            raise TypeError(f"config must be a RandomSearchConfig, got {type(config).__name__}")
        super().__init__(dim, config.batch_size, config, seed)

    def _propose(self, n: int) -> FloatArray:
        return self._rng.uniform(ACTION_LOW, ACTION_HIGH, (n, self.dim))

    def _observe(self, X: FloatArray, fitness: FloatArray) -> None:
        """Nothing to learn: the base class tracks the best point and the history."""
