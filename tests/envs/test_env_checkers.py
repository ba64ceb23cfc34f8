"""Gymnasium's and SB3's env checkers on every registered id, warnings turned into errors."""

from __future__ import annotations

import warnings
from typing import Any

import gymnasium as gym
import pytest
from gymnasium.utils.env_checker import check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import tandem_env  # noqa: F401  (registers the ids)

CASES: list[tuple[str, dict[str, Any]]] = [
    ("TandemWing/LevelFlight-v0", {}),
    ("TandemWing/LevelFlight-v0", {"speed_range": (0.25, 2.0), "thrust_split": "body"}),
    ("TandemWing/Accelerate-v0", {"objective": "vertical"}),
    ("TandemWing/Accelerate-v0", {"objective": "horizontal", "available_power": 60.0}),
    ("TandemWing/Accelerate-v0", {"objective": "resultant", "available_power_range": (50.0, 90.0)}),
    ("TandemWing/SpeedChange-v0", {}),
    ("TandemWing/SpeedChange-v0", {"target_speed": 1.5, "start_speed_range": (0.5, 1.0)}),
]
IDS = [f"{env_id.split('/')[1]}-{kw}" for env_id, kw in CASES]


def test_every_registered_id_is_covered() -> None:
    registered = {env_id for env_id in gym.registry if env_id.startswith("TandemWing/")}
    assert registered == {env_id for env_id, _ in CASES}


@pytest.mark.parametrize(("env_id", "kwargs"), CASES, ids=IDS)
def test_gymnasium_check_env(env_id: str, kwargs: dict[str, Any]) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        env = gym.make(f"tandem_env:{env_id}", **kwargs)
        # The raw env (check_env warns about wrappers); its spec lets the checker re-make it in
        # every render mode, so rendering after a reset (no step yet) is checked too.
        check_env(env.unwrapped, skip_render_check=False)
        env.close()


@pytest.mark.parametrize(("env_id", "kwargs"), CASES, ids=IDS)
def test_sb3_check_env(env_id: str, kwargs: dict[str, Any]) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        env = gym.make(env_id, render_mode="rgb_array", **kwargs)
        sb3_check_env(env, warn=True, skip_render_check=False)
        env.close()
