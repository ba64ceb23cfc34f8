"""The slipstream readings (docs/model.md §5.3, §5.7): the invariance under a time shift of the
hind-wing, the limits in which the convected reading equals the mean one, its interpolation
and its convergence in n_time.

A time shift of the hind-wing by Δ moves its sweep and pitch phases by Δ and its elevation
phase by N·Δ (Eqs. 3-5: each angle is a function of τ + Φ, the elevation of N·τ + Φ_θ).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import tandem_env as te
from tandem_env.physics import cycle, model
from tandem_env.physics.bundle import WingStroke
from tandem_env.physics.kinematics import motion_grid
from tandem_env.physics.options import ModelOptions

MEAN = ModelOptions(slipstream="mean")
CONVECTED = ModelOptions(slipstream="convected")
HIND = 14
#: the hind-wing's sweep, elevation and pitch phases and its elevation harmonic N
SWEEP_PHASE, ELEVATION_PHASE, PITCH_PHASE, HARMONIC = HIND + 7, HIND + 8, HIND + 9, HIND + 11


def _wrap(degrees: np.ndarray) -> np.ndarray:
    return (np.asarray(degrees) + 180.0) % 360.0 - 180.0


def shift_hind(strokes: np.ndarray, delta: float) -> np.ndarray:
    """The strokes with the hind-wing's motion delayed by ``delta`` [deg] of its cycle."""
    out = np.array(strokes, dtype=float, copy=True)
    out[:, SWEEP_PHASE] = _wrap(out[:, SWEEP_PHASE] - delta)
    out[:, PITCH_PHASE] = _wrap(out[:, PITCH_PHASE] - delta)
    out[:, ELEVATION_PHASE] = _wrap(out[:, ELEVATION_PHASE] - out[:, HARMONIC] * delta)
    return out


def uvlm_case(lags) -> np.ndarray:
    """The issue's free-wake comparison: tear-drop wings, f = 37 Hz, sweep ±35°, pitch ±50°
    leading the sweep by 90°, β = 15°, the smallest elevation of Table 4, sinusoidal waveforms;
    the hind-wing lagging the fore-wing by each of ``lags`` [deg]."""
    # f, φ_m, θ_m, η_m, φ_0, θ_0, η_0, Φ_φ, Φ_θ, Φ_η, K, N, C_η, β
    wing = np.array([37.0, 35.0, 1.0, 50.0, 0.0, 5.0, 0.0, 0.0, 0.0, 90.0, 0.01, 1, 0.01, 15.0])
    stroke = np.concatenate([wing, wing])[None, :]
    return np.concatenate([shift_hind(stroke, lag) for lag in lags])


def _random_strokes(seed: int, batch: int = 8) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return te.normalised_to_physical(rng.uniform(-1.0, 1.0, (batch, 28)))


def _relative(a: np.ndarray, b: np.ndarray, floor: float = 1e-6) -> float:
    return float(np.max(np.abs(a - b) / np.maximum(np.abs(b), floor)))


# --- invariance under a time shift of the hind-wing ------------------------------------------
@pytest.mark.parametrize("speed", [0.0, 1.5])
@pytest.mark.parametrize("delta", [90.0, 180.0])
def test_mean_reading_is_blind_to_a_hind_time_shift(speed, delta):
    """Under "mean" the hind-wing sees a cycle-mean slipstream, so delaying it changes
    nothing (Δ a multiple of the grid's spacing: the shifted grid is the same grid)."""
    strokes = _random_strokes(3)
    base = te.evaluate(strokes, speed, options=MEAN).as_dict()
    moved = te.evaluate(shift_hind(strokes, delta), speed, options=MEAN).as_dict()
    for name, want in base.items():
        if want.dtype.kind == "f":
            assert _relative(moved[name], want) < 1e-10, name


@pytest.mark.parametrize("speed", [0.0, 1.5])
def test_convected_reading_sees_a_hind_time_shift(speed):
    """Under "convected" the same shift changes the hind-wing's forces (the fore-wing's stay)."""
    strokes = _random_strokes(3)
    base = te.evaluate(strokes, speed, options=CONVECTED)
    moved = te.evaluate(shift_hind(strokes, 90.0), speed, options=CONVECTED)
    np.testing.assert_allclose(moved.fore_lift_to_weight, base.fore_lift_to_weight, rtol=1e-10)
    change = np.abs(moved.hind_lift_to_weight - base.hind_lift_to_weight)
    # every stroke whose hind-wing feels a slipstream at all
    coupled = te.evaluate(strokes, speed, options=MEAN).hind_lift_to_weight
    isolated = te.evaluate(strokes, speed, options=replace(MEAN, induction="isolated"))
    felt = np.abs(coupled - isolated.hind_lift_to_weight) > 1e-3
    assert felt.sum() >= 4
    assert np.all(change[felt] > 1e-4), change


