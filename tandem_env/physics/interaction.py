"""The vortex reading of the fore/hind interaction (``ModelOptions.slipstream="vortex"``,
docs/model.md §5.8), written once over an array namespace (``xp``: numpy for the numba
backend, torch with autograd for its twin).

Each pair's bound circulation Γ(r, t) (the translational part of Eq. 14) is reduced to a few
strips on a uniform wake grid; each pair's lifting line and prescribed periodic wake
(``vortex.prescribed_wake``) induce, by Biot-Savart with a growing viscous core
(``vortex.segment_velocity``), a velocity at the other pair's three-quarter chord at a few
span stations, interpolated onto its blade elements and its time grid. That field enters
every element velocity of the other pair's next pass (``WingBatch.external``), whose own
inflow stays the momentum solve. The passes run to a fixed point (:func:`vortex_reading`).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from functools import cache, lru_cache, partial
from typing import Any, NamedTuple

import numba
import numpy as np
from numba import njit, prange

from . import blade, cycle
from .kinematics import angles_at, fill_angles
from .vortex import (
    BOUND_VORTEX,
    COLLOCATION,
    MIRROR,
    ROOT_HALF_WIDTH,
    TRAILING_EDGE,
    lattice_geometry,
    segment_influence,
    stroke_angles,
    wake_influence,
    wake_nodes,
    wing_lines,
)
from .xp import BRANCH_FREE, NUMPY, ArrayNamespace, on_namespace, on_one_thread, stroke_loop


@dataclass(frozen=True)
class VortexWake:
    """The reduced wake and the reading's constants (docs/model.md §5.8, items 3-6, 9).

    The four constants ``descent``, ``core_growth``, ``gamma_scale`` and the choice of the
    translational Γ were chosen on the lag study's 32 points (docs/crosscheck.md); its
    generalisation grid tests them out of sample."""

    n_wake: int = 16
    """n_w: wake samples per beat [-]."""
    strips: int = 4
    """N_s: circulation strips per wing [-]."""
    read_points: int = 4
    """M: span stations reading the other pair's velocity [-] (:func:`read_stations`; a
    natural cubic spline through them onto the elements, docs/model.md §5.8 item 9)."""
    fore_beats: float = 3.0
    """The fore pair's wake length [beats] (it passes the hind pair; 4 beats, with the hind
    pair's 3, move the lag study's changes by at most 0.8 points)."""
    hind_beats: float = 2.0
    """The hind pair's wake length [beats] (it leaves the fore pair; 3 beats move the fore
    pair's change at 0.5 m/s by at most 0.4 points, where 1.5 beats were 1.0 point off)."""
    descent: float = 1.0
    """κ_w: the wake descends at κ_w·v̄ along the source's z_s [-]."""
    core: float = 0.5e-3
    """r₀: the core radius at release [m]."""
    core_growth: float = 2.4e-3
    """g in r_c² = r₀² + g·age [m²/s]: 8 mm after a beat at 37 Hz."""
    gamma_scale: float = 1.7
    """Factor on the shed circulation [-]: the lag study's hind-wing RMS is least near it
    (docs/model.md §5.8, "What it gives on the lag study")."""
    tolerance: float = 1e-3
    """The fixed point's tolerance: the RMS of the difference between the strips each pair was
    last given and those the other pair's latest solve gives, relative to the sum of both
    pairs' RMS strips [-]."""
    max_passes: int = 30
    """Most passes of the fixed point (each solves the fore pair, then the hind pair, after
    the isolated pass) [-]."""
    accelerate: bool = True
    """Anderson's step on the passes (False: plain Gauss-Seidel passes)."""
    depth: int = 2
    """Anderson's depth: the differences of the last ``depth`` passes it mixes [-] (1: a
    secant step; 2 converges hover strokes that 1 leaves cycling, docs/model.md §5.8 item 6)."""
    chunk: int = 128
    """Strokes per Biot-Savart evaluation (memory ∝ chunk·n_w·M·segments) and, on the numba
    backend, most strokes per fixed point (the batch's strokes are iterated at most this many
    at a time, fewer where the batch is shared among numba's threads) [-]."""

    def __post_init__(self) -> None:
        for name in ("n_wake", "strips", "read_points", "max_passes", "chunk", "depth"):
            value = getattr(self, name)
            least = 2 if name in ("n_wake", "read_points") else 1
            if not isinstance(value, int) or isinstance(value, bool) or value < least:
                raise ValueError(f"VortexWake.{name} = {value!r}; allowed: an integer >= {least}")
        if not isinstance(self.accelerate, bool):
            raise ValueError(f"VortexWake.accelerate = {self.accelerate!r}; allowed: True, False")
        for name in ("fore_beats", "hind_beats", "descent", "core", "core_growth", "tolerance"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0.0):
                raise ValueError(f"VortexWake.{name} = {value!r}; allowed: a finite number >= 0")
        for name in ("fore_beats", "hind_beats"):
            if round(getattr(self, name) * self.n_wake) < 1:
                raise ValueError(
                    f"VortexWake.{name} = {getattr(self, name)!r}; allowed: at least one wake "
                    f"row, >= 1/n_wake = {1 / self.n_wake:g}"
                )


#: The reading's settings (docs/model.md §5.8).
WAKE = VortexWake()


class Pair(NamedTuple):
    """One wing pair of a batch as the reading sees it (the right wing; the left mirrors it).
    Its motion is either parametric (``params``) or measured (``samples``; the other None)."""

    params: Any
    """(B, 14) the wing's parameters in Hz/rad/- (``kinematics.wing_params_radians``), or
    None."""
    samples: Any
    """(B, n, 3) measured φ, θ, η at the uniform phases 2πk/n [rad], or None."""
    frequency: Any
    """(B,) f [Hz]."""
    beta: Any
    """(B,) the stroke-plane angle β [rad]."""
    coef: Any
    """(B, 1, n_time, ``blade.N_COEF``) frame coefficients on the kernel's grid."""
    phase: Any
    """(B, n_time) the kernel's sample phases ϑ [rad]."""
    v_tangential: Any
    """(B,) V_t [m/s]."""
    v_normal: Any
    """(B,) V_n [m/s]."""
    wing: Any
    """The ``insect.Wing`` (length, chord, C_t)."""
    r: np.ndarray
    """(n_blade,) element radii [m]."""
    width: np.ndarray
    """(n_blade,) quadrature weights dr [m]."""
    root: np.ndarray
    """(3,) the right wing's root in earth axes [m]."""
    grid_coef: Any = None
    """(B, n_w, ``blade.N_COEF``) frame coefficients at the wake grid's phases
    (:func:`grid_frames`), where Γ is shed; None (measured kinematics): Γ is interpolated
    from the kernel's samples around them."""

    def take(self, keep: Any) -> Pair:
        """The pair on the strokes ``keep`` (a boolean mask or indices of the batch)."""
        return self._replace(
            params=None if self.params is None else self.params[keep],
            samples=None if self.samples is None else self.samples[keep],
            frequency=self.frequency[keep], beta=self.beta[keep], coef=self.coef[keep],
            phase=self.phase[keep], v_tangential=self.v_tangential[keep],
            v_normal=self.v_normal[keep],
            grid_coef=None if self.grid_coef is None else self.grid_coef[keep],
        )  # fmt: skip


