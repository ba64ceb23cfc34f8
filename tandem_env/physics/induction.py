"""Momentum inflow through each wing pair's swept sector (Eqs. 20-21 as docs/model.md §5 decides).

Per annulus at radius r, the cycle-mean force along the stroke-plane normal balances Glauert's
momentum relation on the swept sector dA = N_w·2φ_m·r·dr:

    N_w·F̄_n(r, v_i)·dr = 2ρ·dA·v_i·sqrt(V_t² + (V_n' + v_i)²)

(V_n' = V_n for the fore-wing and V_n + C_hf·v_i,fore for the hind-wing). Per unit span and
wing, h(v) = F̄_n(v) − m(v) = 0 with m(v) = 4ρφ_m·r·v·sqrt(V_t² + (V_n' + v)²), and v_i = 0
where F̄_n(0) ≤ 0.

A plain damped fixed point diverges near the root (docs/model.md §5). Each annulus is solved by
safeguarded Newton on the force alone. A force sweep over the cycle (:func:`normal_force_sweep`)
gives F̄_n(v) and keeps every sample's element force and relative velocity; from those,
:func:`normal_force_slope` gives the exact slope dF̄_n/dv without recomputing a force (for a
force-coefficient model other than the paper's, ``coefficients``, from the model's C_L, C_D and
their exact α-rates, :func:`normal_force_rate_model`). The
momentum side m(v) is known exactly, so each step solves a model of F̄_n exactly against m(v)
(cheap scalar Newton, no force sweep): the tangent, bent by the curvature of the last two
slopes, until the root is bracketed; then the cubic Hermite interpolant on the bracket
[lo, hi], h(lo) > 0 ≥ h(hi), whose root always lies inside it. A bracketed step that does not
shrink fast enough is replaced by bisection. The solve starts with the sweep at v = 0 (which
decides v_i = 0 where F̄_n(0) ≤ 0) and typically needs 3 sweeps where it has to solve. It
always ends on a swept point, so the cycle integrals reuse that sweep's element forces instead
of recomputing them (``cycle.wing_cycle``).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .blade import (
    C_DECZ,
    C_DENZ,
    C_ECZ,
    C_ENZ,
    C_SPIN,
    C_WEIGHT,
    element_force_at,
    element_speed,
    relative_velocity,
)
from .coefficients import PAPER, coefficients_and_rates
from .xp import BRANCH_FREE, select

#: Rows of the per-sample record a force sweep leaves, (N_SAMPLE, n_time): element force
#: (F_c, F_n) [N/m] and relative velocity (u, v) [m/s] at the swept inflow, and scratch for the
#: terms of the sweep's mean normal force and of its slope (summed by :func:`row_sum`).
S_FC = 0
S_FN = 1
S_U = 2
S_V = 3
S_RATE = 4
S_SPEED = 5  # |U| [m/s] (``blade.element_speed``), reused by the slope
N_SAMPLE = 6


@njit(cache=True)
def row_sum(x):
    """Σ x (1-D) in order, one running sum (the solve's path depends on every rounding, so its
    sums keep the order they always had)."""
    total = 0.0
    for k in range(x.shape[0]):
        total += x[k]
    return total


@njit(cache=True)
def _added_mass_rate(a, b, c, d, spin, m11, m22):
    """The part of :func:`normal_force_rate` linear in the state: the added mass (the rotational
    circulation ρΓ_r·(−v, u) is normal to n and contributes nothing) [N·s/m²]."""
    return (m22 - m11) * a * b * spin - m11 * a * c - m22 * b * d


@njit(cache=True, error_model=BRANCH_FREE)
def normal_force_rate(u, v, a, b, c, d, spin, section):
    """d/dv_n of the element's force along the stroke-plane normal, F_c·a + F_n·b [N·s/m²]
    (``section``: :class:`~tandem_env.physics.bundle.Section`): :func:`normal_force_rate_at`
    at the element's ``blade.element_speed``."""
    return normal_force_rate_at(u, v, a, b, c, d, spin, section, element_speed(u, v))