@pytest.mark.parametrize(
    ("options", "speed"),
    [
        (MEAN, 1.5),
        (CONVECTED, 1.5),
        (CONVECTED, 0.0),
        (replace(CONVECTED, induction="isolated"), 1.5),
        (replace(CONVECTED, induction="none"), 1.5),
        (replace(CONVECTED, interference=0.0), 1.5),
        (replace(CONVECTED, interference=2.0), 1.5),
        (replace(CONVECTED, hover_inflow="none"), 0.0),
        (replace(CONVECTED, hover_inflow="none"), 1.5),
        (replace(MEAN, hover_inflow="none"), 0.0),
    ],
    ids=[
        "mean",
        "convected",
        "convected-hover",
        "isolated",
        "none",
        "Chf=0",
        "Chf=2",
        "hover-none-hover",
        "hover-none-forward",
        "mean-hover-none-hover",
    ],
)
def test_phase_resolved_says_whether_a_hind_time_shift_changes_anything(options, speed):
    """``ModelOptions.phase_resolved`` (what the report's verdicts on the fore/hind phase rest
    on) is True exactly where delaying the hind-wing by 90° moves its forces beyond rounding."""
    strokes = _random_strokes(11)
    base = te.evaluate(strokes, speed, options=options).hind_lift_to_weight
    moved = te.evaluate(shift_hind(strokes, 90.0), speed, options=options).hind_lift_to_weight
    change = float(np.max(np.abs(moved - base)))
    assert (change > 1e-6) == options.phase_resolved(speed), (change, options)
    assert change > 1e-4 or change < 1e-10, change  # no case near the threshold


def test_hind_vertical_force_varies_with_the_lag_beyond_the_time_grid_error():
    """At the issue's stroke (V = 1 m/s), the hind-wing's cycle-mean vertical force over lags
    0-315° varies by far more than the time grid's error, shown by refinement (128 → 256)."""
    strokes = uvlm_case(np.arange(0.0, 360.0, 45.0))
    hind = te.evaluate(strokes, 1.0, options=CONVECTED).hind_lift_to_weight
    fine = te.evaluate(strokes, 1.0, options=replace(CONVECTED, n_time=256)).hind_lift_to_weight
    grid_error = np.max(np.abs(hind - fine))
    spread = hind.max() - hind.min()
    assert grid_error < 1e-6
    assert spread > 1e4 * grid_error and spread > 0.05, (spread, grid_error)
    # the mean reading has no spread at all
    flat = te.evaluate(strokes, 1.0, options=MEAN).hind_lift_to_weight
    assert np.ptp(flat) < 1e-12


def test_convected_reading_converges_in_n_time():
    """Spectral convergence of the convected reading on random strokes: doubling n_time from
    64 to 128 cuts the difference to a 256-sample run by a large factor."""
    strokes = _random_strokes(11, batch=6)
    speed = np.array([0.0, 0.5, 1.0, 1.5, 2.0, 1.0])
    runs = {
        n: te.evaluate(strokes, speed, options=replace(CONVECTED, n_time=n)).lift_to_weight
        for n in (64, 128, 256)
    }
    coarse = np.max(np.abs(runs[64] - runs[256]))
    default = np.max(np.abs(runs[128] - runs[256]))
    assert default < 5e-3
    assert default < 0.1 * coarse or default < 1e-8, (coarse, default)


# --- limits in which the readings agree -----------------------------------------------------
@pytest.mark.parametrize(
    "options",
    [
        replace(MEAN, induction="isolated"),
        replace(MEAN, induction="none"),
        replace(MEAN, interference=0.0),
    ],
    ids=["isolated", "none", "no interference"],
)
def test_readings_agree_without_a_slipstream(options):
    """With no slipstream on the hind-wing (coupling off, or C_hf = 0) both readings are the
    same, bit for bit."""
    strokes = _random_strokes(5)
    speed = np.array([0.0, 1.0] * 4)
    mean = te.evaluate(strokes, speed, options=options).as_dict()
    convected = te.evaluate(
        strokes, speed, options=replace(options, slipstream="convected")
    ).as_dict()
    for name, want in mean.items():
        np.testing.assert_array_equal(convected[name], want, err_msg=name)


def test_readings_agree_in_hover_without_hover_inflow():
    """``hover_inflow="none"`` gives a hovering wing no induced velocity: no slipstream either."""
    strokes = _random_strokes(6)
    options = replace(MEAN, hover_inflow="none")
    mean = te.evaluate(strokes, 0.0, options=options).as_dict()
    convected = te.evaluate(strokes, 0.0, options=replace(options, slipstream="convected"))
    for name, want in mean.items():
        np.testing.assert_array_equal(convected.as_dict()[name], want, err_msg=name)


def test_fore_wing_is_the_same_under_both_readings():
    """No hind → fore feedback (docs/model.md §5.7): the fore-wing's fields are identical."""
    strokes = _random_strokes(7)
    speed = np.array([0.0, 0.5, 1.0, 2.0] * 2)
    mean = te.evaluate(strokes, speed, options=MEAN)
    convected = te.evaluate(strokes, speed, options=CONVECTED)
    for name in mean.as_dict():
        if name.startswith("fore_"):
            np.testing.assert_array_equal(getattr(convected, name), getattr(mean, name), name)


