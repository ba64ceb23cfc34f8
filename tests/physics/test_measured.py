"""Measured kinematics in, forces out: input forms, conventions, flight path, histories, errors."""

from __future__ import annotations

import contextlib
import io
import math
import re
import warnings
from pathlib import Path

import numpy as np
import pytest

import tandem_env as te
from tandem_env import (
    MeasuredWing,
    ModelOptions,
    evaluate_measured,
    measured_history,
    stroke_history,
)
from tandem_env.physics.kinematics import fill_angles, wing_params_radians

W = te.DRAGONFLY.weight
#: A forward-flight stroke in the form a paper's table gives it (degrees): mean + harmonics.
SWEEP = (2.0, [(37.0, 0.0), (1.5, 40.0)])
ELEVATION = (1.0, [(4.0, 90.0)])
PITCH = (12.0, [(54.0, 90.0), (0.0, 0.0), (10.8, 270.0)])


def shifted(series, phase: float):
    """A series (mean, harmonics) [deg] advanced by ``phase`` [deg] of the cycle."""
    mean, harmonics = series
    return mean, [(a, p + k * phase) for k, (a, p) in enumerate(harmonics, start=1)]


def wing(phase: float = 0.0, beta: float = 45.0, n: int = 256) -> MeasuredWing:
    series = (shifted(s, phase) for s in (SWEEP, ELEVATION, PITCH))
    return MeasuredWing.from_fourier(40.0, *series, beta, n_samples=n)


def pair(beta: float = 45.0, n: int = 256) -> tuple[MeasuredWing, MeasuredWing]:
    return wing(0.0, beta, n), wing(155.0, beta, n)


def path_frame(result: te.Result) -> np.ndarray:
    """Net force along and normal to the flight path [N], from the earth-axis cycle means."""
    fx = result.fore_horizontal_force + result.hind_horizontal_force
    fz = (result.fore_lift_to_weight + result.hind_lift_to_weight) * W
    g = result.flight_path_angle
    return np.stack([fx * np.cos(g) + fz * np.sin(g), -fx * np.sin(g) + fz * np.cos(g)])


def assert_same(a: te.Result, b: te.Result) -> None:
    for name, arr in a.as_dict().items():
        assert np.array_equal(arr, getattr(b, name)), name


# --- input forms ---------------------------------------------------------------------------------


def fourier_by_hand(series, n: int) -> np.ndarray:
    """X(t) = mean + Σ a_k·cos(2πk·f·t + ψ_k) at t = i/(n·f), in degrees, converted to radians."""
    mean, harmonics = series
    t_f = np.arange(n) / n  # f·t
    x = np.full(n, mean)
    for k, (a, psi) in enumerate(harmonics, start=1):
        x = x + a * np.cos(2 * np.pi * k * t_f + np.deg2rad(psi))
    return np.deg2rad(x)


def test_fourier_input_at_256_points_equals_the_same_arrays_given_directly() -> None:
    fourier = pair()
    direct = []
    for w, phase in zip(fourier, (0.0, 155.0), strict=True):
        arrays = [fourier_by_hand(shifted(s, phase), 256) for s in (SWEEP, ELEVATION, PITCH)]
        for got, want in zip((w.sweep, w.elevation, w.pitch), arrays, strict=True):
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-13)
        direct.append(MeasuredWing(*arrays, 40.0, np.deg2rad(45.0)))
    for speed in (0.0, 1.5):
        a = evaluate_measured(*fourier, speed)
        b = evaluate_measured(*direct, speed)
        for name in ("lift_to_weight", "thrust", "drag", "power", "mean_angle_of_attack"):
            np.testing.assert_allclose(getattr(a, name), getattr(b, name), rtol=1e-10, err_msg=name)


def test_lists_are_accepted_wherever_arrays_are() -> None:
    fore, hind = pair(n=64)
    as_lists = MeasuredWing(
        fore.sweep.tolist(),
        list(fore.elevation),
        fore.pitch.tolist(),
        fore.frequency,
        fore.stroke_plane_angle,
    )
    assert isinstance(as_lists.sweep, np.ndarray) and not as_lists.sweep.flags.writeable
    assert_same(evaluate_measured(as_lists, hind, 1.0), evaluate_measured(fore, hind, 1.0))