@njit(cache=True, error_model=BRANCH_FREE)
def normal_force_rate_at(u, v, a, b, c, d, spin, section, speed):
    """:func:`normal_force_rate` at a known ``blade.element_speed`` ``speed`` [m/s] (the force
    sweep's: one division here instead of a square root and a division).

    The derivative of :func:`blade.element_force` (Eqs. 11-14) along the direction in which a
    change of the normal inflow v_n moves the element's state: (u, v, u̇, v̇) change at the rates
    (a, b, c, d) = (e_c·z_s, e_n·z_s, ė_c·z_s, ė_n·z_s). With U = (u, v), n = (a, b),
    p = U·n and q = U⊥·n (U⊥ = (−v, u), whose rate n⊥ is normal to n), the circulatory term
    ρΓ·q changes only through Γ and the viscous term −D·p through D and p (rate |n|²); the
    rotational circulation and the added mass are linear in the state. This must follow
    ``element_force`` term by term (tests/physics/test_inflow_solver.py checks it against finite
    differences of the sweep); a wrong slope would only slow the solve, never change its result.
    """
    chord = section.chord
    rho = section.rho
    cd0 = section.cd0
    cd90 = section.cd90
    rate = _added_mass_rate(a, b, c, d, spin, section.m11, section.m22)
    moving = u * u + v * v > 0.0  # a still element: no translational circulation, no drag
    inv = 1.0 / speed
    along = u * a + v * b  # p
    across = u * b - v * a  # q
    dspeed = along * inv  # d|U|/dv_n
    uv = u * v * inv
    # Γ_t = −C_t·c·uv/|U|, D = ½ρc·(C_d0·u² + C_d90·v²)/|U|
    duv = (a * v + u * b - uv * dspeed) * inv
    k = 0.5 * rho * chord
    drag = k * (cd0 * u * u + cd90 * v * v) * inv
    ddrag = (2.0 * k * (cd0 * u * a + cd90 * v * b) - drag * dspeed) * inv
    viscous = rho * section.ct * chord * duv * across + ddrag * along + drag * (a * a + b * b)
    return rate - select(moving, viscous, 0.0)


@njit(cache=True)
def normal_force_rate_model(u, v, a, b, c, d, spin, section, table):
    """:func:`normal_force_rate` for a force-coefficient model (``coefficients``) [N·s/m²].

    The same derivative of ``blade.element_force``'s non-paper branch along (a, b), with the
    model's C_L(α), C_D(α) and their exact rates (``coefficients.coefficients_and_rates``):
    with p = U·n, q = U⊥·n, the viscous term −D·p, D = ½ρc·C_D·|U|, and the circulatory term
    ρΓ_t·q, Γ_t = −½c·|U|·C_L·sign(v), change through |U| (rate p/|U|) and α = atan2(|v|, u)
    (rate sign(v)·q/|U|²). At v = 0, where sign(v) jumps, the rate is the one towards +n.
    The added mass is as for the paper.
    """
    chord = section.chord
    rho = section.rho
    rate = _added_mass_rate(a, b, c, d, spin, section.m11, section.m22)
    speed2 = u * u + v * v
    if speed2 > 0.0:
        speed = np.sqrt(speed2)
        cl, cd, dcl, dcd = coefficients_and_rates(np.arctan2(abs(v), u), table)
        if v > 0.0:
            side = 1.0
        elif v < 0.0:
            side = -1.0
        else:
            side = 1.0 if b >= 0.0 else -1.0
        along = u * a + v * b  # p
        across = u * b - v * a  # q
        dalpha = side * across / speed2
        k = 0.5 * rho * chord
        drag = k * cd * speed
        ddrag = k * (cd * along / speed + speed * dcd * dalpha)
        dgamma = -0.5 * chord * side * (cl * along / speed + speed * dcl * dalpha)
        rate += rho * dgamma * across - ddrag * along - drag * (a * a + b * b)
    return rate


