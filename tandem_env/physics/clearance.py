"""How close the fore- and hind-wing come over a cycle (docs/model.md §1.7).

Each wing is a flat surface: at every span station r its chord, centred on the pitch axis (the
mid-chord, §2.4), along the chord direction e_c of its frame (§4.1-4.2), the root of the
hind-wing ``Dragonfly.root_spacing`` behind and ``root_drop`` below the fore-wing's. The model
itself does not use this (its slipstream is a reading of the wake, §5.7); it tells which
strokes a solver of the wing surfaces (a vortex lattice) cannot take, and which optima have
brought the wings together (§5.8, *The wings meet*). :func:`wing_clearance` samples a fixed
grid; :func:`wing_gap` searches for the least distance, with the formulas written once
(:func:`chord_ends`, :func:`segment_gap`: compiled, and on numpy or torch arrays).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit, prange

from .checks import is_integer
from .insect import DRAGONFLY, MAX_EDGE_COEFFICIENTS, MAX_WING_GAP, Dragonfly, Wing
from .kinematics import (
    MAX_SWEEP_SHAPE,
    angles_at,
    flapping,
    pitching_scaled,
    weaving_scaled,
    wing_params_radians,
)
from .stroke import N_PER_WING, validate_physical
from .xp import BRANCH_FREE, NUMPY, ArrayNamespace, on_namespace, select, stroke_loop

#: The coarse grid :func:`wing_gap` starts from: instants per fore-wing cycle and span
#: stations per wing. At each instant its closest stations are followed to the surfaces'
#: distance (:data:`GAP_SURFACE_STEP`), and the local minima over the instants to the least
#: distance (docs/model.md §1.7).
GAP_GRID = (64, 5)
#: The coarse grid's instants whose local minima :func:`wing_gap` follows, the closest first.
GAP_CANDIDATES = 3
#: Two places found by the search are one where they differ by less than this in each of
#: (x, r̂_fore, r̂_hind) [-], x the fraction of the fore-wing's cycle (modulo 1 where both wings
#: beat at one frequency, so that the cycle's end is its start).
GAP_SAME_PLACE = 1e-3
#: Where the coarse grid's search over the stations at each instant stops [-] (r/R).
GAP_SURFACE_STEP = 1e-3
#: Where the search for the least distance stops: its step in the time (a fraction of the
#: fore-wing's cycle) and in r/R [-].
GAP_STEP = 1e-8


@njit(cache=True, error_model=BRANCH_FREE)
def segment_gap(px, py, pz, ux, uy, uz, qx, qy, qz, vx, vy, vz):
    """Smallest distance [m] between the segments p + s·u and q + t·v, s, t ∈ [0, 1] (the
    closest points of Eberly's "Distance between two line segments in 3D", clamped to both
    segments); elementwise (numba scalars, or numpy / torch arrays through ``on_namespace``)."""
    wx, wy, wz = px - qx, py - qy, pz - qz
    a = np.maximum(ux * ux + uy * uy + uz * uz, 1e-300)
    b = ux * vx + uy * vy + uz * vz
    c = np.maximum(vx * vx + vy * vy + vz * vz, 1e-300)
    d = ux * wx + uy * wy + uz * wz
    e = vx * wx + vy * wy + vz * wz
    det = a * c - b * b
    parallel = det <= 1e-12 * a * c
    # the lines' closest s, clamped to [0, 1] (0 for parallel segments); then t for that s,
    # clamped; then s again for that t
    s = np.minimum(np.maximum((b * e - c * d) / select(parallel, 0.0 * a + 1.0, det), 0.0), 1.0)
    s = select(parallel, 0.0 * a, s)
    t = np.minimum(np.maximum((b * s + e) / c, 0.0), 1.0)
    s = np.minimum(np.maximum((b * t - d) / a, 0.0), 1.0)
    gx, gy, gz = wx + s * ux - t * vx, wy + s * uy - t * vy, wz + s * uz - t * vz
    return np.sqrt(gx * gx + gy * gy + gz * gz)


@njit(cache=True)
def chord_ends(phi, theta, eta, beta, r, c):
    """Leading end (x, y, z) [m] relative to the root, and chord vector (x, y, z) [m], in earth
    axes, of the right wing's span station r [m] with chord c [m], centred on the pitch axis
    (§2.4), at sweep φ, elevation θ, pitch η and stroke-plane angle β [rad]: the span and chord
    directions of its frame (``blade.fill_frame_coefficients``, §4.1-4.2); elementwise."""
    cf, sf, ct, st, ce, se = (
        np.cos(phi),
        np.sin(phi),
        np.cos(theta),
        np.sin(theta),
        np.cos(eta),
        np.sin(eta),
    )
    cb, sb = np.cos(beta), np.sin(beta)
    span_x, span_y, span_z = ct * sf, ct * cf, st  # stroke-plane axes
    chord_x, chord_y, chord_z = se * cf - st * ce * sf, -se * sf - st * ce * cf, ct * ce
    # stroke-plane axes to earth axes: a rotation by β about y
    ux, uy, uz = c * (cb * chord_x + sb * chord_z), c * chord_y, c * (cb * chord_z - sb * chord_x)
    ax, ay, az = r * (cb * span_x + sb * span_z), r * span_y, r * (cb * span_z - sb * span_x)
    return ax - 0.5 * ux, ay - 0.5 * uy, az - 0.5 * uz, ux, uy, uz


def _planform_table(wing: Wing) -> np.ndarray:
    """The chord c(r/R) of ``wing`` for the compiled search: [R, kind, coefficients …] with
    kind 0 the tear-drop (Eq. 1; c = k₀·√(1 − r̂²)), kind 1 a polynomial in r̂ (Eq. 2)."""
    if wing.planform == "tear-drop":
        return np.array([wing.length, 0.0, 4.0 * wing.mean_chord / np.pi])
    assert wing.real_edges is not None
    upper, lower = (np.asarray(c, dtype=float) for c in wing.real_edges)
    width = np.zeros(MAX_EDGE_COEFFICIENTS)
    width[: len(upper)] += upper
    width[: len(lower)] -= lower
    return np.array([wing.length, 1.0, *(wing.length * width)])


@njit(cache=True)
def _frame(params, scales, length, tau):
    """The tip's axis point [m] and the unit chord [-] of a wing with parameters ``params``
    (14, Hz/rad/-) and waveform ``scales`` (sweep, pitch) at its phase ``tau`` [rad], as a
    6-tuple: a station's ends follow from it (:func:`_pair_gap`)."""
    omega = 2.0 * math.pi * params[0]
    k = min(params[10], MAX_SWEEP_SHAPE)
    phi = weaving_scaled(tau, omega, scales[0], k, params[4], params[7])[0]
    theta = flapping(tau, omega, params[2], params[5], params[8], params[11])[0]
    eta = pitching_scaled(tau, omega, scales[1], params[6], params[9], params[12])[0]
    ends = chord_ends(phi, theta, eta, params[13], length, 1.0)
    return (
        ends[0] + 0.5 * ends[3], ends[1] + 0.5 * ends[4], ends[2] + 0.5 * ends[5],
        ends[3], ends[4], ends[5],
    )  # fmt: skip


