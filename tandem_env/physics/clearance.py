"""How close the fore- and hind-wing come over a cycle (docs/model.md §1.7).

Each wing is a flat surface: at every span station r its chord, centred on the pitch axis (the
mid-chord, §2.4), along the chord direction e_c of its frame (§4.1-4.2), the root of the
hind-wing ``Dragonfly.root_spacing`` behind and ``root_drop`` below the fore-wing's. The model
itself does not use this (its slipstream is a reading of the wake, §5.7); it tells which
strokes a solver of the wing surfaces (a vortex lattice) cannot take.
"""

from __future__ import annotations

import numpy as np

from .checks import is_integer
from .insect import DRAGONFLY, Dragonfly
from .kinematics import fill_angles, wing_params_radians
from .stroke import N_PER_WING, validate_physical


def _segment_distance(p0, u, q0, v):
    """Smallest distance between the segments p0 + s·u and q0 + t·v, s, t ∈ [0, 1] (arrays of
    3-vectors on the last axis, broadcast together) [m] (the closest points of Eberly's
    "Distance between two line segments in 3D", clamped to both segments)."""
    w0 = p0 - q0
    a = np.maximum(np.einsum("...i,...i", u, u), 1e-300)
    b = np.einsum("...i,...i", u, v)
    c = np.maximum(np.einsum("...i,...i", v, v), 1e-300)
    d = np.einsum("...i,...i", u, w0)
    e = np.einsum("...i,...i", v, w0)
    det = a * c - b * b
    parallel = det <= 1e-12 * a * c
    # the lines' closest s, clamped to [0, 1]; then t for that s, clamped; then s again for t
    s = np.where(parallel, 0.0, np.clip((b * e - c * d) / np.where(parallel, 1.0, det), 0.0, 1.0))
    t = np.clip((b * s + e) / c, 0.0, 1.0)
    s = np.clip((b * t - d) / a, 0.0, 1.0)
    gap = w0 + s[..., None] * u - t[..., None] * v
    return np.sqrt(np.einsum("...i,...i", gap, gap))


def _wing_chords(wing_params, wing, phases, root, span_fraction):
    """Leading end (n_time, n_span, 3) and chord vector of each span station in earth axes [m]."""
    angles = np.empty((phases.shape[0], 9))
    fill_angles(wing_params, phases, angles)
    phi, theta, eta = angles[:, 0:1], angles[:, 3:4], angles[:, 6:7]
    cf, sf, ct, st, ce, se = (np.cos(phi), np.sin(phi), np.cos(theta), np.sin(theta),
                              np.cos(eta), np.sin(eta))  # fmt: skip
    # span and chord directions in stroke-plane axes (blade.fill_frame_coefficients, right wing)
    span = np.stack([ct * sf, ct * cf, st], axis=-1)
    chord = np.stack([se * cf - st * ce * sf, -se * sf - st * ce * cf, ct * ce], axis=-1)
    beta = wing_params[13]
    to_earth = np.array(
        [[np.cos(beta), 0.0, np.sin(beta)], [0.0, 1.0, 0.0], [-np.sin(beta), 0.0, np.cos(beta)]]
    )  # columns: x_s, y_s, z_s in earth axes
    span = span @ to_earth.T
    chord = chord @ to_earth.T
    r = span_fraction * wing.length
    c = wing.chord(span_fraction)
    axis = root + r[None, :, None] * span  # (n_time, n_span, 3)
    vector = c[None, :, None] * chord
    return axis - 0.5 * vector, vector


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
    fraction = np.linspace(0.0, 1.0, n_span)
    roots = (np.zeros(3), np.array([-insect.root_spacing, 0.0, -insect.root_drop]))
    out = np.empty(physical.shape[0])
    for b, stroke in enumerate(physical):
        params = [
            wing_params_radians(stroke[w * N_PER_WING : (w + 1) * N_PER_WING]) for w in (0, 1)
        ]
        time = np.arange(n_time) / (n_time * params[0][0])
        chords = [
            _wing_chords(p, wing, 2.0 * np.pi * p[0] * time, root, fraction)
            for p, wing, root in zip(params, (insect.fore, insect.hind), roots, strict=True)
        ]
        (p0, u), (q0, v) = chords
        distance = _segment_distance(
            p0[:, :, None, :], u[:, :, None, :], q0[:, None, :, :], v[:, None, :, :]
        )
        out[b] = distance.min()
    return out