def test_samples_with_time_stamps_open_or_closed_are_the_same_cycle() -> None:
    f, n = 40.0, 64
    w = wing(n=n)
    t = np.arange(n + 1) / (n * f) + 0.0123  # any start time
    closed = [np.rad2deg(np.append(a, a[0])) for a in (w.sweep, w.elevation, w.pitch)]
    from_closed = MeasuredWing.from_samples(t, *closed, 45.0, frequency=f)
    from_open = MeasuredWing.from_samples(t[:-1], *(a[:-1] for a in closed), 45.0, frequency=f)
    for a, b in ((from_closed, w), (from_open, w)):
        assert a.n_samples == n
        np.testing.assert_allclose(a.sweep, b.sweep, rtol=0, atol=1e-14)
        np.testing.assert_allclose(a.pitch, b.pitch, rtol=0, atol=1e-14)
    assert from_closed.stroke_plane_angle == pytest.approx(np.deg2rad(45.0), abs=1e-15)


# --- the flight path and the stroke plane -------------------------------------------------------


def test_flight_path_angle_zero_is_the_default_bit_for_bit() -> None:
    fore, hind = pair(n=128)
    assert_same(
        evaluate_measured(fore, hind, 1.2),
        evaluate_measured(fore, hind, 1.2, flight_path_angle=0.0),
    )