@njit(cache=True)
def _chord(table, rho):
    """The chord [m] at r/R = ``rho`` of the planform ``table`` (:func:`_planform_table`)."""
    if table[1] == 0.0:
        return table[2] * math.sqrt(max(1.0 - rho * rho, 0.0))
    chord = 0.0
    for k in range(table.shape[0] - 1, 1, -1):
        chord = chord * rho + table[k]
    return chord


@njit(cache=True)
def _pair_gap(fore, hind, tables, hind_root, rho_fore, rho_hind):
    """Distance [m] between the fore-wing's chord at r/R = ``rho_fore`` and the hind-wing's at
    ``rho_hind``, of the wings' frames ``fore`` and ``hind`` (:func:`_frame`)."""
    c, e = _chord(tables[0], rho_fore), _chord(tables[1], rho_hind)
    return segment_gap(
        rho_fore * fore[0] - 0.5 * c * fore[3],
        rho_fore * fore[1] - 0.5 * c * fore[4],
        rho_fore * fore[2] - 0.5 * c * fore[5],
        c * fore[3], c * fore[4], c * fore[5],
        rho_hind * hind[0] - 0.5 * e * hind[3] + hind_root[0],
        rho_hind * hind[1] - 0.5 * e * hind[4] + hind_root[1],
        rho_hind * hind[2] - 0.5 * e * hind[5] + hind_root[2],
        e * hind[3], e * hind[4], e * hind[5],
    )  # fmt: skip


