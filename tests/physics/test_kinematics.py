"""Kinematics (Eqs. 3-5): analytic derivatives, the time grid, limits, measured series."""

from __future__ import annotations

import numpy as np
import pytest

import tandem_env as te
from tandem_env import MeasuredWing, ModelOptions, evaluate, evaluate_measured
from tandem_env.physics import blade
from tandem_env.physics.cycle import fill_angle_batch
from tandem_env.physics.kinematics import (
    MAX_SWEEP_SHAPE,
    batched_angle_history,
    fill_angles,
    grid_phases,
    measured_angle_history,
    motion_grid,
    wing_params_radians,
)


def wing_params(
    seed: int, sweep_shape: float | None = None, pitch_shape: float | None = None
) -> np.ndarray:
    x = te.normalised_to_physical(np.random.default_rng(seed).uniform(-1, 1, 28))[:14]
    if sweep_shape is not None:
        x[10] = sweep_shape
    if pitch_shape is not None:
        x[12] = pitch_shape
    return wing_params_radians(x)


def angles_at(params: np.ndarray, t: np.ndarray) -> np.ndarray:
    out = np.empty((t.shape[0], 9))
    fill_angles(params, 2 * np.pi * params[0] * t, out)
    return out


EXTREMES = [(None, None), (1.0, None), (0.999, 5.0), (0.01, 0.01), (None, 5.0)]


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("sweep_shape, pitch_shape", EXTREMES)
def test_analytic_angle_derivatives_match_finite_differences(
    seed, sweep_shape, pitch_shape
) -> None:
    params = wing_params(seed, sweep_shape, pitch_shape)
    period = 1.0 / params[0]
    t = np.linspace(0.0, period, 397, endpoint=False) + 1e-4 * period
    h = 1e-7 * period
    a0, ap, am = angles_at(params, t), angles_at(params, t + h), angles_at(params, t - h)
    ap2, am2 = angles_at(params, t + 2 * h), angles_at(params, t - 2 * h)
    for col in (0, 3, 6):  # φ, θ, η
        # fourth-order central differences
        d1 = (am2[:, col] - 8 * am[:, col] + 8 * ap[:, col] - ap2[:, col]) / (12 * h)
        np.testing.assert_allclose(
            a0[:, col + 1], d1, rtol=0, atol=1e-6 * np.abs(a0[:, col + 1]).max() + 1e-9
        )
        d2 = (ap[:, col + 1] - am[:, col + 1]) / (2 * h)  # derivative of the analytic rate
        np.testing.assert_allclose(
            a0[:, col + 2], d2, rtol=0, atol=1e-5 * np.abs(a0[:, col + 2]).max() + 1e-6
        )
    assert np.all(np.isfinite(a0))