@njit(cache=True)
def normal_force_sweep(
    coef, section, v_tangential, v_normal, samples, table=None, wake=None, external=None
):
    """One force sweep over the cycle of the element ``section`` at normal inflow ``v_normal``:
    F̄_n [N/m].

    Leaves each sample's (F_c, F_n, u, v) in ``samples`` (N_SAMPLE, n_time). ``table``: the
    wing's force-coefficient model (``blade.element_force``; ``None``: the paper's). ``wake``:
    (n_time,) a part of the normal inflow that varies over the cycle [m/s], added to
    ``v_normal`` sample by sample (the convected slipstream, docs/model.md §5.7; ``None``: none,
    compiled exactly as without it). ``external``: (2, n_time) the other pair's induced
    velocity as it changes the element's (u, v) [m/s], −w_e·e_c and −w_e·e_n per sample (the
    vortex reading, §5.8; its rate is not carried into u̇, v̇; ``None``: none). The element loop holds no running sum, so the compiler
    vectorises it (with ``coef`` in Fortran order, each column contiguous); the mean is then
    summed in sample order.
    """
    n = coef.shape[0]
    for k in range(n):
        v_n = v_normal
        if wake is not None:
            v_n = v_normal + wake[k]
        u, v, du, dv = relative_velocity(coef, k, section.r, v_tangential, v_n)
        if external is not None:
            u = u + external[0, k]
            v = v + external[1, k]
        speed = element_speed(u, v)
        fc, fn = element_force_at(u, v, du, dv, coef[k, C_SPIN], section, speed, table)
        samples[S_FC, k] = fc
        samples[S_FN, k] = fn
        samples[S_U, k] = u
        samples[S_V, k] = v
        samples[S_SPEED, k] = speed
        samples[S_RATE, k] = (fc * coef[k, C_ECZ] + fn * coef[k, C_ENZ]) * coef[k, C_WEIGHT]
    return row_sum(samples[S_RATE]) / n


@njit(cache=True)
def normal_force_slope(coef, section, samples, table=None):
    """dF̄_n/dv_n [N·s/m²] at the inflow of the sweep that left ``samples`` (from its stored
    relative velocities: no element force is recomputed; ``table``: the wing's force-coefficient
    model, ``None`` or the paper's: :func:`normal_force_rate`, any other:
    :func:`normal_force_rate_model`)."""
    n = coef.shape[0]
    paper = True
    if table is not None:
        paper = table[0] == PAPER
    if paper:
        for k in range(n):
            samples[S_RATE, k] = coef[k, C_WEIGHT] * normal_force_rate_at(
                samples[S_U, k], samples[S_V, k], coef[k, C_ECZ], coef[k, C_ENZ],
                coef[k, C_DECZ], coef[k, C_DENZ], coef[k, C_SPIN], section, samples[S_SPEED, k],
            )  # fmt: skip
    else:
        for k in range(n):
            samples[S_RATE, k] = coef[k, C_WEIGHT] * normal_force_rate_model(
                samples[S_U, k], samples[S_V, k], coef[k, C_ECZ], coef[k, C_ENZ],
                coef[k, C_DECZ], coef[k, C_DENZ], coef[k, C_SPIN], section, table,
            )  # fmt: skip
    return row_sum(samples[S_RATE]) / n


@njit(cache=True)
def mean_normal_force(coef, section, v_tangential, v_normal, table=None):
    """Cycle-mean aerodynamic force per unit span along the stroke-plane normal [N/m] of the
    element ``section``; ``table``: the force-coefficient model (``blade.element_force``)."""
    samples = np.empty((N_SAMPLE, coef.shape[0]))
    return normal_force_sweep(coef, section, v_tangential, v_normal, samples, table)


@njit(cache=True, error_model=BRANCH_FREE)
def _momentum(v, k_area, v_tangential, v_normal0):
    """m(v) = k·v·sqrt(V_t² + (V_n' + v)²) and dm/dv (0 where the root vanishes)."""
    w = v_normal0 + v
    root2 = v_tangential * v_tangential + w * w
    flowing = root2 > 0.0
    root = np.sqrt(select(flowing, root2, 1.0))
    m = select(flowing, k_area * v * root, 0.0)
    return m, select(flowing, k_area * (root + v * w / root), 0.0)