def grid_angles(pair: Pair, tau: Any, xp: ArrayNamespace) -> tuple[Any, Any, Any]:
    """The pair's φ, θ, η at the phases ``tau`` (1, n) [rad], each (B, n) [rad]: Eqs. 3-5 of
    its parameters (``vortex.stroke_angles``), or the trigonometric interpolant of its
    measured samples (exact at the samples; measured kinematics run on numpy only)."""
    if pair.params is not None:
        return stroke_angles(pair.params, tau, xp)
    n = pair.samples.shape[1]
    spectrum = np.fft.rfft(pair.samples, axis=1) / n  # (B, n // 2 + 1, 3)
    k = np.arange(spectrum.shape[1])
    # each harmonic twice (e^{ikt} and its conjugate) but the mean and, n even, the Nyquist one
    spectrum[:, (k > 0) & (2 * k != n)] *= 2.0
    basis = np.exp(1j * k[:, None] * np.asarray(tau)[0][None, :])  # (n // 2 + 1, n_t)
    values = np.einsum("bkc,kt->bct", spectrum, basis).real
    return values[:, 0], values[:, 1], values[:, 2]


@njit(cache=True, error_model=BRANCH_FREE)
def _fill_brackets(source, target, index, weight):
    """:func:`periodic_brackets` on numpy, compiled: ``source`` (B, n_s), ``target`` (B, n_t)
    (leading axes broadcast by the caller); writes ``index``, ``weight`` (B, n_t, 2)."""
    two_pi = 2.0 * math.pi
    n = source.shape[1]
    src = np.empty(n)
    for b in range(source.shape[0]):
        start = source[b, 0]
        for s in range(n):
            x = source[b, s] - start
            src[s] = x - two_pi * np.floor(x / two_pi)
        for t in range(target.shape[1]):
            x = target[b, t] - start
            tgt = x - two_pi * np.floor(x / two_pi)
            count = 0
            for s in range(n):
                count += src[s] <= tgt
            x0 = src[count - 1]
            x1 = src[count % n] + (two_pi if count % n == 0 else 0.0)
            share = (tgt - x0) / max(x1 - x0, 1e-300)
            index[b, t, 0], index[b, t, 1] = count - 1, count % n
            weight[b, t, 0], weight[b, t, 1] = 1.0 - share, share


def periodic_brackets(source: Any, target: Any, xp: ArrayNamespace) -> tuple[Any, Any]:
    """Periodic linear interpolation in phase, values at phases ``target`` (B, n_t) [rad] of
    series sampled at phases ``source`` (B, n_s) [rad], increasing over one period from any
    start (the leading axes broadcast): the two samples around each target, (B, n_t, 2)
    integer indices, and their weights (B, n_t, 2)."""
    if xp is NUMPY:
        lead = np.broadcast_shapes(source.shape[:-1], target.shape[:-1])
        shape = (*lead, target.shape[-1], 2)
        index, weight = np.empty(shape, dtype=np.int64), np.empty(shape)
        _fill_brackets(
            np.broadcast_to(source, (*lead, source.shape[-1])).reshape(-1, source.shape[-1]),
            np.broadcast_to(target, (*lead, target.shape[-1])).reshape(-1, target.shape[-1]),
            index.reshape(-1, *shape[-2:]),
            weight.reshape(-1, *shape[-2:]),
        )
        return index, weight
    two_pi = 2.0 * math.pi
    n = source.shape[-1]
    start = source[..., :1]
    # x − 2π·floor(x/2π), not xp.remainder: torch's loses float64 precision with a number
    src = (source - start) - two_pi * xp.floor((source - start) / two_pi)
    tgt = (target - start) - two_pi * xp.floor((target - start) / two_pi)
    count = ((src[..., None, :] <= tgt[..., :, None]) * 1).sum(-1)  # 1 … n: src[0] = 0
    index = xp.arange_like(n, source)
    x0 = ((index == (count - 1)[..., None]) * src[..., None, :]).sum(-1)
    x1 = ((index == (count % n)[..., None]) * src[..., None, :]).sum(-1)
    x1 = xp.where((count % n) == 0, x1 + two_pi, x1)  # a number times a bool: float32 in torch
    t = (tgt - x0) / xp.maximum(x1 - x0, 1e-300)
    return xp.stack([count - 1, count % n], -1), xp.stack([1.0 - t, t], -1)


@stroke_loop()
def _fill_grid_frames(params, tau, spin_total, out):
    """:func:`grid_frames` on numpy, compiled and parallel over strokes b: the kernel's own
    ``kinematics.fill_angles`` and ``blade.fill_frame_coefficients`` at the phases ``tau``
    (n,) of each stroke's ``params`` (B, 14); writes ``out`` (B, n, N_COEF)."""
    for b in prange(params.shape[0]):
        angles = np.empty((tau.shape[0], 9))
        fill_angles(params[b], tau, angles)
        weight = np.ones(tau.shape[0])
        blade.fill_frame_coefficients(angles, weight, params[b, 13], spin_total, 1, out[b])


def grid_frames(params: Any, spin_total: bool, wake: VortexWake, xp: ArrayNamespace) -> Any:
    """The right wing's frame coefficients (B, n_w, ``blade.N_COEF``) at the wake grid's
    uniform phases 2πi/n_w, of its (B, 14) parameters in Hz/rad/- (``blade.frame_columns`` of
    ``kinematics.angles_at``; the weight column 1): Γ is shed where the wake's rows are
    released, computed there rather than interpolated from the kernel's samples, whose phases
    move with the stroke (docs/model.md §5.8 item 1)."""
    tau = 2.0 * np.pi * np.arange(wake.n_wake) / wake.n_wake
    if xp is NUMPY:
        out = np.empty((len(params), wake.n_wake, blade.N_COEF))
        _fill_grid_frames(len(params), np.ascontiguousarray(params), tau, spin_total, out)
        return out
    angles = xp.stack(angles_at(params, xp.constant_like(tau[None], params), xp), -1)
    beta = params[:, 13:14]
    zero = 0.0 * angles[..., 0]
    columns = on_namespace(blade.frame_columns, xp)(
        angles, ..., zero + 1.0, xp.cos(beta), xp.sin(beta), spin_total, 1
    )
    return xp.stack([column + zero for column in columns], -1)


@cache
def spline_prefilter(n: int) -> np.ndarray:
    """The (n, n) matrix from values on a uniform periodic grid of n points to the
    coefficients of the periodic cubic B-spline through them (the inverse of the circulant
    (1/6, 2/3, 1/6)) [-]."""
    circulant = np.zeros((n, n))
    for i in range(n):
        circulant[i, i] += 2.0 / 3.0
        circulant[i, (i - 1) % n] += 1.0 / 6.0
        circulant[i, (i + 1) % n] += 1.0 / 6.0
    return np.linalg.inv(circulant)


@njit(cache=True)
def spline_basis(u):
    """The cubic B-spline's four weights at the fraction ``u`` in [0, 1) of a grid interval,
    for the grid points before it, at its start, at its end and after it [-]."""
    v = 1.0 - u
    u2 = u * u
    return (
        v * v * v / 6.0,
        (3.0 * u2 * u - 6.0 * u2 + 4.0) / 6.0,
        (-3.0 * u2 * u + 3.0 * u2 + 3.0 * u + 1.0) / 6.0,
        u2 * u / 6.0,
    )


