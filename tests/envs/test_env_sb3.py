"""The SB3 adapter equals SB3's DummyVecEnv over single envs, and SB3 is imported lazily."""

from __future__ import annotations

import subprocess
import sys
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from stable_baselines3.common.vec_env import DummyVecEnv, VecMonitor

from tandem_env.envs import TandemVecEnv, make_sb3_vec_env

LEVEL = "TandemWing/LevelFlight-v0"
ACCELERATE_ID = "TandemWing/Accelerate-v0"


def dummy(env_id: str, n: int, **kwargs: Any) -> DummyVecEnv:
    return DummyVecEnv([lambda: gym.make(env_id, **kwargs) for _ in range(n)])


@pytest.mark.parametrize(
    ("env_id", "kwargs"),
    [
        (LEVEL, {"speed_range": (0.25, 2.0)}),
        (
            ACCELERATE_ID,
            {"objective": "horizontal", "available_power_range": (50.0, 90.0), "planform": "real"},
        ),
    ],
)
def test_adapter_matches_dummy_vec_env(env_id: str, kwargs: dict, same) -> None:
    n = 4
    ours = make_sb3_vec_env(env_id, n_envs=n, seed=10, **kwargs)
    theirs = dummy(env_id, n, **kwargs)
    theirs.seed(10)
    assert isinstance(ours, TandemVecEnv)
    assert ours.observation_space == theirs.observation_space
    assert ours.action_space == theirs.action_space
    assert ours.metadata == theirs.metadata and ours.render_mode == theirs.render_mode
    same(ours.reset(), theirs.reset())
    same(ours.reset_infos, theirs.reset_infos)
    rng = np.random.default_rng(0)
    for _ in range(3):
        actions = rng.uniform(-1.0, 1.0, (n, 28)).astype(np.float32)
        out_ours, out_theirs = ours.step(actions), theirs.step(actions)
        same(out_ours, out_theirs)
        assert out_ours[1].dtype == np.float32 and out_ours[2].all()
        assert "terminal_observation" in out_ours[3][0]
        same(ours.reset_infos, theirs.reset_infos)
    # Seeds and per-env options are used at the next reset only, as in DummyVecEnv.
    key = "speed" if env_id == LEVEL else "available_power"
    value = 1.0 if env_id == LEVEL else 60.0
    for venv in (ours, theirs):
        venv.seed(3)
        venv.set_options([{key: value}, {}, {}, {}])
    same(ours.reset(), theirs.reset())
    same(ours.reset_infos, theirs.reset_infos)
    actions = rng.uniform(-1.0, 1.0, (n, 28)).astype(np.float32)
    same(ours.step(actions), theirs.step(actions))


def test_adapter_attribute_access_and_sb3_training_smoke() -> None:
    from stable_baselines3 import PPO

    venv = make_sb3_vec_env(LEVEL, n_envs=16, seed=0, monitor=True, speed_range=(0.25, 2.0))
    assert isinstance(venv, VecMonitor)
    assert venv.get_attr("render_mode") == [None] * 16
    assert venv.env_is_wrapped(gym.Wrapper, indices=[0, 1]) == [False, False]
    assert venv.get_attr("config", indices=0)[0].speed_range == (0.25, 2.0)
    model = PPO("MlpPolicy", venv, n_steps=4, batch_size=32, n_epochs=1, seed=0, device="cpu")
    model.learn(total_timesteps=128)
    assert len(model.ep_info_buffer) > 0  # VecMonitor saw the one-step episodes end
    venv.close()


def test_adapter_rejects_other_vector_envs() -> None:
    sync = gym.make_vec(LEVEL, num_envs=2, vectorization_mode="sync")
    with pytest.raises(ValueError, match="native vector env"):
        TandemVecEnv(sync)  # type: ignore[arg-type]


def test_import_does_not_pull_in_sb3_torch_or_matplotlib() -> None:
    code = (
        "import sys, gymnasium as gym, tandem_env, tandem_env.envs;"
        "env = gym.make('TandemWing/LevelFlight-v0'); env.reset(seed=0);"
        "env.step(env.action_space.sample());"
        "gym.make_vec('TandemWing/Accelerate-v0', num_envs=2).reset(seed=0);"
        "print(sorted(m for m in ('stable_baselines3', 'torch', 'matplotlib') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
