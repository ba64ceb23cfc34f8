"""Span-wise pitch: η(r, t) at span stations, interpolated over the blade elements.

Each element has its own chord direction and rotation rate; the elements run one by one and
their force histories are summed (``measured.run_measured``). The tests pin the routing of an
untwisted table to the 1-D path, the decomposition against the whole-wing kernel, the local angle
of attack of a steady twisted wing, and the local rotation rate of a wing twisting in still air.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad

import tandem_env as te
from tandem_env import MeasuredWing, ModelOptions, evaluate_measured, measured_history
from tandem_env.physics import cycle, measured
from tandem_env.physics.model import wing_tables

STATIONS = [0.25, 0.5, 0.75]
#: A twisted wing takes the mean reading only (the convected and vortex readings follow a whole
#: wing's loading or lifting line; docs/measured.md).
MEAN = ModelOptions(slipstream="mean")


def series(amplitude: float, phase: float = 0.0) -> tuple:
    return (12.0, [(amplitude, 90.0 + phase), (0.0, 0.0), (0.2 * amplitude, 3 * (90.0 + phase))])


def twisted(amplitudes, phase: float = 0.0, n: int = 128) -> MeasuredWing:
    return MeasuredWing.from_fourier(
        40.0,
        (0.0, [(37.0, phase)]),
        (0.0, [(4.0, 90.0 + phase)]),
        [series(a, phase) for a in amplitudes],
        45.0,
        n_samples=n,
        pitch_stations=STATIONS,
    )


def test_equal_columns_are_the_one_dimensional_pitch_bit_for_bit() -> None:
    uniform = [twisted([54.0] * 3, phase) for phase in (0.0, 155.0)]
    plain = [
        MeasuredWing.from_fourier(
            40.0, (0.0, [(37.0, p)]), (0.0, [(4.0, 90.0 + p)]), series(54.0, p), 45.0, n_samples=128
        )
        for p in (0.0, 155.0)
    ]
    assert uniform[0].pitch.shape == (128, 3) and not uniform[0].twisted
    for induction in ("coupled", "none"):
        options = ModelOptions(induction=induction)
        a = evaluate_measured(*uniform, 1.5, options=options)
        b = evaluate_measured(*plain, 1.5, options=options)
        for name, arr in a.as_dict().items():
            assert np.array_equal(arr, getattr(b, name)), name


def test_element_by_element_evaluation_is_the_whole_wing_kernel() -> None:
    """Run every blade element alone (what a twisted wing does) with the same pitch everywhere:
    the cycle means, inflow and histories are the whole-wing kernel's to rounding."""
    insect, options = te.DRAGONFLY, MEAN
    fore, hind = twisted([54.0] * 3), twisted([54.0] * 3, 155.0)
    angles, weights, frequency, beta, sweep = measured.measured_inputs(fore, hind, insect, options)
    v, gamma = np.array([1.5]), np.array([0.1])
    whole = measured.run_measured(
        angles, weights, frequency, beta, sweep, v, gamma, insect, options, keep_history=True
    )
    per_element = [np.repeat(a, options.n_blade, axis=0) for a in angles]
    split = measured.run_measured(
        per_element, weights, frequency, beta, sweep, v, gamma, insect, options, keep_history=True
    )
    for a, b in zip(whole, split, strict=True):
        np.testing.assert_allclose(b, a, rtol=1e-12, atol=1e-13 * np.abs(a).max())


def test_station_interpolation_is_linear_and_held_beyond_the_ends() -> None:
    wing = twisted([40.0, 50.0, 70.0])
    at = wing.pitch_at(np.array([0.0, 0.25, 0.375, 0.5, 0.75, 1.0]))
    p = wing.pitch
    np.testing.assert_array_equal(at[:, 0], p[:, 0])
    np.testing.assert_array_equal(at[:, 1], p[:, 0])
    np.testing.assert_allclose(at[:, 2], 0.5 * (p[:, 0] + p[:, 1]), rtol=1e-14, atol=1e-15)
    np.testing.assert_array_equal(at[:, 4], p[:, 2])
    np.testing.assert_array_equal(at[:, 5], p[:, 2])


@pytest.mark.parametrize(
    "stations, tolerance",
    # kinks of α(r) at inner stations: the span quadrature converges algebraically (5.4e-5 at
    # 96 elements, about 5× smaller per doubling); a linear α over the whole span is smooth
    [([0.25, 0.5, 0.75], 2e-4), ([0.0, 1.0], 1e-12)],
)
def test_steady_twisted_wing_has_the_local_angle_of_attack_along_the_span(
    stations, tolerance: float
) -> None:
    """A motionless twisted wing in the free stream: every element meets the air at its own
    α(r) = 90° − η(r), so the lift is ½ρV²·∫c(r)·C_t·sin 2α(r) dr (integrated here by quad)."""
    n, speed = 32, 2.0
    alphas = np.linspace(10.0, 35.0, len(stations))  # [deg], washin towards the tip
    pitch = np.tile(np.deg2rad(90.0 - alphas), (n, 1))
    zeros = np.zeros(n)
    wing = MeasuredWing(zeros, zeros, pitch, 40.0, 0.0, pitch_stations=stations)
    options = ModelOptions(induction="none", n_blade=96)
    result = evaluate_measured(wing, wing, speed, options=options)
    insect = te.DRAGONFLY
    for name, geometry in (("fore", insect.fore), ("hind", insect.hind)):

        def lift(r_hat: float, geometry=geometry) -> float:
            alpha = np.deg2rad(np.interp(r_hat, stations, alphas))
            return float(geometry.chord(r_hat)) * np.sin(2 * alpha)

        integral, _ = quad(lift, 0.0, 1.0, points=stations, limit=200)
        q = 0.5 * insect.air_density * speed**2
        expected = 2 * q * geometry.translational_coefficient * geometry.length * integral
        got = getattr(result, f"{name}_lift_to_weight")[0] * insect.weight
        assert got == pytest.approx(expected, rel=tolerance)


