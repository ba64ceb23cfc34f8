"""Table 4 and the normalised map."""

from __future__ import annotations

import numpy as np
import pytest

import tandem_env as te
from tandem_env import Stroke
from tandem_env.physics.stroke import DISCRETE, LOWER, PARAMETER_NAMES, UPPER


def test_table_4_as_data() -> None:
    assert len(PARAMETER_NAMES) == 28
    assert PARAMETER_NAMES[0] == "fore_frequency" and PARAMETER_NAMES[14] == "hind_frequency"
    names = dict(zip(PARAMETER_NAMES, zip(LOWER, UPPER, strict=True), strict=True))
    assert names["fore_elevation_offset"] == (5.0, 30.0)
    assert names["hind_elevation_offset"] == (-30.0, 5.0)
    assert names["fore_pitch_amplitude"] == (1.0, 90.0)
    assert names["hind_stroke_plane_angle"] == (5.0, 30.0)
    assert names["fore_sweep_shape"] == (0.01, 1.0)
    assert names["hind_pitch_shape"] == (0.01, 5.0)


def test_normalised_map_is_linear_with_sign_rule_for_n() -> None:
    a = np.zeros(28)
    x = te.normalised_to_physical(a)
    continuous = ~DISCRETE
    np.testing.assert_allclose(x[continuous], 0.5 * (LOWER + UPPER)[continuous])
    assert np.all(x[DISCRETE] == 2.0)  # a = 0 is not < 0
    np.testing.assert_allclose(
        te.normalised_to_physical(-np.ones(28))[continuous], LOWER[continuous]
    )
    np.testing.assert_allclose(
        te.normalised_to_physical(np.ones(28))[continuous], UPPER[continuous]
    )
    a[DISCRETE] = -1e-9
    assert np.all(te.normalised_to_physical(a)[DISCRETE] == 1.0)


def test_round_trip_physical_normalised_physical() -> None:
    rng = np.random.default_rng(0)
    x = te.normalised_to_physical(rng.uniform(-1, 1, (100, 28)))
    np.testing.assert_allclose(
        te.normalised_to_physical(te.physical_to_normalised(x)), x, rtol=1e-12
    )


def test_named_stroke_round_trip() -> None:
    x = te.normalised_to_physical(np.random.default_rng(1).uniform(-1, 1, 28))
    stroke = Stroke.from_vector(x)
    np.testing.assert_array_equal(stroke.to_vector(), x)
    assert stroke.fore.frequency == x[0]
    assert isinstance(stroke.hind.elevation_harmonic, int)
    named = stroke.to_dict()
    assert list(named) == list(PARAMETER_NAMES)
    np.testing.assert_allclose(Stroke.from_normalised(stroke.to_normalised()).to_vector(), x)


@pytest.mark.parametrize(
    "index, value, message",
    [
        (0, 50.0, r"fore_frequency = 50 Hz is outside Table 4: allowed 30 to 45 Hz"),
        (19, 10.0, r"hind_elevation_offset = 10 deg is outside Table 4: allowed -30 to 5 deg"),
        (3, float("nan"), r"fore_pitch_amplitude = nan is not finite"),
        (25, 1.5, r"hind_elevation_harmonic = 1.5 must be exactly 1 or 2"),
    ],
)
def test_bad_physical_strokes_are_named(index: int, value: float, message: str) -> None:
    x = te.normalised_to_physical(np.zeros(28))
    x[index] = value
    with pytest.raises(ValueError, match=message):
        te.evaluate(x)


def test_bad_shapes_and_normalised_values() -> None:
    with pytest.raises(ValueError, match=r"shape \(28,\) or \(B, 28\)"):
        te.evaluate(np.zeros((3, 27)))
    with pytest.raises(ValueError, match="outside \\[-1, 1\\]"):
        te.normalised_to_physical(np.full(28, 1.5))
    with pytest.raises(ValueError, match="not finite"):
        te.normalised_to_physical(np.full(28, np.inf))
    with pytest.raises(ValueError, match="speed"):
        te.evaluate(te.normalised_to_physical(np.zeros(28)), speed=-1.0)
    with pytest.raises(
        ValueError, match=r"speed has shape \(3,\); allowed: a real number or a \(2,\) array"
    ):
        te.evaluate(te.normalised_to_physical(np.zeros((2, 28))), speed=np.ones(3))


def test_model_options_validated() -> None:
    with pytest.raises(
        ValueError, match="induction = 'on'; allowed: 'coupled', 'isolated', 'none'"
    ):
        te.ModelOptions(induction="on")
    with pytest.raises(ValueError, match="n_time"):
        te.ModelOptions(n_time=3)
    with pytest.raises(ValueError, match="thrust_split"):
        te.ModelOptions(thrust_split="component")
    with pytest.raises(ValueError, match="interference = 'high'; allowed: 0 to 2"):
        te.ModelOptions(interference="high")
    with pytest.raises(ValueError, match="n_blade"):
        te.ModelOptions(n_blade=True)
    assert te.ModelOptions(n_time=np.int64(64)).n_time == 64


def test_result_records_its_options_and_integer_sweep_counts() -> None:
    options = te.ModelOptions(thrust_split="body")
    result = te.evaluate(te.normalised_to_physical(np.zeros((2, 28))), 1.0, options=options)
    assert result.options.thrust_split == "body"
    assert result.planform == "tear-drop"
    assert "options" not in result.as_dict()
    row = result.row(0)
    assert isinstance(row["induction_evaluations"], int)
    assert isinstance(row["efficiency_above_one"], bool)


def test_bound_sides_flag_values_within_the_tolerance_of_a_bound() -> None:
    span = te.UPPER - te.LOWER
    inside = te.LOWER + 0.5 * span
    inside[[11, 25]] = 1.0  # N: discrete, never "at a bound"
    assert not te.bound_sides(inside).any() and te.describe_bounds(inside) == ""
    near = inside.copy()
    near[1] = te.LOWER[1] + 0.5 * te.BOUND_TOLERANCE * span[1]  # fore φ_m just above 30°
    near[27] = te.UPPER[27]  # hind β_m at 30°
    near[3] = te.LOWER[3] + 2.0 * te.BOUND_TOLERANCE * span[3]  # fore η_m: twice the tolerance
    near[7] = 180.0  # fore Φ_φ: a phase, periodic, so at no bound
    sides = te.bound_sides(np.stack([near, inside]))
    assert sides.shape == (2, 28) and not sides[1].any()
    assert {i: int(s) for i, s in enumerate(sides[0]) if s} == {1: -1, 27: 1}
    assert te.describe_bounds(near) == "fore_sweep_amplitude=lower; hind_stroke_plane_angle=upper"
