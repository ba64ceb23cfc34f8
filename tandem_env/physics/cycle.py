"""One wing-beat cycle of a batch of tandem strokes (Eqs. 16-19), compiled and parallel.

For each stroke, the fore-wing is solved first (its momentum inflow per annulus), then the
hind-wing in the fore-wing's slipstream (docs/model.md §5). Annulus by annulus, the element forces
at the solved inflow (the inflow solver's last force sweep, reused rather than recomputed) are
integrated over the span per sample; the span integrals are then rotated to earth axes (Eq. 16)
and averaged over the cycle into force (Eq. 17) and power (Eqs. 18-19, as docs/model.md §6 decides).

Quadrature: the cycle is sampled on the motion-following grid of ``kinematics``; smooth
integrands use the periodic trapezoid rule (spectrally accurate), and the positive parts and
absolute values (thrust, drag, |P|) integrate the trigonometric interpolant exactly between its
located zero crossings, so the kinks do not cost accuracy (docs/model.md §11).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numba import njit, prange

from .blade import (
    C_DSPIN,
    C_SPIN,
    C_WEIGHT,
    N_COEF,
    acute_angle,
    earth_forces,
    element_moment,
    element_power,
    fill_frame_coefficients,
    inertial_power,
    relative_velocity,
    shed_force,
)
from .bundle import Section, WingStroke
from .induction import N_SAMPLE, S_FC, S_FN, S_U, S_V, sweep_annulus
from .kinematics import fill_angle_history
from .xp import BRANCH_FREE, select, stroke_loop

# Blade-element node table columns.
N_R = 0  # radius r [m]
N_CHORD = 1  # chord c(r) [m]
N_WIDTH = 2  # quadrature weight dr [m]
N_M11 = 3  # ¼πρb_t² [kg/m]
N_M22 = 4  # ¼πρc² [kg/m]
N_IA = 5  # (1/128)πρ(c² + b_t²)² [kg·m]
N_DAMP = 6  # (1/16)πρc⁴ [kg·m]
N_COLUMNS = 7

# Wing constant vector.
K_CT = 0
K_CD0 = 1
K_CD90 = 2
K_CR = 3
K_MU1 = 4
K_MU2 = 5
K_I_SPAN = 6  # ∫ m'(r)·r² dr [kg·m²]: flapping inertia of the pitch axis line
K_I_PITCH = 7  # ∫ m'(r)·c²/12 dr [kg·m²]: thin-plate inertia about the mid-chord
N_CONSTANTS = 8

# Per-wing outputs (single wing of a pair; multiply by N_w for the pair).
W_FZ = 0  # cycle-mean vertical force [N]
W_FX = 1  # cycle-mean horizontal force, + forward [N]
W_THRUST = 2  # cycle mean of the forward part of F_x(t) [N]
W_DRAG = 3  # cycle mean of the rearward part of F_x(t) (≥ 0) [N]
W_P_AERO = 4  # mean |P_aero| [W]
W_P_INER = 5  # mean |P_iner| [W]
W_P_ELASTIC = 6  # mean of the positive part of P_aero + P_iner [W]
W_AOA = 7  # area-weighted cycle-mean acute angle of attack [rad]
W_CONVERGED = 8  # 1 if every annulus's inflow converged
W_EVALS = 9  # largest number of force sweeps an annulus needed
W_INFLOW = 10  # area-weighted mean induced velocity [m/s]
W_P_AERO_POSITIVE = 11  # mean of the positive part of P_aero [W]
W_SWEEPS = 12  # force sweeps over the cycle, all annuli together (benchmarks/roofline.py)
W_SLOPES = 13  # slopes of the mean normal force (``induction.normal_force_slope``) computed
N_WING_OUT = 14

MODE_NONE = 0
MODE_ISOLATED = 1
MODE_COUPLED = 2


@njit(cache=True)
def section_at(nodes, j, consts, rho):
    """The :class:`~tandem_env.physics.bundle.Section` of annulus ``j`` of a wing's node table
    ``nodes`` and constants ``consts`` (``model.wing_tables``) in air of density ``rho``
    [kg/m³]."""
    return Section(
        nodes[j, N_R], nodes[j, N_CHORD], nodes[j, N_WIDTH], nodes[j, N_M11], nodes[j, N_M22],
        nodes[j, N_IA], nodes[j, N_DAMP], rho, consts[K_CT], consts[K_CD0], consts[K_CD90],
        consts[K_CR], consts[K_MU1], consts[K_MU2],
    )  # fmt: skip


@lru_cache(maxsize=16)
def fourier_tables(n_time: int) -> tuple[np.ndarray, np.ndarray]:
    """cos(m·s_k), sin(m·s_k) for s_k = 2πk/n and m = 1 … (n − 1)//2: (n, M) each, read-only.

    One row per sample, so that the Fourier sums over the samples run along contiguous rows
    of modes (:func:`fourier_coefficients`). Cached: every evaluation at a resolution uses the
    same tables.
    """
    m = np.arange(1, (n_time - 1) // 2 + 1)[None, :]
    s = 2.0 * np.pi * np.arange(n_time)[:, None] / n_time
    tables = np.ascontiguousarray(np.cos(m * s)), np.ascontiguousarray(np.sin(m * s))
    for table in tables:
        table.setflags(write=False)
    return tables


#: A Newton step shorter than this [rad] ends the search for a zero crossing of the
#: interpolant in :func:`positive_part_of_series`: the antiderivative there is then corrected to
#: the root to O(p''·δ³) ≈ 1e-18 relative, one evaluation of the series sooner.
NEWTON_SHORT = 1e-6

#: Most steps of :func:`turning_point` (Illinois: superlinear, ~8 steps to 1e-13 rad in an
#: interval of 2π/128; bisection alone would need 40).
TURNING_STEPS = 40
#: :func:`turning_point` stops at a step shorter than this [rad].
TURNING_SHORT = 1e-13

#: Independent partial sums of the interpolant's series in :func:`_trig_eval`: harmonics
#: m ≡ i (mod 4) run in four chains, so that their rotations overlap instead of waiting on
#: one another.
CHAINS = 4


@njit(cache=True)
def _fft(re, im, cos_table, sin_table):
    """In place, the discrete Fourier transform X_m = Σ_k x_k·exp(−2πi·mk/n) of the complex
    series ``re`` + i·``im`` (n,), n a power of two (iterative radix 2, O(n log n)); the
    twiddles are the first column of :func:`fourier_tables`."""
    n = re.shape[0]
    j = 0
    for i in range(1, n):  # bit-reversed order
        bit = n >> 1
        while j & bit:
            j ^= bit
            bit >>= 1
        j |= bit
        if i < j:
            re[i], re[j] = re[j], re[i]
            im[i], im[j] = im[j], im[i]
    size = 2
    while size <= n:
        half = size // 2
        step = n // size
        for k in range(half):
            wr = cos_table[k * step, 0]
            wi = -sin_table[k * step, 0]
            for a in range(k, n, size):
                b = a + half
                tr = wr * re[b] - wi * im[b]
                ti = wr * im[b] + wi * re[b]
                re[b] = re[a] - tr
                im[b] = im[a] - ti
                re[a] += tr
                im[a] += ti
        size *= 2


@njit(cache=True)
def fourier_coefficients(g, cos_table, sin_table):
    """Series coefficients of the trigonometric interpolants of the rows of ``g`` (S, n), S
    even: (S, 6, M') of a_m, b_m, m·a_m, m·b_m, a_m/m, b_m/m (value, slope and antiderivative),
    zero beyond M (M' a multiple of :data:`CHAINS`), and the means a_0 (S,).

    a_m − i·b_m = (2/n)·Σ_k g_k·exp(−i·m·s_k): for n a power of two by the FFT, two real rows
    as one complex series (:func:`_fft`), O(n log n); else summed sample by sample (O(n²)).
    """
    n_series, n = g.shape
    n_modes = cos_table.shape[1]
    padded = -(-n_modes // CHAINS) * CHAINS
    series = np.zeros((n_series, 6, padded))
    a0 = np.empty(n_series)
    for i in range(n_series):
        total = 0.0
        for k in range(n):
            total += g[i, k]
        a0[i] = total / n
    a = np.zeros((n_series, n_modes))
    b = np.zeros((n_series, n_modes))
    if n & (n - 1) == 0:
        re = np.empty(n)
        im = np.empty(n)
        for i in range(0, n_series, 2):
            re[:] = g[i]
            im[:] = g[i + 1]
            _fft(re, im, cos_table, sin_table)
            for j in range(n_modes):
                m = j + 1
                a[i, j] = (re[m] + re[n - m]) / n
                b[i, j] = (im[n - m] - im[m]) / n
                a[i + 1, j] = (im[m] + im[n - m]) / n
                b[i + 1, j] = (re[m] - re[n - m]) / n
    else:
        for k in range(n):
            cos_k = cos_table[k]
            sin_k = sin_table[k]
            for i in range(n_series):
                gk = g[i, k]
                for j in range(n_modes):
                    a[i, j] += gk * cos_k[j]
                    b[i, j] += gk * sin_k[j]
        a *= 2.0 / n
        b *= 2.0 / n
    for i in range(n_series):
        for j in range(n_modes):
            m = j + 1.0
            series[i, 0, j] = a[i, j]
            series[i, 1, j] = b[i, j]
            series[i, 2, j] = m * a[i, j]
            series[i, 3, j] = m * b[i, j]
            series[i, 4, j] = a[i, j] / m
            series[i, 5, j] = b[i, j] / m
    return series, a0


@njit(cache=True)
def _trig_eval(a0, series, s):
    """Trigonometric interpolant p(s), its derivative and its antiderivative P(s) (P(0) = 0 + …)
    of one row of :func:`fourier_coefficients`.

    cos(ms), sin(ms) by rotation, in :data:`CHAINS` = 4 interleaved chains (m ≡ 1, 2, 3, 4
    mod 4), each stepping by 4s, with their own partial sums.
    """
    c1 = np.cos(s)
    s1 = np.sin(s)
    c2 = c1 * c1 - s1 * s1
    s2 = 2.0 * s1 * c1
    c3 = c2 * c1 - s2 * s1
    s3 = s2 * c1 + c2 * s1
    c4 = c2 * c2 - s2 * s2
    s4 = 2.0 * s2 * c2
    ca, cb, cc, cd = c1, c2, c3, c4
    sa, sb, sc, sd = s1, s2, s3, s4
    va = vb = vc = vd = 0.0
    da = db = dc = dd = 0.0
    ia = ib = ic = id_ = 0.0
    for j in range(0, series.shape[1], CHAINS):
        va += series[0, j] * ca + series[1, j] * sa
        vb += series[0, j + 1] * cb + series[1, j + 1] * sb
        vc += series[0, j + 2] * cc + series[1, j + 2] * sc
        vd += series[0, j + 3] * cd + series[1, j + 3] * sd
        da += series[3, j] * ca - series[2, j] * sa
        db += series[3, j + 1] * cb - series[2, j + 1] * sb
        dc += series[3, j + 2] * cc - series[2, j + 2] * sc
        dd += series[3, j + 3] * cd - series[2, j + 3] * sd
        ia += series[4, j] * sa - series[5, j] * ca
        ib += series[4, j + 1] * sb - series[5, j + 1] * cb
        ic += series[4, j + 2] * sc - series[5, j + 2] * cc
        id_ += series[4, j + 3] * sd - series[5, j + 3] * cd
        ca, sa = ca * c4 - sa * s4, sa * c4 + ca * s4
        cb, sb = cb * c4 - sb * s4, sb * c4 + cb * s4
        cc, sc = cc * c4 - sc * s4, sc * c4 + cc * s4
        cd, sd = cd * c4 - sd * s4, sd * c4 + cd * s4
    return (
        a0 + ((va + vb) + (vc + vd)),
        (da + db) + (dc + dd),
        a0 * s + ((ia + ib) + (ic + id_)),
    )


@njit(cache=True)
def _crossing(a0, series, lo, width, f_lo, f_hi):
    """The zero crossing of the interpolant in [lo, lo + width], where it goes from ``f_lo`` to
    ``f_hi`` (of the other sign): (s [rad], P(s)). Linear guess, then Newton kept inside the
    bracket (bisection where a step would leave it)."""
    hi = lo + width
    x = lo + width * f_lo / (f_lo - f_hi)
    big_p = 0.0
    for _ in range(6):
        p, dp, big_p = _trig_eval(a0, series, x)
        if (p > 0.0) == (f_lo > 0.0):
            lo = x
        else:
            hi = x
        newton = dp != 0.0
        x_new = x - p / dp if newton else 0.5 * (lo + hi)
        if not lo <= x_new <= hi:
            x_new = 0.5 * (lo + hi)
            newton = False
        if newton and abs(x_new - x) < NEWTON_SHORT:
            # P at the root from the last point, P(x + δ) = P + p·δ + ½p'·δ² with the
            # Newton step δ = −p/p': exact to O(p''·δ³), the root's own error (O(δ²))
            # entering only squared (the integrand vanishes there)
            big_p -= 0.5 * p * p / dp
            x = x_new
            break
        if abs(x_new - x) < 1e-11:
            break
        x = x_new
    return x, big_p


@njit(cache=True)
def sample_slopes(series, n, cos_table, sin_table):
    """p'(s_k) of one row's interpolant at its n samples (n,): the series m·b_m, −m·a_m
    transformed back (:func:`_fft` of the conjugate) for n a power of two, O(n log n); else
    evaluated sample by sample."""
    n_modes = cos_table.shape[1]
    re = np.zeros(n)
    im = np.zeros(n)
    if n & (n - 1) == 0:
        for j in range(n_modes):
            re[j + 1] = series[3, j]
            im[j + 1] = -series[2, j]
        _fft(re, im, cos_table, sin_table)
    else:
        for k in range(n):
            re[k] = _trig_eval(0.0, series, 2.0 * np.pi * k / n)[1]
    return re


@njit(cache=True)
def turning_point(a0, series, lo, hi, slope_lo, slope_hi):
    """The zero of p' in [lo, hi], where p' goes from ``slope_lo`` to ``slope_hi`` (of the other
    sign): (s [rad], p(s)). Regula falsi with the Illinois correction (the end kept twice in a
    row has its slope halved), bisection where a step would leave the bracket."""
    x = lo
    kept = 0  # +1: lo was kept by the last step, −1: hi
    for _ in range(TURNING_STEPS):
        x_new = (lo * slope_hi - hi * slope_lo) / (slope_hi - slope_lo)
        if not lo < x_new < hi:
            x_new = 0.5 * (lo + hi)
        step = abs(x_new - x)
        x = x_new
        slope = _trig_eval(a0, series, x)[1]
        if slope == 0.0 or step < TURNING_SHORT:
            break
        if (slope > 0.0) == (slope_lo > 0.0):
            lo, slope_lo = x, slope
            if kept == -1:
                slope_hi *= 0.5
            kept = -1
        else:
            hi, slope_hi = x, slope
            if kept == 1:
                slope_lo *= 0.5
            kept = 1
    return x, _trig_eval(a0, series, x)[0]


@njit(cache=True)
def positive_part_of_series(g, a0, series, cos_table, sin_table):
    """Cycle mean of max(g, 0) of n periodic samples g at s_k = 2πk/n from the coefficients of
    their interpolant (:func:`fourier_coefficients`: ``a0`` and ``series``, one row).

    Its zero crossings are found interval by interval. Where p' has one sign over an interval,
    p is taken as monotone there: one crossing if the samples change sign. Where p' changes
    sign, p turns inside the interval (:func:`turning_point`), and each of the two monotone
    pieces has a crossing where its end values differ in sign. Without the turning points,
    p dipping across zero between two samples of one sign would be missed until a sample
    crossed zero, and the mean would jump there (docs/model.md §11)."""
    n = g.shape[0]
    h = 2.0 * np.pi / n
    slopes = sample_slopes(series, n, cos_table, sin_table)
    # Between two samples p departs from their chord by at most max|p''|·h²/8, and
    # max|p''| <= Σ m²·(|a_m| + |b_m|); the evaluation's rounding stays far below 1e-10 of
    # Σ|coefficients|. An interval whose samples clear zero by more than both cannot cross it
    # wherever its turning point lies, so its bisection is skipped: the same roots, the same bits.
    bend = 0.0
    size = abs(a0)
    for j in range(series.shape[1]):
        bend += (j + 1.0) * (abs(series[2, j]) + abs(series[3, j]))
        size += abs(series[0, j]) + abs(series[1, j])
    clearance = bend * h * h / 8.0 + 1e-10 * size
    roots = np.empty(2 * n)
    antiderivative = np.empty(2 * n)
    after_positive = np.empty(2 * n, dtype=np.bool_)
    n_roots = 0
    for k in range(n):
        g0 = g[k]
        g1 = g[(k + 1) % n]
        lo = k * h
        if (slopes[k] > 0.0) == (slopes[(k + 1) % n] > 0.0):
            if (g0 > 0.0) != (g1 > 0.0):
                x, big_p = _crossing(a0, series, lo, h, g0, g1)
                roots[n_roots] = x
                antiderivative[n_roots] = big_p
                after_positive[n_roots] = g1 > 0.0
                n_roots += 1
            continue
        if min(g0, g1) > clearance or max(g0, g1) < -clearance:
            continue
        x_turn, p_turn = turning_point(a0, series, lo, lo + h, slopes[k], slopes[(k + 1) % n])
        if (g0 > 0.0) != (p_turn > 0.0):
            x, big_p = _crossing(a0, series, lo, x_turn - lo, g0, p_turn)
            roots[n_roots] = x
            antiderivative[n_roots] = big_p
            after_positive[n_roots] = p_turn > 0.0
            n_roots += 1
        if (p_turn > 0.0) != (g1 > 0.0):
            x, big_p = _crossing(a0, series, x_turn, lo + h - x_turn, p_turn, g1)
            roots[n_roots] = x
            antiderivative[n_roots] = big_p
            after_positive[n_roots] = g1 > 0.0
            n_roots += 1
    if n_roots == 0:
        return max(a0, 0.0) if g[0] > 0.0 else 0.0
    total = 0.0
    two_pi = 2.0 * np.pi
    for i in range(n_roots):
        if after_positive[i]:
            j = (i + 1) % n_roots
            # P(s + 2π) = P(s) + 2π·a0 closes the arc that wraps past s = 2π
            wrap = two_pi * a0 if j <= i else 0.0
            total += antiderivative[j] + wrap - antiderivative[i]
    return max(total, 0.0) / two_pi


@njit(cache=True)
def mean_positive_part(g, cos_table, sin_table):
    """Cycle mean of max(g, 0) for n periodic samples g at s_k = 2πk/n, to spectral accuracy.

    The trapezoid rule is spectrally accurate for smooth periodic g but only second order for
    its positive part, whose kinks sit between samples (docs/model.md §11). So we integrate the
    trigonometric interpolant p of the samples exactly: its zero crossings are located by
    safeguarded Newton inside each interval where the samples change sign, and the positive
    arcs are summed with p's antiderivative (:func:`positive_part_of_series`).
    """
    rows = np.zeros((2, g.shape[0]))
    rows[0] = g
    series, a0 = fourier_coefficients(rows, cos_table, sin_table)
    return positive_part_of_series(g, a0[0], series[0], cos_table, sin_table)


#: Rows of the cycle means' Fourier analysis (:func:`cycle_means`), paired two by two into
#: complex series: P_aero and P_aero + P_iner each beside F_x, so that a wing without inertial
#: power gets the same bits for both; P_iner alone.
_AERO, _FX, _ELASTIC, _INER = 0, 1, 2, 4


@njit(cache=True)
def cycle_means(histories, weight, out, cos_table, sin_table):
    """Cycle means of one wing's per-sample F_x, F_z, F_y, P_aero, P_iner (``histories``,
    (n_time, 5) [N, W]) with quadrature weights ``weight`` (n_time,): writes W_FX, W_FZ,
    W_THRUST, W_DRAG, W_P_AERO, W_P_AERO_POSITIVE, W_P_INER and W_P_ELASTIC of ``out``.

    The four positive parts (F_x, P_aero, P_iner, P_aero + P_iner) share one Fourier analysis
    (:func:`fourier_coefficients`, three complex series)."""
    n_time = histories.shape[0]
    g = np.zeros((6, n_time))
    fx = 0.0
    fz = 0.0
    mean_aero = 0.0
    mean_iner = 0.0
    for k in range(n_time):
        w = weight[k]
        fx += histories[k, 0] * w
        fz += histories[k, 1] * w
        g[_FX, k] = histories[k, 0] * w
        g[_FX + 2, k] = g[_FX, k]
        g[_AERO, k] = histories[k, 3] * w
        g[_INER, k] = histories[k, 4] * w
        g[_ELASTIC, k] = (histories[k, 3] + histories[k, 4]) * w
        mean_aero += g[_AERO, k]
        mean_iner += g[_INER, k]
    out[W_FX] = fx / n_time
    out[W_FZ] = fz / n_time
    mean_aero /= n_time
    mean_iner /= n_time
    series, a0 = fourier_coefficients(g, cos_table, sin_table)
    # T = mean F_x⁺, D = mean F_x⁻ = T − mean F_x; mean|P| = 2·mean P⁺ − mean P
    out[W_THRUST] = positive_part_of_series(g[_FX], a0[_FX], series[_FX], cos_table, sin_table)
    out[W_DRAG] = max(out[W_THRUST] - out[W_FX], 0.0)
    aero = positive_part_of_series(g[_AERO], a0[_AERO], series[_AERO], cos_table, sin_table)
    out[W_P_AERO_POSITIVE] = aero
    out[W_P_AERO] = max(2.0 * aero - mean_aero, 0.0)
    iner = positive_part_of_series(g[_INER], a0[_INER], series[_INER], cos_table, sin_table)
    out[W_P_INER] = max(2.0 * iner - mean_iner, 0.0)
    out[W_P_ELASTIC] = positive_part_of_series(
        g[_ELASTIC], a0[_ELASTIC], series[_ELASTIC], cos_table, sin_table
    )


@njit(cache=True)
def add_to_span(frame, samples, section, frequency, span):
    """Add one annulus's element forces, power and acute angle of attack at the samples of its
    final sweep (``samples``, ``induction.N_SAMPLE`` rows) into the span integrals ``span``
    (4, n_time): chordwise and chord-normal force [N], P_aero [W] and the chord-weighted angle
    [m²·rad]. Each row is its own contiguous array, so the loop vectorises."""
    width = section.width
    area = section.chord * width
    span_c = span[0]
    span_n = span[1]
    span_power = span[2]
    span_angle = span[3]
    fc_row = samples[S_FC]
    fn_row = samples[S_FN]
    u_row = samples[S_U]
    v_row = samples[S_V]
    for k in range(span_c.shape[0]):
        fc = fc_row[k]
        fn = fn_row[k]
        u = u_row[k]
        v = v_row[k]
        moment = element_moment(u, v, frame[k, C_SPIN], frame[k, C_DSPIN], section, frequency)
        span_c[k] += width * fc
        span_n[k] += width * fn
        span_power[k] += width * element_power(frame, k, fc, fn, moment, section)
        span_angle[k] += area * acute_angle(u, v)


@njit(cache=True)
def wing_cycle(
    wing, settings, v_external, solve, out_inflow, out, histories, wake=None, out_load=None,
    external=None,
):  # fmt: skip
    """Solve the inflow of one wing and integrate its cycle (writes ``out`` and ``out_inflow``).

    ``wing``: the wing of one stroke (:class:`~tandem_env.physics.bundle.WingStroke`);
    ``settings``: the options, the air and the Fourier tables
    (:class:`~tandem_env.physics.bundle.Settings`); ``solve``: the wing solves its inflow.
    ``v_external``: (n_r,) inflow imposed from upstream [m/s] (the fore-wing's slipstream on the
    hind-wing, already scaled by C_hf). ``wake``: (n_time,) the part of that inflow that varies
    over the cycle [m/s] (the convected slipstream, docs/model.md §5.7): annulus j sees
    v_external[j] + wake[k] at sample k; ``None``: the same at every sample (compiled exactly
    as without it). ``out_load``: (n_time,) receives the span integral of the circulatory and
    viscous element forces along the stroke-plane normal per sample at the solved inflow (the
    force the wing sheds into its wake, §5.7) [N], or ``None``. ``histories``: (n_time, 5)
    scratch receiving F_x, F_z, F_y, P_aero, P_iner per sample (one wing) [N, W]. The wing's
    ``table``: its force-coefficient model (``coefficients``), ``None`` for the paper's (then
    compiled exactly as without models). ``external``: (n_r, 2, n_time) the other pair's induced
    velocity in each element's (u, v) (the vortex reading, docs/model.md §5.8;
    ``induction.normal_force_sweep``), or ``None``.
    """
    coef = wing.coef
    nodes = wing.nodes
    consts = wing.consts
    table = wing.table
    frequency = wing.frequency
    v_tangential = wing.v_tangential
    v_normal = wing.v_normal
    n_time = coef.shape[0]
    n_r = nodes.shape[0]
    converged = True
    max_evals = 0
    sweeps = 0
    slopes = 0
    area = 0.0
    inflow_mean = 0.0
    # Per sample: span integrals of the chordwise and chord-normal force [N], P_aero [W] and
    # the chord-weighted acute angle of attack, summed annulus by annulus.
    span = np.zeros((4, n_time))
    samples = np.empty((N_SAMPLE, n_time))
    # the frame coefficients in Fortran order (each column contiguous), so that the loops over
    # samples here and in the inflow solve vectorise
    coef_by_column = np.empty((N_COEF, n_time))
    for k in range(n_time):
        for c in range(N_COEF):
            coef_by_column[c, k] = coef[k, c]
    frame = coef_by_column.T
    for j in range(n_r):
        section = section_at(nodes, j, consts, settings.rho)
        r = section.r
        chord = section.chord
        width = section.width
        v_upstream = v_normal + v_external[j]
        # ``samples`` ends up holding the element forces at the annulus's final inflow
        if external is None:
            v_induced, evals, ok = sweep_annulus(
                frame, section, v_tangential, v_upstream, solve, wing.sweep, settings, samples,
                table, wake,
            )  # fmt: skip
        else:
            v_induced, evals, ok = sweep_annulus(
                frame, section, v_tangential, v_upstream, solve, wing.sweep, settings, samples,
                table, wake, external[j],
            )  # fmt: skip
        converged = converged and ok
        max_evals = max(max_evals, evals)
        sweeps += max(evals, 1)
        # a solve takes the slope at every sweep but the one it stops at (all, if it fails)
        slopes += max(evals - 1, 0) + (0 if ok else 1)
        out_inflow[j] = v_induced
        area += chord * width
        inflow_mean += chord * width * v_induced
        add_to_span(frame, samples, section, frequency, span)
        if out_load is not None:
            if j == 0:
                for k in range(n_time):
                    out_load[k] = 0.0
            for k in range(n_time):
                _, _, du, dv = relative_velocity(frame, k, r, v_tangential, v_upstream + v_induced)
                out_load[k] += width * shed_force(
                    frame, k, samples[S_U, k], samples[S_V, k], du, dv, samples[S_FC, k],
                    samples[S_FN, k], section,
                )  # fmt: skip
    aoa = 0.0
    for k in range(n_time):
        fx, fz, fy = earth_forces(frame, k, span[0, k], span[1, k])
        histories[k, 0] = fx
        histories[k, 1] = fz
        histories[k, 2] = fy
        histories[k, 3] = span[2, k]
        histories[k, 4] = inertial_power(frame, k, consts[K_I_SPAN], consts[K_I_PITCH])
        aoa += span[3, k] * frame[k, C_WEIGHT]
    if settings.means:
        cycle_means(
            histories, coef_by_column[C_WEIGHT], out, settings.cos_table, settings.sin_table
        )
    out[W_AOA] = aoa / (area * n_time) if area > 0.0 else 0.0
    out[W_CONVERGED] = 1.0 if converged else 0.0
    out[W_EVALS] = max_evals
    out[W_SWEEPS] = sweeps
    out[W_SLOPES] = slopes
    out[W_INFLOW] = inflow_mean / area if area > 0.0 else 0.0


@njit(cache=True, error_model=BRANCH_FREE)
def slipstream_delay(disc_inflow_fore, normal_speed_hind, beta_fore, beta_hind, roots):
    """Time t_d [s] the fore-wing's wake takes to reach the hind-wing's stroke plane (§5.7).

    The wake leaves the fore-wing's root at the free stream plus the fore-wing's induced
    velocity v̄ (``disc_inflow_fore`` [m/s], the mean over its swept disc, ∫v_i·r·dr / ∫r·dr:
    :func:`disc_inflow`, along −z_s of the fore-wing) and crosses the distance from the
    fore-wing's root to the hind-wing's stroke plane, h_n = d·sin β_h + D·cos β_h (d
    ``roots.root_spacing`` aft, D ``roots.root_drop`` below [m]: the ``Settings`` or the
    ``Dragonfly``; β [rad]), at the flow
    speed normal to that plane, U = V_n,h + v̄·cos(β_f − β_h) (``normal_speed_hind`` V_n,h
    [m/s]), bounded below by v̄·cos(β_f − β_h)/2 where the free stream opposes the wake (the
    vortex-ring state, where momentum theory no longer holds): t_d = h_n / U. Zero where the
    fore-wing induces nothing (its wake is then zero too).
    """
    along = disc_inflow_fore * np.cos(beta_fore - beta_hind)
    ahead = normal_speed_hind + along
    speed = select(0.5 * along > ahead, 0.5 * along, ahead)
    normal = roots.root_spacing * np.sin(beta_hind) + roots.root_drop * np.cos(beta_hind)
    distance = select(0.0 > normal, 0.0, normal)
    moving = speed > 0.0
    return select(moving, distance / select(moving, speed, 1.0), 0.0)


#: Strength of the exponential filter on the convected wake's harmonics, exp(−36·(m/m_c)^16)
#: (:func:`convected_wake`): 36 ≈ −ln(machine epsilon), so harmonics beyond m_c vanish to
#: rounding (the exponential filter of spectral methods, Gottlieb & Hesthaven 2001).
WAKE_FILTER = 36.0


@njit(cache=True)
def disc_inflow(inflow, nodes):
    """Mean induced velocity over a wing's swept disc, ∫v_i·r·dr / ∫r·dr [m/s] (§5.7)."""
    num = 0.0
    den = 0.0
    for j in range(nodes.shape[0]):
        area = nodes[j, N_R] * nodes[j, N_WIDTH]
        num += area * inflow[j]
        den += area
    return num / den if den > 0.0 else 0.0