@njit(cache=True)
def _fill_spline(target, n, index, weight):
    """:func:`periodic_spline` on numpy, compiled: ``target`` (B, n_t); writes ``index``,
    ``weight`` (B, n_t, 4)."""
    for b in range(target.shape[0]):
        for t in range(target.shape[1]):
            x = target[b, t] * (n / (2.0 * math.pi))
            x = x - n * np.floor(x / n)
            base = np.floor(x)
            taps = spline_basis(x - base)
            for q in range(4):
                index[b, t, q] = (int(base) + q - 1) % n
                weight[b, t, q] = taps[q]


def periodic_spline(target: Any, n: int, xp: ArrayNamespace) -> tuple[Any, Any]:
    """The periodic cubic B-spline's four taps from a uniform grid of ``n`` points over one
    period (phases 2πi/n) to the phases ``target`` (B, n_t) [rad]: (B, n_t, 4) grid indices
    and weights [-] (:func:`spline_basis`). Applied to :func:`spline_prefilter`'s
    coefficients it interpolates the grid's values, twice continuously differentiable in the
    target phase: the kernel's sample phases move with the stroke, and linear interpolation
    would put a kink in every result wherever a sample crosses a grid point, on which an
    optimiser comes to rest."""
    if xp is NUMPY:
        index = np.empty((*target.shape, 4), dtype=np.int64)
        weight = np.empty((*target.shape, 4))
        _fill_spline(np.ascontiguousarray(target, dtype=float), n, index, weight)
        return index, weight
    x = target * (n / (2.0 * math.pi))
    x = x - n * xp.floor(x / n)
    base = xp.floor(x)
    start = xp.as_int64(base)
    index = xp.stack([(start + shift) % n for shift in (-1, 0, 1, 2)], -1)
    return index, xp.stack(on_namespace(spline_basis, xp)(x - base), -1)


def read_stations(wake: VortexWake) -> np.ndarray:
    """The M read stations' span fractions r/R [-] over 2-98 % of the span, halfway between
    even spacing and the Chebyshev-Lobatto points (closer at the ends, where the other pair's
    tip vortices bend the field most): r/R = 0.02 + 0.96·(u + (1 − cos πu)/2)/2, u = m/(M − 1)
    (docs/model.md §5.8 item 9)."""
    u = np.arange(wake.read_points) / (wake.read_points - 1)
    return 0.02 + 0.96 * 0.5 * (u + 0.5 * (1.0 - np.cos(np.pi * u)))


def station_weights(pair: Pair, wake: VortexWake) -> np.ndarray:
    """(n_blade, M) weights of the natural cubic spline in r through the M
    :func:`read_stations` onto the pair's elements, held constant beyond the end stations
    (docs/model.md §5.8 item 5)."""
    return span_interpolation(read_stations(wake), pair.r / pair.wing.length, spline=True)


def span_interpolation(source: np.ndarray, target: np.ndarray, spline: bool = False) -> np.ndarray:
    """(n_t, n_s) weights of interpolation in r from ``source`` to ``target`` radii, linear or
    (``spline``) by a natural cubic spline, held constant beyond the ends: a copy of the
    weights kept per pair of radii (every pass of every call of a wing asks for the same)."""
    return _span_weights(
        tuple(np.asarray(source, float).tolist()), tuple(np.asarray(target, float).tolist()), spline
    ).copy()


@lru_cache(maxsize=64)
def _span_weights(source: tuple[float, ...], target: tuple[float, ...], spline: bool) -> np.ndarray:
    # column j: the interpolant through the unit vector of station j's value (the weights are
    # linear in the values), at the targets held within the stations
    stations = np.asarray(source)
    at = np.clip(target, stations[0], stations[-1])
    if spline:
        # imported here: only the vortex reading's read stations need scipy's interpolation
        from scipy.interpolate import CubicSpline

        weights = CubicSpline(stations, np.eye(len(source)), bc_type="natural")(at)
    else:
        weights = np.stack([np.interp(at, stations, column) for column in np.eye(len(source))], -1)
    weights.flags.writeable = False
    return weights


@stroke_loop(error_model=BRANCH_FREE)
def _fill_circulation(coef, samples, r, v_t, vn, offsets, chord, c_t, table, read, out):
    """:func:`circulation` on numpy, compiled and parallel over strokes b: ``coef`` (B, n_time,
    N_COEF), ``samples`` (B, n), ``r``, ``chord`` (n_blade,), ``v_t`` (B,), ``vn`` (B,
    n_blade) the total normal inflow, ``offsets`` the field's (u, v) offsets at the M stations
    and their weights onto the elements (:func:`element_field`, ``cycle.station_offsets``) or
    ``None``, ``c_t`` and ``table`` the wing's force-coefficient model
    (``blade.translational_terms``), ``read`` (n_blade,) the elements to compute (the others'
    Γ is left 0); writes Γ into ``out`` (B, n_blade, n)."""
    for b in prange(coef.shape[0]):
        for s in range(samples.shape[1]):
            k = samples[b, s]
            for e in range(r.shape[0]):
                out[b, e, s] = 0.0  # a still element sheds nothing
                if not read[e]:
                    continue
                u, v, _, _ = blade.relative_velocity(coef[b], k, r[e], v_t[b], vn[b, e])
                if offsets is not None:
                    stations, to_elements = offsets
                    du = 0.0
                    dv = 0.0
                    for m in range(to_elements.shape[1]):
                        du += to_elements[e, m] * stations[b, 0, m, k]
                        dv += to_elements[e, m] * stations[b, 1, m, k]
                    u += du
                    v += dv
                speed2 = u * u + v * v
                if speed2 > 0.0:
                    out[b, e, s] = blade.translational_terms(
                        u, v, np.sqrt(speed2), chord[e], c_t, 0.0, 0.0, 0.0, table
                    )[0]


