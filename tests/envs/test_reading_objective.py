"""Accelerate's objective "horizontal_literal": Eq. 24 read literally (docs/model.md §7.6)."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import tandem_env as te
from agents import harness
from agents.tasks import ACCELERATE_TASK
from tandem_env.envs import AccelerateConfig

ACCELERATE_ID = "TandemWing/Accelerate-v0"
KWARGS = {"objective": "horizontal_literal", "available_power": 60.0}


def test_env_checkers_pass() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        env = gym.make(f"tandem_env:{ACCELERATE_ID}", **KWARGS)
        check_env(env.unwrapped, skip_render_check=False)
        env.close()
        env = gym.make(ACCELERATE_ID, render_mode="rgb_array", **KWARGS)
        sb3_check_env(env, warn=True, skip_render_check=False)
        env.close()


def test_feasible_stroke_is_rewarded_with_exactly_its_literal_excess_force(
    accelerate_feasible_action,
) -> None:
    env = gym.make(ACCELERATE_ID, **KWARGS)
    obs, _ = env.reset(seed=0)
    _, reward, _, _, info = env.step(accelerate_feasible_action)
    direct = te.evaluate(te.normalised_to_physical(accelerate_feasible_action), 0.0, 60.0)
    assert info["feasible"] and info["constraint_violation"] == 0.0
    assert reward == info["excess_horizontal_literal"] == info["objective"]
    assert reward == direct.excess_horizontal_literal[0] > 0.0
    # the observation and the info keys are those of any other objective, but the score: the
    # reference table holds F̄_h, not this reading's literal F̄_h (docs/reference.md)
    other = gym.make(ACCELERATE_ID, objective="horizontal", available_power=60.0)
    other_obs, _ = other.reset(seed=0)
    _, _, _, _, other_info = other.step(accelerate_feasible_action)
    np.testing.assert_array_equal(obs, other_obs)
    assert "score" not in info and "score" in other_info
    assert set(info) == set(other_info) - {"score"}
    assert env.observation_space == other.observation_space


def test_every_objective_is_a_harness_objective() -> None:
    assert set(ACCELERATE_TASK.declared_objectives.metrics) == set(
        AccelerateConfig.DECLARATION.objectives.choices
    )
    (plan,) = harness.prepare("random", "accelerate", 70.0, 10, [0], objective="horizontal_literal")
    assert plan.objective_name == "excess_horizontal_literal"
    assert plan.env_kwargs == {"objective": "horizontal_literal", "available_power": 70.0}


def test_bad_objective_names_value_and_allowed() -> None:
    with pytest.raises(ValueError, match=r"objective = 'literal'; allowed: .*'horizontal_literal'"):
        te.envs.AccelerateConfig(objective="literal")