@njit(cache=True)
def convected_wake(load, fore, phase_hind, delay, inflow_fore, settings, out):
    """The part of the fore-wing's slipstream on the hind-wing that varies over the cycle (§5.7):
    out[k] = C_hf·Δv(ϑ_h,k − δ) [m/s], the same on every annulus.

    ``fore``: the fore-wing of the stroke (:class:`~tandem_env.physics.bundle.WingStroke`: its
    ``weight``, ``phase``, ``nodes``, ``sweep``, ``v_tangential``, ``v_normal`` are read), and
    ``settings`` its ``rho`` and ``interference`` (:class:`~tandem_env.physics.bundle.Settings`).
    ``load`` (n,) is the force along the fore-wing's stroke-plane normal that it sheds into its
    wake, per sample (one wing: the span integral of the circulatory and viscous element forces
    at the solved inflow, without the added mass) [N]. Linearised momentum theory on the fore
    disc (the quasi-steady limit of Pitt & Peters' uniform dynamic-inflow mode) turns its
    fluctuation into a fluctuation of the induced velocity, uniform over the disc,
    Δv = (L − L̄)/(2ρφ_m·R²·V_m) (R² = 2∫r·dr over the nodes), with the disc's mass-flow
    parameter V_m = U + v̄·w/U at its mean induced velocity v̄ (:func:`disc_inflow`),
    w = V_n + v̄, U = sqrt(V_t² + w²) (the fore-wing's V_t, V_n [m/s]),
    bounded below by sqrt(L_rms/(2ρφ_m·R²)), the speed the loading's fluctuation alone drives
    through the disc (it keeps Δv finite where the disc's mean flow vanishes).

    Δv is evaluated at the hind-wing's phases ``phase_hind`` less ``delay`` δ = 2π·f_h·t_d
    [rad] from its Fourier series in the fore-wing's phase ϑ, harmonics m = 1 … (n − 1)/2,
    whose coefficients are trapezoid sums over the fore-wing's samples (its ``phase``) with the
    grid's weights dϑ/ds (its ``weight``; spectrally accurate on the motion-following grid,
    §3.5). Where that grid is sparsest its spacing in ϑ is max(dϑ/ds) = 1 + λ times the
    uniform one, so harmonic m is weighted by the exponential filter σ_m = exp(−36·(m/m_c)^16)
    (:data:`WAKE_FILTER`), m_c = ((n − 1)/2)/max(dϑ/ds): the harmonics the sparsest samples
    cannot resolve are filtered out smoothly (a sharp cut would make the result jump with K),
    and σ_m → 1 for every m as n grows.
    """
    weight_fore = fore.weight
    phase_fore = fore.phase
    nodes_fore = fore.nodes
    v_tangential = fore.v_tangential
    v_normal = fore.v_normal
    n = load.shape[0]
    for k in range(n):
        out[k] = 0.0
    half_square = 0.0  # ∫r·dr = R²/2
    for j in range(nodes_fore.shape[0]):
        half_square += nodes_fore[j, N_R] * nodes_fore[j, N_WIDTH]
    k_disc = 4.0 * settings.rho * fore.sweep * half_square
    if not k_disc > 0.0:
        return
    mean = 0.0
    for i in range(n):
        mean += load[i] * weight_fore[i]
    mean /= n
    square = 0.0
    for i in range(n):
        square += (load[i] - mean) ** 2 * weight_fore[i]
    rms = np.sqrt(square / n)
    v_disc = disc_inflow(inflow_fore, nodes_fore)
    w = v_normal + v_disc
    speed = np.sqrt(v_tangential * v_tangential + w * w)
    mass_flow = speed + v_disc * w / speed if speed > 0.0 else 0.0
    mass_flow = max(mass_flow, np.sqrt(rms / k_disc))
    if not mass_flow > 0.0:
        return
    scale = settings.interference / (k_disc * mass_flow)
    n_modes = (n - 1) // 2
    densest = 0.0
    for i in range(n):
        densest = max(densest, weight_fore[i])
    cutoff = n_modes / densest
    a = np.zeros(n_modes)
    b = np.zeros(n_modes)
    for i in range(n):
        f = (load[i] - mean) * weight_fore[i]
        c1 = np.cos(phase_fore[i])
        s1 = np.sin(phase_fore[i])
        cm = 1.0
        sm = 0.0
        for j in range(n_modes):
            cm, sm = cm * c1 - sm * s1, sm * c1 + cm * s1  # cos(mϑ), sin(mϑ) by rotation
            a[j] += f * cm
            b[j] += f * sm
    for j in range(n_modes):
        sigma = np.exp(-WAKE_FILTER * ((j + 1) / cutoff) ** 16)
        a[j] *= 2.0 * scale * sigma / n
        b[j] *= 2.0 * scale * sigma / n
    for k in range(n):
        x = phase_hind[k] - delay
        c1 = np.cos(x)
        s1 = np.sin(x)
        cm = 1.0
        sm = 0.0
        total = 0.0
        for j in range(n_modes):
            cm, sm = cm * c1 - sm * s1, sm * c1 + cm * s1
            total += a[j] * cm + b[j] * sm
        out[k] = total


