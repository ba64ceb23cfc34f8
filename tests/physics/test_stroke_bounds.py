"""A flyer's own stroke bounds: an insect may set the bounds of any of the 28 stroke
parameters (``Dragonfly.stroke_bounds``), Table 4's by default; the env's action map, the
optimisers' box, the model's checks, the at-bound reports and the reference scores follow,
and a flyer that keeps Table 4's bounds keeps its record keys."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import tandem_env as te
from agents.harness import run
from agents.jobs import Job
from tandem_env import MODEL_LIMITS, PARAMETER_NAMES, TABLE_4_BOUNDS, StrokeBounds
from tandem_env.envs.reference import ConfigReference
from tandem_env.io.files import to_jsonable
from tandem_env.physics.insect import DRAGONFLY, insect_mapping, load_insect
from tandem_env.physics.stroke import DISCRETE, LOWER, UPPER

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "scaled_dragonfly.yaml"
LEVEL = "TandemWing/LevelFlight-v0"
F_FORE, F_HIND = PARAMETER_NAMES.index("fore_frequency"), PARAMETER_NAMES.index("hind_frequency")
SLOW = {"stroke_bounds": {"fore_frequency": [20, 30], "hind_frequency": [20, 30]}}


def test_table_4_is_every_flyers_default() -> None:
    assert DRAGONFLY.stroke_bounds == TABLE_4_BOUNDS
    np.testing.assert_array_equal(TABLE_4_BOUNDS.lower_array, LOWER)
    np.testing.assert_array_equal(TABLE_4_BOUNDS.upper_array, UPPER)
    # a file or mapping that sets one field keeps Table 4's bounds
    assert load_insect({"body_mass": 2e-4}).stroke_bounds == TABLE_4_BOUNDS
    assert TABLE_4_BOUNDS.label == "Table 4" and MODEL_LIMITS.label == "the model's limits"


def test_bounds_as_data_round_trip() -> None:
    insect = load_insect(SLOW)
    assert insect_mapping(insect) == {
        "stroke_bounds": {"fore_frequency": [20.0, 30.0], "hind_frequency": [20.0, 30.0]}
    }
    assert load_insect(insect_mapping(insect)) == insect
    assert "fore_frequency = 20 to 30" in te.describe_insect(insect)
    # what differs is said; the other 26 keep Table 4's
    bounds = insect.stroke_bounds
    assert bounds.changes() == {"fore_frequency": [20.0, 30.0], "hind_frequency": [20.0, 30.0]}
    others = [i for i in range(28) if i not in (F_FORE, F_HIND)]
    np.testing.assert_array_equal(bounds.lower_array[others], LOWER[others])


@pytest.mark.parametrize(
    ("bounds", "message"),
    [
        ({"fore_frequency": [30, 20]}, r"insect\.stroke_bounds: fore_frequency bounds = \[30, 20\] "
         r"Hz; allowed: 1 <= low < high <= 1000 Hz \(what the model's equations take"),
        ({"hind_sweep_shape": [0.0, 1.0]}, r"hind_sweep_shape bounds = \[0, 1\]; allowed: 0\.01 <= "),
        ({"fore_stroke_plane_angle": [5, 120]}, r"fore_stroke_plane_angle bounds = \[5, 120\] deg"),
        ({"fore_elevation_harmonic": [1, 1]}, r"fore_elevation_harmonic bounds = \[1, 1\]; "
         r"allowed: \[1, 2\]"),
        ({"fore_freq": [20, 30]}, r"insect\.stroke_bounds\.fore_freq: unknown stroke parameter; "
         r"allowed: fore_frequency, "),
        ({"fore_frequency": 25}, r"insect\.stroke_bounds\.fore_frequency = 25; allowed: \[low, "
         r"high\], two numbers in Hz"),
        ({"fore_frequency": ["20", 30]}, r"fore_frequency = \['20', 30\]; allowed: \[low, high\]"),
        ({"fore_frequency": [float("nan"), 30]}, r"fore_frequency bounds = \[nan, 30\] Hz"),
        ("slow", r"insect\.stroke_bounds = 'slow'; allowed: a mapping of stroke parameter names"),
    ],
)  # fmt: skip
def test_bad_bounds_are_refused_naming_them(bounds: object, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        load_insect({"stroke_bounds": bounds})


def test_the_action_map_follows_the_flyers_bounds() -> None:
    bounds = load_insect(SLOW).stroke_bounds
    for a, expected in ((-1.0, 20.0), (0.0, 25.0), (1.0, 30.0)):
        x = te.normalised_to_physical(np.full(28, a), bounds)
        assert x[F_FORE] == x[F_HIND] == expected
        np.testing.assert_allclose(te.physical_to_normalised(x, bounds)[~DISCRETE], a)
    # the env's step maps its action onto them
    env = gym.make(LEVEL, insect=SLOW)
    env.reset(seed=0)
    info = env.step(-np.ones(28, dtype=np.float32))[4]
    assert info["stroke"]["fore_frequency"] == info["stroke"]["hind_frequency"] == 20.0
    assert env.action_space.low.min() == -1.0 and env.action_space.high.max() == 1.0
    default = gym.make(LEVEL)
    default.reset(seed=0)
    assert default.step(-np.ones(28, dtype=np.float32))[4]["stroke"]["fore_frequency"] == 30.0


def test_the_optimisers_box_is_the_flyers() -> None:
    problem = gym.make(LEVEL, insect=SLOW).unwrapped.problem()
    assert (problem.physical_low[F_FORE], problem.physical_high[F_FORE]) == (20.0, 30.0)
    assert (problem.physical_low[F_HIND], problem.physical_high[F_HIND]) == (20.0, 30.0)
    np.testing.assert_array_equal(gym.make(LEVEL).unwrapped.problem().physical_low, LOWER)
    # a search's strokes lie in that box: random search's, from 16 draws, all below 30 Hz
    (record,) = run("random", "level", 1.0, 16, [0], progress=False, env_kwargs={"insect": SLOW})
    for wing in ("fore", "hind"):
        assert 20.0 <= record.stroke[f"{wing}_frequency"] <= 30.0
    # and the record says which of the flyer's bounds its stroke sits at
    stroke = [record.stroke[name] for name in PARAMETER_NAMES]
    at = te.describe_bounds(stroke, load_insect(SLOW).stroke_bounds)
    assert record.summary_row()["at_bounds"] == at != te.describe_bounds(stroke)  # not Table 4
    # the autograd gradient maps onto the flyer's bounds too: it is the central difference of
    # the flyer's own objective (a wrong map, Table 4's, would differ by the range's ratio 10/15)
    point = np.full((1, 28), 0.1)
    exact = problem.differentiate(point, 1.0).objective_gradient[0, F_FORE]
    step = np.zeros((1, 28))
    step[0, F_FORE] = 1e-5
    plus, minus = (problem.evaluate(point + s, 1.0).objective[0] for s in (step, -step))
    assert exact == pytest.approx((plus - minus) / 2e-5, rel=1e-5)


def test_the_model_checks_the_flyers_bounds() -> None:
    stroke = te.normalised_to_physical(np.zeros(28))
    stroke[[F_FORE, F_HIND]] = 22.0
    with pytest.raises(ValueError, match=r"fore_frequency = 22 Hz is outside Table 4: allowed 30"):
        te.evaluate(stroke, 1.0)
    slow = load_insect(SLOW)
    assert np.isfinite(te.evaluate(stroke, 1.0, insect=slow).efficiency).all()
    stroke[F_FORE] = 37.5
    with pytest.raises(
        ValueError, match=r"37\.5 Hz is outside the insect's stroke bounds: allowed 20 to 30 Hz"
    ):
        te.evaluate(stroke, 1.0, insect=slow)
    with pytest.raises(ValueError, match="outside the model's limits: allowed 1 to 1000 Hz"):
        te.validate_physical(np.where(np.arange(28) == F_FORE, 2000.0, stroke))
    # which bound a stroke sits at is the flyer's
    stroke[F_FORE] = 20.0
    assert "fore_frequency=lower" in te.describe_bounds(stroke, slow.stroke_bounds)
    assert te.bound_sides(stroke, slow.stroke_bounds)[F_FORE] == -1


def test_table_4_bounds_keep_keys_fingerprints_and_scores() -> None:
    same = load_insect({"stroke_bounds": {"fore_frequency": [30.0, 45.0]}})  # Table 4's own
    assert same == DRAGONFLY and insect_mapping(same) == {}
    assert "stroke_bounds" not in to_jsonable(DRAGONFLY)  # the JSON a fingerprint hashes
    spec = Job("pso", "level", 1.0, 64, 0)
    assert Job("pso", "level", 1.0, 64, 0, env_kwargs={"insect": same}).key == spec.key
    foreign = Job("pso", "level", 1.0, 64, 0, env_kwargs={"insect": SLOW})
    assert foreign.key != spec.key
    # the reference table scores the paper's flyer, not one with foreign bounds
    assert ConfigReference(gym.make(LEVEL).unwrapped.config).series is not None
    assert ConfigReference(gym.make(LEVEL, insect=SLOW).unwrapped.config).series is None


def test_the_scaled_example_has_bounds_that_suit_it() -> None:
    insect = load_insect(EXAMPLE)
    assert insect.stroke_bounds.changes() == {
        "fore_frequency": [20.0, 36.74],
        "hind_frequency": [20.0, 36.74],
    }
    # Table 4's 30-45 Hz at 1.5 times the length, the YAML's reasoning: the lowest by f ∝ 1/L,
    # the highest by f ∝ L^-1/2
    scale = insect.fore.length / DRAGONFLY.fore.length
    bounds = insect.stroke_bounds
    for f in (F_FORE, F_HIND):
        np.testing.assert_allclose(bounds.lower_array[f] * scale, 30.0, rtol=1e-3)
        np.testing.assert_allclose(bounds.upper_array[f] * scale**0.5, 45.0, rtol=1e-3)


def test_stroke_bounds_are_a_value() -> None:
    bounds = StrokeBounds(tuple(LOWER), tuple(UPPER))
    assert bounds == TABLE_4_BOUNDS and hash(bounds) == hash(TABLE_4_BOUNDS)
    with pytest.raises(ValueError, match=r"StrokeBounds\.lower has shape"):
        StrokeBounds(tuple(LOWER[:27]), tuple(UPPER))


def test_a_studys_pinned_parameters_are_at_the_flyers_bounds() -> None:
    from eval.studies.tables import pinned, row_bounds

    stroke = te.normalised_to_physical(np.zeros(28))
    stroke[[F_FORE, F_HIND]] = 30.0  # Table 4's lower bound, the slow flyer's upper one
    row = {"feasible": True, **dict(zip(PARAMETER_NAMES, stroke.tolist(), strict=True))}
    assert pinned([row], "frequency") == "lower"
    own = {**row, "stroke_bounds": SLOW["stroke_bounds"]}
    assert row_bounds(own) == load_insect(SLOW).stroke_bounds
    assert pinned([own], "frequency") == "upper"
    as_csv = {**row, "stroke_bounds": '{"fore_frequency": [20, 30], "hind_frequency": [20, 30]}'}
    assert pinned([as_csv], "frequency") == "upper"