@njit(cache=True)
def _frames(params, scales, tables, x):
    """Both wings' frames (:func:`_frame`) at the fraction ``x`` of the fore-wing's cycle, each
    wing at its own phase."""
    tau = 2.0 * math.pi * x
    fore = _frame(params[0], scales[0], tables[0, 0], tau)
    hind = _frame(params[1], scales[1], tables[1, 0], tau * params[1, 0] / params[0, 0])
    return fore, hind


@njit(cache=True)
def _surfaces(frames, tables, hind_root, start, step):
    """The least distance [m] between the two wings' surfaces at one instant (their ``frames``)
    and its stations (r̂_fore, r̂_hind): a compass search over the stations from ``start``,
    along the axes and diagonals, the step halved down to :data:`GAP_SURFACE_STEP`."""
    fore, hind = frames
    point = start.copy()
    best = _pair_gap(fore, hind, tables, hind_root, point[0], point[1])
    while step > GAP_SURFACE_STEP:
        moved = False
        for d in range(SURFACE_DIRECTIONS.shape[0]):
            trial_fore = min(max(point[0] + SURFACE_DIRECTIONS[d, 0] * step, 0.0), 1.0)
            trial_hind = min(max(point[1] + SURFACE_DIRECTIONS[d, 1] * step, 0.0), 1.0)
            value = _pair_gap(fore, hind, tables, hind_root, trial_fore, trial_hind)
            if value < best:
                best, point[0], point[1], moved = value, trial_fore, trial_hind, True
                break
        if not moved:
            step *= 0.5
    return best, point[0], point[1]


#: The compass search's directions (x, r̂_fore, r̂_hind): the axes and the diagonals of each
#: pair of them, either way (a valley across the axes stalls a search along them alone).
DIRECTIONS = (
    np.array([d for d in np.ndindex(3, 3, 3) if sum(1 for v in d if v != 1) in (1, 2)], dtype=float)
    - 1.0
)
#: The directions of :func:`_surfaces`: those of :data:`DIRECTIONS` at one instant.
SURFACE_DIRECTIONS = DIRECTIONS[DIRECTIONS[:, 0] == 0.0, 1:]


@njit(cache=True)
def _follow(params, scales, tables, hind_root, start, step_x, step_rho, periodic):
    """A compass search from ``start`` (x, r̂_fore, r̂_hind) to a local least distance: after a
    scan along the time, a step along each of :data:`DIRECTIONS`, the first that comes closer
    taken; the steps halved where none does, down to :data:`GAP_STEP` (r̂ held in [0, 1], x
    too unless ``periodic``, both wings beating at one frequency: then x is taken modulo 1).
    Returns (distance [m], x, r̂_fore, r̂_hind)."""
    point = start.copy()
    fore, hind = _frames(params, scales, tables, point[0])
    best = _pair_gap(fore, hind, tables, hind_root, point[1], point[2])
    # first along the time at the start's stations, finer than the coarse grid (two minima of
    # a root chord's distance can lie within one of its steps)
    for m in range(-16, 17):
        x = _instant(start[0] + m * step_x / 16.0, periodic)
        trial_fore, trial_hind = _frames(params, scales, tables, x)
        value = _pair_gap(trial_fore, trial_hind, tables, hind_root, point[1], point[2])
        if value < best:
            best, point[0], fore, hind = value, x, trial_fore, trial_hind
    steps = np.array([step_x, step_rho, step_rho])
    last = 0  # the direction that came closer last is tried first
    while steps[0] > GAP_STEP or steps[1] > GAP_STEP:
        moved = False
        for n in range(DIRECTIONS.shape[0]):
            d = (last + n) % DIRECTIONS.shape[0]
            trial = point + DIRECTIONS[d] * steps
            trial[0] = _instant(trial[0], periodic)
            for i in range(1, 3):
                trial[i] = min(max(trial[i], 0.0), 1.0)
            trial_fore, trial_hind = fore, hind  # the frames move only with the time
            if trial[0] != point[0]:
                trial_fore, trial_hind = _frames(params, scales, tables, trial[0])
            value = _pair_gap(trial_fore, trial_hind, tables, hind_root, trial[1], trial[2])
            if value < best:
                best, point, moved, fore, hind = value, trial, True, trial_fore, trial_hind
                last = d
                break
        if not moved:
            steps *= 0.5
    return best, point[0], point[1], point[2]


