"""The reference optima (tandem_env/data/reference_optima.json) and the normalised score.

The table is data made by ``python -m eval reference``; these tests check that it still
describes this model (its fingerprint is the defaults'), that every optimum it stores flies and
is what the model says of its stroke, that it covers the envelopes the issue asks for, and that
the envs score strokes against it as docs/reference.md says."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import tandem_env
from tandem_env.envs import ACCELERATE_ID, LEVEL_FLIGHT_ID
from tandem_env.envs.reference import (
    REFERENCE_GRID,
    default_fingerprint,
    load_reference_table,
    normalised_score,
    reference_series,
)
from tandem_env.envs.registration import config_class
from tandem_env.physics.insect import PLANFORMS

TABLE = load_reference_table()
SERIES = [(s.env_id, s.objective, s.planform) for s in TABLE.series]


def test_the_table_holds_every_series_of_the_grid():
    expected = {
        (env_id, objective, planform)
        for env_id, (objectives, _) in REFERENCE_GRID.items()
        for objective in objectives
        for planform in PLANFORMS
    }
    assert set(SERIES) == expected
    for series in TABLE.series:
        assert series.conditions == REFERENCE_GRID[series.env_id][1]


def test_the_grid_covers_the_envelopes_at_the_steps_asked_for():
    for env_id, step in ((LEVEL_FLIGHT_ID, 0.125), (ACCELERATE_ID, 5.0)):
        conditions = np.array(REFERENCE_GRID[env_id][1])
        low, high = config_class(env_id).CONDITION.envelope
        assert conditions[0] <= low and conditions[-1] >= high
        assert np.all(np.diff(conditions) <= step + 1e-12)


@pytest.mark.parametrize(("env_id", "objective", "planform"), SERIES)
def test_the_table_was_made_with_todays_defaults(env_id, objective, planform):
    # Fails when a default model option, the insect or a task's tolerance changes: regenerate
    # the table with `python -m eval reference` (docs/reference.md).
    series = reference_series(env_id, objective=objective, planform=planform)
    assert series.fingerprint == default_fingerprint(env_id, planform), (
        f"{env_id} {objective} {planform}: the reference table was made with other defaults; "
        "rerun `python -m eval reference`"
    )


@pytest.mark.parametrize(("env_id", "objective", "planform"), SERIES)
def test_every_stored_optimum_flies_and_replays_to_its_objective(env_id, objective, planform):
    series = reference_series(env_id, objective=objective, planform=planform)
    keyword = config_class(env_id).CONDITION.keyword
    kwargs = {"planform": planform}
    if config_class(env_id).OBJECTIVES.keyword is not None:
        kwargs["objective"] = objective
    env = gym.make(env_id, **kwargs)
    steps = []
    for point in series.points:
        env.reset(seed=0, options={keyword: point["condition"]})
        stroke = np.array(point["normalised_stroke"], dtype=np.float32)  # the action type
        _, reward, _, _, info = env.step(stroke)
        steps.append((reward, info))
    reward = np.array([r for r, _ in steps])
    info = {k: np.array([i[k] for _, i in steps]) for k in ("feasible", "objective", "score")}
    assert all(p["feasible"] for p in series.points)
    assert info["feasible"].all()
    np.testing.assert_allclose(info["objective"], series.objectives, rtol=1e-6)
    # so the env scores each optimum 100 (and a feasible stroke's reward is its objective)
    np.testing.assert_allclose(info["score"], 100.0, rtol=1e-6)
    np.testing.assert_allclose(reward, series.objectives, rtol=1e-6)
    # the optimum kept is the best of what was found for the point
    for point in series.points:
        found = [v for v in (*point["seed_objectives"], *point["continued_objectives"]) if v]
        assert max(found) <= point["objective"]


def test_reference_is_linear_between_grid_points_and_exact_on_them():
    series = reference_series(LEVEL_FLIGHT_ID)
    v, eta = np.array(series.conditions), np.array(series.objectives)
    assert tandem_env.reference(LEVEL_FLIGHT_ID, v[3]) == eta[3]
    middle = tandem_env.reference(LEVEL_FLIGHT_ID, 0.5 * (v[3] + v[4]))
    assert middle == pytest.approx(0.5 * (eta[3] + eta[4]), rel=1e-12)
    both = tandem_env.reference(LEVEL_FLIGHT_ID, v[:2])
    np.testing.assert_array_equal(both, eta[:2])


def test_reference_refuses_conditions_outside_the_grid_and_unknown_series():
    with pytest.raises(ValueError, match=r"outside the reference grid .* \[0.25, 2\]"):
        tandem_env.reference(LEVEL_FLIGHT_ID, 2.5)
    with pytest.raises(ValueError, match=r"outside the reference grid .* \[50, 90\]"):
        tandem_env.reference(ACCELERATE_ID, 45.0, objective="vertical")
    with pytest.raises(ValueError, match=r"no reference for .* objective 'sideways'"):
        tandem_env.reference(ACCELERATE_ID, 60.0, objective="sideways")
    with pytest.raises(ValueError, match="no reference for 'TandemWing/SpeedChange-v0'"):
        tandem_env.reference("TandemWing/SpeedChange-v0", 1.0)


def test_the_score_of_feasible_and_infeasible_strokes():
    score = normalised_score(
        reference_objective=[0.5, 0.5, 0.5, 0.5, np.nan],
        objective=[0.5, 0.25, 0.9, 0.9, 0.4],
        feasible=[True, True, False, False, True],
        violation=[0.0, 0.0, 0.003, 7.0, 0.0],
    )
    np.testing.assert_allclose(score[:4], [100.0, 50.0, -0.3, -100.0])
    assert np.isnan(score[4])


def test_the_env_reports_the_score_of_every_step():
    env = gym.make(ACCELERATE_ID, objective="horizontal", planform="real")
    env.reset(seed=3, options={"available_power": 62.5})
    _, _, _, _, info = env.step(env.action_space.sample())
    ref = tandem_env.reference(ACCELERATE_ID, 62.5, objective="horizontal", planform="real")
    expected = normalised_score(
        ref, info["objective"], info["feasible"], info["constraint_violation"]
    )
    assert info["score"] == pytest.approx(float(expected))
    assert info["score"] <= 0.0 or info["feasible"]


def test_an_env_the_table_does_not_describe_has_no_score():
    # another model resolution is another problem: its optimum is not the table's
    env = gym.make(LEVEL_FLIGHT_ID, n_time=32)
    env.reset(seed=0)
    _, _, _, _, info = env.step(env.action_space.sample())
    assert "score" not in info
    # and a condition outside the grid has no reference
    env = gym.make(LEVEL_FLIGHT_ID, speed=3.0, speed_envelope=(0.25, 4.0))
    env.reset(seed=0)
    _, _, _, _, info = env.step(env.action_space.sample())
    assert np.isnan(info["score"])


def test_the_split_alternates_and_trains_at_the_envelope_ends():
    from tandem_env.envs.reference import held_out_conditions, training_conditions

    for env_id, (_, grid) in REFERENCE_GRID.items():
        train, held = training_conditions(env_id), held_out_conditions(env_id)
        assert sorted(train + held) == list(grid)
        assert not set(train) & set(held)
        assert train[0] == grid[0] and train[-1] == grid[-1]
    assert held_out_conditions(ACCELERATE_ID) == (55.0, 65.0, 75.0, 85.0)


@pytest.mark.parametrize("planform", PLANFORMS)
def test_accelerating_optima_grow_with_the_power_and_the_resultant_bounds_its_parts(planform):
    # A stroke that flies at P_avail flies, with the same forces, at any higher P_avail (the
    # power only caps P/m), so the best known F̄ cannot fall as the power rises; and
    # F̄_a = |(F̄_v, F̄_h)| >= each part for the same stroke, so the best F̄_a is at least the
    # best F̄_v and the best F̄_h at the same power.
    best = {
        objective: np.array(
            reference_series(ACCELERATE_ID, objective=objective, planform=planform).objectives
        )
        for objective in ("vertical", "horizontal", "resultant")
    }
    for objective, values in best.items():
        assert np.all(np.diff(values) >= 0.0), (objective, values)
    assert np.all(best["resultant"] >= best["vertical"])
    assert np.all(best["resultant"] >= best["horizontal"])


def test_the_documented_table_is_the_packaged_one():
    # docs/reference.md renders docs/numbers/reference-table.json (python -m eval numbers
    # --only reference-table copies the package's table there): a stale copy fails here
    import json
    from pathlib import Path

    from tandem_env.envs.reference import reference_path

    stored = Path(__file__).resolve().parents[2] / "docs" / "numbers" / "reference-table.json"
    documented = json.loads(stored.read_text(encoding="utf-8"))
    packaged = json.loads(reference_path().read_text(encoding="utf-8"))
    assert documented["series"] == packaged["series"]
    assert documented["provenance"] == packaged["provenance"]


def test_score_strokes_scores_the_optima_100_and_agrees_with_the_env():
    from tandem_env.envs.reference import score_strokes

    series = reference_series(LEVEL_FLIGHT_ID)
    env = gym.make(LEVEL_FLIGHT_ID)
    problem = env.unwrapped.problem()
    strokes = np.array([p["normalised_stroke"] for p in series.points])
    conditions = np.array(series.conditions)
    np.testing.assert_allclose(score_strokes(problem, strokes, conditions), 100.0, rtol=1e-6)
    # a random stroke: what the env's step says of it
    rng = np.random.default_rng(0)
    stroke = rng.uniform(-1.0, 1.0, size=(1, strokes.shape[1]))
    env.reset(seed=0, options={"speed": 1.125})
    _, _, _, _, info = env.step(stroke[0].astype(np.float32))
    found = score_strokes(problem, stroke.astype(np.float32), [1.125])
    assert found[0] == pytest.approx(info["score"], rel=1e-9, abs=1e-9)
    # another problem (another resolution) has no table: NaN, not a score against it
    other = gym.make(LEVEL_FLIGHT_ID, n_time=32).unwrapped.problem()
    assert np.isnan(score_strokes(other, strokes[:1], conditions[:1])).all()