def test_the_root_geometry_sets_the_delay():
    """Moving the hind-wing's root changes the convected reading (through the delay), never
    the mean one."""
    strokes = uvlm_case([0.0, 90.0])
    near = replace(te.DRAGONFLY, root_spacing=0.0, root_drop=0.0)
    for options, changes in ((MEAN, False), (CONVECTED, True)):
        a = te.evaluate(strokes, 1.0, options=options).hind_lift_to_weight
        b = te.evaluate(strokes, 1.0, options=options, insect=near).hind_lift_to_weight
        assert (np.max(np.abs(a - b)) > 1e-3) == changes


# --- the pieces -------------------------------------------------------------------------------
def test_convected_wake_is_the_shifted_linearised_momentum_fluctuation():
    """``cycle.convected_wake`` on a loading known in closed form, sampled on a strongly
    crowded motion-following grid (K = 0.9): it returns C_hf·(L(ψ − δ) − L̄)/(2ρφ_m·R²·V_m)
    at the hind-wing's phases to spectral accuracy."""
    n = 96
    params = np.zeros((2, 14))
    params[:, 10] = (0.9, 0.3)  # K: the two grids crowd differently
    params[:, 7] = (0.4, -1.1)  # Φ_φ: and at other reversals
    phases = motion_grid(params, n)[0]
    s = 2.0 * np.pi * np.arange(n) / n
    weight = 1.0 - params[0, 10] ** 2 * np.cos(2.0 * (s - (0.5 * np.pi - params[0, 7])))

    def loading(phase):
        return 2e-4 * (1.0 + np.cos(phase) + 0.5 * np.sin(3.0 * phase - 0.2))

    nodes, _ = model.wing_tables(te.DRAGONFLY.fore, 24, 1.225)
    rho, sweep, delay, interference = 1.225, 0.6, 0.7, 0.8
    v_normal = 1.0  # no induced velocity, no tangential flow: V_m = 1 m/s
    out = np.empty(n)
    fore = WingStroke(None, nodes, None, None, 0.0, sweep, 0.0, v_normal, weight, phases[0])
    settings = model.kernel_settings(
        replace(te.DRAGONFLY, air_density=rho), ModelOptions(interference=interference), n
    )
    cycle.convected_wake(loading(phases[0]), fore, phases[1], delay, np.zeros(24), settings, out)
    k_disc = 4.0 * rho * sweep * np.sum(nodes[:, cycle.N_R] * nodes[:, cycle.N_WIDTH])
    want = interference * (loading(phases[1] - delay) - 2e-4) / k_disc
    assert np.sqrt(np.mean((loading(phases[0]) - 2e-4) ** 2) / k_disc) < v_normal  # V_m = 1
    np.testing.assert_allclose(out, want, rtol=0, atol=1e-12 * np.abs(want).max())


def test_root_geometry_is_validated():
    for name in ("root_spacing", "root_drop"):
        for bad in (-1e-3, float("nan"), float("inf"), "9 mm"):
            with pytest.raises(ValueError, match=f"Dragonfly.{name}"):
                replace(te.DRAGONFLY, **{name: bad})
    with pytest.raises(ValueError, match="slipstream"):
        ModelOptions(slipstream="instant")


def test_measured_input_of_a_sampled_stroke_gives_the_same_convected_reading():
    """The stroke sampled at 200 uniform phases and given as measured kinematics (uniform
    samples, spectral derivatives) has the convected reading of the 28-parameter stroke (the
    motion-following grid): the phases of both grids enter the wake's Fourier series alike."""
    from tandem_env.physics import MeasuredWing, evaluate_measured
    from tandem_env.physics.kinematics import fill_angles, wing_params_radians

    physical = uvlm_case([90.0])[0]
    physical[[10, 24]] = 0.3  # a smooth weaving waveform
    n = 200
    wings = []
    for w in range(2):
        params = wing_params_radians(physical[14 * w : 14 * w + 14])
        a = np.empty((n, 9))
        fill_angles(params, 2 * np.pi * np.arange(n) / n, a)
        wings.append(MeasuredWing(a[:, 0], a[:, 3], a[:, 6], params[0], params[13]))
    measured = evaluate_measured(*wings, 1.0, options=CONVECTED)
    parametric = te.evaluate(physical, 1.0, options=CONVECTED)
    mean = te.evaluate(physical, 1.0, options=MEAN)
    assert abs(parametric.hind_lift_to_weight[0] - mean.hind_lift_to_weight[0]) > 1e-2
    for name in ("fore_lift_to_weight", "hind_lift_to_weight", "hind_power"):
        np.testing.assert_allclose(getattr(measured, name), getattr(parametric, name), rtol=1e-6)