def circulation(
    pair: Pair,
    inflow: Any,
    external: tuple[Any, Any] | None,
    samples: Any,
    xp,
    to_elements: Any = None,
    read: np.ndarray | None = None,
) -> Any:
    """The translational bound circulation Γ_t (Eq. 14: −C_t·c·u·v/|U| with the paper's
    coefficients, −½·c·|U|·C_L(α)·sign(v) with the wing's other model, as the kernel's forces
    take it, ``blade.translational_terms``) of every element at the kernel's samples ``samples``
    (B, n) (indices into each stroke's n_time; the wake grid
    reads only those), (B, n_blade, n) [m²/s], at the pair's solved ``inflow`` (B, n_blade)
    [m/s] with the other pair's field ``external`` (:func:`element_field`: its (u, v) offsets
    and its mean upstream inflow (B, n_blade)) or ``None``; ``to_elements`` (n_blade, M): the
    offsets' weights onto the elements on numpy, where they stay at the M stations; ``read``
    (n_blade,) on numpy: the elements whose Γ is used (the strips read two per strip,
    :func:`strip_circulation`), the others left 0 (None: all)."""
    vn = pair.v_normal[:, None] + inflow
    if external is not None:
        vn = vn + external[1]
    if xp is NUMPY:
        out = np.empty((*vn.shape, samples.shape[1]))
        _fill_circulation(
            len(out),
            np.ascontiguousarray(pair.coef[:, 0]), np.ascontiguousarray(samples), pair.r,
            np.ascontiguousarray(pair.v_tangential), np.ascontiguousarray(vn),
            None if external is None else (external[0], np.ascontiguousarray(to_elements)),
            pair.wing.chord(pair.r / pair.wing.length), pair.wing.translational_coefficient,
            pair.wing.coefficients.table(),
            np.ones(len(pair.r), dtype=bool) if read is None else read, out,
        )  # fmt: skip
        return out
    stroke = xp.as_int64(xp.arange_like(samples.shape[0], vn))[:, None]
    r = xp.constant_like(pair.r, vn)[None, :, None]
    u, v, _, _ = on_namespace(blade.relative_velocity, xp)(
        pair.coef[:, 0][stroke, samples][:, None], ..., r, pair.v_tangential[:, None, None],
        vn[:, :, None],
    )  # fmt: skip
    if external is not None:
        offsets = xp.moveaxis(external[0], -1, 1)[stroke, samples]  # (B, n, n_blade, 2)
        u = u + xp.moveaxis(offsets[..., 0], 1, -1)
        v = v + xp.moveaxis(offsets[..., 1], 1, -1)
    chord = xp.constant_like(pair.wing.chord(pair.r / pair.wing.length), vn)[None, :, None]
    speed2 = u * u + v * v
    moving = speed2 > 0.0
    # the paper's coefficients (no table): the torch backend takes no other model
    speed = xp.sqrt(xp.where(moving, speed2, 1.0))
    c_t = pair.wing.translational_coefficient
    gamma, _ = on_namespace(blade.translational_terms, xp)(u, v, speed, chord, c_t, 0.0, 0.0, 0.0)
    return xp.where(moving, gamma, 0.0)


def disc_mean(pair: Pair, inflow: Any, xp) -> Any:
    """v̄: the disc mean ∫v_i·r·dr / ∫r·dr of the pair's inflow (B, n_blade) (§5.7) [m/s]."""
    area = xp.constant_like(pair.r * pair.width, inflow)
    return (inflow * area).sum(-1) / float(np.sum(pair.r * pair.width))


class Lattice(NamedTuple):
    """A pair's lifting-line and wake geometry on the wake grid (fixed over the passes)."""

    bound: Any  # (B, n_w, N_s + 1, 3) [m]
    edge: Any  # (B, n_w, N_s + 1, 3) [m]
    carried: Any  # (B, K + 1, 3) [m]
    core: Any  # (B, 1, S) per segment of a wing [m]
    to_strips: Any  # (N_s, n_blade) elements → strip mid-points


def lattice(
    pair: Pair, v_bar: Any, speed: Any, path_angle: Any, beats: float, wake: VortexWake, xp
) -> Lattice:
    """The pair's :class:`Lattice`: its bound line and trailing edge at N_s + 1 stations on
    n_w uniform phases, its wake rows carried by the free stream −V·(cos γ, 0, sin γ) plus
    κ_w·v̄ along −z_s (``v_bar`` (B,) [m/s]), K = round(beats·n_w) rows, and the growing core
    of each segment."""
    n_w, n_s = wake.n_wake, wake.strips
    like = pair.phase
    frac = np.linspace(0.0, 1.0, n_s + 1)
    tau = xp.constant_like(2.0 * np.pi * np.arange(n_w)[None] / n_w, like)
    chord = xp.constant_like(pair.wing.chord(frac), like)
    frac_x = xp.constant_like(frac, like)
    root = xp.constant_like(pair.root, like)
    angles = grid_angles(pair, tau, xp)
    bound = wing_lines(angles, pair.beta, frac_x, pair.wing.length, chord, BOUND_VORTEX, root, xp)
    edge = wing_lines(angles, pair.beta, frac_x, pair.wing.length, chord, TRAILING_EDGE, root, xp)
    rows = round(beats * n_w)
    dt = 1.0 / (pair.frequency * n_w)  # (B,) [s]
    age = dt[:, None] * xp.constant_like(np.arange(rows + 1.0), like)[None]  # (B, K + 1)
    beta = pair.beta
    descent = wake.descent * v_bar
    carry = [
        -speed * xp.cos(path_angle) - descent * xp.sin(beta),
        0.0 * speed,
        -speed * xp.sin(path_angle) - descent * xp.cos(beta),
    ]
    carried = xp.stack([age * c[:, None] for c in carry], -1)
    # each segment's age in samples: along the rows (row k released k − 1 samples ago), then
    # between the rows (trailed), as vortex.lattice_segments orders them
    k = np.arange(rows + 2)
    along = np.repeat(np.maximum(k - 1, 0), n_s)
    between = np.repeat(np.maximum(k[:-1] - 0.5, 0), n_s + 1)
    ages = xp.constant_like(np.concatenate([along, between]), like)
    core = xp.sqrt(wake.core**2 + wake.core_growth * dt[:, None] * ages[None])[:, None]
    mids = 0.5 * (frac[1:] + frac[:-1])
    to_strips = xp.constant_like(span_interpolation(pair.r / pair.wing.length, mids), like)
    return Lattice(bound, edge, carried, core, to_strips)


def both_wings(segments: Any, circulation: Any, xp) -> tuple[Any, Any]:
    """A right wing's segments (..., S, 2, 3) [m] and circulations (..., S) [m²/s] with its
    left wing's, the mirror image (Y → −Y) carrying −Γ: (..., 2S, 2, 3) and (..., 2S)."""
    mirrored = segments * xp.constant_like(MIRROR, segments)
    return (
        xp.concatenate([segments, mirrored], -3),
        xp.concatenate([circulation, -circulation], -1),
    )


def strip_circulation(to_strips: Any, weights: Any, gamma: Any, wake: VortexWake, xp) -> Any:
    """The shed strip circulations (B, n_w, N_s) [m²/s] on the wake grid of the elements'
    ``gamma`` (B, n_blade, n_w) [m²/s] there or, with ``weights``, (B, n_blade, 2·n_w) at the
    kernel's two samples around each wake-grid instant (item 1), interpolated with their
    ``weights`` (B, n_w, 2) (:func:`periodic_brackets`), reduced to the strips by
    ``Lattice.to_strips``, times ``wake.gamma_scale``."""
    on_grid = gamma
    if weights is not None:
        pairs = gamma.reshape(*gamma.shape[:2], -1, 2) * weights[:, None]
        # the two samples' sum written out: a reduction over an axis of 2 costs numpy more
        on_grid = pairs[..., 0] + pairs[..., 1]
    return wake.gamma_scale * xp.einsum("sj,bjw->bws", to_strips, on_grid)