@njit(cache=True)
def _instant(x, periodic):
    """The fraction ``x`` of the fore-wing's cycle held in [0, 1], or modulo 1 if ``periodic``."""
    return x - math.floor(x) if periodic else min(max(x, 0.0), 1.0)


@stroke_loop()
def _search(params, tables, hind_root, n_time, n_span, out):
    """The places (x, r̂_fore, r̂_hind) of each stroke's two closest local least distances,
    into ``out`` (B, 2, 3): at each of the coarse grid's instants the surfaces' distance
    (:func:`_surfaces` from the grid's closest stations), its :data:`GAP_CANDIDATES` closest
    local minima over the instants followed by :func:`_follow`; the closest place first, then
    the closest of the others apart from it (:data:`GAP_SAME_PLACE`), NaN where none is."""
    for b in prange(params.shape[0]):
        stroke = params[b]
        scales = np.empty((2, 2))
        for w in range(2):
            scales[w, 0] = stroke[w, 1] / math.asin(min(stroke[w, 10], MAX_SWEEP_SHAPE))
            scales[w, 1] = stroke[w, 3] / math.tanh(stroke[w, 12])
        # the instants x = k/n_time, k = 0 … n_time, both ends: where the wings beat at
        # different frequencies the cycle's end is not its start (at one, it is: k < n_time)
        periodic = stroke[0, 0] == stroke[1, 0]
        n_instants = n_time if periodic else n_time + 1
        nearest = np.full(n_instants, np.inf)
        where = np.zeros((n_instants, 2))
        for k in range(n_instants):
            frames = _frames(stroke, scales, tables, k / n_time)
            for i in range(n_span):
                for j in range(n_span):
                    rho_fore, rho_hind = i / (n_span - 1), j / (n_span - 1)
                    value = _pair_gap(*frames, tables, hind_root, rho_fore, rho_hind)
                    if value < nearest[k]:
                        nearest[k], where[k, 0], where[k, 1] = value, rho_fore, rho_hind
            # the stations between the grid's: the two surfaces' distance at this instant (a
            # narrow valley between stations, where two chords nearly cross, is found here)
            nearest[k], where[k, 0], where[k, 1] = _surfaces(
                frames, tables, hind_root, where[k], 1.0 / (n_span - 1)
            )
        # the local minima over the instants (around the cycle where periodic), the closest first
        minimum = np.zeros(n_instants, dtype=np.bool_)
        for k in range(n_instants):
            before, after = (k - 1) % n_instants, (k + 1) % n_instants
            below = (k == 0 and not periodic) or nearest[k] <= nearest[before]
            minimum[k] = below and ((after == 0 and not periodic) or nearest[k] <= nearest[after])
        order = np.argsort(np.where(minimum, nearest, np.inf))
        count = min(GAP_CANDIDATES, minimum.sum())
        found = np.empty((count, 4))  # (distance, x, r̂_fore, r̂_hind) of each candidate
        for n in range(count):
            k = order[n]
            start = np.array([k / n_time, where[k, 0], where[k, 1]])
            found[n] = _follow(
                stroke, scales, tables, hind_root, start, 1.0 / n_time, 1.0 / (n_span - 1), periodic
            )
        ranked = np.argsort(found[:, 0], kind="mergesort")  # equal distances: the grid's order
        first = found[ranked[0], 1:]
        out[b, 0] = first
        out[b, 1] = np.nan
        for n in ranked[1:]:
            apart = np.abs(found[n, 1:] - first)
            if periodic:  # x modulo the cycle
                apart[0] = min(apart[0], 1.0 - apart[0])
            if apart.max() >= GAP_SAME_PLACE:
                out[b, 1] = found[n, 1:]
                break


