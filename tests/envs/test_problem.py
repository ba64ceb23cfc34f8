"""The optimisation problem an env offers (tandem_env/envs/problem.py): bounds, constraints and a
batched evaluation at explicit conditions that scores strokes exactly as the env does."""

from __future__ import annotations

import importlib
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

from tandem_env.envs import ACCELERATE_ID, LEVEL_FLIGHT_ID, SPEED_CHANGE_ID
from tandem_env.envs.base import ACTION_HIGH, ACTION_LOW, as_action_type
from tandem_env.envs.problem import FlightProblem
from tandem_env.physics import normalised_to_physical

SMALL = {"n_time": 32, "n_blade": 8}
# (env id, the condition's keyword, conditions inside its envelope)
TASKS = [
    (LEVEL_FLIGHT_ID, "speed", (0.5, 1.5, 2.0)),
    (ACCELERATE_ID, "available_power", (50.0, 70.0, 90.0)),
]


def _toy_task():
    # the one-file toy task, whose lift constraint declares no margin (tests/agents/toy_task.py)
    folder = str(Path(__file__).resolve().parents[1] / "agents")
    if folder not in sys.path:
        sys.path.insert(0, folder)
    return importlib.import_module("toy_task")


def _strokes(count: int, seed: int) -> np.ndarray:
    # as the action type carries them, so the env's float32 action is the same stroke
    return as_action_type(np.random.default_rng(seed).uniform(-1.0, 1.0, (count, 28)))


@pytest.mark.parametrize(("env_id", "keyword", "conditions"), TASKS)
def test_the_problem_scores_each_stroke_as_the_env_steps_it(env_id, keyword, conditions):
    env = gym.make(env_id, disable_env_checker=True, **SMALL)
    problem = env.unwrapped.problem()
    # three strokes at each condition, all in ONE evaluation, each with its own condition
    values = np.repeat(conditions, 3)
    actions = _strokes(values.size, seed=1)
    found = problem.evaluate(actions, values)
    assert found.objective.shape == found.feasible.shape == (values.size,)
    assert found.margins.shape == (values.size, len(problem.constraints))
    for k, (action, value) in enumerate(zip(actions, values, strict=True)):
        env.reset(seed=0, options={keyword: float(value)})
        _, reward, _, _, info = env.step(action.astype(np.float32))
        assert info[keyword] == value
        assert found.objective[k] == info["objective"]  # the same model call per stroke
        assert found.feasible[k] == info["feasible"]
        assert getattr(found.result, problem.objective_metric)[k] == info["objective"]
        for name, column in zip(problem.constraint_names, found.margins.T, strict=True):
            # the margin is >= 0 exactly where the env reports no violation of it
            assert (column[k] >= 0.0) == (info[name] == 0.0), name
        if info["feasible"]:
            assert reward == info["objective"]
    env.close()


@pytest.mark.parametrize(("env_id", "keyword", "conditions"), TASKS)
def test_the_condition_is_an_input_not_the_envs_state(env_id, keyword, conditions):
    env = gym.make(env_id, disable_env_checker=True, **SMALL)  # never reset
    problem = env.unwrapped.problem()
    actions = _strokes(4, seed=2)
    low, high = conditions[0], conditions[-1]
    mixed = problem.evaluate(actions, [low, high, low, high])
    at_low, at_high = problem.evaluate(actions, low), problem.evaluate(actions, high)
    for k, alone in enumerate((at_low, at_high, at_low, at_high)):
        assert mixed.objective[k] == alone.objective[k]
        np.testing.assert_array_equal(mixed.margins[k], alone.margins[k])
    # it does enter the model (the available power only the power cap's margin)
    assert not np.array_equal(at_low.margins, at_high.margins)
    assert problem.condition.keyword == keyword
    env.close()


def test_bounds_constraints_and_the_envs_views_agree():
    single = gym.make(LEVEL_FLIGHT_ID, disable_env_checker=True, constraint_tolerance=0.05)
    vector = gym.make_vec(
        LEVEL_FLIGHT_ID, 3, vectorization_mode="vector_entry_point", constraint_tolerance=0.05
    )
    problem = single.unwrapped.problem()
    assert isinstance(problem, FlightProblem) and problem.dim == 28
    space = single.action_space
    np.testing.assert_array_equal(problem.normalised_low, space.low)
    np.testing.assert_array_equal(problem.normalised_high, space.high)
    assert (ACTION_LOW, ACTION_HIGH) == (-1.0, 1.0) == (space.low.min(), space.high.max())
    continuous = ~problem.discrete
    assert problem.discrete.sum() == 2  # each wing's harmonic N
    np.testing.assert_allclose(
        normalised_to_physical(problem.normalised_low)[continuous],
        problem.physical_low[continuous],
    )
    np.testing.assert_allclose(
        normalised_to_physical(problem.normalised_high)[continuous],
        problem.physical_high[continuous],
    )
    assert problem.constraint_names == ("lift_violation", "thrust_violation", "power_violation")
    assert problem.has_margins and problem.objective_metric == "efficiency"
    assert problem.config.constraint_tolerance == 0.05  # the env's own config
    actions = _strokes(6, seed=3)
    one, other = problem.evaluate(actions, 1.0), vector.unwrapped.problem().evaluate(actions, 1.0)
    np.testing.assert_array_equal(one.objective, other.objective)
    np.testing.assert_array_equal(one.margins, other.margins)
    single.close()
    vector.close()


def test_bad_shapes_are_refused_naming_them():
    problem = gym.make(LEVEL_FLIGHT_ID, disable_env_checker=True).unwrapped.problem()
    with pytest.raises(ValueError, match=r"actions of shape \(28,\); allowed: \(B, 28\)"):
        problem.evaluate(np.zeros(28), 1.0)
    with pytest.raises(ValueError, match=r"conditions of shape \(3,\) for 2 strokes"):
        problem.evaluate(np.zeros((2, 28)), [1.0, 1.5, 2.0])
    with pytest.raises(ValueError, match="outside"):
        problem.evaluate(np.full((1, 28), 1.5), 1.0)


def test_a_task_without_margins_and_a_sequential_task():
    toy = _toy_task()
    problem = toy.CruiseVectorEnv(2, autoreset_mode="Disabled").problem()
    assert not problem.has_margins
    found = problem.evaluate(_strokes(2, seed=4), 1.0)
    assert found.margins is None and found.feasible.shape == (2,)
    with pytest.raises(ValueError, match=r"\['lift_deficit'\] declare no margin"):
        problem.differentiate(_strokes(1, seed=4), 1.0)
    speed_change = gym.make(SPEED_CHANGE_ID, disable_env_checker=True)
    with pytest.raises(TypeError, match="poses no one-stroke problem"):
        speed_change.unwrapped.problem()
    speed_change.close()