def influence(source: Lattice, target: Pair, wake: VortexWake, xp) -> Any:
    """The source pair's influence on the target: the velocity its lattice induces at the
    target's three-quarter chord on the wake grid per unit strip circulation, (B, n_w, M·3,
    n_w·N_s) [m/s per m²/s] (both of the source's wings; the target's right wing).

    Entry (i, (m, c), (e, j)) multiplies strip j's circulation released e samples before t_i,
    Γ_j(t_{i−e}) (periodic), in component c of the velocity at station m at t_i
    (:func:`field_on_grid`). The geometry does not depend on Γ (item 6), so this is built once
    per stroke: each ring's segments by Biot-Savart (``vortex.segment_influence``), the rings
    of ``vortex.prescribed_wake`` summed over their segments, and the rings' circulations
    (ring 0: Γ(t_i); ring k ≥ 1: ½·(Γ(t_{i−k+1}) + Γ(t_{i−k}))) folded onto the release ages
    modulo the period."""
    n_w, n_s, m = wake.n_wake, wake.strips, wake.read_points
    frac = read_stations(wake)
    like = target.phase
    tau = xp.constant_like(2.0 * np.pi * np.arange(n_w)[None] / n_w, like)
    points = wing_lines(
        grid_angles(target, tau, xp), target.beta, xp.constant_like(frac, like), target.wing.length,
        xp.constant_like(target.wing.chord(frac), like), COLLOCATION,
        xp.constant_like(target.root, like), xp,
    )  # fmt: skip
    mirror = xp.constant_like(MIRROR, like)
    # the left wing (its mirror image, −Γ) induces at x what the right induces at its mirror
    # image, mirrored: the right wing's segments read at both
    points = xp.concatenate([points, points * mirror], -2)
    if xp is NUMPY:  # the same sum, compiled for the lattice's structure, into one array
        out = np.empty((like.shape[0], n_w, m, 3, n_w * n_s))
        for start in range(0, like.shape[0], wake.chunk):
            part = slice(start, start + wake.chunk)
            wake_influence(
                source.bound[part], source.edge[part], source.carried[part], points[part],
                source.core[part], out[part],
            )  # fmt: skip
        return out.reshape(like.shape[0], n_w, m * 3, n_w * n_s)
    combine = ring_ages(source.carried.shape[1], n_s, n_w)
    parts = []
    for start in range(0, like.shape[0], wake.chunk):
        part = slice(start, start + wake.chunk)
        nodes = wake_nodes(source.bound[part], source.edge[part], source.carried[part], xp)
        unit = segment_influence(
            lattice_geometry(nodes, xp), points[part], source.core[part], combine, xp, True
        )  # (b, n_w, M, 3, n_w·N_s)
        parts.append(unit.reshape(*unit.shape[:2], m * 3, n_w * n_s))
    return xp.concatenate(parts, 0)