@stroke_loop()
def fill_angle_batch(params, n_time, angles, weight):
    """Angle histories of a (B, 14) batch of one wing's parameters (Hz, rad, -)."""
    for b in prange(params.shape[0]):
        fill_angle_history(params[b], n_time, angles[b], weight[b])


@njit(cache=True)
def stroke_wing(wing, b, coef):
    """The :class:`~tandem_env.physics.bundle.WingStroke` of stroke ``b`` of a
    :class:`~tandem_env.physics.bundle.WingBatch`, with its frame coefficients ``coef``."""
    phase = wing.phases[b] if wing.phases.shape[0] > b else wing.phases[0:0, 0]
    return WingStroke(
        coef, wing.nodes, wing.consts, wing.table, wing.frequency[b], wing.sweep[b],
        wing.v_tangential[b], wing.v_normal[b], wing.weight[b], phase,
    )  # fmt: skip


@njit(cache=True)
def station_offsets(stations, to_elements):
    """The other pair's (u, v) offsets on the elements (n_blade, 2, n_time) [m/s] of one
    stroke's at the M read stations ``stations`` (2, M, n_time), by the interpolation weights
    ``to_elements`` (n_blade, M) (the vortex reading, docs/model.md §5.8 item 5): computed per
    stroke, where the sweeps read them from cache, rather than held for the batch."""
    n_r = to_elements.shape[0]
    n_time = stations.shape[2]
    out = np.zeros((n_r, 2, n_time))
    for j in range(n_r):
        for k in range(2):
            for m in range(to_elements.shape[1]):
                weight = to_elements[j, m]
                for t in range(n_time):
                    out[j, k, t] += weight * stations[k, m, t]
    return out


