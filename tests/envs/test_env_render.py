"""Rendering: an (H, W, 3) uint8 picture of the last stroke; human mode works headless."""

from __future__ import annotations

import warnings

import gymnasium as gym
import matplotlib
import numpy as np
import pytest

from tandem_env.envs import AccelerateEnv, LevelFlightEnv
from tandem_env.envs.render import FRAME_SIZE

LEVEL = "TandemWing/LevelFlight-v0"


def test_rgb_array_before_reset_after_reset_and_after_step(level_feasible_action) -> None:
    env = LevelFlightEnv(render_mode="rgb_array")
    width, height = FRAME_SIZE
    frames = [env.render()]
    env.reset(seed=0)
    frames.append(env.render())
    env.step(level_feasible_action)
    frames.append(env.render())
    for frame in frames:
        assert isinstance(frame, np.ndarray) and frame.dtype == np.uint8
        assert frame.shape == (height, width, 3)
    # The stroke adds the tip paths and the angle histories (coloured pixels).
    coloured = [np.count_nonzero(np.ptp(f.astype(int), axis=2) > 60) for f in frames]
    assert coloured[2] > 10 * max(coloured[1], 1)
    env.close()


def test_accelerate_renders_too() -> None:
    env = gym.make("TandemWing/Accelerate-v0", render_mode="rgb_array", objective="resultant")
    env.reset(seed=0)
    env.step(env.action_space.sample())
    assert env.render().shape[2] == 3
    assert isinstance(env.unwrapped, AccelerateEnv)


def test_human_mode_draws_without_warnings_and_closes_its_window() -> None:
    import matplotlib.pyplot as plt

    if matplotlib.get_backend().lower() != "agg":
        pytest.skip("needs the headless Agg backend (a GUI backend would open a window)")
    before = set(plt.get_fignums())
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        env = gym.make(LEVEL, render_mode="human")
        env.reset(seed=0)
        env.step(env.action_space.sample())
        assert env.render() is None
        assert len(set(plt.get_fignums()) - before) == 1
        env.close()
    assert set(plt.get_fignums()) == before


def test_render_without_a_mode_warns_and_returns_none() -> None:
    env = gym.make(LEVEL)
    env.reset()
    with pytest.warns(UserWarning, match="without a render mode"):
        assert env.render() is None


def _coloured(frame: np.ndarray) -> int:
    """Pixels of the stroke's coloured lines (the empty picture is grey on white)."""
    return int(np.count_nonzero(np.ptp(frame.astype(int), axis=2) > 60))


def test_frames_after_sb3s_reset_inside_the_step_show_the_stroke_just_flown(
    level_feasible_action,
) -> None:
    """SB3's VecEnv resets an ended episode inside ``step`` (every step, here), and video
    recorders (rl-zoo3, SB3's VecVideoRecorder) draw after it: the frame is of the stroke
    flown, not an empty "no stroke" picture, until the next step."""
    from tandem_env.envs.sb3 import make_sb3_vec_env

    venv = make_sb3_vec_env(LEVEL, n_envs=2, seed=0, render_mode="rgb_array")
    venv.reset()
    empty = venv.get_images()
    venv.step(np.stack([level_feasible_action] * 2).astype(np.float32))
    flown = venv.get_images()
    for before, after in zip(empty, flown, strict=True):
        assert _coloured(after) > 10 * max(_coloured(before), 1)
    assert venv.render().shape[2] == 3  # SB3's tiled picture of them
    venv.close()
