"""SpeedChange's motion: the integrator, the net force of a step, and the flight-path rotation."""

from __future__ import annotations

from dataclasses import replace

import gymnasium as gym
import numpy as np
import pytest

import tandem_env as te
from tandem_env.envs import SPEED_CHANGE_ID, SpeedChangeEnv
from tandem_env.envs.speed_change import (
    Flight,
    SpeedChangeCore,
    advance,
    body_drag,
    cycle_time,
    flight_path,
    net_force,
)
from tandem_env.envs.speed_change_config import SpeedChangeConfig
from tandem_env.physics.stroke import N_PER_WING, TABLE_4

BETA = [
    wing * N_PER_WING + i
    for wing in range(2)
    for i, p in enumerate(TABLE_4)
    if p.name == "stroke_plane_angle"
]


def test_no_force_and_no_velocity_moves_nothing() -> None:
    zeros = np.zeros(3)
    dt = np.array([0.02, 1.0 / 30.0, 1.0 / 45.0])
    u, w, x, h = advance(zeros, zeros, zeros, zeros, zeros, zeros, 121.9e-6, dt)
    for value in (u, w, x, h):
        np.testing.assert_array_equal(value, 0.0)


def test_velocity_changes_by_force_over_mass_times_cycle_time() -> None:
    rng = np.random.default_rng(0)
    u, w, x, h = rng.uniform(0.2, 2.0, 8), rng.normal(0, 0.3, 8), rng.random(8), rng.random(8)
    fx, fz = rng.normal(0, 1e-3, 8), rng.normal(0, 1e-3, 8)
    mass, dt = 121.9e-6, rng.uniform(1 / 45, 1 / 30, 8)
    u2, w2, x2, h2 = advance(u, w, x, h, fx, fz, mass, dt)
    np.testing.assert_allclose(u2 - u, fx / mass * dt, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(w2 - w, fz / mass * dt, rtol=1e-12, atol=1e-15)
    # positions: the trapezoidal rule on the velocity (exact for the constant force)
    np.testing.assert_allclose(h2 - h, 0.5 * (w + w2) * dt, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(x2 - x, 0.5 * (u + u2) * dt, rtol=1e-12, atol=1e-15)


def test_the_scheme_is_exact_for_a_constant_force() -> None:
    """Two half steps under the same force land where one whole step does: the position update
    is the exact solution for constant acceleration (explicit Euler on h would not be)."""
    u, w, x, h = np.array([1.0]), np.array([0.4]), np.array([0.0]), np.array([0.1])
    fx, fz, mass, dt = np.array([3e-4]), np.array([-8e-4]), 121.9e-6, np.array([0.03])
    whole = advance(u, w, x, h, fx, fz, mass, dt)
    half = advance(u, w, x, h, fx, fz, mass, dt / 2)
    halves = advance(*half, fx, fz, mass, dt / 2)
    for a, b in zip(whole, halves, strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-13, atol=1e-16)


def test_cycle_time_is_the_longer_wing_period() -> None:
    strokes = te.normalised_to_physical(np.zeros((3, 28)))
    strokes[:, 0], strokes[:, N_PER_WING] = [30.0, 45.0, 40.0], [45.0, 30.0, 40.0]
    np.testing.assert_array_equal(cycle_time(strokes), [1 / 30.0, 1 / 30.0, 1 / 40.0])


def _stepped(env: SpeedChangeEnv, action: np.ndarray, **options: float) -> dict:
    env.reset(seed=0, options=options)
    return env.step(action)[4]


@pytest.mark.parametrize("vertical_speed", [0.0, 0.35, -0.6])
def test_a_step_moves_the_body_by_the_net_force(vertical_speed: float) -> None:
    """u' − u = F_x/m·Δt with F = wings + body drag + weight, computed here from the model."""
    env = SpeedChangeEnv(start_speed=1.2, target_speed=1.5)
    insect = env.config.insect
    action = np.random.default_rng(3).uniform(-1, 1, 28)
    info = _stepped(env, action, vertical_speed=vertical_speed)
    physical = te.normalised_to_physical(action)[None]
    speed, gamma = np.hypot(1.2, vertical_speed), np.arctan2(vertical_speed, 1.2)
    result = te.evaluate(
        physical, speed, 90.0, flight_path_angle=gamma, insect=insect, options=env.config.options
    )
    drag = 0.5 * insect.air_density * speed**2 * insect.body_drag_area
    fx = result.fore_horizontal_force[0] + result.hind_horizontal_force[0] - drag * np.cos(gamma)
    lift = (result.fore_lift_to_weight[0] + result.hind_lift_to_weight[0]) * insect.weight
    fz = lift - drag * np.sin(gamma) - insect.weight
    dt = 1.0 / min(physical[0, 0], physical[0, N_PER_WING])
    assert info["cycle_time"] == pytest.approx(dt, rel=1e-15)
    assert info["force_horizontal"] == pytest.approx(fx, rel=1e-12)
    assert info["force_vertical"] == pytest.approx(fz, rel=1e-12)
    m = insect.body_mass
    assert info["forward_speed"] - 1.2 == pytest.approx(fx / m * dt, rel=1e-9)
    assert info["vertical_speed"] - vertical_speed == pytest.approx(fz / m * dt, rel=1e-9)
    assert info["altitude"] == pytest.approx(vertical_speed * dt + 0.5 * fz / m * dt**2, rel=1e-9)
    # thrust_split="body" (the env's default) reports exactly these net forces as F̄_h, F̄_v
    assert info["force_horizontal"] == pytest.approx(
        info["excess_horizontal"] * insect.weight, rel=1e-12
    )
    assert info["force_vertical"] == pytest.approx(
        info["excess_vertical"] * insect.weight, rel=1e-12, abs=1e-18
    )
    assert info["speed"] == speed and info["flight_path_angle"] == gamma
    assert info["energy"] == pytest.approx(result.power[0] * dt, rel=1e-15)


def _zero_horizontal_force_at_rest() -> tuple[np.ndarray, float]:
    """A stroke whose mean horizontal wing force at rest is 0 (bisection between two nearby
    lifting strokes of opposite sign) and its mean vertical wing force [N] (> 0)."""
    rng = np.random.default_rng(7)
    candidates = rng.uniform(-1, 1, (256, 28))
    candidates[:, [11, N_PER_WING + 11]] = 0.5  # same N on the whole segment (continuity)
    result = te.evaluate(te.normalised_to_physical(candidates), 0.0)
    fx = result.fore_horizontal_force + result.hind_horizontal_force
    lifting = result.lift_to_weight > 1.0
    a = candidates[np.flatnonzero(lifting & (fx > 0))[0]]
    pushing = candidates[lifting & (fx < 0)]
    b = pushing[np.argmin(np.linalg.norm(pushing - a, axis=1))]

    def force(t: float) -> te.Result:
        return te.evaluate(te.normalised_to_physical(a + t * (b - a)), 0.0)

    low, high = 0.0, 1.0
    for _ in range(60):
        mid = 0.5 * (low + high)
        r = force(mid)
        if r.fore_horizontal_force[0] + r.hind_horizontal_force[0] > 0:
            low = mid
        else:
            high = mid
    r = force(low)
    lift = (r.fore_lift_to_weight[0] + r.hind_lift_to_weight[0]) * te.DRAGONFLY.weight
    assert abs(r.fore_horizontal_force[0] + r.hind_horizontal_force[0]) < 1e-15, "no root"
    assert lift > 0, "the root does not lift; choose another pair"
    return a + low * (b - a), lift


def test_at_rest_a_stroke_with_no_net_force_moves_nothing() -> None:
    """At rest the body has no drag; a stroke whose horizontal wing force is 0, flown by an
    insect whose weight its lift just carries, leaves the body at rest."""
    action, lift = _zero_horizontal_force_at_rest()
    insect = replace(te.DRAGONFLY, gravity=lift / te.DRAGONFLY.body_mass)
    env = gym.make(
        SPEED_CHANGE_ID,
        insect=insect,
        speed_envelope=(0.0, 2.0),
        start_speed=0.0,
        target_speed=1.0,
        power_convention="elastic",  # any power: the cap must not matter for the motion
    )
    env.reset(seed=0)
    _, _, terminated, _, info = env.step(action)
    assert abs(info["force_horizontal"]) < 1e-15 and abs(info["force_vertical"]) < 1e-15
    # what is left is rounding: |F| < 1e-15 N moves 121.9 mg by < 3e-13 m/s in a cycle
    assert abs(info["forward_speed"]) < 1e-12 and abs(info["vertical_speed"]) < 1e-12
    assert abs(info["altitude"]) < 1e-14 and abs(info["distance"]) < 1e-14
    assert not terminated  # the residual horizontal force is >= 0 by the bisection


def test_turning_path_and_stroke_plane_together_rotates_the_forces_rigidly() -> None:
    """From a climb at γ = δ with every stroke plane turned by −δ, the body meets the air as in
    level flight: the aerodynamic force (net force less the weight) in path axes, the power and
    the cycle time are unchanged, and in earth axes the force turned by δ."""
    delta, speed = np.deg2rad(15.0), 1.3
    physical = te.normalised_to_physical(np.random.default_rng(5).uniform(-1, 1, 28))
    physical[BETA] = 25.0
    turned = physical.copy()
    turned[BETA] = 25.0 - np.rad2deg(delta)
    # the paper's (mean) reading: the vortex reading's wakes also see the roots' spacing and
    # drop, fixed to the body, which turning the stroke plane against the path moves
    options = te.ModelOptions(thrust_split="body", slipstream="mean")
    env = SpeedChangeEnv(start_speed=1.0, target_speed=1.0, options=options)
    weight = env.config.insect.weight
    level = _stepped(env, te.physical_to_normalised(physical), start_speed=speed)
    climb = _stepped(
        env,
        te.physical_to_normalised(turned),
        start_speed=speed * np.cos(delta),
        vertical_speed=speed * np.sin(delta),
    )
    assert climb["flight_path_angle"] == pytest.approx(delta, rel=1e-14)

    def path_axes(info: dict, gamma: float) -> np.ndarray:
        fx, fz = info["force_horizontal"], info["force_vertical"] + weight
        return np.array(
            [fx * np.cos(gamma) + fz * np.sin(gamma), -fx * np.sin(gamma) + fz * np.cos(gamma)]
        )

    np.testing.assert_allclose(path_axes(climb, delta), path_axes(level, 0.0), rtol=1e-9)
    assert climb["power"] == pytest.approx(level["power"], rel=1e-9)
    assert climb["cycle_time"] == level["cycle_time"]
    earth = np.array([level["force_horizontal"], level["force_vertical"] + weight])
    rotation = np.array([[np.cos(delta), -np.sin(delta)], [np.sin(delta), np.cos(delta)]])
    np.testing.assert_allclose(
        [climb["force_horizontal"], climb["force_vertical"] + weight], rotation @ earth, rtol=1e-9
    )


def test_body_drag_opposes_the_velocity() -> None:
    insect = te.DRAGONFLY
    assert body_drag(np.array([2.0]), insect)[0] == pytest.approx(
        0.5 * 1.225 * 4.0 * 12.5e-6, rel=1e-15
    )
    speed, gamma = flight_path(np.array([1.0, 0.0, 1.0]), np.array([0.0, 1.0, -1.0]))
    np.testing.assert_allclose(speed, [1.0, 1.0, np.sqrt(2.0)])
    np.testing.assert_allclose(gamma, [0.0, np.pi / 2, -np.pi / 4])
    # A stroke with the wings' forces removed: what is left is drag along −velocity, and weight.
    result = te.evaluate(
        te.normalised_to_physical(np.zeros((3, 28))), speed, flight_path_angle=gamma
    )
    zero = np.zeros(3)
    wingless = replace(
        result,
        fore_horizontal_force=zero,
        hind_horizontal_force=zero,
        fore_lift_to_weight=zero,
        hind_lift_to_weight=zero,
    )
    fx, fz = net_force(wingless, insect)
    drag = body_drag(speed, insect)
    np.testing.assert_allclose(fx, -drag * np.cos(gamma), atol=1e-18)
    np.testing.assert_allclose(fz + insect.weight, -drag * np.sin(gamma), atol=1e-18)


def test_an_envelope_where_one_step_is_not_resolved_is_refused() -> None:
    """A widened band let one step reverse the flight (19.9 -> -29 m/s); it is refused."""
    from tandem_env.envs.speed_change_config import MAX_BAND_SPEED

    wide = {"speed_envelope": (0.25, 20.0), "forward_speed_band": (0.0, 20.0)}
    with pytest.raises(
        ValueError, match=r"forward_speed_band = \(0.0, 20.0\) m/s; allowed: a band"
    ):
        gym.make("TandemWing/SpeedChange-v0", **wide)
    # What the refusal prevents: at speeds past the limit the zero-order hold overshoots.
    core = SpeedChangeCore(SpeedChangeConfig())
    actions = np.random.default_rng(0).uniform(-1.0, 1.0, (2048, 28))
    physical = te.normalised_to_physical(actions)
    flight = Flight.empty(2048)
    flight.forward_speed[:] = 19.9  # a state the refused envelope would have allowed
    after = core.step(physical, flight).after.forward_speed
    assert (after < 0.0).mean() > 0.5  # most strokes reverse the flight in one cycle
    # At the band's top all but a rare strong brake among the same strokes keep flying forward.
    flight.forward_speed[:] = MAX_BAND_SPEED
    after = core.step(physical, flight).after.forward_speed
    assert (after > 0.0).mean() > 0.99
    # A reset that would start the body beyond the limit is refused at reset, naming the option.
    env = gym.make("TandemWing/SpeedChange-v0")
    with pytest.raises(ValueError, match=r"reset option vertical_speed = 5.0; allowed"):
        env.reset(options={"vertical_speed": 5.0})