def gap_places(physical: np.ndarray, insect: Dragonfly = DRAGONFLY) -> np.ndarray:
    """(B, 2, 3) where the fore- and hind-wing come closest over a cycle, of (B, 28) validated
    physical strokes (Table 4 units): the fraction of the fore-wing's cycle [-] and the span
    stations r/R of the fore- and hind-wing [-] of the least distance, then of the next
    closest local minimum of the distance elsewhere (NaN where the search found none): the
    compiled search of :func:`wing_gap`."""
    params = np.stack(
        [wing_params_radians(physical[:, w * N_PER_WING : (w + 1) * N_PER_WING]) for w in (0, 1)],
        axis=1,
    )
    tables = np.zeros((2, 2 + MAX_EDGE_COEFFICIENTS))
    for w, wing in enumerate((insect.fore, insect.hind)):
        table = _planform_table(wing)
        tables[w, : len(table)] = table
    hind_root = np.array(_root(insect))
    out = np.empty((physical.shape[0], 2, 3))
    _search(len(out), np.ascontiguousarray(params), tables, hind_root, *GAP_GRID, out)
    return out


def gaps(
    physical: Any, insect: Dragonfly = DRAGONFLY, xp: ArrayNamespace = NUMPY
) -> tuple[Any, Any]:
    """``Result.wing_gap`` and ``Result.wing_gap_next`` [m] of physical strokes (B, 28) in the
    array namespace ``xp`` (on torch differentiable; the places searched on numpy): the
    distance at each of :func:`gap_places`' two places, the second :data:`MAX_WING_GAP` above
    the first where the search found one place only (so that a constraint on it never acts)."""
    searched = physical if xp is NUMPY else physical.detach().cpu().double().numpy()
    places = gap_places(searched, insect)
    alone = np.isnan(places[:, 1, 0])
    places[alone, 1] = places[alone, 0]
    both = gap_at(physical, places, insect, xp)  # (B, 2)
    return both[:, 0], both[:, 1] + xp.constant_like(np.where(alone, MAX_WING_GAP, 0.0), both)


def gap_at(
    physical: Any, place: np.ndarray, insect: Dragonfly = DRAGONFLY, xp: ArrayNamespace = NUMPY
) -> Any:
    """Distance [m] between the fore-wing's chord and the hind-wing's at ``place``, (B, 3) or
    (B, n, 3) places (:func:`gap_places`), of physical strokes (B, 28) in the array namespace
    ``xp``: (B,) or (B, n); on torch, differentiable with respect to the strokes (at a least
    distance, its derivative with the place held is the whole derivative: the envelope
    theorem)."""
    places = place.reshape(len(place), -1, 3)  # (B, n, 3)
    fore = wing_params_radians(physical[:, :N_PER_WING], xp)
    hind = wing_params_radians(physical[:, N_PER_WING:], xp)
    x = 2.0 * math.pi * xp.constant_like(places[:, :, 0], fore[:, :1])  # the fore-wing's phase
    p = _station_ends(fore, x, places[:, :, 1], insect.fore, (0.0, 0.0, 0.0), xp)
    q = _station_ends(
        hind, x * (hind[:, :1] / fore[:, :1]), places[:, :, 2], insect.hind, _root(insect), xp
    )
    return on_namespace(segment_gap, xp)(*p, *q).reshape(place.shape[:-1])


def _root(insect: Dragonfly) -> tuple[float, float, float]:
    """The hind-wing's root relative to the fore-wing's, in earth axes [m] (§1.7)."""
    return (-insect.root_spacing, 0.0, -insect.root_drop)