@cache
def ring_ages(rings: int, n_s: int, n_w: int) -> np.ndarray:
    """The (S, n_w·N_s) matrix from the right wing's segments (``vortex.lattice_geometry``'s
    order) to the strip circulations by release
    age modulo the period, Γ_j(t_{i−e}): ring (k, j) of ``rings`` = K + 1 rows of N_s strips
    is +along row k, −along row k + 1, −trailed at node j, +trailed at node j + 1
    (``vortex.lattice_segments``); ring 0 carries Γ(t_i), ring k ≥ 1 ½·(Γ(t_{i−k+1}) +
    Γ(t_{i−k})); the ages beyond one period fold onto it."""
    along = np.zeros((rings + 1, n_s, rings, n_s))  # segment (row, j) ← ring (k, j')
    trailed = np.zeros((rings, n_s + 1, rings, n_s))
    for k in range(rings):
        for j in range(n_s):
            along[k, j, k, j] += 1.0
            along[k + 1, j, k, j] -= 1.0
            trailed[k, j, k, j] -= 1.0
            trailed[k, j + 1, k, j] += 1.0
    to_rings = np.concatenate([along.reshape(-1, rings, n_s), trailed.reshape(-1, rings, n_s)])
    ages = np.zeros((rings, -(-rings // n_w) * n_w))  # ring k ← Γ released d samples ago
    ages[0, 0] = 1.0
    for k in range(1, rings):
        ages[k, k - 1] += 0.5
        ages[k, k] += 0.5
    folded = ages.reshape(rings, -1, n_w).sum(1)  # (K + 1, n_w)
    return np.einsum("skj,ke->sej", to_rings, folded).reshape(to_rings.shape[0], n_w * n_s)


@stroke_loop(error_model=BRANCH_FREE, fastmath={"reassoc", "contract"})
def _fill_field(matrix, rows, strips, out):
    """:func:`field_on_grid` on numpy, compiled and parallel over strokes b: ``out[b, i, r]`` =
    Σ_(e, j) ``matrix[rows[b], i, r, e·N_s + j]``·``strips[b, (i − e) mod n_w, j]``."""
    n_w, n_s = strips.shape[1], strips.shape[2]
    for b in prange(strips.shape[0]):
        at = rows[b]
        shifted = np.empty(n_w * n_s)
        for i in range(n_w):
            for e in range(n_w):
                back = (i - e) % n_w
                for j in range(n_s):
                    shifted[e * n_s + j] = strips[b, back, j]
            for r in range(matrix.shape[2]):
                total = 0.0
                for c in range(n_w * n_s):
                    total += matrix[at, i, r, c] * shifted[c]
                out[b, i, r] = total


def field_on_grid(matrix: Any, strips: Any, xp, rows: Any = None) -> Any:
    """The velocity (B, n_w, M, 3) [m/s] of the :func:`influence` ``matrix`` with the source's
    strip circulations ``strips`` (B, n_w, N_s) [m²/s] on the wake grid: one batched product,
    Γ_j(t_{i−e}) gathered for each t_i. ``rows`` (B,): the matrix's strokes to read (``None``:
    all, in order), so that the strokes still iterating read theirs without a copy of it (on
    numpy a compiled loop; on torch the rows taken and a batched product)."""
    n_b, n_w = strips.shape[:2]
    if xp is NUMPY:
        rows = np.arange(n_b) if rows is None else np.asarray(rows)
        out = np.empty((n_b, n_w, matrix.shape[2]))
        _fill_field(n_b, matrix, rows.astype(np.int64), np.ascontiguousarray(strips), out)
        return out.reshape(n_b, n_w, -1, 3)
    if rows is not None:
        matrix = matrix[rows]
    shifted = strips[:, [[(i - e) % n_w for e in range(n_w)] for i in range(n_w)]]
    flat = shifted.reshape(n_b, n_w, -1, 1)  # (B, n_w, n_w·N_s, 1)
    return (matrix @ flat).reshape(n_b, n_w, -1, 3)


@njit(cache=True, error_model=BRANCH_FREE)
def _project(coef, w, cb, sb, mean, out):
    """The (u, v) offsets −w·e_c, −(w − mean·z_s)·e_n at the M stations of one stroke's field
    ``w`` (n, M·3) in earth axes at its samples' frame coefficients ``coef`` (n, N_COEF)
    (cos β ``cb``, sin β ``sb`` fold β into e_c, e_n; ``mean`` (M,)), into ``out`` (2, M,
    n)."""
    c_x = (blade.C_ECX, blade.C_ENX)
    c_y = (blade.C_ECY, blade.C_ENY)
    c_z = (blade.C_ECZ, blade.C_ENZ)
    for t in range(coef.shape[0]):
        for k in range(2):
            ex = cb * coef[t, c_x[k]] + sb * coef[t, c_z[k]]
            ey = coef[t, c_y[k]]
            ez = cb * coef[t, c_z[k]] - sb * coef[t, c_x[k]]
            for m in range(mean.shape[0]):
                out[k, m, t] = coef[t, c_z[k]] * mean[m] - (
                    ex * w[t, 3 * m] + ey * w[t, 3 * m + 1] + ez * w[t, 3 * m + 2]
                )


@stroke_loop(error_model=BRANCH_FREE)
def _fill_element_field(flat, prefilter, taps, coef, beta, grid_coef, out, mean, grid_out):
    """:func:`element_field` on numpy, compiled and parallel over strokes b: ``flat`` (B, n_w,
    M·3) the scaled field on the wake grid, ``prefilter`` (n_w, n_w) its spline's
    (:func:`spline_prefilter`), ``taps`` its (B, n_time, 4) indices and weights
    (:func:`periodic_spline`), ``coef`` (B, n_time, N_COEF), ``beta`` (B,), ``grid_coef`` (B,
    n_g, N_COEF) the frames at the wake grid (n_g = n_w, or 0); writes the offsets at the M
    stations into ``out`` (B, 2, M, n_time), the mean into ``mean`` (B, M) and the offsets at
    the wake grid into ``grid_out`` (B, 2, M, n_g)."""
    index, weight = taps
    n_w, n_c, n_t = flat.shape[1], flat.shape[2], index.shape[1]
    for b in prange(flat.shape[0]):
        cb, sb = np.cos(beta[b]), np.sin(beta[b])
        spline = np.zeros((n_w, n_c))
        for i in range(n_w):
            for j in range(n_w):
                for c in range(n_c):
                    spline[i, c] += prefilter[i, j] * flat[b, j, c]
        w = np.zeros((n_t, n_c))
        for t in range(n_t):
            for q in range(index.shape[2]):
                at, share = index[b, t, q], weight[b, t, q]
                for c in range(n_c):
                    w[t, c] += spline[at, c] * share
        for m in range(mean.shape[1]):
            total = 0.0
            for t in range(n_t):
                total += (w[t, 3 * m] * sb + w[t, 3 * m + 2] * cb) * coef[b, t, blade.C_WEIGHT]
            mean[b, m] = total / n_t
        _project(coef[b], w, cb, sb, mean[b], out[b])
        _project(grid_coef[b], flat[b], cb, sb, mean[b], grid_out[b])


def element_field(
    w: Any, target: Pair, taps: tuple[Any, Any], to_elements: Any, scale: Any, xp
) -> tuple[tuple[Any, Any], Any]:
    """The field ``w`` (B, n_w, M, 3) [m/s] on the target's elements and samples, as the
    kernel takes it: its (u, v) offsets −w·e_c, −w·e_n less the cycle-mean normal part, (B,
    n_blade, 2, n_time) on torch, and on numpy (B, 2, M, n_time) at the M stations, which the
    kernel interpolates onto each stroke's elements (``to_elements``; ``cycle.station_offsets``)
    rather than holding every element's in memory; and that mean along −z_s, (B, n_blade), the
    upstream inflow of the momentum side (docs/model.md §5.8 item 5); times ``scale`` (B,)
    (C_hf, 0 where off). Also the offsets at the wake grid's phases (the same layouts with
    n_w for n_time), at the target's ``grid_coef`` (None where it has none), where its Γ is
    shed.
    ``taps``: :func:`periodic_spline` from the wake grid to the kernel's samples, (B, n_time,
    4) indices and weights. The interpolation, the projections and the mean are linear and
    the same along the span, so they are taken at the M stations, the projections on e_c and
    e_n in earth axes (β folded into them), and interpolated onto the elements last."""
    n_b, n_w = w.shape[:2]
    flat = w.reshape(n_b, n_w, -1) * scale[:, None, None]  # (B, n_w, M·3)
    prefilter = spline_prefilter(n_w)
    n_m = to_elements.shape[1]
    if xp is NUMPY:
        coef = np.ascontiguousarray(target.coef[:, 0])
        grid = target.grid_coef
        grid = np.empty((n_b, 0, coef.shape[2])) if grid is None else np.ascontiguousarray(grid)
        out = np.empty((n_b, 2, n_m, coef.shape[1]))
        grid_out = np.empty((n_b, 2, n_m, grid.shape[1]))
        mean = np.empty((n_b, n_m))
        _fill_element_field(
            n_b, np.ascontiguousarray(flat), prefilter,
            tuple(np.ascontiguousarray(a) for a in taps), coef,
            np.ascontiguousarray(target.beta), grid, out, mean, grid_out,
        )  # fmt: skip
        # a stroke's sum in one order whatever the batch (a BLAS product's order depends on
        # the number of rows), so that a stroke's result does not depend on its batch
        upstream = -np.einsum("bm,em->be", mean, to_elements)
        return (out, upstream), None if target.grid_coef is None else grid_out
    stroke = xp.as_int64(xp.arange_like(n_b, flat))[:, None]
    spline = xp.einsum("ij,bjc->bic", xp.constant_like(prefilter, flat), flat)
    index, weight = taps
    w = sum(spline[stroke, index[..., q]] * weight[..., q : q + 1] for q in range(4))
    beta = target.beta[:, None]
    cb, sb = xp.cos(beta), xp.sin(beta)
    coef = target.coef[:, 0]  # (B, n_time, N_COEF)
    w = w.reshape(*w.shape[:2], -1, 3)  # (B, n_time, M, 3)
    wz = w[..., 0] * sb[..., None] + w[..., 2] * cb[..., None]  # (B, n_time, M)
    mean = (wz * coef[:, :, blade.C_WEIGHT, None]).sum(1) / coef.shape[1]  # (B, M)

    def offsets(coef: Any, w: Any) -> Any:
        """(B, n_blade, 2, n) in the kernel's layout, of ``w`` (B, n, M, 3) at ``coef``."""
        # w in stroke-plane axes is (w_x·cos β − w_z·sin β, w_y, w_x·sin β + w_z·cos β)
        project = xp.stack(
            [
                xp.stack(
                    [
                        cb * coef[..., x] + sb * coef[..., z],
                        coef[..., y],
                        cb * coef[..., z] - sb * coef[..., x],
                    ],
                    -1,
                )
                for x, y, z in (
                    (blade.C_ECX, blade.C_ECY, blade.C_ECZ),
                    (blade.C_ENX, blade.C_ENY, blade.C_ENZ),
                )
            ],
            -2,
        )  # fmt: skip  (B, n, 2, 3): e_c, e_n in earth axes
        normal = xp.stack([coef[..., blade.C_ECZ], coef[..., blade.C_ENZ]], -1)  # (B, n, 2)
        # −(w − mean·z_s)·e: (B, n, 2, M)
        d = normal[..., None] * mean[:, None, None, :] - project @ xp.moveaxis(w, -1, -2)
        on_elements = d.reshape(n_b, -1, d.shape[-1]) @ to_elements.T  # (B, n·2, n_blade)
        on_elements = on_elements.reshape(*d.shape[:3], -1)
        return xp.moveaxis(xp.moveaxis(on_elements, -1, 1), -1, -2)

    at_grid = None
    if target.grid_coef is not None:
        at_grid = offsets(target.grid_coef, flat.reshape(n_b, n_w, -1, 3))
    return (offsets(coef, w), -(mean @ to_elements.T)), at_grid


#: A backend's solve of one pair: ``run(w, field, rows)`` solves pair ``w`` (0 fore, 1 hind) on
#: the strokes ``rows`` (integer indices into the batch; ``None``: all) with the other pair's
#: field on those rows (``element_field``'s pair) or ``None`` (isolated, the whole batch), and
#: returns its inflow ((n, n_blade) [m/s]) and the backend's result of the whole batch: that
#: pair's rows this solve's, the rest as the solve that last wrote them left them.
Run = Callable[[int, Any, Any], tuple[Any, Any]]


def vortex_reading(
    fore: Pair,
    hind: Pair,
    run: Run,
    speed: Any,
    path_angle: Any,
    scale: Any,
    xp: ArrayNamespace,
    wake: VortexWake = WAKE,
) -> tuple[Any, Any]:
    """The two pairs iterated to the fixed point of the vortex reading (docs/model.md §5.8
    item 6); returns the result (each pair's from the solve at which its stroke stopped) and
    the strokes (B,) whose fixed point converged.

    Pass 0 solves each pair isolated; its v̄ fixes both wakes' descent (so the geometry), and
    the hind pair's strip circulations start the iteration. Pass m (Gauss-Seidel) gives the fore
    pair the field of hind strips x_m and solves it (its strips f_m), then gives the hind pair
    the field of f_m and solves it: its strips g_m = G(x_m). A stroke's fixed point is reached
    where each pair was last given strips within ``wake.tolerance`` of what the other pair's
    latest solve gives (RMS, relative to the sum of both pairs' RMS strips): after the hind
    pair's solve, |g_m − x_m|; after the fore pair's solve of pass m + 1, |x_{m+1} − g_m| and
    |f_{m+1} − f_m| both (the hind pair's solve of that pass is then not needed). The strokes
    that stop there keep those solves, and the later ones run the other strokes only (every step
    below is stroke by stroke, so a stroke's result does not depend on the others). Otherwise
    x_{m+1} = g_m, or with ``wake.accelerate`` Anderson's step of depth k = ``wake.depth``,
    x_{m+1} = g_m − Σ_i β_i·(g_{m−i+1} − g_{m−i}), the β minimising |r_m − Σ_i β_i·(r_{m−i+1} −
    r_{m−i})| (r = g − x; i = 1 … k, as many as the passes so far give). ``speed`` V [m/s],
    ``path_angle`` γ [rad] and ``scale`` (C_hf, 0 where the reading is off) are (B,).
    """
    inflow = [run(w, None, None)[0] for w in (0, 1)]
    pairs = (fore, hind)
    beats = (wake.fore_beats, wake.hind_beats)
    lattices = [
        lattice(p, disc_mean(p, v, xp), speed, path_angle, b, wake, xp)
        for p, v, b in zip(pairs, inflow, beats, strict=True)
    ]
    to_elements = [xp.constant_like(station_weights(p, wake), p.phase) for p in pairs]
    to_grid = [periodic_spline(p.phase, wake.n_wake, xp) for p in pairs]
    matrices = [influence(lattices[1 - w], pairs[w], wake, xp) for w in (0, 1)]
    uniform = xp.constant_like(2.0 * np.pi * np.arange(wake.n_wake) / wake.n_wake, fore.phase)
    # where a pair has no frames at the wake grid (measured kinematics): the kernel's samples
    # around each grid instant, whose Γ is interpolated there
    samples = [
        None if p.grid_coef is not None else periodic_brackets(p.phase, uniform[None], xp)
        for p in pairs
    ]
    # the strips read two elements each: on numpy only theirs are computed
    read = [(lat.to_strips != 0.0).any(0) if xp is NUMPY else None for lat in lattices]
    rows = xp.as_int64(xp.arange_like(fore.phase.shape[0], fore.phase))  # the strokes solved
    converged = xp.zeros_bool(rows)

    def strips_of(w: int, inflow: Any, field: Any, at_grid: Any) -> Any:
        """Pair w's strip circulations (n, n_w, N_s) [m²/s] at its solved ``inflow`` in the
        other pair's ``field`` (None: isolated), whose offsets at the wake grid are
        ``at_grid``: Γ at the wake grid's phases where the pair has their frames, else at
        the kernel's samples around them, interpolated."""
        pair = pairs[w]
        if pair.grid_coef is None:
            index, weights = samples[w]
            around = index.reshape(len(index), -1)
            gamma = circulation(pair, inflow, field, around, xp, to_elements[w], read[w])
            return strip_circulation(lattices[w].to_strips, weights, gamma, wake, xp)
        grid = xp.as_int64(xp.arange_like(wake.n_wake, inflow))[None] + 0 * rows[:, None]
        on_grid = pair._replace(coef=pair.grid_coef[:, None])
        field = None if field is None else (at_grid, field[1])
        gamma = circulation(on_grid, inflow, field, grid, xp, to_elements[w], read[w])
        return strip_circulation(lattices[w].to_strips, None, gamma, wake, xp)

    def solve(w: int, strips: Any) -> tuple[Any, Any]:
        """Pair w solved in the other pair's field of its ``strips`` (n, n_w, N_s): its own
        strips and the backend's result."""
        on_grid = field_on_grid(matrices[w], strips, xp, rows)
        field, at_grid = element_field(on_grid, pairs[w], to_grid[w], to_elements[w], scale, xp)
        inflow, result = run(w, field, rows)
        return strips_of(w, inflow, field, at_grid), result

    def rms(strips: Any) -> Any:
        return xp.sqrt((strips * strips).mean((1, 2)))

    def stop(done: Any) -> bool:
        """Mark the strokes ``done`` converged and iterate the others only; True where none
        is left."""
        nonlocal rows, scale, pairs, samples, to_grid, history
        nonlocal given, fore_strips, hind_strips, fore_given
        converged[rows[done]] = True
        if bool(done.all()):
            return True
        if bool(done.any()):
            keep = ~done
            rows, scale, given = rows[keep], scale[keep], given[keep]
            fore_strips, hind_strips, fore_given = (
                fore_strips[keep],
                hind_strips[keep],
                fore_given[keep],
            )
            pairs = tuple(p.take(keep) for p in pairs)
            samples = [None if s is None else (s[0][keep], s[1][keep]) for s in samples]
            to_grid = [(i[keep], g[keep]) for i, g in to_grid]
            history = [(g[keep], r[keep]) for g, r in history]
        return False

    # x_1: the isolated hind pair's strips; each pair's latest solve's strips, and the fore
    # strips the hind pair was last given
    given = hind_strips = strips_of(1, inflow[1], None, None)
    fore_strips = fore_given = None
    history: list[tuple[Any, Any]] = []  # the last passes' (strips g, residual r), oldest first
    for passes in range(1, wake.max_passes + 1):
        fore_strips, result = solve(0, given)
        if fore_given is not None:  # each pair given what the other's latest solve gives?
            bound = wake.tolerance * (rms(fore_strips) + rms(hind_strips))
            fore_held = rms(fore_strips - fore_given) <= bound  # the hind pair's input
            hind_held = rms(given - hind_strips) <= bound  # the fore pair's
            if stop(fore_held & hind_held):
                break
        hind_strips, result = solve(1, fore_strips)
        fore_given = fore_strips
        bound = wake.tolerance * (rms(fore_strips) + rms(hind_strips))
        if stop(rms(hind_strips - given) <= bound) or passes == wake.max_passes:
            break
        history = [*history, (hind_strips, hind_strips - given)][-(wake.depth + 1) :]
        given = anderson_step(history, xp) if wake.accelerate and len(history) > 1 else hind_strips
    return result, converged


def anderson_step(history: list[tuple[Any, Any]], xp: ArrayNamespace) -> Any:
    """Anderson's next input from the passes' ``history`` of (g, r), oldest first, each (n, …):
    g_m − ΔG·β with β the least-squares solution of ΔR·β ≈ r_m, stroke by stroke (ΔG, ΔR the
    differences of successive passes; its normal equations regularised by 10⁻¹² of their trace,
    so that equal passes give β = 0)."""
    g, r = history[-1]
    n, k = g.shape[0], len(history) - 1
    dg, dr = (
        xp.stack([new[i] - old[i] for old, new in itertools.pairwise(history)], 1).reshape(n, k, -1)
        for i in (0, 1)
    )
    gram = xp.einsum("nid,njd->nij", dr, dr)
    floor = 1e-12 * xp.einsum("nii->n", gram) + 1e-300
    gram = gram + floor[:, None, None] * xp.constant_like(np.eye(k), g)
    beta = xp.linalg.solve(gram, xp.einsum("nid,nd->ni", dr, r.reshape(n, -1))[..., None])
    return g - xp.einsum("ni,nid->nd", beta[..., 0], dg).reshape(g.shape)


@stroke_loop()
def _fill_frames(angles, weight, beta, spin_total, out):
    """Each stroke's frame coefficients (``blade.fill_frame_coefficients``, the right wing):
    ``angles`` (B, n_time, 9), ``weight`` (B, n_time), ``beta`` (B,); ``out`` (B, n_time,
    N_COEF)."""
    for b in prange(angles.shape[0]):
        blade.fill_frame_coefficients(angles[b], weight[b], beta[b], spin_total, 1, out[b])


def kernel_reading(
    wings: tuple[Any, Any],
    params: tuple[np.ndarray, np.ndarray] | None,
    phases: np.ndarray,
    run_pass: Callable[..., Any],
    speed: np.ndarray,
    path_angle: np.ndarray,
    scale: np.ndarray,
    insect: Any,
    spin_total: bool,
    fields_out: list | None = None,
) -> Any:
    """The vortex reading on the numba kernel: ``wings`` the fore and hind
    ``bundle.WingBatch``, ``params`` their (B, 14) parameters [Hz, rad, -] or None (measured
    kinematics: the wings' angles on uniform phases, read from their histories), ``phases``
    (B, 2, n_time) [rad]; ``run_pass(wings, pairs)`` runs the kernel on the whole batch,
    solving the pairs ``pairs`` names (``bundle.Settings.pairs``), and returns its
    ``bundle.Outputs``; ``run_pass(wings, pairs, rows, into)`` solves the strokes ``rows``
    (``bundle.Settings.rows``) into their rows of ``into``; each sample's frame coefficients
    are computed once here (``WingBatch.frames``). Returns each stroke's
    outputs of the pass at which it stopped, with the fixed point's convergence folded into
    each wing's ``W_CONVERGED`` (``cycle``); the caller takes the cycle means from their
    history where its passes leave them out (``Settings.means``). ``fields_out``: a list that
    receives, per wing, the other pair's field in the pass at which each stroke stopped
    (:func:`element_field`, times C_hf): its (u, v) offsets on the elements (B, n_blade, 2,
    n_time) and the upstream inflow (B, n_blade) [m/s] (zero where the reading is off)."""

    pairs = []
    frames = []
    for w, (batch, wing) in enumerate(zip(wings, (insect.fore, insect.hind), strict=True)):
        coef = np.empty((*batch.weight.shape, blade.N_COEF))
        _fill_frames(
            len(coef),
            np.ascontiguousarray(batch.angles), np.ascontiguousarray(batch.weight),
            np.ascontiguousarray(batch.beta), spin_total, coef,
        )  # fmt: skip
        frames.append(coef)  # the kernel's own, computed once for all passes
        coef = coef[:, None]
        root = np.array([-insect.root_spacing * w, ROOT_HALF_WIDTH, -insect.root_drop * w])
        pairs.append(
            Pair(
                params=None if params is None else params[w],
                # measured: the angle history's φ, θ, η columns (kinematics.ANGLE_COLUMNS)
                samples=np.ascontiguousarray(batch.angles[:, :, ::3]) if params is None else None,
                frequency=batch.frequency,  # the parameters' f and β where there are some
                beta=batch.beta,
                coef=coef,
                phase=phases[:, w],
                v_tangential=batch.v_tangential,
                v_normal=batch.v_normal,
                wing=wing,
                r=np.array(batch.nodes[:, cycle.N_R]),
                width=np.array(batch.nodes[:, cycle.N_WIDTH]),
                root=root,
                grid_coef=None
                if params is None
                else grid_frames(params[w], spin_total, WAKE, NUMPY),
            )
        )

    wings = tuple(b._replace(frames=f) for b, f in zip(wings, frames, strict=True))
    result = run_pass(wings, 3)  # pass 0, the isolated pairs, on the whole batch
    to_elements = [np.ascontiguousarray(station_weights(p, WAKE)) for p in pairs]
    converged = np.zeros(len(speed), dtype=bool)
    n_time = phases.shape[-1]
    kept = [  # each stroke's fields of its latest pass, at the read stations, where asked
        (np.zeros((len(speed), 2, WAKE.read_points, n_time)), np.zeros((len(speed), len(p.r))))
        for p in (pairs if fields_out is not None else ())
    ]

    def fixed_point(part: np.ndarray) -> None:
        """The fixed point of the strokes ``part``, into ``result``, ``converged``, ``kept``."""

        def run(w: int, field: Any, rows: Any) -> tuple[Any, Any]:
            if field is None:
                return result.inflow[part, w], result
            index = part[rows]
            batch = wings[w]._replace(
                external=field[0], external_inflow=np.ascontiguousarray(field[1]),
                to_elements=to_elements[w],
            )  # fmt: skip
            # the kernel solves the strokes ``index`` into their rows of ``result``; the pair
            # not solved is not read (``Settings.pairs``): this batch stands in its place
            run_pass((batch, batch), 1 << w, index, result)
            if fields_out is not None:
                kept[w][0][index], kept[w][1][index] = field
            return result.inflow[index, w], result

        chunk = tuple(p.take(part) for p in pairs)
        _, converged[part] = vortex_reading(
            *chunk, run, speed[part], path_angle[part], scale[part], NUMPY, WAKE
        )

    # the fixed point, stroke by stroke, on at most WAKE.chunk strokes at a time: the same
    # results (item 6), and arrays small enough to be reused rather than mapped afresh at
    # each pass. On several numba threads the chunks run side by side, each on one thread
    # (its compiled loops serial and without the GIL): a pass's loops over a few dozen
    # strokes gain less from a parallel launch than whole chunks do from a thread each
    threads = numba.get_num_threads()
    size = min(WAKE.chunk, -(-len(speed) // threads))
    parts = [np.arange(at, min(at + size, len(speed))) for at in range(0, len(speed), size)]
    if threads > 1 and len(parts) > 1:
        with ThreadPoolExecutor(min(threads, len(parts))) as pool:
            list(pool.map(partial(on_one_thread, fixed_point), parts))
    else:
        for part in parts:
            fixed_point(part)
    outputs = result
    outputs.means[:, :, cycle.W_CONVERGED] *= converged[:, None]
    if fields_out is not None:
        fields_out.extend(
            (np.einsum("em,bkmt->bekt", elements, offsets), upstream)
            for (offsets, upstream), elements in zip(kept, to_elements, strict=True)
        )
    return outputs
