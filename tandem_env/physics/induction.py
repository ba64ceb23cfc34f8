"""Momentum inflow through each wing pair's swept sector (Eqs. 20-21 as docs/model.md §5 decides).

Per annulus at radius r, the cycle-mean force along the stroke-plane normal balances Glauert's
momentum relation on the swept sector dA = N_w·2φ_m·r·dr:

    N_w·F̄_n(r, v_i)·dr = 2ρ·dA·v_i·sqrt(V_t² + (V_n' + v_i)²)

(V_n' = V_n for the fore-wing and V_n + C_hf·v_i,fore for the hind-wing). Per unit span and
wing, h(v) = F̄_n(v) − 4ρφ_m·r·v·sqrt(V_t² + (V_n' + v)²) = 0, with v_i = 0 where F̄_n(0) ≤ 0.

A plain damped fixed point diverges near the root (docs/model.md §5), so each annulus is solved by
a bracketed secant on the force alone: the momentum side m(v) is known exactly, so we model only
F̄_n(v) (nearly linear in v) by the secant through its last two evaluations and solve
F_model(v) = m(v) exactly (cheap scalar Newton), falling back to bisection whenever the step
leaves the bracket. It starts from the hover estimate m(v) = F̄_n(0) and typically needs 3-4
force evaluations (each a sweep over the cycle) to reach the tolerance.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .blade import C_ECZ, C_ENZ, C_SPIN, C_WEIGHT, element_force, relative_velocity


@njit(cache=True)
def mean_normal_force(
    coef, r, chord, m11, m22, rho, ct, cd0, cd90, cr, v_tangential, v_normal, table=None
):
    """Cycle-mean aerodynamic force per unit span along the stroke-plane normal [N/m];
    ``table``: the force-coefficient model (``blade.element_force``)."""
    n = coef.shape[0]
    total = 0.0
    for k in range(n):
        u, v, du, dv = relative_velocity(coef, k, r, v_tangential, v_normal)
        fc, fn = element_force(
            u, v, du, dv, coef[k, C_SPIN], chord, m11, m22, rho, ct, cd0, cd90, cr, table
        )
        total += (fc * coef[k, C_ECZ] + fn * coef[k, C_ENZ]) * coef[k, C_WEIGHT]
    return total / n


@njit(cache=True)
def _momentum(v, k_area, v_tangential, v_normal0):
    """m(v) = k·v·sqrt(V_t² + (V_n' + v)²) and dm/dv."""
    w = v_normal0 + v
    root = np.sqrt(v_tangential * v_tangential + w * w)
    if root == 0.0:
        return 0.0, 0.0
    return k_area * v * root, k_area * (root + v * w / root)


@njit(cache=True)
def _solve_model(f1, slope, x1, k_area, vt, vn0, lo, hi):
    """Root of F1 + slope·(v − x1) − m(v) in [lo, hi] by safeguarded Newton (no force calls)."""
    v = 0.5 * (lo + hi)
    a = lo
    b = hi
    for _ in range(60):
        m, dm = _momentum(v, k_area, vt, vn0)
        q = f1 + slope * (v - x1) - m
        if q > 0.0:
            a = v
        else:
            b = v
        dq = slope - dm
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
def solve_annulus(
    coef,
    r,
    chord,
    m11,
    m22,
    rho,
    ct,
    cd0,
    cd90,
    cr,
    v_tangential,
    v_normal0,
    sweep_amplitude,
    tolerance,
    max_iterations,
    table=None,
):
    """Induced velocity v_i [m/s] of one annulus; returns (v_i, force evaluations, converged).

    ``table``: the wing's force-coefficient model (``blade.element_force``).

    Converged means |h(v_i)| ≤ tolerance·F̄_n(0) or the bracket is narrower than
    tolerance·v_hover.
    """
    k_area = 4.0 * rho * sweep_amplitude * r
    f0 = mean_normal_force(
        coef, r, chord, m11, m22, rho, ct, cd0, cd90, cr, v_tangential, v_normal0, table
    )
    if f0 <= 0.0 or k_area <= 0.0:
        return 0.0, 1, True
    # hover estimate: the momentum side alone absorbs F̄_n(0)
    hi = 1.0
    while _momentum(hi, k_area, v_tangential, v_normal0)[0] < f0:
        hi *= 2.0
    v_hover = _solve_model(f0, 0.0, 0.0, k_area, v_tangential, v_normal0, 0.0, hi)
    f_tol = tolerance * f0
    x_tol = tolerance * max(v_hover, 1e-9)
    lo = 0.0
    x1, f1 = 0.0, f0
    x2 = v_hover
    evaluations = 1
    f2 = 0.0
    # establish the bracket [lo, hi]: h(lo) > 0 >= h(hi)
    while True:
        f2 = mean_normal_force(
            coef, r, chord, m11, m22, rho, ct, cd0, cd90, cr, v_tangential, v_normal0 + x2, table
        )
        evaluations += 1
        h2 = f2 - _momentum(x2, k_area, v_tangential, v_normal0)[0]
        if abs(h2) <= f_tol:
            return x2, evaluations, True
        if h2 < 0.0:
            hi = x2
            break
        lo = x2
        x1, f1 = x2, f2
        x2 = 2.0 * x2
        if evaluations >= max_iterations:
            return x2, evaluations, False
    width_before = hi - lo
    while evaluations < max_iterations:
        slope = (f2 - f1) / (x2 - x1)
        v = _solve_model(f1, slope, x1, k_area, v_tangential, v_normal0, lo, hi)
        if hi - lo > 0.5 * width_before:
            # the secant model keeps landing on one side (regula-falsi stagnation): bisect
            v = 0.5 * (lo + hi)
            width_before = hi - lo
        fv = mean_normal_force(
            coef, r, chord, m11, m22, rho, ct, cd0, cd90, cr, v_tangential, v_normal0 + v, table
        )
        evaluations += 1
        hv = fv - _momentum(v, k_area, v_tangential, v_normal0)[0]
        if hv > 0.0:
            lo = v
        else:
            hi = v
        if abs(hv) <= f_tol or hi - lo <= x_tol:
            return v, evaluations, True
        x1, f1 = x2, f2
        x2, f2 = v, fv
    return 0.5 * (lo + hi), evaluations, False