def _station_ends(
    params: Any, tau: Any, rho: np.ndarray, wing: Wing, root: tuple[float, ...], xp: ArrayNamespace
) -> tuple[Any, ...]:
    """:func:`chord_ends` of one wing's (B, 14) parameters [Hz, rad, -] at its phases ``tau``
    [rad] ((B, n) or (1, n)) and span stations r/R ``rho`` (broadcast with them), the leading
    ends moved to the root at ``root`` [m]."""
    angles = angles_at(params, tau, xp)
    r, c = (xp.constant_like(v, params[:, :1]) for v in (rho * wing.length, wing.chord(rho)))
    ends = on_namespace(chord_ends, xp)(angles[0], angles[3], angles[6], params[:, 13:14], r, c)
    return (*(end + offset for end, offset in zip(ends[:3], root, strict=True)), *ends[3:])


def wing_gap(strokes: np.ndarray, insect: Dragonfly = DRAGONFLY) -> np.ndarray:
    """The least distance [m] between the fore- and hind-wing's surfaces over a cycle, (B,), of
    (B, 28) or (28,) physical strokes (Table 4 units), over the instants 0 ≤ t ≤ 1/f_fore: the
    surfaces' distance at the instants of :data:`GAP_GRID`, its closest local minima followed
    to a step of :data:`GAP_STEP` (:func:`gap_places`), and the distance there (:func:`gap_at`).
    A continuous search, so smooth in the stroke where the closest place moves smoothly; zero
    where the wings cross. :func:`wing_clearance` is the same on a fixed grid (what this is
    tested against), at about 12 times the cost: the measure a task's constraint on the
    wings' distance needs (docs/model.md §1.7, §5.8 *The wings meet*)."""
    if not isinstance(insect, Dragonfly):
        raise ValueError(f"insect must be a Dragonfly; got {type(insect).__name__}")
    physical = validate_physical(strokes, bounds=insect.stroke_bounds)
    return gap_at(physical, gap_places(physical, insect)[:, 0], insect)


def wing_clearance(
    strokes: np.ndarray,
    insect: Dragonfly = DRAGONFLY,
    n_time: int = 256,
    n_span: int = 32,
) -> np.ndarray:
    """Smallest distance between the fore- and hind-wing's surfaces over a cycle, (B,) [m].

    ``strokes``: (B, 28) or (28,) in Table 4 units. The right wings (the left ones mirror
    them) are sampled at ``n_time`` instants of the fore-wing's cycle, t = k/(n_time·f_fore), each
    wing at its own phase 2πf·t, and at ``n_span`` span stations r/R = 0 … 1, each a chord
    segment; the result is the least distance between any two of these segments. Zero or a
    fraction of a millimetre means the wings meet: sampling can only overestimate the true
    distance, by up to about the distance a wing moves between samples or half the station
    spacing (both printed by nothing: choose ``n_time`` and ``n_span`` for the accuracy
    needed; the defaults resolve about 0.5 mm at f = 37 Hz and R = 28 mm).
    """
    for name, value, low in (("n_time", n_time, 8), ("n_span", n_span, 2)):
        if not is_integer(value) or not low <= value <= 4096:
            raise ValueError(
                f"wing_clearance: {name} = {value!r}; allowed: an integer {low} to 4096"
            )
    if not isinstance(insect, Dragonfly):
        raise ValueError(f"insect must be a Dragonfly; got {type(insect).__name__}")
    physical = validate_physical(strokes, bounds=insect.stroke_bounds)
    fraction = np.linspace(0.0, 1.0, n_span)[:, None]  # (n_span, 1): each station's row
    roots = ((0.0, 0.0, 0.0), _root(insect))
    out = np.empty(physical.shape[0])
    for b, stroke in enumerate(physical):
        time = np.arange(n_time)[None] / (n_time * stroke[0])  # (1, n_time) [s]
        ends = []  # each wing's, (n_span, n_time)
        for w, wing in enumerate((insect.fore, insect.hind)):
            params = wing_params_radians(stroke[None, w * N_PER_WING : (w + 1) * N_PER_WING])
            tau = 2.0 * np.pi * params[0, 0] * time
            ends.append(_station_ends(params, tau, fraction, wing, roots[w], NUMPY))
        gap_of = on_namespace(segment_gap, NUMPY)
        out[b] = gap_of(*(e[:, None] for e in ends[0]), *(e[None] for e in ends[1])).min()
    return out
