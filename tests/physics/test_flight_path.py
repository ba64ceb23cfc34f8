"""The flight-path angle γ: the free stream comes along the body's velocity, forces stay in earth
axes. Only the stroke plane's angle to the path (β + γ) enters the flow, so turning the path and
the stroke plane together must turn the earth-axis forces as a rigid body and change nothing else.
"""

from __future__ import annotations

import numpy as np
import pytest

import tandem_env as te
from tandem_env import MeasuredWing, ModelOptions, evaluate, evaluate_measured, stroke_history
from tandem_env.physics.model import freestream_components
from tandem_env.physics.stroke import N_PER_WING, TABLE_4

#: The stroke-plane angle's column of each wing in a (B, 28) stroke.
BETA = [
    wing * N_PER_WING + i
    for wing in range(2)
    for i, p in enumerate(TABLE_4)
    if p.name == "stroke_plane_angle"
]


def random_strokes(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return te.normalised_to_physical(rng.uniform(-1.0, 1.0, (n, 28)))


def path_frame(result: te.Result, insect: te.Dragonfly = te.DRAGONFLY) -> np.ndarray:
    """Net force along and normal to the flight path [N], from the earth-axis cycle means."""
    fx = result.fore_horizontal_force + result.hind_horizontal_force
    fz = (result.fore_lift_to_weight + result.hind_lift_to_weight) * insect.weight
    g = result.flight_path_angle
    return np.stack([fx * np.cos(g) + fz * np.sin(g), -fx * np.sin(g) + fz * np.cos(g)])


def test_freestream_components_at_zero_path_angle_are_the_level_flight_ones() -> None:
    speed = np.array([0.0, 1.0, 2.5])
    beta = np.deg2rad(np.array([[5.0, 30.0], [10.0, 20.0], [25.0, 12.0]]))
    parts = freestream_components(speed, beta, np.zeros(3))
    # bit for bit: γ = 0 must reproduce the earlier V·cos β, V·sin β exactly
    assert np.array_equal(parts[:, :, 0], speed[:, None] * np.cos(beta))
    assert np.array_equal(parts[:, :, 1], speed[:, None] * np.sin(beta))


def test_freestream_is_the_body_velocity_in_stroke_plane_axes() -> None:
    """(V_t, V_n) = (x_s · u, z_s · u) for u = V(cos γ, 0, sin γ)."""
    beta, gamma, v = 0.3, -0.7, 1.7
    x_s = np.array([np.cos(beta), 0.0, -np.sin(beta)])
    z_s = np.array([np.sin(beta), 0.0, np.cos(beta)])
    u = v * np.array([np.cos(gamma), 0.0, np.sin(gamma)])
    parts = freestream_components(np.array([v]), np.array([[beta, beta]]), np.array([gamma]))
    assert parts[0, 0] == pytest.approx([x_s @ u, z_s @ u], abs=1e-15)


@pytest.mark.parametrize("split", ["sign", "body"])
def test_default_path_angle_is_level_flight(split: str) -> None:
    strokes = random_strokes(16, 1)
    options = ModelOptions(thrust_split=split)
    base = evaluate(strokes, 1.5, options=options)
    level = evaluate(strokes, 1.5, flight_path_angle=0.0, options=options)
    for name, arr in base.as_dict().items():
        assert np.array_equal(arr, getattr(level, name)), name


@pytest.mark.parametrize("speed", [0.8, 2.0])
@pytest.mark.parametrize("induction", ["coupled", "none"])
def test_turning_path_and_stroke_plane_together_rotates_the_forces_rigidly(
    speed: float, induction: str
) -> None:
    """β → β − δ, γ → γ + δ: the flow is unchanged, so the path-frame forces, the power and the
    angles of attack are unchanged while the earth-axis forces turn by δ."""
    strokes = random_strokes(24, 2)
    strokes[:, BETA] = 25.0
    delta = np.deg2rad(15.0)
    # the paper's (mean) reading: the vortex reading's wakes also see the roots' spacing and
    # drop, fixed to the body, which turning the stroke plane against the path moves
    options = ModelOptions(induction=induction, slipstream="mean")
    level = evaluate(strokes, speed, options=options)
    turned = strokes.copy()
    turned[:, BETA] = 25.0 - np.rad2deg(delta)
    climb = evaluate(turned, speed, flight_path_angle=delta, options=options)
    np.testing.assert_allclose(path_frame(climb), path_frame(level), rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(climb.power, level.power, rtol=1e-9)
    np.testing.assert_allclose(climb.mean_angle_of_attack, level.mean_angle_of_attack, rtol=1e-9)
    np.testing.assert_allclose(climb.fore_inflow, level.fore_inflow, rtol=1e-9, atol=1e-12)
    # and the earth-axis forces did turn: the vertical force changed by the rotation
    fx = level.fore_horizontal_force + level.hind_horizontal_force
    fz = level.lift_to_weight * te.DRAGONFLY.weight
    expected_lift = (fx * np.sin(delta) + fz * np.cos(delta)) / te.DRAGONFLY.weight
    np.testing.assert_allclose(climb.lift_to_weight, expected_lift, rtol=1e-9, atol=1e-12)


def test_hover_does_not_depend_on_the_path_angle() -> None:
    strokes = random_strokes(8, 3)
    hover = evaluate(strokes, 0.0)
    tilted = evaluate(strokes, 0.0, flight_path_angle=0.9)
    np.testing.assert_array_equal(hover.lift_to_weight, tilted.lift_to_weight)
    np.testing.assert_array_equal(hover.power, tilted.power)


def test_steady_wing_in_a_climb_turns_its_lift_and_drag_with_the_path() -> None:
    """A motionless wing (only the free stream moves past it): in a climb at γ with the stroke
    plane tilted by −γ, it meets the air exactly as in level flight, and its earth-axis force is
    the level-flight force turned by γ."""
    n, gamma = 64, np.deg2rad(30.0)
    zeros = np.zeros(n)
    pitch = np.full(n, np.deg2rad(60.0))

    def wings(beta: float) -> tuple[MeasuredWing, MeasuredWing]:
        return MeasuredWing(zeros, zeros, pitch, 40.0, beta), MeasuredWing(
            zeros, zeros, pitch, 40.0, beta
        )

    options = ModelOptions(induction="none")
    level = evaluate_measured(*wings(0.0), 2.0, options=options)
    climb = evaluate_measured(*wings(-gamma), 2.0, flight_path_angle=gamma, options=options)
    np.testing.assert_allclose(path_frame(climb), path_frame(level), rtol=1e-10, atol=1e-14)
    assert climb.lift_to_weight[0] != pytest.approx(level.lift_to_weight[0], rel=1e-3)


def test_body_drag_acts_along_the_path() -> None:
    """With thrust_split="body", D is the body drag's horizontal part and its vertical part
    counts against the lift."""
    strokes = random_strokes(4, 4)
    options = ModelOptions(thrust_split="body")
    gamma = 0.4
    level = evaluate(strokes, 2.0, options=options)
    climb = evaluate(strokes, 2.0, flight_path_angle=gamma, options=options)
    body = level.drag  # γ = 0: all of the body drag is horizontal
    np.testing.assert_allclose(climb.drag, body * np.cos(gamma), rtol=1e-12)
    wings = climb.fore_lift_to_weight + climb.hind_lift_to_weight
    np.testing.assert_allclose(
        climb.lift_to_weight, wings - body * np.sin(gamma) / te.DRAGONFLY.weight, rtol=1e-12
    )


def test_history_takes_the_path_angle_and_matches_evaluate() -> None:
    stroke = random_strokes(1, 5)[0]
    history = stroke_history(stroke, 1.2, flight_path_angle=0.3)
    direct = evaluate(stroke, 1.2, flight_path_angle=0.3)
    assert history.result.lift_to_weight[0] == direct.lift_to_weight[0]
    assert history.result.flight_path_angle[0] == 0.3


@pytest.mark.parametrize("bad", [2.0, -1.7, np.nan, np.inf])
def test_path_angle_outside_the_allowed_range_is_rejected(bad: float) -> None:
    with pytest.raises(ValueError, match=r"flight_path_angle.*allowed.*rad"):
        evaluate(random_strokes(1, 0), 1.0, flight_path_angle=bad)