@pytest.mark.parametrize("induction", ["coupled", "none"])
def test_climb_with_the_stroke_plane_100_degrees_from_the_path(induction: str) -> None:
    """A 60° climb with the stroke planes 40° from the horizontal meets the air exactly as level
    flight with the stroke planes at 100° (past the vertical): path-frame forces, power and angles
    of attack are unchanged, and the earth-axis forces turn by 60°."""
    # the paper's (mean) reading: the vortex reading's wakes also see the roots' spacing and
    # drop, fixed to the body, which turning the stroke plane against the path moves
    options = ModelOptions(induction=induction, slipstream="mean")
    gamma = np.deg2rad(60.0)
    level = evaluate_measured(*pair(beta=100.0), 0.7, options=options)
    climb = evaluate_measured(*pair(beta=40.0), 0.7, flight_path_angle=gamma, options=options)
    np.testing.assert_allclose(path_frame(climb), path_frame(level), rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(climb.power, level.power, rtol=1e-9)
    np.testing.assert_allclose(climb.mean_angle_of_attack, level.mean_angle_of_attack, rtol=1e-9)
    fx = level.fore_horizontal_force + level.hind_horizontal_force
    fz = level.lift_to_weight * W
    np.testing.assert_allclose(
        climb.lift_to_weight, (fx * np.sin(gamma) + fz * np.cos(gamma)) / W, rtol=1e-9
    )
    assert abs(climb.lift_to_weight[0] - level.lift_to_weight[0]) > 0.05


def test_stroke_plane_angle_wraps_to_one_turn() -> None:
    z = np.zeros(16)
    assert MeasuredWing(z, z, z, 40.0, 0.3).stroke_plane_angle == 0.3  # unchanged in (−π, π]
    assert MeasuredWing(z, z, z, 40.0, math.pi).stroke_plane_angle == math.pi
    assert MeasuredWing(z, z, z, 40.0, -math.pi).stroke_plane_angle == pytest.approx(math.pi)
    assert MeasuredWing(z, z, z, 40.0, 1.5 * math.pi).stroke_plane_angle == pytest.approx(
        -0.5 * math.pi
    )
    # 100° and −260° are the same plane: the same forces to rounding
    a = evaluate_measured(*pair(beta=100.0, n=64), 1.0)
    b = evaluate_measured(*pair(beta=-260.0, n=64), 1.0)
    np.testing.assert_allclose(a.lift_to_weight, b.lift_to_weight, rtol=1e-12)
    np.testing.assert_allclose(a.thrust, b.thrust, rtol=1e-12)


# --- the sign of η ------------------------------------------------------------------------------


def test_flipped_pitch_sign_warns_and_loses_the_lift() -> None:
    fore, hind = pair(n=128)
    flipped = [
        MeasuredWing(w.sweep, w.elevation, -w.pitch, w.frequency, w.stroke_plane_angle)
        for w in (fore, hind)
    ]
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the right sign does not warn
        right = evaluate_measured(fore, hind, 1.5)
    with pytest.warns(UserWarning) as caught:
        wrong = evaluate_measured(*flipped, 1.5)
    messages = [str(w.message) for w in caught]
    for name in ("fore", "hind"):
        assert any(f"{name}-wing's pitch η runs against its sweep rate" in m for m in messages)
    assert right.lift_to_weight[0] > 0.5
    assert wrong.lift_to_weight[0] < 0.5 * right.lift_to_weight[0]


def test_a_wing_that_does_not_sweep_raises_no_pitch_warning() -> None:
    z = np.zeros(32)
    steady = MeasuredWing(z, z, np.full(32, 1.0), 40.0, 0.0)
    assert steady.pitch_sign_correlation() == 0.0


# --- histories ------------------------------------------------------------------------------------


def test_history_of_measured_input_matches_its_cycle_means() -> None:
    fore, hind = pair(n=128)
    history = measured_history(fore, hind, 1.5, flight_path_angle=0.2)
    direct = evaluate_measured(fore, hind, 1.5, flight_path_angle=0.2)
    assert_same(history.result, direct)
    for name in ("fore", "hind"):
        w = getattr(history, name)
        assert w.vertical_force.shape == (128,)
        assert np.mean(w.vertical_force) / W == pytest.approx(
            getattr(direct, f"{name}_lift_to_weight")[0], rel=1e-12
        )
        assert np.mean(w.horizontal_force) == pytest.approx(
            getattr(direct, f"{name}_horizontal_force")[0], rel=1e-12
        )
    thrust = sum(getattr(history, w).thrust_and_drag()[0] for w in ("fore", "hind"))
    drag = sum(getattr(history, w).thrust_and_drag()[1] for w in ("fore", "hind"))
    assert thrust == pytest.approx(direct.thrust[0], rel=1e-12)
    assert drag == pytest.approx(direct.drag[0], rel=1e-12)


def test_measured_history_of_a_sampled_stroke_is_the_stroke_history() -> None:
    """The 28-parameter stroke sampled at 200 uniform points and given as measured input has the
    histories of ``stroke_history`` (spectral instead of analytic derivatives)."""
    physical = te.normalised_to_physical(np.random.default_rng(4).uniform(-1, 1, 28))
    physical[[10, 24]] = 0.3  # a smooth weaving waveform (K), so 200 uniform samples resolve it
    physical[[12, 26]] = 0.5
    n = 200
    wings = []
    for w in range(2):
        params = wing_params_radians(physical[14 * w : 14 * w + 14])
        a = np.empty((n, 9))
        fill_angles(params, 2 * np.pi * np.arange(n) / n, a)
        wings.append(MeasuredWing(a[:, 0], a[:, 3], a[:, 6], params[0], params[13]))
    measured = measured_history(*wings, 1.0)
    reference = stroke_history(physical, 1.0, n_samples=n)
    for name in ("fore", "hind"):
        m, r = getattr(measured, name), getattr(reference, name)
        scale = np.abs(r.vertical_force).max()
        np.testing.assert_allclose(m.vertical_force, r.vertical_force, atol=1e-6 * scale)
        np.testing.assert_allclose(
            m.aero_power, r.aero_power, atol=1e-6 * np.abs(r.aero_power).max()
        )
        # α = atan(|v|/|u|) amplifies velocity errors where |U| is small (stroke reversal)
        np.testing.assert_allclose(m.angle_of_attack, r.angle_of_attack, atol=1e-4)


def test_left_wings_of_measured_input_mirror_the_right() -> None:
    fore, hind = pair(n=64)
    mean = ModelOptions(slipstream="mean")  # the mirror image is refused under the others
    right = measured_history(fore, hind, 1.0, options=mean)
    left = measured_history(fore, hind, 1.0, side=-1, options=mean)
    for name in ("fore", "hind"):
        r, l = getattr(right, name), getattr(left, name)
        np.testing.assert_allclose(l.vertical_force, r.vertical_force, rtol=1e-10, atol=1e-14)
        np.testing.assert_allclose(l.lateral_force, -r.lateral_force, rtol=1e-10, atol=1e-14)


# --- bad input -------------------------------------------------------------------------------------


@pytest.mark.parametrize("bad", [None, np.zeros(64), "fore", 3.0])
def test_a_wing_that_is_not_a_measured_wing_is_named(bad) -> None:
    _, hind = pair(n=64)
    with pytest.raises(ValueError, match=r"evaluate_measured: fore = .*allowed: a MeasuredWing"):
        evaluate_measured(bad, hind)
    with pytest.raises(ValueError, match=r"evaluate_measured: hind = .*allowed: a MeasuredWing"):
        evaluate_measured(hind, bad)


@pytest.mark.parametrize("bad", [None, "fast", {"n_blade": 8}])
def test_bad_options_and_insect_are_named(bad) -> None:
    fore, hind = pair(n=64)
    with pytest.raises(ValueError, match=r"options = .*allowed: a ModelOptions"):
        evaluate_measured(fore, hind, options=bad)
    with pytest.raises(ValueError, match=r"insect = .*allowed: a Dragonfly"):
        evaluate_measured(fore, hind, insect=bad)


def test_unequal_sample_counts_are_named() -> None:
    with pytest.raises(ValueError, match=r"fore has 64 samples per cycle and hind 60"):
        evaluate_measured(wing(n=64), wing(n=60))
    z = np.zeros(32)
    with pytest.raises(ValueError, match=r"elevation has 31 samples but sweep has 32"):
        MeasuredWing(z, np.zeros(31), z, 40.0, 0.1)
    with pytest.raises(ValueError, match=r"at least 8"):
        MeasuredWing(z[:4], z[:4], z[:4], 40.0, 0.1)


def test_non_finite_samples_are_located() -> None:
    z = np.zeros(32)
    bad = z.copy()
    bad[7] = np.nan
    with pytest.raises(ValueError, match=r"MeasuredWing.pitch has non-finite samples \(first at 7"):
        MeasuredWing(z, z, bad, 40.0, 0.1)
    with pytest.raises(ValueError, match="frequency"):
        MeasuredWing(z, z, z, -40.0, 0.1)


@pytest.mark.parametrize(
    "field, values, beta",
    [
        ("sweep", 35.0 * np.cos(np.linspace(0, 2 * np.pi, 32, endpoint=False)), 0.5),
        ("elevation", np.full(32, 5.0), 0.5),
        ("pitch", np.full(32, 60.0), 0.5),
        ("stroke_plane_angle", np.zeros(32), 55.0),
    ],
)
def test_degrees_given_as_radians_are_rejected(field: str, values: np.ndarray, beta: float) -> None:
    angles = {"sweep": np.zeros(32), "elevation": np.zeros(32), "pitch": np.zeros(32)}
    if field in angles:
        angles[field] = values
    with pytest.raises(ValueError, match=rf"MeasuredWing.{field}.*look like degrees.*deg2rad"):
        MeasuredWing(**angles, frequency=40.0, stroke_plane_angle=beta)


def test_fourier_amplitudes_in_degrees_with_degrees_false_are_rejected() -> None:
    with pytest.raises(ValueError, match=r"sweep has a mean or amplitude of 37 rad.*degrees=True"):
        MeasuredWing.from_fourier(40.0, SWEEP, ELEVATION, PITCH, 0.7, degrees=False)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"sweep": (0.0, [37.0, 0.0])}, r"sweep must be \(mean, \[\(amplitude_1, phase_1\)"),
        ({"sweep": 37.0}, r"sweep must be \(mean"),
        ({"pitch": (0.0, [(1.0, 0.0)] * 10), "n_samples": 16}, r"pitch\[0\] has 10 harmonics"),
        ({"n_samples": 4}, r"n_samples = 4; allowed: an integer >= 8"),
        ({"pitch_stations": [0.25, 0.75]}, r"with pitch_stations, pitch must be a list of series"),
    ],
)
def test_malformed_fourier_series_are_named(kwargs: dict, message: str) -> None:
    args = {"sweep": SWEEP, "elevation": ELEVATION, "pitch": PITCH} | kwargs
    n = args.pop("n_samples", 256)
    stations = args.pop("pitch_stations", None)
    with pytest.raises(ValueError, match=message):
        MeasuredWing.from_fourier(
            40.0, args["sweep"], args["elevation"], args["pitch"], 45.0, n_samples=n,
            pitch_stations=stations,
        )  # fmt: skip