def frame_vectors(angles: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """e_s, e_c, e_n in stroke-plane axes, from the rotation R_z(−φ)·R_x(θ)·R_y(η) (numpy)."""
    phi, theta, eta = angles[:, 0], angles[:, 3], angles[:, 6]

    def rz(a):
        c, s = np.cos(a), np.sin(a)
        return np.array([[c, -s, 0 * c], [s, c, 0 * c], [0 * c, 0 * c, 1 + 0 * c]]).transpose(
            2, 0, 1
        )

    def rx(a):
        c, s = np.cos(a), np.sin(a)
        return np.array([[1 + 0 * c, 0 * c, 0 * c], [0 * c, c, -s], [0 * c, s, c]]).transpose(
            2, 0, 1
        )

    def ry(a):
        c, s = np.cos(a), np.sin(a)
        return np.array([[c, 0 * c, s], [0 * c, 1 + 0 * c, 0 * c], [-s, 0 * c, c]]).transpose(
            2, 0, 1
        )

    rot = rz(-phi) @ rx(theta) @ ry(eta)
    return rot[:, :, 1], rot[:, :, 2], rot[:, :, 0]


@pytest.mark.parametrize("seed", range(3))
def test_frame_rates_match_finite_differences(seed: int) -> None:
    """The angular-velocity formulas of ``blade`` against differences of the rotated frame."""
    params = wing_params(seed)
    period = 1.0 / params[0]
    t = np.linspace(0.0, period, 61, endpoint=False)
    h = 1e-6 * period
    coef = np.empty((t.shape[0], blade.N_COEF))
    blade.fill_frame_coefficients(
        angles_at(params, t), np.ones(t.shape[0]), params[13], False, 1, coef
    )
    (es, ec, en), (es_p, ec_p, en_p), (es_m, ec_m, en_m) = (
        frame_vectors(angles_at(params, t + d)) for d in (0.0, h, -h)
    )
    des = (es_p - es_m) / (2 * h)
    dec = (ec_p - ec_m) / (2 * h)
    den = (en_p - en_m) / (2 * h)
    dd_es = (es_p - 2 * es + es_m) / h**2
    scale = np.abs(des).max()
    np.testing.assert_allclose(np.cross(es, ec), en, atol=1e-12)  # right-handed
    np.testing.assert_allclose(coef[:, blade.C_AU], np.sum(des * ec, 1), atol=1e-6 * scale)
    np.testing.assert_allclose(coef[:, blade.C_AV], np.sum(des * en, 1), atol=1e-6 * scale)
    np.testing.assert_allclose(coef[:, blade.C_DECX], dec[:, 0], atol=1e-6 * scale)
    np.testing.assert_allclose(coef[:, blade.C_DENZ], den[:, 2], atol=1e-6 * scale)
    accel = np.sum(dd_es * ec, 1) + np.sum(des * dec, 1)
    np.testing.assert_allclose(coef[:, blade.C_BU], accel, atol=1e-4 * np.abs(accel).max())
    np.testing.assert_allclose(
        coef[:, blade.C_KIN], np.sum(des * dd_es, 1), atol=1e-4 * np.abs(accel).max() * scale
    )
    # the true spin about the span, ω·e_s = η̇ − φ̇·sin θ
    spin = np.empty_like(coef)
    blade.fill_frame_coefficients(
        angles_at(params, t), np.ones(t.shape[0]), params[13], True, 1, spin
    )
    a = angles_at(params, t)
    np.testing.assert_allclose(
        spin[:, blade.C_SPIN], a[:, 7] - a[:, 1] * np.sin(a[:, 3]), rtol=1e-12, atol=1e-9
    )


def test_sweep_shape_cap_changes_the_triangle_wave_by_less_than_half_a_percent_of_the_sweep() -> (
    None
):
    """K = 1 is capped at 1 − 10⁻⁴: φ moves by < 0.5 % of its peak-to-peak sweep 2φ_m (0.39 %;
    it is 0.78 % of φ_m, mostly through the normalisation by asin K)."""
    params = wing_params(0, sweep_shape=1.0)
    tau = np.linspace(0, 2 * np.pi, 10001)
    out = np.empty((tau.shape[0], 9))
    fill_angles(params, tau, out)
    x = tau + params[7]
    triangle = params[1] * np.arcsin(np.sin(x)) / (np.pi / 2) + params[4]
    assert np.abs(out[:, 0] - triangle).max() < 0.005 * 2 * params[1]
    assert MAX_SWEEP_SHAPE == 1.0 - 1e-4


@pytest.mark.parametrize("sweep_shape", [0.01, 0.9, 1.0])
def test_motion_following_grid_integrates_exactly(sweep_shape: float) -> None:
    physical = te.normalised_to_physical(np.random.default_rng(3).uniform(-1, 1, 28))[:14]
    physical[10] = sweep_shape
    angles = np.empty((1, 64, 9))
    weight = np.empty((1, 64))
    fill_angle_batch(1, wing_params_radians(physical[None, :]), 64, angles, weight)
    tau = motion_grid(wing_params_radians(physical[None, :]), 64)[0]
    assert weight.mean() == pytest.approx(1.0, rel=1e-12)
    assert np.all(np.diff(tau[0]) > 0) and np.all(weight > 0)
    # mean of φ over the cycle is φ_0; of θ is θ_0 (odd parts average out)
    assert np.mean(angles[0, :, 0] * weight[0]) == pytest.approx(np.deg2rad(physical[4]), abs=1e-12)
    assert np.mean(angles[0, :, 3] * weight[0]) == pytest.approx(np.deg2rad(physical[5]), abs=1e-12)
    # periodic motion: the mean rate is zero
    assert np.mean(angles[0, :, 1] * weight[0]) == pytest.approx(
        0.0, abs=1e-9 * np.abs(angles[0, :, 1]).max()
    )


@pytest.mark.parametrize("n_time", [63, 128])
def test_batched_angle_history_is_the_compiled_one_on_whole_arrays(n_time: int) -> None:
    """The angle history written once over an array namespace (the torch backend's kinematics)
    equals the compiled per-sample loop, extremes of K and C_η included: to rounding only, since
    numpy's vectorised arcsin and tanh are not libm's."""
    physical = te.normalised_to_physical(np.random.default_rng(5).uniform(-1, 1, (40, 28)))[:, :14]
    physical[:5, 10] = [1.0, 0.999, 0.01, 0.5, 1.0]
    physical[:5, 12] = [5.0, 0.01, 5.0, 0.01, 0.01]
    params = wing_params_radians(physical)
    angles = np.empty((physical.shape[0], n_time, 9))
    weight = np.empty((physical.shape[0], n_time))
    fill_angle_batch(
        len(params), params, n_time, angles, weight
    )  # the compiled kernel's, per sample
    got, got_weight, tau = batched_angle_history(params, n_time)
    np.testing.assert_array_equal(got_weight, weight)
    want_tau = np.empty(n_time)
    for b in range(physical.shape[0]):
        grid_phases(params[b], n_time, want_tau, np.empty(n_time))
        np.testing.assert_array_equal(tau[b], want_tau)
    for column in range(9):
        want = angles[:, :, column]
        np.testing.assert_allclose(got[column], want, rtol=0, atol=1e-13 * np.abs(want).max())


def test_spectral_derivatives_of_measured_series() -> None:
    params = wing_params(5, sweep_shape=0.5, pitch_shape=1.0)
    n = 256
    t = np.arange(n) / n / params[0]
    exact = angles_at(params, t)
    measured = measured_angle_history(exact[:, 0], exact[:, 3], exact[:, 6], params[0])
    for col in range(9):
        scale = np.abs(exact[:, col]).max()
        np.testing.assert_allclose(
            measured[:, col], exact[:, col], atol=1e-7 * scale, err_msg=str(col)
        )


def test_measured_kinematics_reproduce_the_parametric_model() -> None:
    physical = te.normalised_to_physical(np.random.default_rng(9).uniform(-1, 1, 28))
    physical[[10, 24]] = 0.5  # smooth enough for uniform sampling
    n = 256
    wings = []
    for w in range(2):
        params = wing_params_radians(physical[14 * w : 14 * w + 14])
        a = angles_at(params, np.arange(n) / n / params[0])
        wings.append(MeasuredWing(a[:, 0], a[:, 3], a[:, 6], params[0], params[13]))
    for speed in (0.0, 1.2):
        measured = evaluate_measured(*wings, speed)
        parametric = evaluate(physical, speed)
        for name in ("lift_to_weight", "thrust", "drag", "power", "mean_angle_of_attack"):
            assert getattr(measured, name)[0] == pytest.approx(
                getattr(parametric, name)[0], rel=2e-3
            ), name


def test_measured_wing_validation() -> None:
    z = np.zeros(32)
    with pytest.raises(ValueError, match="same length"):
        MeasuredWing(z, np.zeros(31), z, 40.0, 0.1)
    with pytest.raises(ValueError, match="frequency"):
        MeasuredWing(z, z, z, -40.0, 0.1)
    with pytest.raises(ValueError, match="non-finite"):
        MeasuredWing(np.full(32, np.nan), z, z, 40.0, 0.1)
    assert ModelOptions().n_time >= 64