@njit(cache=True)
def _model_residual(v, model, k_area, vt, vn0):
    """Force model c0 + c1·d + c2·d² + c3·d³ (d = v − x0, ``model`` = (x0, c0, c1, c2, c3))
    minus m(v), and its derivative."""
    x0, c0, c1, c2, c3 = model
    d = v - x0
    m, dm = _momentum(v, k_area, vt, vn0)
    return c0 + d * (c1 + d * (c2 + d * c3)) - m, c1 + d * (2.0 * c2 + 3.0 * d * c3) - dm


@njit(cache=True)
def _solve_model(model, k_area, vt, vn0, lo, hi):
    """Root of the force model minus m(v) in [lo, hi] by safeguarded Newton (no force sweeps).

    The residual must be positive at lo and non-positive at hi.
    """
    v = 0.5 * (lo + hi)
    a = lo
    b = hi
    for _ in range(60):
        q, dq = _model_residual(v, model, k_area, vt, vn0)
        if q > 0.0:
            a = v
        else:
            b = v
        step_ok = dq != 0.0
        if step_ok:
            v_new = v - q / dq
            step_ok = a < v_new < b
        if not step_ok:
            v_new = 0.5 * (a + b)
        if abs(v_new - v) <= 1e-12 * (1.0 + abs(v)):
            return v_new
        v = v_new
    return v


@njit(cache=True)
def _search_upwards(model, k_area, vt, vn0, lo, start):
    """Root of the model minus m(v) above lo, bracketed by doubling from ``start``; −1 if the
    model has no sign change there."""
    if _model_residual(lo, model, k_area, vt, vn0)[0] <= 0.0:
        return -1.0
    a = lo
    b = max(start, 2.0 * lo, 1e-6)
    for _ in range(64):
        if _model_residual(b, model, k_area, vt, vn0)[0] <= 0.0:
            return _solve_model(model, k_area, vt, vn0, a, b)
        a = b
        b *= 2.0
    return -1.0