@njit(cache=True)
def plain_cycle(batch, e, wing, settings, v_ext, solve, out_inflow, out, hist):
    """:func:`wing_cycle` of a stroke without the convected slipstream: with the other pair's
    field and upstream inflow at row ``e`` of ``batch.external`` where the vortex reading's
    pass gives them (docs/model.md §5.8), else with ``v_ext``."""
    if batch.external.shape[0] > e:
        wing_cycle(
            wing, settings, batch.external_inflow[e], solve, out_inflow, out, hist, None, None,
            station_offsets(batch.external[e], batch.to_elements),
        )  # fmt: skip
    else:
        wing_cycle(wing, settings, v_ext, solve, out_inflow, out, hist)


@njit(cache=True)
def tandem_stroke(b, e, fore, hind, settings, outputs):
    """Cycle means of stroke ``b`` of a batch: the fore-wing first, then the hind-wing in its
    slipstream, each where ``settings.pairs`` asks; ``e`` the stroke's row of the wings'
    ``external`` fields (see :func:`tandem_cycle` for the other arguments)."""
    n_time = fore.angles.shape[1]
    n_r = fore.nodes.shape[0]
    mode = settings.mode
    out = outputs.means
    out_inflow = outputs.inflow
    coef_fore = np.empty((n_time, N_COEF))
    coef_hind = np.empty((n_time, N_COEF))
    hist = np.empty((n_time, 5))
    v_ext = np.zeros(n_r)
    # the convected slipstream (§5.7) where the hind-wing feels a fore-wing's wake at all
    convect = (
        settings.convected
        and mode == MODE_COUPLED
        and not (fore.inflow_off[b] or hind.inflow_off[b])
    )
    load = np.empty(n_time if convect else 0)
    wake = np.empty(n_time if convect else 0)
    spin_total = settings.spin_total
    # each wing's frame coefficients: the vortex reading's passes give them (``frames``)
    if fore.frames.shape[0] > b:
        coef_fore = fore.frames[b]
    else:
        fill_frame_coefficients(
            fore.angles[b], fore.weight[b], fore.beta[b], spin_total, 1, coef_fore
        )
    if hind.frames.shape[0] > b:
        coef_hind = hind.frames[b]
    else:
        fill_frame_coefficients(
            hind.angles[b], hind.weight[b], hind.beta[b], spin_total, 1, coef_hind
        )
    fore_wing = stroke_wing(fore, b, coef_fore)
    hind_wing = stroke_wing(hind, b, coef_hind)
    if settings.pairs & 1:
        # a wing with its induced velocity switched off (``ModelOptions.hover_inflow``) neither
        # solves its own inflow nor sees the fore-wing's slipstream
        solve = mode != MODE_NONE and not fore.inflow_off[b]
        if convect:
            wing_cycle(
                fore_wing, settings, v_ext, solve, out_inflow[b, 0], out[b, 0], hist, None, load
            )
        else:
            plain_cycle(
                fore, e, fore_wing, settings, v_ext, solve, out_inflow[b, 0], out[b, 0], hist
            )
        if outputs.history.shape[0] > b:
            outputs.history[b, 0] = hist
    if settings.pairs & 2:
        if mode == MODE_COUPLED and not hind.inflow_off[b]:
            for j in range(n_r):
                v_ext[j] = settings.interference * out_inflow[b, 0, j]
        solve = mode != MODE_NONE and not hind.inflow_off[b]
        if convect:
            delay = slipstream_delay(
                disc_inflow(out_inflow[b, 0], fore.nodes), hind_wing.v_normal, fore.beta[b],
                hind.beta[b], settings,
            )  # fmt: skip
            convected_wake(
                load, fore_wing, hind_wing.phase, 2.0 * np.pi * hind_wing.frequency * delay,
                out_inflow[b, 0], settings, wake,
            )  # fmt: skip
            wing_cycle(hind_wing, settings, v_ext, solve, out_inflow[b, 1], out[b, 1], hist, wake)
        else:
            plain_cycle(
                hind, e, hind_wing, settings, v_ext, solve, out_inflow[b, 1], out[b, 1], hist
            )
        if outputs.history.shape[0] > b:
            outputs.history[b, 1] = hist