def test_twisting_in_still_air_spins_each_element_at_its_own_rate() -> None:
    """Pitching about the span with no sweep and no flow: no element translates, so the only
    loads are the pitching moment's added inertia and damping, −I_a·Ω̇ − (πρc⁴/16)(μ₁f + μ₂|Ω|)Ω,
    with Ω = η̇(r) of each element, and the inertial power is Σ m'c²/12·Ω·Ω̇ dr."""
    n, f = 64, 40.0
    s = 2 * np.pi * np.arange(n) / n
    amplitudes = np.deg2rad([20.0, 45.0, 70.0])
    pitch = amplitudes[None, :] * np.sin(s)[:, None]
    zeros = np.zeros(n)
    wing = MeasuredWing(zeros, zeros, pitch, f, 0.0, pitch_stations=STATIONS)
    options = ModelOptions(induction="none")
    history = measured_history(wing, wing, 0.0, options=options)
    insect = te.DRAGONFLY
    for name, geometry in (("fore", insect.fore), ("hind", insect.hind)):
        nodes, _ = wing_tables(geometry, options.n_blade, insect.air_density)
        r_hat = nodes[:, cycle.N_R] / geometry.length
        local = np.interp(r_hat, STATIONS, amplitudes)  # amplitude of η at each element
        omega = 2 * np.pi * f
        spin = local[None, :] * omega * np.cos(s)[:, None]
        dspin = -local[None, :] * omega**2 * np.sin(s)[:, None]
        damping = nodes[:, cycle.N_DAMP] * (geometry.damping_linear * f)
        damping = damping + nodes[:, cycle.N_DAMP] * geometry.damping_quadratic * np.abs(spin)
        moment = -nodes[:, cycle.N_IA] * dspin - damping * spin
        aero = -(moment * spin) @ nodes[:, cycle.N_WIDTH]
        chord, width = nodes[:, cycle.N_CHORD], nodes[:, cycle.N_WIDTH]
        mass_per_span = geometry.mass * chord / (geometry.mean_chord * geometry.length)
        inertial = (spin * dspin) @ (mass_per_span * chord**2 / 12 * width)
        w = getattr(history, name)
        n_w = insect.wings_per_pair
        # the spectral derivatives of a pure sine are exact to rounding
        np.testing.assert_allclose(
            w.aero_power, n_w * aero, rtol=1e-9, atol=1e-12 * abs(aero).max()
        )
        np.testing.assert_allclose(
            w.inertial_power, n_w * inertial, rtol=1e-9, atol=1e-12 * abs(inertial).max()
        )
        assert np.abs(w.vertical_force).max() == 0.0


def test_twisted_left_wings_mirror_the_right() -> None:
    fore, hind = twisted([40.0, 54.0, 66.0], n=64), twisted([44.0, 54.0, 60.0], 155.0, n=64)
    right = measured_history(fore, hind, 1.0, options=MEAN)
    left = measured_history(fore, hind, 1.0, side=-1, options=MEAN)
    for name in ("fore", "hind"):
        r, l = getattr(right, name), getattr(left, name)
        np.testing.assert_allclose(l.vertical_force, r.vertical_force, rtol=1e-10, atol=1e-14)
        np.testing.assert_allclose(l.lateral_force, -r.lateral_force, rtol=1e-10, atol=1e-14)
    direct = evaluate_measured(fore, hind, 1.0, options=MEAN)
    assert right.result.lift_to_weight[0] == direct.lift_to_weight[0]
    np.testing.assert_allclose(right.fore.pitch, np.rad2deg(fore.pitch_at(0.75)), rtol=1e-14)


def test_twist_changes_the_forces() -> None:
    """Washout (the tip turned further) lowers the outer angle of attack and the lift."""
    base = evaluate_measured(twisted([54.0] * 3), twisted([54.0] * 3, 155.0), 1.5, options=MEAN)
    washout = evaluate_measured(
        twisted([44.0, 54.0, 64.0]), twisted([44.0, 54.0, 64.0], 155.0), 1.5, options=MEAN
    )
    assert washout.mean_angle_of_attack[0] < base.mean_angle_of_attack[0]
    assert washout.lift_to_weight[0] < base.lift_to_weight[0]


@pytest.mark.parametrize(
    "stations, message",
    [
        ([0.5, 0.25, 0.75], r"pitch_stations = \[0.5, 0.25, 0.75\] are not in order"),
        ([0.25, 0.5], r"pitch_stations has 2 entries but pitch has 3 column"),
        ([0.25, 0.5, 1.5], r"pitch_stations = .*allowed: r/R from 0 to 1"),
        (None, r"pitch has shape \(32, 3\).*pitch_stations is not given"),
    ],
)
def test_bad_stations_are_named(stations, message: str) -> None:
    z = np.zeros(32)
    with pytest.raises(ValueError, match=message):
        MeasuredWing(z, z, np.zeros((32, 3)), 40.0, 0.0, pitch_stations=stations)
