"""Wing kinematics (Eqs. 3-5) with exact first and second time derivatives, and the time grid.

All angles are in radians and derivatives are with respect to physical time [rad/s, rad/s²].
The functions are numba-compiled for scalars (:func:`fill_angle_history`, one wing's cycle);
:func:`batched_angle_history` runs the same functions elementwise on whole numpy or torch arrays
(``xp.on_namespace``): the torch backend's kinematics.

Time grid (docs/model.md §3). The cycle phase τ = 2πft is not sampled uniformly: with K → 1 the
weaving angle becomes a triangle wave whose acceleration is a narrow spike at the reversals, and
uniform samples would need thousands of points to integrate it. We sample a smooth periodic
change of variable, τ(s) = s − (λ/2)·sin 2(s − s_r), uniformly in s; its density
dτ/ds = 1 − λ·cos 2(s − s_r) is smallest at the reversals s_r (where sin(τ + Φ_φ) = ±1), so
samples crowd there, and every integrand stays analytic and periodic in s, which keeps the
trapezoid rule spectrally accurate. λ = K² switches the crowding on only where the weaving
waveform is sharp. K itself is capped at 1 − 10⁻⁴ (``MAX_SWEEP_SHAPE``), which keeps φ̈ finite
and moves φ by at most 0.39 % of the peak-to-peak sweep 2φ_m (0.78 % of φ_m).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit

from .stroke import ANGULAR, N_PER_WING
from .xp import NUMPY, ArrayNamespace, on_namespace

MAX_SWEEP_SHAPE = 1.0 - 1e-4
"""Cap on K: at K = 1 exactly φ̈ is infinite at the reversals (docs/model.md §3)."""

#: Columns of an angle history: φ, φ̇, φ̈, θ, θ̇, θ̈, η, η̇, η̈.
ANGLE_COLUMNS = ("phi", "dphi", "ddphi", "theta", "dtheta", "ddtheta", "eta", "deta", "ddeta")


@njit(cache=True)
def weaving(tau, omega, amplitude, offset, phase, shape):
    """Weaving (sweep) angle φ of Eq. 3 and its time derivatives.

    φ = φ_m/asin(K)·asin(K·sin x) + φ_0 with x = τ + Φ_φ, τ = ωt, ω = 2πf [rad/s].
    Returns (φ [rad], φ̇ [rad/s], φ̈ [rad/s²]).
    """
    k = np.minimum(shape, MAX_SWEEP_SHAPE)
    return weaving_scaled(tau, omega, amplitude / np.arcsin(k), k, offset, phase)


@njit(cache=True)
def weaving_scaled(tau, omega, scale, k, offset, phase):
    """:func:`weaving` with its scale φ_m/asin(K) [rad] and its capped K known (the same
    operations; a loop over the samples of one stroke computes them once)."""
    x = tau + phase
    sx = np.sin(x)
    cx = np.cos(x)
    q = 1.0 - k * k * sx * sx
    root = np.sqrt(q)
    phi = scale * np.arcsin(k * sx) + offset
    dphi = omega * scale * k * cx / root
    # d²/dτ² asin(K sin x) = K (K² − 1) sin x / (1 − K² sin² x)^{3/2}
    ddphi = omega * omega * scale * k * (k * k - 1.0) * sx / (q * root)
    return phi, dphi, ddphi


@njit(cache=True)
def flapping(tau, omega, amplitude, offset, phase, harmonic):
    """Flapping (elevation) angle θ of Eq. 4: θ = θ_m·cos(Nτ + Φ_θ) + θ_0, and derivatives."""
    x = harmonic * tau + phase
    theta = amplitude * np.cos(x) + offset
    dtheta = -omega * harmonic * amplitude * np.sin(x)
    ddtheta = -omega * omega * harmonic * harmonic * amplitude * np.cos(x)
    return theta, dtheta, ddtheta


@njit(cache=True)
def pitching(tau, omega, amplitude, offset, phase, shape):
    """Pitch angle η of Eq. 5: η = η_m/tanh(C_η)·tanh(C_η·sin y) + η_0, y = τ + Φ_η."""
    return pitching_scaled(tau, omega, amplitude / np.tanh(shape), offset, phase, shape)


@njit(cache=True)
def pitching_scaled(tau, omega, scale, offset, phase, shape):
    """:func:`pitching` with its scale η_m/tanh(C_η) [rad] known (the same operations; a loop
    over the samples of one stroke computes it once)."""
    y = tau + phase
    sy = np.sin(y)
    cy = np.cos(y)
    z = shape * sy
    tz = np.tanh(z)
    sech2 = 1.0 - tz * tz
    eta = scale * tz + offset
    deta = omega * scale * shape * cy * sech2
    ddeta = omega * omega * scale * shape * sech2 * (-sy - 2.0 * shape * cy * cy * tz)
    return eta, deta, ddeta


@njit(cache=True)
def phase_grid(s, reversal, crowding):
    """Phase τ(s) = s − (λ/2)·sin 2(s − s_r) and its density dτ/ds (see module docstring)."""
    d = 2.0 * (s - reversal)
    return s - 0.5 * crowding * np.sin(d), 1.0 - crowding * np.cos(d)


@njit(cache=True)
def fill_angles(wing_params, tau, out_angles):
    """φ, φ̇, φ̈, θ, θ̇, θ̈, η, η̇, η̈ of one wing at the phases ``tau`` = 2πft [rad].

    ``wing_params``: 14 parameters in Hz/rad/- (the order of Table 4); writes (n, 9).
    """
    omega = 2.0 * math.pi * wing_params[0]
    # the waveforms' scales once per wing, not per sample (libm calls the compiler keeps)
    sweep_shape = np.minimum(wing_params[10], MAX_SWEEP_SHAPE)
    sweep_scale = wing_params[1] / np.arcsin(sweep_shape)
    pitch_shape = wing_params[12]
    pitch_scale = wing_params[3] / np.tanh(pitch_shape)
    for k in range(tau.shape[0]):
        phi, dphi, ddphi = weaving_scaled(
            tau[k], omega, sweep_scale, sweep_shape, wing_params[4], wing_params[7]
        )
        theta, dtheta, ddtheta = flapping(
            tau[k], omega, wing_params[2], wing_params[5], wing_params[8], wing_params[11]
        )
        eta, deta, ddeta = pitching_scaled(
            tau[k], omega, pitch_scale, wing_params[6], wing_params[9], pitch_shape
        )
        out_angles[k, 0] = phi
        out_angles[k, 1] = dphi
        out_angles[k, 2] = ddphi
        out_angles[k, 3] = theta
        out_angles[k, 4] = dtheta
        out_angles[k, 5] = ddtheta
        out_angles[k, 6] = eta
        out_angles[k, 7] = deta
        out_angles[k, 8] = ddeta


@njit(cache=True)
def grid_phases(wing_params, n_time, out_tau, out_weight):
    """Phases τ_k and weights dτ/ds of the motion-following grid of one wing (n_time samples)."""
    k_shape = min(wing_params[10], MAX_SWEEP_SHAPE)
    crowding = k_shape * k_shape
    reversal = 0.5 * math.pi - wing_params[7]
    for k in range(n_time):
        s = 2.0 * math.pi * k / n_time
        tau, w = phase_grid(s, reversal, crowding)
        out_tau[k] = tau
        out_weight[k] = w


@njit(cache=True)
def fill_angle_history(wing_params, n_time, out_angles, out_weight):
    """Angle history of one wing over one cycle on the motion-following grid.

    Writes ``out_angles[k, :]`` (φ, φ̇, φ̈, θ, θ̇, θ̈, η, η̇, η̈) and ``out_weight[k]`` = dτ/ds at
    the k-th sample, so that a cycle mean is Σ_k g_k·w_k / n_time.
    """
    tau = np.empty(n_time)
    grid_phases(wing_params, n_time, tau, out_weight)
    fill_angles(wing_params, tau, out_angles)


def motion_grid(params: Any, n_time: int, xp: ArrayNamespace = NUMPY) -> tuple[Any, Any]:
    """Phases τ_k [rad] and weights dτ/ds of the motion-following grid, each (B, n_time), of a
    batch of one wing's (B, 14) parameters in Hz/rad/- (the arrays :func:`grid_phases` fills),
    in the array namespace ``xp`` (numpy or torch)."""
    s = 2.0 * math.pi * xp.arange_like(n_time, params) / n_time
    k_shape = xp.minimum(params[:, 10:11], MAX_SWEEP_SHAPE)
    reversal = 0.5 * math.pi - params[:, 7:8]
    return on_namespace(phase_grid, xp)(s, reversal, k_shape * k_shape)


def batched_angle_history(
    params: Any, n_time: int, xp: ArrayNamespace = NUMPY
) -> tuple[list[Any], Any, Any]:
    """φ, φ̇, φ̈, θ, θ̇, θ̈, η, η̇, η̈ (each (B, n_time)), dτ/ds and the phases τ [rad] of a batch
    of one wing's (B, 14) parameters in Hz/rad/- on the motion-following grid, in the array
    namespace ``xp``: :func:`fill_angle_history`'s formulas (:func:`weaving`, :func:`flapping`,
    :func:`pitching`, :func:`phase_grid`) on whole arrays, differentiable on torch."""
    tau, weight = motion_grid(params, n_time, xp)
    return angles_at(params, tau, xp), weight, tau


def angles_at(params: Any, tau: Any, xp: ArrayNamespace = NUMPY) -> list[Any]:
    """φ, φ̇, φ̈, θ, θ̇, θ̈, η, η̇, η̈ [rad, rad/s, rad/s²] of a batch of one wing's (B, 14)
    parameters in Hz/rad/- at the phases ``tau`` (B, n) or (1, n) [rad], each (B, n):
    :func:`fill_angles`'s formulas on whole arrays, differentiable on torch."""
    col = [params[:, i : i + 1] for i in range(params.shape[1])]
    omega = 2.0 * math.pi * col[0]
    phi = on_namespace(weaving, xp)(tau, omega, col[1], col[4], col[7], col[10])
    theta = on_namespace(flapping, xp)(tau, omega, col[2], col[5], col[8], col[11])
    eta = on_namespace(pitching, xp)(tau, omega, col[3], col[6], col[9], col[12])
    return [*phi, *theta, *eta]


