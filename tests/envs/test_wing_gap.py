"""The wings' gap as a constraint of every flight task (the insect's ``min_wing_gap``,
docs/model.md §5.8, *The wings meet*): absent, and every key and fingerprint as before, where the
flyer sets none; scored from the model's ``Result.wing_gap`` where it does."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import tandem_env as te
from tandem_env.envs import ACCELERATE_ID, LEVEL_FLIGHT_ID, SPEED_CHANGE_ID
from tandem_env.envs.reference import ConfigReference
from tandem_env.io.files import to_jsonable
from tandem_env.physics.clearance import wing_gap

SMALL = {"n_time": 32, "n_blade": 8}
# roots at one height: random strokes bring the wings within a millimetre, some through each other
LEVEL_ROOTS = {"root_drop": 0.0, "min_wing_gap": 1e-3}


def _actions(count: int, seed: int) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-1.0, 1.0, (count, 28))


@pytest.mark.parametrize("env_id", [LEVEL_FLIGHT_ID, ACCELERATE_ID, SPEED_CHANGE_ID])
def test_a_flyer_without_a_gap_has_no_such_constraint(env_id):
    env = gym.make(env_id, **SMALL)
    env.reset(seed=0)
    info = env.step(env.action_space.sample())[4]
    assert not {"wing_gap", "wing_gap_violation", "wing_gap_next", "wing_gap_next_violation"} & set(
        info
    )
    assert "min_wing_gap" not in to_jsonable(te.DRAGONFLY)  # the JSON a fingerprint hashes
    env.close()


def test_a_gap_is_another_problem_with_its_own_reference():
    plain = gym.make(LEVEL_FLIGHT_ID).unwrapped.config
    gapped = gym.make(LEVEL_FLIGHT_ID, insect={"min_wing_gap": 1e-3}).unwrapped.config
    assert ConfigReference(plain).series is not None
    assert ConfigReference(gapped).series is None  # the table is of the flyer without one


def test_the_gap_is_scored_from_the_models_distance():
    """The margins are gap / min_wing_gap − 1 at the least distance and at the next place the
    wings come close, each violation its negative part; strokes whose wings come within 1 mm
    are infeasible whatever else they do, the others keep their other constraints' verdict."""
    problem = gym.make(LEVEL_FLIGHT_ID, insect=LEVEL_ROOTS, **SMALL).unwrapped.problem()
    assert problem.constraint_names[-2:] == ("wing_gap_violation", "wing_gap_next_violation")
    actions = _actions(64, seed=2)
    found = problem.evaluate(actions, 1.0)
    gap, next_gap = found.result.wing_gap, found.result.wing_gap_next
    physical = te.normalised_to_physical(actions, problem.config.insect.stroke_bounds)
    np.testing.assert_array_equal(gap, wing_gap(physical, problem.config.insect))
    np.testing.assert_allclose(found.margins[:, -2], gap / 1e-3 - 1.0, rtol=1e-12)
    np.testing.assert_allclose(found.margins[:, -1], next_gap / 1e-3 - 1.0, rtol=1e-12)
    assert np.all(next_gap >= gap) and ((next_gap < 1e-3) & (gap < 1e-3)).any()
    close = gap < 1e-3
    assert 0 < close.sum() < len(close) and (gap < 1e-9).any()  # some touch, some cross
    assert not found.feasible[close].any()
    others = problem.declaration.score(found.result, problem.config).violations
    assert np.array_equal(others["wing_gap_violation"], np.maximum(0.0, 1.0 - gap / 1e-3))
    touching = np.maximum(0.0, 1.0 - next_gap / 1e-3)
    assert np.array_equal(others["wing_gap_next_violation"], touching)
    apart = gym.make(LEVEL_FLIGHT_ID, insect={"root_drop": 0.0}, **SMALL).unwrapped.problem()
    np.testing.assert_array_equal(
        found.feasible[~close], apart.evaluate(actions, 1.0).feasible[~close]
    )


def test_the_env_reports_the_gap_and_penalises_it():
    env = gym.make(LEVEL_FLIGHT_ID, insect=LEVEL_ROOTS, **SMALL)
    env.reset(seed=0, options={"speed": 1.0})
    for action in _actions(16, seed=2).astype(np.float32):
        info = env.step(action)[4]
        assert info["wing_gap_violation"] == pytest.approx(max(0.0, 1.0 - info["wing_gap"] / 1e-3))
        if info["wing_gap"] < 1e-3:
            assert not info["feasible"] and info["penalty"] > 0.0
        env.reset(options={"speed": 1.0})
    env.close()