@njit(cache=True)
def solve_annulus_samples(
    coef, section, v_tangential, v_normal0, sweep_amplitude, settings, samples, table=None,
    wake=None, external=None,
):  # fmt: skip
    """Induced velocity v_i [m/s] of one annulus; returns (v_i, force sweeps, converged).

    ``section``: the annulus's element (:class:`~tandem_env.physics.bundle.Section`);
    ``settings``: the options (:class:`~tandem_env.physics.bundle.Settings`: ``tolerance``,
    ``max_evaluations``); ``sweep_amplitude`` φ_m [rad]. ``table``: the wing's
    force-coefficient model (``blade.element_force``; ``None``: the paper's). ``wake``:
    (n_time,) the part of the upstream normal inflow that varies over the cycle [m/s]
    (:func:`normal_force_sweep`; so ``external``); the momentum side m(v) takes the cycle-mean upstream inflow
    ``v_normal0``. Converged means |h(v_i)| ≤ tolerance·F̄_n(0) or the bracket is narrower than
    tolerance·v_hover (v_hover: the inflow at which m alone absorbs F̄_n(0)). ``samples``
    (N_SAMPLE, n_time) is left holding the sweep at exactly the returned v_i.

    Each step solves a model of F̄_n exactly against m(v): once the root is bracketed, the
    cubic Hermite interpolant of F̄_n and its slope at the bracket ends (which reproduces the
    sign change of h, so its root lies inside the bracket); before that, the tangent at the
    last point bent by the curvature of the last two slopes. A bracketed step longer than half
    the step before last is replaced by bisection (the safeguard of Numerical Recipes' rtsafe).
    """
    vt = v_tangential
    vn0 = v_normal0
    tolerance = settings.tolerance
    max_iterations = settings.max_evaluations
    k_area = 4.0 * section.rho * sweep_amplitude * section.r
    f0 = normal_force_sweep(coef, section, vt, vn0, samples, table, wake, external)
    if f0 <= 0.0 or k_area <= 0.0:
        return 0.0, 1, True
    s0 = normal_force_slope(coef, section, samples, table)
    v_hover = _search_upwards((0.0, f0, 0.0, 0.0, 0.0), k_area, vt, vn0, 0.0, 1.0)
    f_tol = tolerance * f0
    x_tol = tolerance * max(v_hover, 1e-9)
    # bracket h(lo) > 0 >= h(hi), with F̄_n and its slope at both ends; hi unknown at first
    lo, f_lo, s_lo = 0.0, f0, s0
    hi, f_hi, s_hi = np.inf, 0.0, 0.0
    curvature = 0.0  # of F̄_n, from the last two slopes while there is no hi
    step_last = np.inf  # lengths of the last step and of the one before
    step_before = np.inf
    evaluations = 1
    v = 0.0
    while evaluations < max_iterations:
        if hi == np.inf:
            v = _search_upwards(
                (lo, f_lo, s_lo, 0.5 * curvature, 0.0), k_area, vt, vn0, lo, v_hover
            )
            if evaluations == 1 and s_lo > 0.0:
                # a force that rises with inflow (α > 45° moving towards 45°) must bend down
                # again beyond the root: its tangent may overshoot far, so trust it only up to
                # a few hover estimates
                v = min(v, 4.0 * v_hover) if v > lo else 4.0 * v_hover
            if not v > lo:
                v = 2.0 * max(lo, v_hover)  # no sign change in the model: extend the search
        else:
            w = hi - lo
            secant = (f_hi - f_lo) / w
            c2 = (3.0 * secant - 2.0 * s_lo - s_hi) / w
            c3 = (s_lo + s_hi - 2.0 * secant) / (w * w)
            v_model = _solve_model((lo, f_lo, s_lo, c2, c3), k_area, vt, vn0, lo, hi)
            # steps that stop shrinking (each under half the one before last) mean the model
            # is poor here: bisect instead
            if lo < v_model < hi and abs(v_model - v) <= 0.5 * step_before:
                v_new = v_model
            else:
                v_new = 0.5 * (lo + hi)
            step_before = step_last
            step_last = abs(v_new - v)
            v = v_new
        fv = normal_force_sweep(coef, section, vt, vn0 + v, samples, table, wake, external)
        evaluations += 1
        hv = fv - _momentum(v, k_area, vt, vn0)[0]
        if abs(hv) <= f_tol or (hi - v if hv > 0.0 else v - lo) <= x_tol:
            return v, evaluations, True
        # the slope only where the next step needs it: not at the sweep that converges
        sv = normal_force_slope(coef, section, samples, table)
        if hv > 0.0:
            curvature = (sv - s_lo) / (v - lo)
            lo, f_lo, s_lo = v, fv, sv
        else:
            hi, f_hi, s_hi = v, fv, sv
    return v, evaluations, False


@njit(cache=True)
def sweep_annulus(
    coef, section, v_tangential, v_normal0, solve, sweep_amplitude, settings, samples,
    table=None, wake=None, external=None,
):  # fmt: skip
    """One annulus of the compiled cycle (``cycle.wing_cycle``) at its final inflow; returns
    (v_i [m/s], force sweeps of the solve, converged).

    ``solve``: the inflow is solved (:func:`solve_annulus_samples`); else v_i = 0 and one force
    sweep at ``v_normal0`` (:func:`normal_force_sweep`), returned as (0, 0, True): no solve, so
    no sweep of one. Either way ``samples`` is left holding the sweep at the returned v_i (the
    solve ends on a swept point, so its last sweep is reused, not redone). ``table``,
    ``wake`` and ``external`` as for :func:`solve_annulus_samples`; ``None`` is compiled exactly as without them.
    """
    if solve:
        return solve_annulus_samples(
            coef, section, v_tangential, v_normal0, sweep_amplitude, settings, samples, table,
            wake, external,
        )  # fmt: skip
    normal_force_sweep(coef, section, v_tangential, v_normal0, samples, table, wake, external)
    return 0.0, 0, True


@njit(cache=True)
def solve_annulus(coef, section, v_tangential, v_normal0, sweep_amplitude, settings, table=None):
    """Induced velocity v_i [m/s] of one annulus; returns (v_i, force sweeps, converged).

    :func:`solve_annulus_samples` without keeping the samples.
    """
    samples = np.empty((N_SAMPLE, coef.shape[0]))
    return solve_annulus_samples(
        coef, section, v_tangential, v_normal0, sweep_amplitude, settings, samples, table
    )