#: Per parameter of one wing: π/180 for an angle in degrees (``stroke.ANGULAR``), else 1.
RADIANS_PER_UNIT = np.where(ANGULAR[:N_PER_WING], np.pi / 180.0, 1.0)


def wing_params_radians(wing_physical: Any, xp: ArrayNamespace = NUMPY) -> Any:
    """Convert (…, 14) Table 4 parameters (Hz, deg, -) of one wing to (Hz, rad, -), a new array
    in the array namespace ``xp`` (numpy or torch)."""
    if xp is NUMPY:
        wing_physical = np.asarray(wing_physical, dtype=float)
    return wing_physical * xp.constant_like(RADIANS_PER_UNIT, wing_physical)


def spectral_derivatives(series: np.ndarray, frequency: float) -> np.ndarray:
    """A periodic series and its first two time derivatives, by spectral differentiation.

    ``series``: (n,) or (n, k) samples [rad] uniform over exactly one cycle (the first at t = 0,
    the last at t = (n − 1)/n·T; the cycle is closed implicitly), k series in columns;
    ``frequency`` f [Hz]. Returns (n, 3) or (n, 3, k): value, rate [rad/s], acceleration [rad/s²].
    The Nyquist mode of an even n has no well-defined derivative and is dropped from them.
    """
    n = series.shape[0]
    wavenumber = np.fft.rfftfreq(n, d=1.0 / n)  # harmonics of the beat
    if series.ndim == 2:
        wavenumber = wavenumber[:, None]
    omega = 2.0 * np.pi * frequency
    spectrum = np.fft.rfft(series, axis=0)
    if n % 2 == 0:
        spectrum_d = spectrum.copy()
        spectrum_d[-1] = 0.0
    else:
        spectrum_d = spectrum
    first = np.fft.irfft(1j * wavenumber * omega * spectrum_d, n=n, axis=0)
    second = np.fft.irfft(-((wavenumber * omega) ** 2) * spectrum_d, n=n, axis=0)
    return np.stack([series, first, second], axis=1)


def measured_angle_history(
    phi: np.ndarray, theta: np.ndarray, eta: np.ndarray, frequency: float
) -> np.ndarray:
    """Angles and derivatives of a measured periodic stroke, by spectral differentiation.

    Parameters
    ----------
    phi, theta, eta : (n,) arrays
        The angles [rad] sampled uniformly over exactly one cycle (the first sample at t = 0,
        the last at t = (n − 1)/n·T; the cycle is closed implicitly).
    frequency : float
        Wing-beat frequency f [Hz].

    Returns
    -------
    (n, 9) array of φ, φ̇, φ̈, θ, θ̇, θ̈, η, η̇, η̈ [rad, rad/s, rad/s²].
    """
    out = np.empty((phi.shape[0], 9))
    for j, series in enumerate((phi, theta, eta)):
        out[:, 3 * j : 3 * j + 3] = spectral_derivatives(series, frequency)
    return out
