"""Vortex filaments for the vortex reading of the tandem interaction (docs/model.md §5.8).

The induced velocity of straight vortex segments with a viscous core (:func:`segment_velocity`,
the Biot-Savart law), the ring lattice a lifting line and its wake form
(:func:`lattice_segments`), and the geometry the reading needs from the existing kinematics:
where a wing's span stations are at each instant (:func:`wing_lines`, of the angles
:func:`stroke_angles` gives or a measured motion's) and where the wake it
released sits (:func:`prescribed_wake`). Everything is written once over an array namespace
(``xp``, :mod:`~tandem_env.physics.xp`): numpy by default, torch (``torch_model.TORCH``) with
autograd, batched over any leading axes, with no branches on values.

Axes are the earth axes of docs/model.md §4.1 attached to the insect (X forward, Y right, Z up)
and lengths are in metres; a circulation Γ [m²/s] is positive by the right-hand rule along its
segment, from its first end to its second.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit, prange

from .kinematics import angles_at
from .xp import BRANCH_FREE, NUMPY, ArrayNamespace, on_namespace, stroke_loop

#: Distance of each wing root from the body's mid-plane [m]: half the thorax's 4 mm width
#: (docs/model.md §1.5; the cross-check's ``ROOT_OFFSET`` is the same).
ROOT_HALF_WIDTH = 2.0e-3
#: Where the bound vortex sits, as a fraction of the chord ahead of the mid-chord pitch axis
#: (§2.4): the quarter chord of lifting-line theory (Weissinger), 0.25 c ahead of mid-chord.
BOUND_VORTEX = 0.25
#: Where a wing reads the other pair's induced velocity: the three-quarter chord, 0.25 c behind
#: the mid-chord (Pistolesi's point: for a velocity varying linearly along the chord it gives
#: the thin aerofoil's effective angle of attack).
COLLOCATION = -0.25
#: Right wing → left wing (Y → −Y); the left wing carries −Γ along the mirrored segment.
MIRROR = np.array([1.0, -1.0, 1.0])
#: The trailing edge, 0.5 c behind the mid-chord, where the wake is released.
TRAILING_EDGE = -0.5
#: Squared lengths below this are treated as zero [m²] (a point on a segment's end, a segment of
#: no length), and the core's h⁴ + r_c⁴ is kept above its square: 1e-18 m², a nanometre, far
#: below any length of the model, and its square a normal float32.
_TINY = 1.0e-18


@njit(cache=True, error_model=BRANCH_FREE)
def unit_velocity(x1, y1, z1, x2, y2, z2, px, py, pz, core2):
    """Velocity [m/s] per unit circulation [m²/s] induced at (px, py, pz) by the segment from
    (x1, y1, z1) to (x2, y2, z2) [m] with the squared core radius ``core2`` [m²]: Eq. (5.8.4)
    of :func:`segment_velocity` with Γ = 1, elementwise (numba's scalars, or broadcast arrays
    through ``xp.on_namespace``). Returns (v_x, v_y, v_z)."""
    r1x, r1y, r1z = px - x1, py - y1, pz - z1
    r2x, r2y, r2z = px - x2, py - y2, pz - z2
    r0x, r0y, r0z = x2 - x1, y2 - y1, z2 - z1
    cx = r1y * r2z - r1z * r2y
    cy = r1z * r2x - r1x * r2z
    cz = r1x * r2y - r1y * r2x
    length2 = np.maximum(r0x * r0x + r0y * r0y + r0z * r0z, _TINY)
    n1 = np.sqrt(np.maximum(r1x * r1x + r1y * r1y + r1z * r1z, _TINY))
    n2 = np.sqrt(np.maximum(r2x * r2x + r2y * r2y + r2z * r2z, _TINY))
    along = (r0x * r1x + r0y * r1y + r0z * r1z) / n1 - (r0x * r2x + r0y * r2y + r0z * r2z) / n2
    h2 = (cx * cx + cy * cy + cz * cz) / length2
    root = np.sqrt(np.maximum(h2 * h2 + core2 * core2, _TINY * _TINY))
    factor = along / (4.0 * math.pi * length2 * root)
    return factor * cx, factor * cy, factor * cz


def _unit_arguments(segments: Any, points: Any, core_radius: Any) -> tuple[Any, ...]:
    """:func:`unit_velocity`'s arguments broadcast to (..., P, S): segments (..., S, 2, 3),
    points (..., P, 3), core radius a number or (..., S)."""
    ends = [segments[..., None, :, e, i] for e in (0, 1) for i in range(3)]  # (..., 1, S)
    at = [points[..., :, None, i] for i in range(3)]  # (..., P, 1)
    core2 = core_radius * core_radius
    if getattr(core2, "ndim", 0) > 0:
        core2 = core2[..., None, :]  # per segment
    return (*ends, *at, core2)


def _check_shapes(segments: Any, points: Any) -> None:
    if segments.shape[-2:] != (2, 3) or points.shape[-1] != 3:
        raise ValueError(
            f"segments of shape {tuple(segments.shape)} and points of shape "
            f"{tuple(points.shape)}; allowed: segments (..., S, 2, 3) and points (..., P, 3)"
        )


def segment_velocity(
    segments: Any,
    circulation: Any,
    points: Any,
    core_radius: Any,
    xp: ArrayNamespace = NUMPY,
) -> Any:
    """Velocity induced at ``points`` by straight vortex segments, summed over the segments.

    ``segments`` (..., S, 2, 3): each segment's first and second end [m]; ``circulation``
    (..., S) [m²/s]; ``points`` (..., P, 3) [m]; ``core_radius`` [m], a number or (..., S),
    ≥ 0. Returns (..., P, 3) [m/s]. The leading axes broadcast.

    The Biot-Savart law of a straight segment (Katz & Plotkin 2001, Low-Speed Aerodynamics,
    section 10.4.5) with Vatistas' n = 2 core (Vatistas, Kozel & Mih 1991, Exp. Fluids 11:73; as
    Bagai & Leishman 1993 use it for rotor wakes), with r1, r2 from the ends to the point and
    r0 = r1 − r2 from the first end to the second:

        v = Γ/(4π) · (r1 × r2) · r0·(r1/|r1| − r2/|r2|) / (|r0|² · sqrt(h⁴ + r_c⁴)),

    h = |r1 × r2|/|r0| the distance from the segment's line. With r_c = 0 it is the inviscid
    Γ/(4πh)·(cos θ1 − cos θ2); the core multiplies that by h²/sqrt(h⁴ + r_c⁴), which tends to
    1 − ½(r_c/h)⁴ outside the core (Scully's n = 1 core, the Rosenhead-Moore regularisation,
    departs as (r_c/h)², ten times more at 1.8 r_c), peaks at h = r_c, and vanishes on the
    line as h/r_c², so the velocity is finite everywhere and zero on the axis. With r_c = 0 a
    point on a segment itself gets an unbounded velocity (autograd there too). The formula is
    :func:`unit_velocity`'s.
    """
    _check_shapes(segments, points)
    unit = on_namespace(unit_velocity, xp)(*_unit_arguments(segments, points, core_radius))
    weight = circulation[..., None, :]
    return xp.stack([(weight * c).sum(-1) for c in unit], -1)


@njit(cache=True, parallel=True, error_model=BRANCH_FREE)
def _fill_influence(ends, core2, points, rows, weights, signs, out):
    """``out[q, i, c, o]`` = Σ_t ``weights[o, t]``·Σ_k ``signs[k, c]``·(:func:`unit_velocity`
    of segment ``rows[o, t]``, its ends ``ends[q, :, s]`` = x1, y1, z1, x2, y2, z2 and
    ``core2[q, s]``, at ``points[q, i + k·P]``)[c], P = ``out.shape[1]``: the numpy backend's
    compiled loop, parallel over q, for what :func:`segment_influence` broadcasts on torch
    (``rows``, ``weights``: the nonzero entries of each column of its ``combine``; ``signs``
    (1, 3) ones, or (2, 3) ones and ``MIRROR`` for its ``mirrored`` fold, which is linear and
    so taken before the combination)."""
    n_s = ends.shape[2]
    for q in prange(ends.shape[0]):
        unit = np.empty((3, n_s))
        for i in range(out.shape[1]):
            unit[:] = 0.0
            for k in range(signs.shape[0]):
                p = i + k * out.shape[1]
                px, py, pz = points[q, p, 0], points[q, p, 1], points[q, p, 2]
                sx, sy, sz = signs[k, 0], signs[k, 1], signs[k, 2]
                for s in range(n_s):
                    vx, vy, vz = unit_velocity(
                        ends[q, 0, s], ends[q, 1, s], ends[q, 2, s],
                        ends[q, 3, s], ends[q, 4, s], ends[q, 5, s],
                        px, py, pz, core2[q, s],
                    )  # fmt: skip
                    unit[0, s] += sx * vx
                    unit[1, s] += sy * vy
                    unit[2, s] += sz * vz
            for o in range(rows.shape[0]):
                vx = vy = vz = 0.0
                for t in range(rows.shape[1]):
                    s, w = rows[o, t], weights[o, t]
                    vx += w * unit[0, s]
                    vy += w * unit[1, s]
                    vz += w * unit[2, s]
                out[q, i, 0, o], out[q, i, 1, o], out[q, i, 2, o] = vx, vy, vz


def segment_influence(
    segments: Any,
    points: Any,
    core_radius: Any,
    combine: np.ndarray | None = None,
    xp: ArrayNamespace = NUMPY,
    mirrored: bool = False,
) -> Any:
    """The velocity per unit circulation [m/s per m²/s] each segment induces at each point,
    not summed, or combined linearly: ``segments`` (..., S, 2, 3) [m], ``points`` (..., P, 3)
    [m], ``core_radius`` (..., S) [m] (the leading axes broadcast), ``combine`` a numpy (S, O)
    matrix (None: the identity). Returns (..., P, 3, O): the unit velocities (..., P, 3, S)
    times ``combine``, so that :func:`segment_velocity` is this with ``combine`` = Γ as a
    column. ``mirrored``: the last P/2 points are the first P/2's mirror images (Y → −Y),
    and their velocities, mirrored, are added to the first P/2's: (..., P/2, 3, O) (what a
    right wing's segments and its mirror image, the left wing carrying −Γ, induce at the first
    P/2). On numpy a compiled loop over the leading axes that keeps the unit velocities of one
    point only and adds each column's nonzero entries (:func:`_fill_influence`); on torch the
    same formula broadcast (:func:`unit_velocity`) and a product."""
    _check_shapes(segments, points)
    n_s, n_p = segments.shape[-3], points.shape[-2]
    half = n_p // 2 if mirrored else n_p
    if mirrored and n_p % 2:
        raise ValueError(f"{n_p} points, mirrored; allowed: an even number (points, images)")
    combine = np.eye(n_s) if combine is None else np.asarray(combine, dtype=float)
    if xp is not NUMPY:
        unit = on_namespace(unit_velocity, xp)(*_unit_arguments(segments, points, core_radius))
        unit = xp.stack(unit, -2) @ xp.constant_like(combine, points)
        if mirrored:
            mirror = xp.constant_like(MIRROR, points)[:, None]
            unit = unit[..., :half, :, :] + unit[..., half:, :, :] * mirror
        return unit
    lead = np.broadcast_shapes(segments.shape[:-3], points.shape[:-2])
    ends = np.broadcast_to(np.moveaxis(segments.reshape(*segments.shape[:-2], 6), -1, -2),
                           (*lead, 6, n_s))  # fmt: skip
    core2 = np.broadcast_to(core_radius * core_radius, (*lead, n_s))
    nonzero = combine != 0.0
    width = max(int(nonzero.sum(0).max()), 1)
    rows = np.argsort(~nonzero, axis=0, kind="stable")[:width].T  # each column's nonzero rows
    weights = np.take_along_axis(combine.T, rows, 1)  # zero where a column has fewer
    out = np.empty((*lead, half, 3, combine.shape[1]))
    _fill_influence(
        np.ascontiguousarray(ends.reshape(-1, 6, n_s)),
        np.ascontiguousarray(core2.reshape(-1, n_s)),
        np.ascontiguousarray(np.broadcast_to(points, (*lead, n_p, 3)).reshape(-1, n_p, 3)),
        np.ascontiguousarray(rows),
        np.ascontiguousarray(weights),
        np.stack([np.ones(3), MIRROR]) if mirrored else np.ones((1, 3)),
        out.reshape(-1, half, 3, combine.shape[1]),
    )
    return out


def lattice_segments(nodes: Any, rings: Any, xp: ArrayNamespace = NUMPY) -> tuple[Any, Any]:
    """The segments and their net circulations of a lattice of vortex rings.

    ``nodes`` (..., K + 1, N, 3) [m]: K + 1 rows of N nodes each (for a lifting line and its
    wake: row 0 the bound vortex, root to tip, then the rows released at the trailing edge,
    newest first); ``rings`` (..., K, N − 1) [m²/s]: ring (k, j) runs node (k, j) → (k, j + 1)
    → (k + 1, j + 1) → (k + 1, j) → back. Returns the (..., (K + 1)·(N − 1) + K·N, 2, 3)
    segments and their (...) circulations: along each row (shed or bound) the difference of the
    rings on either side, Γ(k, j) − Γ(k − 1, j); between two rows (trailed) Γ(k, j − 1) −
    Γ(k, j), zero beyond the lattice. The last row closes the lattice (its segments carry
    −Γ(K − 1, j): the oldest vorticity, a starting vortex), so every segment's vorticity is
    conserved (Helmholtz) and the velocity is the rings' sum exactly.
    """
    if nodes.shape[-1] != 3 or tuple(rings.shape[-2:]) != (
        nodes.shape[-3] - 1,
        nodes.shape[-2] - 1,
    ):
        raise ValueError(
            f"nodes of shape {tuple(nodes.shape)} and rings of shape {tuple(rings.shape)}; "
            "allowed: nodes (..., K + 1, N, 3) and rings (..., K, N - 1)"
        )
    zeros_row = rings[..., :1, :] * 0.0
    zeros_col = rings[..., :, :1] * 0.0
    padded = xp.concatenate([zeros_row, rings, zeros_row], -2)  # (..., K + 2, N − 1)
    shed = padded[..., 1:, :] - padded[..., :-1, :]  # (..., K + 1, N − 1), row k
    sides = xp.concatenate([zeros_col, rings, zeros_col], -1)  # (..., K, N + 1)
    trailed = sides[..., :, :-1] - sides[..., :, 1:]  # (..., K, N), node (k, j) → (k + 1, j)
    lead = tuple(nodes.shape[:-3])
    circulation = xp.concatenate([shed.reshape(*lead, -1), trailed.reshape(*lead, -1)], -1)
    return lattice_geometry(nodes, xp), circulation


def lattice_geometry(nodes: Any, xp: ArrayNamespace = NUMPY) -> Any:
    """The segments (..., (K + 1)·(N − 1) + K·N, 2, 3) [m] of :func:`lattice_segments`'s
    lattice on ``nodes`` (..., K + 1, N, 3): first along each row k (node (k, j) → (k, j + 1)),
    row by row, then between rows k and k + 1 (node (k, j) → (k + 1, j))."""
    lead = tuple(nodes.shape[:-3])
    along_rows = xp.stack([nodes[..., :, :-1, :], nodes[..., :, 1:, :]], -2)
    between_rows = xp.stack([nodes[..., :-1, :, :], nodes[..., 1:, :, :]], -2)
    return xp.concatenate(
        [along_rows.reshape(*lead, -1, 2, 3), between_rows.reshape(*lead, -1, 2, 3)], -3
    )


def stroke_angles(params: Any, tau: Any, xp: ArrayNamespace = NUMPY) -> tuple[Any, Any, Any]:
    """φ, θ, η [rad] (Eqs. 3-5) of a wing's parameters ``params`` (B, 14) in Hz/rad/-
    (``kinematics.wing_params_radians``) at phases ``tau`` (B, n) or (1, n) 2πft [rad]: each
    (B, n), as :func:`wing_lines` takes them."""
    angles = angles_at(params, tau, xp)
    return angles[0], angles[3], angles[6]


def wing_lines(
    angles: tuple[Any, Any, Any],
    beta: Any,
    span_fraction: Any,
    length: float,
    chord: Any,
    chord_position: float,
    root: Any,
    xp: ArrayNamespace = NUMPY,
) -> Any:
    """Points of a right wing along its span at n instants, in earth axes [m].

    ``angles`` the wing's sweep φ, elevation θ and pitch η at those instants, each (B, n)
    [rad] (:func:`stroke_angles` of a parametric stroke, or a measured motion's);
    ``beta`` (B,) its stroke-plane angle β [rad]; ``span_fraction`` (N,) r/R; ``length`` R
    [m]; ``chord`` (N,) c(r) [m]; ``span_fraction``, ``chord`` and ``root`` are arrays of
    ``xp`` (torch: tensors, ``xp.constant_like``); ``chord_position`` the points' place along
    the chord from the mid-chord pitch axis (§2.4) towards the leading edge, in chords
    (:data:`BOUND_VORTEX`, :data:`COLLOCATION`, :data:`TRAILING_EDGE`); ``root`` (3,) the
    wing root [m]. Returns (B, n, N, 3). The frame is docs/model.md §4.2's,
    R_z(−φ)·R_x(θ)·R_y(η), the leading edge on +e_c; the left wing is the mirror image
    (Y → −Y).
    """
    phi, theta, eta = angles
    cf, sf, ct, st = xp.cos(phi), xp.sin(phi), xp.cos(theta), xp.sin(theta)
    ce, se = xp.cos(eta), xp.sin(eta)
    # span e_s and chord e_c in stroke-plane axes (blade.fill_frame_coefficients)
    span = (ct * sf, ct * cf, st)
    chord_dir = (se * cf - st * ce * sf, -se * sf - st * ce * cf, ct * ce)
    r = (span_fraction * length)[None, None, :]
    offset = (chord_position * chord)[None, None, :]
    local = [s[..., None] * r + c[..., None] * offset for s, c in zip(span, chord_dir, strict=True)]
    # stroke-plane axes to earth axes: x_s = (cos β, 0, −sin β), z_s = (sin β, 0, cos β)
    cb, sb = xp.cos(beta)[:, None, None], xp.sin(beta)[:, None, None]
    earth = [cb * local[0] + sb * local[2], local[1], -sb * local[0] + cb * local[2]]
    return xp.stack([earth[i] + root[i] for i in range(3)], -1)


def prescribed_wake(
    bound: Any,
    trailing_edge: Any,
    circulation: Any,
    carried: Any,
    xp: ArrayNamespace = NUMPY,
) -> tuple[Any, Any]:
    """The ring lattice of a lifting line and its prescribed periodic wake at each sample.

    ``bound``, ``trailing_edge`` (B, n, N, 3): the bound vortex's and the trailing edge's
    nodes at n samples uniform over one cycle [m]; ``circulation`` (B, n, N − 1): each strip's
    bound circulation Γ at those samples [m²/s]; ``carried`` (B, K + 1, 3): how far the wake
    has carried a row k samples after its release, k = 0 … K [m] (zero at k = 0; k·u_c·T/n
    for a wake carried at u_c, or any descent law of the age). Returns, per sample i, the nodes
    (B, n, K + 2, N, 3) and the rings (B, n, K + 1, N − 1) of :func:`lattice_segments`: row 0
    the bound vortex at t_i, row 1 the trailing edge at t_i, row k + 1 the trailing edge at
    t_{i−k} moved by ``carried[k]`` (periodic: t_{i−k} is sample i − k mod n); ring 0 carries
    Γ(t_i), ring k ≥ 1, between the rows released at t_{i−k+1} and t_{i−k}, the mean of Γ over
    its release, ½(Γ_{i−k+1} + Γ_{i−k}).
    """
    nodes = wake_nodes(bound, trailing_edge, carried, xp)
    n, rows = bound.shape[1], carried.shape[1] - 1
    index = [[(i - k) % n for k in range(rows + 1)] for i in range(n)]
    gamma = circulation[:, index]  # (B, n, K + 1, N − 1): Γ_{i−k}
    rings = xp.concatenate([gamma[:, :, :1], 0.5 * (gamma[:, :, :-1] + gamma[:, :, 1:])], 2)
    return nodes, rings


def wake_nodes(bound: Any, trailing_edge: Any, carried: Any, xp: ArrayNamespace = NUMPY) -> Any:
    """The nodes (B, n, K + 2, N, 3) [m] of :func:`prescribed_wake`'s lattice (its geometry,
    which does not depend on the circulation): row 0 ``bound`` at t_i, row k + 1
    ``trailing_edge`` at t_{i−k} (periodic) moved by ``carried[k]``."""
    n, rows = bound.shape[1], carried.shape[1] - 1
    if rows < 1 or carried.shape[-1] != 3:
        raise ValueError(
            f"carried of shape {tuple(carried.shape)}; allowed: (B, K + 1, 3), K >= 1 wake rows"
        )
    index = [[(i - k) % n for k in range(rows + 1)] for i in range(n)]
    released = trailing_edge[:, index]  # (B, n, K + 1, N, 3)
    return xp.concatenate([bound[:, :, None], released + carried[:, None, :, None, :]], 2)


#: The compiled wake sums' floating-point licence: fused multiply-adds and x/y as x·(1/y),
#: which move their results by ~1e-15 relative (no assumption of finite values).
_FAST = {"contract", "arcp"}


@njit(cache=True, error_model=BRANCH_FREE, fastmath=_FAST)
def _segment_terms(segment, start, end):
    """One segment's Biot-Savart terms at one read point for :func:`_pair_velocities`:
    ``segment`` its r0 (3), 1/|r0|² and r_c⁴, ``start`` and ``end`` its nodes' offsets from
    the point and their lengths (4 each) [m]; returns r1 × r2 (3), r0·(r1·|r2| − r2·|r1|) and
    the denominator sqrt(h⁴ + r_c⁴)·|r1|·|r2| (h² = |r1 × r2|²/|r0|²)."""
    dx, dy, dz, inv, core4 = segment
    sx, sy, sz, sl = start
    ex, ey, ez, el = end
    cx = sy * ez - sz * ey
    cy = sz * ex - sx * ez
    cz = sx * ey - sy * ex
    along = (dx * sx + dy * sy + dz * sz) * el - (dx * ex + dy * ey + dz * ez) * sl
    h2 = (cx * cx + cy * cy + cz * cz) * inv
    return cx, cy, cz, along, np.sqrt(max(h2 * h2 + core4, _TINY * _TINY)) * sl * el


@njit(cache=True, error_model=BRANCH_FREE, fastmath=_FAST)
def _pair_velocities(rel, seg, step, count, out):
    """``out[:, n]``, n < ``count``: the unit velocity of the segment from node n to node
    n + ``step`` at a read point plus the mirrored one (Y → −Y, :data:`MIRROR`) at a second
    point (the read point's image): ``rel`` (8, nodes) each node's offset from the read point
    and its length, then the same from the image [m]; ``seg`` (5, ≥ ``count``) each segment's
    r0 (3), 1/|r0|² and r_c⁴. :func:`unit_velocity`'s formula, with the node lengths and the
    core's root in the denominator and one division for both points. One loop over the
    segments, structure of arrays, no branches: it vectorises (sqrt and division 4-wide).
    Every index is a loop's or a shift known not to be negative (``max(step, 0)``), so the
    loads are plain vector loads (a possibly negative index would take numba's wraparound
    and make each a gather)."""
    step = max(step, 0)
    for n in range(count):
        m = n + step
        segment = (seg[0, n], seg[1, n], seg[2, n], seg[3, n], seg[4, n])
        acx, acy, acz, a_along, a_den = _segment_terms(
            segment, (rel[0, n], rel[1, n], rel[2, n], rel[3, n]),
            (rel[0, m], rel[1, m], rel[2, m], rel[3, m]),
        )  # fmt: skip
        bcx, bcy, bcz, b_along, b_den = _segment_terms(
            segment, (rel[4, n], rel[5, n], rel[6, n], rel[7, n]),
            (rel[4, m], rel[5, m], rel[6, m], rel[7, m]),
        )  # fmt: skip
        both = segment[3] / (4.0 * math.pi * a_den * b_den)
        fa = a_along * b_den * both
        fb = b_along * a_den * both
        out[0, n] = fa * acx + fb * bcx
        out[1, n] = fa * acy - fb * bcy
        out[2, n] = fa * acz + fb * bcz


@njit(cache=True, error_model=BRANCH_FREE)
def _node_offsets(nodes, point, image, rel):
    """``rel`` (8, nodes) of :func:`_pair_velocities`: each of ``nodes`` (3, nodes)' offset
    from ``point`` (3,) and its length, then the same from ``image`` (3,) [m]."""
    px, py, pz = point[0], point[1], point[2]
    qx, qy, qz = image[0], image[1], image[2]
    for n in range(rel.shape[1]):
        x, y, z = px - nodes[0, n], py - nodes[1, n], pz - nodes[2, n]
        rel[0, n], rel[1, n], rel[2, n] = x, y, z
        rel[3, n] = np.sqrt(max(x * x + y * y + z * z, _TINY))
        x, y, z = qx - nodes[0, n], qy - nodes[1, n], qz - nodes[2, n]
        rel[4, n], rel[5, n], rel[6, n] = x, y, z
        rel[7, n] = np.sqrt(max(x * x + y * y + z * z, _TINY))


@njit(cache=True, error_model=BRANCH_FREE)
def _segments(nodes, step, count, seg):
    """``seg`` (5, nodes) of :func:`_pair_velocities`: the segments from node n < ``count``
    to node n + ``step`` of ``nodes`` (3, nodes) [m], r0 and 1/|r0|², and r_c⁴ = 1 (the
    caller sets the cores); beyond ``count``, r0 = 0 and the rest 1."""
    step = max(step, 0)
    for n in range(count):
        x = nodes[0, n + step] - nodes[0, n]
        y = nodes[1, n + step] - nodes[1, n]
        z = nodes[2, n + step] - nodes[2, n]
        seg[0, n], seg[1, n], seg[2, n] = x, y, z
        seg[3, n] = 1.0 / max(x * x + y * y + z * z, _TINY)
        seg[4, n] = 1.0
    for n in range(max(count, 0), seg.shape[1]):
        seg[0, n] = seg[1, n] = seg[2, n] = 0.0
        seg[3, n] = seg[4, n] = 1.0


@njit(cache=True, error_model=BRANCH_FREE)
def _build_lattice(bound, edge, carried, core2, i, nodes, along, trailed):
    """Sample ``i``'s lattice for :func:`_pair_velocities`: ``nodes`` (3, R·N) flat n =
    row·N + j (:func:`wake_nodes`: row 0 ``bound[i]``, row k + 1 ``edge`` at sample i − k,
    periodic, plus ``carried[k]``); ``along`` (5, R·N) the segments from node n to n + 1
    (those across two rows, j = N − 1, are read by nothing), ``trailed`` (5, R·N) from node
    n to n + N, each r0 (3), 1/|r0|² and r_c⁴ from ``core2`` (S,) in
    :func:`lattice_geometry`'s order. ``bound``, ``edge`` (n_w, N, 3), ``carried``
    (K + 1, 3) one stroke's."""
    n_w, n_n = bound.shape[0], bound.shape[1]
    n_rows = carried.shape[0] + 1
    n_all = n_rows * n_n
    n_strips = n_n - 1
    for c in range(3):
        for j in range(n_n):
            nodes[c, j] = bound[i, j, c]
        back = i
        for k in range(n_rows - 1):
            for j in range(n_n):
                nodes[c, (k + 1) * n_n + j] = edge[back, j, c] + carried[k, c]
            back = back - 1 if back > 0 else n_w - 1
    _segments(nodes, 1, n_all - 1, along)
    _segments(nodes, n_n, n_all - n_n, trailed)
    for row in range(n_rows):
        for j in range(n_strips):
            along[4, row * n_n + j] = core2[row * n_strips + j] ** 2
    for row in range(n_rows - 1):
        for j in range(n_n):
            trailed[4, row * n_n + j] = core2[n_rows * n_strips + row * n_n + j] ** 2


@njit(cache=True, error_model=BRANCH_FREE, fastmath=_FAST)
def _fold_rings(u_a, u_t, n_n, folded, out):
    """``out`` (3, n_w·(N − 1)) from the segments' unit velocities ``u_a`` (along) and
    ``u_t`` (trailed) (3, R·N) of :func:`_build_lattice`'s lattice: ring (k, j) at flat n =
    k·N + j is +along n, −along n + N, −trailed n, +trailed n + 1 (:func:`lattice_segments`);
    ring 0 carries Γ at age 0, ring k ≥ 1 ½·(Γ at age k − 1 + Γ at age k), the ages folded
    modulo n_w (``interaction.ring_ages``), rings k ≡ e (mod n_w) summed in ``folded``
    (3, n_w·N) in the lattice's order. The shifted reads are slices, so that every index is
    a loop's (no wraparound check) and the loops vectorise."""
    span = folded.shape[1]
    n_w = span // n_n
    n_ring = u_a.shape[1] - n_n
    n_strips = n_n - 1
    for c in range(3):
        fold = folded[c]
        for m in range(span):
            fold[m] = 0.0
        for start in range(0, n_ring, span):
            first = n_n if start == 0 else 0  # ring 0 is not folded
            a0, a1 = u_a[c, start + first :], u_a[c, start + first + n_n :]
            t0, t1 = u_t[c, start + first :], u_t[c, start + first + 1 :]
            into = fold[first:]
            for m in range(min(span, n_ring - start) - first):
                into[m] += 0.5 * (a0[m] - a1[m] - t0[m] + t1[m])
        row = out[c]
        for e in range(n_w):
            now, later = fold[e * n_n :], fold[(e + 1) * n_n if e + 1 < n_w else 0 :]
            into = row[e * n_strips :]
            for j in range(n_strips):
                into[j] = now[j] + later[j]
        a0, a1, t0, t1 = u_a[c], u_a[c, n_n:], u_t[c], u_t[c, 1:]
        for j in range(n_strips):
            row[j] += a0[j] - a1[j] - t0[j] + t1[j]


@stroke_loop(error_model=BRANCH_FREE)
def _fill_wake_influence(bound, edge, carried, core2, points, out):
    """:func:`wake_influence`'s compiled loop, parallel over strokes b: ``bound``, ``edge``
    (B, n_w, N, 3), ``carried`` (B, K + 1, 3), ``core2`` (B, S) each segment's squared core
    radius in :func:`lattice_geometry`'s order, ``points`` (B, n_w, 2·P, 3) the read points
    then their images; ``out`` (B, n_w, P, 3, n_w·(N − 1)). Per sample, the lattice
    (:func:`_build_lattice`); per read point, the nodes' offsets from it and its image
    (:func:`_node_offsets`), both families' unit velocities (:func:`_pair_velocities`) and
    their rings folded onto the ages (:func:`_fold_rings`)."""
    n_b, n_w, n_n = bound.shape[0], bound.shape[1], bound.shape[2]
    n_points = out.shape[2]
    n_all = (carried.shape[1] + 1) * n_n
    for b in prange(n_b):
        nodes = np.empty((3, n_all))
        along = np.empty((5, n_all))
        trailed = np.empty((5, n_all))
        rel = np.empty((8, n_all))
        # the entries no segment fills (past the last row) stay zero: the folds read them
        # only into the strips' unused last slot, j = N − 1
        u_a = np.zeros((3, n_all))
        u_t = np.zeros((3, n_all))
        folded = np.empty((3, n_w * n_n))
        for i in range(n_w):
            _build_lattice(bound[b], edge[b], carried[b], core2[b], i, nodes, along, trailed)
            for p in range(n_points):
                _node_offsets(nodes, points[b, i, p], points[b, i, n_points + p], rel)
                _pair_velocities(rel, along, 1, n_all - 1, u_a)
                _pair_velocities(rel, trailed, n_n, n_all - n_n, u_t)
                _fold_rings(u_a, u_t, n_n, folded, out[b, i, p])


def wake_influence(
    bound: np.ndarray,
    edge: np.ndarray,
    carried: np.ndarray,
    points: np.ndarray,
    core_radius: np.ndarray,
    out: np.ndarray | None = None,
) -> np.ndarray:
    """What :func:`segment_influence` gives, ``mirrored``, for :func:`lattice_geometry`'s
    segments of :func:`wake_nodes`' lattices on ``bound``, ``edge`` (B, n_w, N, 3) and
    ``carried`` (B, K + 1, 3) [m], with ``combine`` the rings' circulations folded onto their
    release ages modulo n_w (``interaction.ring_ages``): the velocity per unit circulation
    at the first P/2 of ``points`` (B, n_w, P, 3) [m] of the right wing's lattice read there
    and at the last P/2 (their mirror images), (B, n_w, P/2, 3, n_w·(N − 1));
    ``core_radius`` (B, 1, S) or (B, S) per segment [m]. numpy only: a compiled loop over
    strokes and samples that builds each lattice's nodes, takes each node's distance from a
    point once for the (up to) four segments that share it and each segment's direction and
    length once for all points, reads each point and its image in the same vectorised loop
    over the segments, and sums the segments into rings and the rings into ages in the
    lattice's order, without the general combination matrix. ``out``: a contiguous array of
    the result's shape to write it into (None: a new one)."""
    n_b, n_w, n_n = bound.shape[:3]
    n_p = points.shape[-2]
    if n_p % 2 or points.shape[:2] != (n_b, n_w) or carried.shape[0] != n_b:
        raise ValueError(
            f"bound of shape {bound.shape}, carried {carried.shape}, points {points.shape}; "
            "allowed: (B, n_w, N, 3), (B, K + 1, 3) and (B, n_w, P, 3), P even (points, images)"
        )
    shape = (n_b, n_w, n_p // 2, 3, n_w * (n_n - 1))
    if out is None:
        out = np.empty(shape)
    elif out.shape != shape or not out.flags.c_contiguous:
        raise ValueError(f"out of shape {out.shape}; allowed: a contiguous array of {shape}")
    core2 = core_radius.reshape(n_b, -1) ** 2
    _fill_wake_influence(
        n_b,
        np.ascontiguousarray(bound), np.ascontiguousarray(edge), np.ascontiguousarray(carried),
        np.ascontiguousarray(core2), np.ascontiguousarray(points), out,
    )  # fmt: skip
    return out
