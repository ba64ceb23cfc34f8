"""Rewards: exactly the objective when feasible, objective − penalty otherwise."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import tandem_env as te
from tandem_env.envs import LevelFlightConfig, PenaltyConfig
from tandem_env.envs.level_flight import LevelFlightCore

LEVEL = "TandemWing/LevelFlight-v0"
ACCELERATE_ID = "TandemWing/Accelerate-v0"


def test_feasible_level_stroke_is_rewarded_with_exactly_its_efficiency(
    level_feasible_action,
) -> None:
    env = gym.make(LEVEL, speed=1.5)
    env.reset(seed=0)
    _, reward, _, _, info = env.step(level_feasible_action)
    direct = te.evaluate(te.normalised_to_physical(level_feasible_action), 1.5)
    assert info["feasible"] and info["constraint_violation"] == 0.0
    assert abs(direct.lift_to_weight[0] - 1.0) <= 0.02 and abs(direct.excess_horizontal[0]) <= 0.02
    assert reward == info["efficiency"] == direct.efficiency[0] == info["objective"]
    assert info["penalty"] == 0.0 and info["constraint_violation"] == 0.0
    assert 0.0 < reward < 1.0


def test_feasibility_does_not_depend_on_the_penalty_settings(level_feasible_action) -> None:
    env = gym.make(LEVEL, speed=1.5, penalty_weight=1000.0, penalty_offset=50.0)
    env.reset()
    _, reward, _, _, info = env.step(level_feasible_action)
    assert reward == info["efficiency"]


def test_infeasible_level_strokes_are_penalised_by_their_normalised_violation() -> None:
    weight, offset = 7.0, 0.5
    core = LevelFlightCore(
        LevelFlightConfig(speed=1.0, penalty=PenaltyConfig(weight=weight, offset=offset))
    )
    actions = np.random.default_rng(0).uniform(-1.0, 1.0, (256, 28))
    batch = core.step(te.normalised_to_physical(actions), np.full(256, 1.0))
    r = batch.result
    assert not batch.feasible.any()  # random strokes never fly level
    # The declared constraints, written out from the model's forces and power.
    violation = (
        np.maximum(0.0, np.abs(r.lift_to_weight - 1.0) - 0.02)
        + np.maximum(0.0, np.abs(r.excess_horizontal) - 0.02)
        + np.maximum(0.0, r.power_per_mass - 90.0) / 90.0
    )
    np.testing.assert_allclose(batch.scores.total, violation, rtol=1e-12, atol=0.0)
    np.testing.assert_allclose(batch.penalty, weight * violation + offset, rtol=1e-12)
    np.testing.assert_array_equal(batch.penalty, weight * batch.scores.total + offset)
    np.testing.assert_array_equal(batch.reward, r.efficiency - batch.penalty)
    assert np.all(batch.reward < batch.objective)
    # The penalty ranks infeasible strokes by how infeasible they are.
    order = np.argsort(violation)
    assert np.all(np.diff(batch.penalty[order]) >= 0.0)


def test_constraint_tolerance_moves_the_feasibility_band(level_feasible_action) -> None:
    env = gym.make(LEVEL, speed=1.5, constraint_tolerance=0.0)
    env.reset()
    _, reward, _, _, info = env.step(level_feasible_action)
    # L/W = 1.0037 misses L = W by 0.0037 once the tolerance is 0: a small, proportionate penalty.
    assert not info["feasible"]
    assert info["lift_violation"] == pytest.approx(abs(info["lift_to_weight"] - 1.0))
    assert reward == pytest.approx(info["efficiency"] - 10.0 * info["constraint_violation"])
    assert info["efficiency"] - 0.1 < reward < info["efficiency"]


@pytest.mark.parametrize(
    ("objective", "metric"),
    [
        ("vertical", "excess_vertical"),
        ("horizontal", "excess_horizontal"),
        ("resultant", "excess_total"),
    ],
)
def test_feasible_accelerate_stroke_is_rewarded_with_exactly_its_excess_force(
    objective: str, metric: str, accelerate_feasible_action
) -> None:
    env = gym.make(ACCELERATE_ID, objective=objective, available_power=60.0)
    env.reset()
    _, reward, _, _, info = env.step(accelerate_feasible_action)
    direct = te.evaluate(te.normalised_to_physical(accelerate_feasible_action), 0.0, 60.0)
    assert info["feasible"] and info["constraint_violation"] == 0.0
    assert direct.excess_vertical[0] >= 0.0 and direct.excess_horizontal[0] >= 0.0
    assert reward == info[metric] == getattr(direct, metric)[0] == info["objective"]
    assert reward > 0.0


def test_accelerate_power_above_the_available_power_is_penalised(
    accelerate_feasible_action,
) -> None:
    env = gym.make(ACCELERATE_ID, objective="vertical", available_power=50.0)
    env.reset()
    _, reward, _, _, info = env.step(accelerate_feasible_action)
    assert not info["feasible"]
    excess = (info["power_per_mass"] - 50.0) / 50.0
    assert info["constraint_violation"] == pytest.approx(excess)
    assert reward == pytest.approx(info["excess_vertical"] - 10.0 * excess)
    assert reward < info["objective"]


def test_accelerate_deficits_are_penalised() -> None:
    env = gym.make(ACCELERATE_ID, objective="resultant", available_power=90.0)
    env.reset(seed=0)
    _, reward, _, _, info = env.step(np.zeros(28, dtype=np.float32))
    assert info["horizontal_deficit"] > 0.0 or info["vertical_deficit"] > 0.0
    violation = (
        info["vertical_deficit"] + info["horizontal_deficit"] + info["power_violation"] / 90.0
    )
    assert info["constraint_violation"] == pytest.approx(violation)
    assert reward == pytest.approx(info["excess_total"] - 10.0 * violation)
    assert reward < info["excess_total"]
