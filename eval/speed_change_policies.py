"""The policies ``python -m eval speed-change`` flies (:mod:`eval.speed_change`): each chooses
the next stroke of B episodes from their observations and states."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from tandem_env.envs.registration import SPEED_CHANGE_ID
from tandem_env.envs.speed_change import Flight


class Policy(Protocol):
    """Chooses the next stroke of B episodes from their observations and states."""

    name: str

    def act(self, observations: np.ndarray, flight: Flight) -> np.ndarray:
        """(B, 28) normalised strokes in [-1, 1]."""
        ...


@dataclass
class RandomPolicy:
    """Uniform random strokes, a fresh one each cycle, from a seeded generator."""

    seed: int = 0
    name: str = "random"
    _rng: np.random.Generator = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self._rng = np.random.default_rng(self.seed)

    def act(self, observations: np.ndarray, flight: Flight) -> np.ndarray:
        return self._rng.uniform(-1.0, 1.0, (observations.shape[0], 28))


@dataclass(frozen=True)
class SteadyPolicy:
    """The level-flight optimum at the grid speed nearest each episode's target, every cycle."""

    speeds: np.ndarray
    """(G,) grid speeds [m/s]."""
    actions: np.ndarray
    """(G, 28) normalised level-flight optimum at each grid speed."""
    name: str = "steady"

    def act(self, observations: np.ndarray, flight: Flight) -> np.ndarray:
        nearest = np.argmin(np.abs(flight.target_speed[:, None] - self.speeds[None, :]), axis=1)
        return self.actions[nearest]


@dataclass(frozen=True)
class SB3Policy:
    """A Stable-Baselines3 model's deterministic action (clipped to the action box)."""

    model: Any
    name: str

    @classmethod
    def load(cls, run_dir: str | os.PathLike[str], name: str, which: str = "final") -> SB3Policy:
        """The model of a ``python -m train`` run folder (``which``: "final" or "best"), named
        ``"<name> (<steps>k steps)"``."""
        from train.trained_policy import TrainedPolicy

        policy = TrainedPolicy.load(run_dir, which)  # type: ignore[arg-type]
        if policy.algo != name:
            raise ValueError(
                f"--{name} {run_dir} is a {policy.algo.upper()} run; allowed: a "
                f"{name.upper()} run (or give it with --{policy.algo})"
            )
        if policy.env_id != SPEED_CHANGE_ID:
            raise ValueError(
                f"{run_dir} was trained on {policy.env_id}; allowed: a run on {SPEED_CHANGE_ID}"
            )
        if policy.normalizer_path is not None:
            raise ValueError(
                f"{run_dir} normalised its observations (VecNormalize); allowed here: runs with "
                "normalize: false, as in train/hyperparams"
            )
        steps = int(policy.model.num_timesteps)
        return cls(policy.model, f"{name} ({steps / 1000:.0f}k steps)")

    def act(self, observations: np.ndarray, flight: Flight) -> np.ndarray:
        actions, _ = self.model.predict(observations, deterministic=True)
        return np.clip(actions, -1.0, 1.0)
