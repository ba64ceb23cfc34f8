"""The final deterministic evaluation plays each env's episode to its end."""

from __future__ import annotations

import gymnasium as gym
import numpy as np

import tandem_env  # noqa: F401 - registers the ids
from tandem_env.envs.sb3 import make_sb3_vec_env
from train.run import evaluate_deterministic


class ConstantPolicy:
    """The one stroke ``action`` everywhere (the ``predict`` of an SB3 model)."""

    def __init__(self, action: np.ndarray) -> None:
        self.action = action

    def predict(self, observations: np.ndarray, deterministic: bool = True):
        return np.tile(self.action, (len(observations), 1)), None


def play(env_id: str, action: np.ndarray, seed: int, **kwargs) -> tuple[float, int]:
    """Return and length of one episode of ``action`` in a plain Gymnasium env."""
    env = gym.make(env_id, **kwargs)
    env.reset(seed=seed)
    total, steps, done = 0.0, 0, False
    while not done:
        _, reward, terminated, truncated, _ = env.step(action)
        total, steps, done = total + float(reward), steps + 1, terminated or truncated
    env.close()
    return total, steps


def test_episodic_rows_are_whole_episodes() -> None:
    action = np.zeros(28, dtype=np.float32)
    venv = make_sb3_vec_env("TandemWing/SpeedChange-v0", n_envs=2, seed=7)
    rows = evaluate_deterministic(ConstantPolicy(action), venv)
    venv.close()
    for k, row in enumerate(rows):
        total, steps = play("TandemWing/SpeedChange-v0", action, seed=7 + k)
        assert row["episode_length"] == steps > 1
        np.testing.assert_allclose(row["reward"], total, rtol=1e-5)
        assert row["action"] == [0.0] * 28


def test_one_cycle_rows_are_one_stroke() -> None:
    action = np.full(28, 0.25, dtype=np.float32)
    venv = make_sb3_vec_env("TandemWing/LevelFlight-v0", n_envs=1, seed=0, speed=1.0)
    [row] = evaluate_deterministic(ConstantPolicy(action), venv)
    venv.close()
    total, steps = play("TandemWing/LevelFlight-v0", action, seed=0, speed=1.0)
    assert row["episode_length"] == steps == 1
    np.testing.assert_allclose(row["reward"], total, rtol=1e-6)
    assert row["speed"] == 1.0