@stroke_loop()
def tandem_cycle(fore, hind, settings, outputs):
    """Cycle means of a batch of tandem strokes, in parallel over the batch.

    ``fore``, ``hind``: each wing's inputs (:class:`~tandem_env.physics.bundle.WingBatch`:
    angles (B, n_time, 9), weights (B, n_time), frequency, β, sweep amplitude (B,) [Hz, rad,
    rad], the body's velocity along x_s and z_s of the wing's stroke plane, (V_t, V_n) (B,)
    [m/s] (``model.freestream_components``), ``inflow_off`` (B,) bool, True where the wing has
    no induced velocity whatever the mode (``model.inflow_switched_off``), node table, constants
    and force-coefficient model (``None``: the paper's; numba compiles that signature without the
    models' code), and the grid phases ϑ = 2πft (B, n_time) [rad], read only under the convected
    slipstream). ``settings``: :class:`~tandem_env.physics.bundle.Settings` (the options, the
    air, the roots' ``root_spacing`` and ``root_drop`` [m] and the Fourier tables).
    ``convected``: the hind-wing sees the fore-wing's slipstream as it varies over the cycle
    (``ModelOptions.slipstream="convected"``, docs/model.md §5.7).
    Writes ``outputs`` (:class:`~tandem_env.physics.bundle.Outputs`): the means (B, 2,
    N_WING_OUT) and the inflow (B, 2, n_r) [m/s]; if its history has B rows, also the per-sample
    F_x, F_z, F_y, P_aero, P_iner of each wing (B, 2, n_time, 5). Where ``settings.rows``
    names some strokes, only those run, each into its own row.
    """
    rows = settings.rows
    if rows.shape[0] == 0:
        for b in prange(fore.angles.shape[0]):
            tandem_stroke(b, b, fore, hind, settings, outputs)
    else:
        for i in prange(rows.shape[0]):
            tandem_stroke(rows[i], i, fore, hind, settings, outputs)


@stroke_loop()
def history_means(history, fore_weight, hind_weight, cos_table, sin_table, means):
    """Each wing's :func:`cycle_means` from its per-sample history (B, 2, n_time, 5) [N, W]
    (``Outputs.history`` of a kernel call with ``Settings.means`` off) and quadrature weights
    (B, n_time) each: the same function on the same numbers, so the same bits as computing
    them in :func:`wing_cycle`; writes the cycle-mean columns of ``means`` (B, 2,
    N_WING_OUT)."""
    for b in prange(history.shape[0]):
        cycle_means(history[b, 0], fore_weight[b], means[b, 0], cos_table, sin_table)
        cycle_means(history[b, 1], hind_weight[b], means[b, 1], cos_table, sin_table)
