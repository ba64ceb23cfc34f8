"""The RL methods choose their reported stroke by the harness's rule: feasible first."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from stable_baselines3.common.vec_env import DummyVecEnv

from train.run import StrokeRecorder


class Scripted(gym.Env):
    """One-step env: reward = action[0]; feasible where action[1] > 0."""

    def __init__(self) -> None:
        self.action_space = spaces.Box(-1.0, 1.0, (2,), dtype=np.float32)
        self.observation_space = spaces.Box(-1.0, 1.0, (1,), dtype=np.float32)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        return np.zeros(1, dtype=np.float32), {}

    def step(self, action: np.ndarray):
        reward = float(action[0])
        info = {"objective": reward, "penalty": 0.0, "feasible": bool(action[1] > 0)}
        return np.zeros(1, dtype=np.float32), reward, True, False, info


def test_recorder_prefers_the_best_feasible_stroke_and_keeps_a_monotone_history() -> None:
    recorder = StrokeRecorder(DummyVecEnv([Scripted, Scripted]))
    recorder.reset()
    steps = [
        [[0.2, -1.0], [0.1, -1.0]],  # nothing feasible yet: best reward 0.2
        [[0.9, -1.0], [0.3, 1.0]],  # 0.9 is infeasible; 0.3 is the first feasible stroke
        [[0.8, -1.0], [0.25, 1.0]],  # neither beats the feasible 0.3
        [[0.5, 1.0], [0.95, -1.0]],  # a better feasible stroke
    ]
    expected = [(0.2, False), (0.3, True), (0.3, True), (0.5, True)]
    for actions, (reward, feasible) in zip(steps, expected, strict=True):
        recorder.step(np.array(actions, dtype=np.float32))
        assert recorder.best_reward == np.float32(reward) and recorder.best_feasible is feasible
    assert [h[1] for h in recorder.history] == [np.float32(r) for r in (0.2, 0.9, 0.9, 0.95)]