def test_non_uniform_or_partial_time_samples_are_rejected() -> None:
    f, n = 40.0, 32
    t = np.arange(n) / (n * f)
    a = np.zeros(n)
    uneven = t.copy()
    uneven[5] += 0.2 / (n * f)
    with pytest.raises(ValueError, match=r"time is not uniform \(step 4"):
        MeasuredWing.from_samples(uneven, a, a, a, 0.0, frequency=f)
    with pytest.raises(ValueError, match=r"one cycle at frequency = 30 Hz"):
        MeasuredWing.from_samples(t, a, a, a, 0.0, frequency=30.0)
    with pytest.raises(ValueError, match=r"pitch has 31 samples but time has 32"):
        MeasuredWing.from_samples(t, a, a, a[:-1], 0.0, frequency=f)


def test_the_worked_example_in_the_docs_runs_and_prints_what_the_docs_say() -> None:
    text = (Path(__file__).resolve().parents[2] / "docs" / "measured.md").read_text()
    code = re.search(r"```python\n(.*?)```", text, re.DOTALL).group(1)
    printed = re.search(r"prints `([^`]*)`", text).group(1)
    out = io.StringIO()
    with contextlib.redirect_stdout(out), warnings.catch_warnings():
        warnings.simplefilter("error")
        exec(compile(code, "docs/measured.md", "exec"), {})
    assert out.getvalue().strip() == printed
