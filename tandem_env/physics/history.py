"""Time histories of one stroke over its wing-beat cycle (for the kinematics figures, Figs. 9-13).

The histories come from the same compiled cycle as
:func:`~tandem_env.physics.model.evaluate_numba` (the inflow is solved the same way), sampled on
a uniform time grid so that curves can be plotted and compared directly: :func:`stroke_history`
for a 28-parameter stroke, :func:`measured_history` for a pair of
:class:`~tandem_env.physics.measured.MeasuredWing`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from . import blade, cycle
from .bundle import WingStroke
from .checks import is_integer
from .insect import DRAGONFLY, Dragonfly
from .kinematics import fill_angles, wing_params_radians
from .measured import (
    MeasuredWing,
    element_tables,
    evaluate_measured,
    measured_inputs,
    run_measured,
)
from .model import (
    DEFAULT_OPTIONS,
    Result,
    coefficient_tables,
    evaluate_numba,
    freestream_components,
    inflow_switched_off,
    kernel_settings,
    validate_conditions,
    wing_tables,
)
from .options import ModelOptions
from .stroke import N_PER_WING, validate_physical


@dataclass(frozen=True)
class WingHistory:
    """One wing pair over one of its own cycles; arrays are (n,) unless stated."""

    cycle_fraction: np.ndarray
    """t/T [-], uniform over [0, 1)."""
    time: np.ndarray
    """t [s]."""
    sweep: np.ndarray
    """φ [deg]."""
    elevation: np.ndarray
    """θ [deg]."""
    pitch: np.ndarray
    """η [deg] (of a twisted measured wing: at r/R = 0.75)."""
    tip_path: np.ndarray
    """(n, 3) wing-tip position relative to the wing base, earth axes (X forward, Y right, Z up),
    normalised by the wing length [-]."""
    angle_of_attack: np.ndarray
    """Area-weighted acute angle of attack over the span [deg]."""
    relative_speed: np.ndarray
    """Speed of the element at r/R = 0.75 relative to the air [m/s] (interpolated)."""
    vertical_force: np.ndarray
    """Vertical aerodynamic force of the pair (N_w wings) [N]."""
    horizontal_force: np.ndarray
    """Horizontal aerodynamic force of the pair, + forward [N]."""
    lateral_force: np.ndarray
    """Lateral force of one (right) wing [N]; cancels between the two wings of a pair."""
    aero_power: np.ndarray
    """Aerodynamic power of the pair [W] (signed)."""
    inertial_power: np.ndarray
    """Inertial power of the pair [W] (signed)."""
    inflow: np.ndarray
    """(n_blade,) induced velocity of each annulus [m/s] (own inflow plus the upstream share)."""

    def thrust_and_drag(self) -> tuple[float, float]:
        """Cycle means of the forward and rearward parts of the pair's horizontal force [N]
        (``thrust_split="sign"``, docs/model.md §7.3), by the kernel's quadrature
        (``cycle.mean_positive_part``) on these samples. For measured input they are the
        evaluation's own samples, so fore plus hind is the result's T and D."""
        g = np.ascontiguousarray(self.horizontal_force, dtype=float)
        thrust = float(cycle.mean_positive_part(g, *cycle.fourier_tables(g.shape[0])))
        return thrust, max(thrust - float(g.mean()), 0.0)


@dataclass(frozen=True)
class StrokeHistory:
    fore: WingHistory
    hind: WingHistory
    result: Result
    """The cycle means of :func:`evaluate_numba` (or :func:`evaluate_measured`) for this stroke
    (B = 1)."""


def _tip_path(angles: np.ndarray, beta: float, side: int = 1) -> np.ndarray:
    phi, theta = angles[:, 0], angles[:, 3]
    span = np.stack(
        [np.cos(theta) * np.sin(phi), np.cos(theta) * np.cos(phi), np.sin(theta)], axis=1
    )
    x_e = np.cos(beta) * span[:, 0] + np.sin(beta) * span[:, 2]
    z_e = -np.sin(beta) * span[:, 0] + np.cos(beta) * span[:, 2]
    return np.stack([x_e, side * span[:, 1], z_e], axis=1)


def _check_reading(options: Any, side: int) -> None:
    """Refuse the mirror image under a phase-resolved reading (docs/model.md §5.7-5.8) before
    any computation: it imposes the right wings' inflow on the left ones, without the other
    pair's field of that instant."""
    slipstream = getattr(options, "slipstream", None)
    if side == -1 and slipstream in ("convected", "vortex"):
        raise ValueError(
            f'side = -1 with ModelOptions.slipstream = "{slipstream}"; allowed: side = 1 (the '
            'left wings mirror the right ones), or slipstream = "mean"'
        )


def _check_side(n_samples: int, side: int) -> None:
    if not is_integer(n_samples) or n_samples < 8:
        raise ValueError(f"n_samples = {n_samples!r}; allowed: an integer >= 8")
    if side not in (1, -1):
        raise ValueError(f"side = {side!r}; allowed: 1 (right wings) or -1 (left wings)")


def stroke_history(
    stroke: np.ndarray,
    speed: float = 0.0,
    available_power: float | None = None,
    *,
    flight_path_angle: float = 0.0,
    insect: Dragonfly = DRAGONFLY,
    options: ModelOptions = DEFAULT_OPTIONS,
    n_samples: int = 200,
    side: int = 1,
) -> StrokeHistory:
    """Time histories of one physical stroke (28,) at flight speed ``speed`` [m/s] along a path
    inclined by ``flight_path_angle`` γ [rad, + climbing]; forces in earth axes.

    The histories have ``n_samples`` uniform samples per cycle; ``result`` is exactly
    :func:`evaluate_numba` of the stroke (on its motion-following grid). ``side = -1`` evaluates the
    mirror image (the left wings), for the symmetry checks.
    """
    bounds = insect.stroke_bounds if isinstance(insect, Dragonfly) else None  # else named below
    physical = validate_physical(stroke, bounds=bounds)
    if physical.shape[0] != 1:
        raise ValueError(f"stroke_history takes one stroke of shape (28,); got {np.shape(stroke)}")
    _check_side(n_samples, side)
    _check_reading(options, side)
    n_samples = int(n_samples)
    v, p_avail, gamma = validate_conditions(speed, available_power, flight_path_angle, 1, insect)
    angles, weights, frequency, beta, sweep = (
        [],
        [],
        np.empty((1, 2)),
        np.empty((1, 2)),
        np.empty((1, 2)),
    )
    for w in range(2):
        wing_physical = physical[:, w * N_PER_WING : (w + 1) * N_PER_WING]
        params = wing_params_radians(wing_physical)
        s = np.arange(n_samples) / n_samples
        uniform = np.empty((n_samples, 9))
        fill_angles(params[0], 2.0 * np.pi * s, uniform)
        angles.append(uniform[None])
        weights.append(np.ones((1, n_samples)))
        frequency[0, w] = params[0, 0]
        beta[0, w] = params[0, 13]
        sweep[0, w] = params[0, 1]
    result = evaluate_numba(
        physical, v, p_avail, flight_path_angle=gamma, insect=insect, options=options
    )
    return _histories(
        angles, weights, frequency, beta, sweep, v, gamma, result, insect, options, side
    )


def measured_history(
    fore: MeasuredWing,
    hind: MeasuredWing,
    speed: float = 0.0,
    available_power: float | None = None,
    *,
    flight_path_angle: float = 0.0,
    insect: Dragonfly = DRAGONFLY,
    options: ModelOptions = DEFAULT_OPTIONS,
    side: int = 1,
) -> StrokeHistory:
    """Time histories of measured kinematics over one cycle, on their own samples.

    The same :class:`StrokeHistory` as :func:`stroke_history` (forces, power, angle of attack
    and inflow per wing pair; earth axes), ``result`` exactly :func:`evaluate_measured` of the
    pair. Each wing's history has its samples t = i/(n·f); ``pitch`` of a twisted wing is
    reported at r/R = 0.75. ``side = -1`` evaluates the mirror image (the left wings).
    """
    _check_reading(options, side)
    result = evaluate_measured(
        fore,
        hind,
        speed,
        available_power,
        flight_path_angle=flight_path_angle,
        insect=insect,
        options=options,
    )
    _check_side(fore.n_samples, side)
    angles, weights, frequency, beta, sweep = measured_inputs(fore, hind, insect, options)
    pitch = [np.rad2deg(wing.pitch_at(0.75)) for wing in (fore, hind)]
    return _histories(
        angles, weights, frequency, beta, sweep, result.speed, result.flight_path_angle, result,
        insect, options, side, pitch,
    )  # fmt: skip


def _histories(
    angles: list[np.ndarray],
    weights: list[np.ndarray],
    frequency: np.ndarray,
    beta: np.ndarray,
    sweep: np.ndarray,
    v: np.ndarray,
    gamma: np.ndarray,
    result: Result,
    insect: Dragonfly,
    options: ModelOptions,
    side: int,
    pitch: list[np.ndarray] | None = None,
) -> StrokeHistory:
    """The histories of both wing pairs from their angles on a uniform grid (B = 1); ``angles``
    per wing (1, n, 9), or (n_blade, n, 9) per blade element of a twisted wing. Under the
    convected slipstream (docs/model.md §5.7) the forces and powers follow it; the reported
    ``inflow`` and angle of attack use its cycle mean; under the vortex reading (§5.8) they
    take the other pair's field of each instant, as the kernel's element velocities do. The
    mirror image is refused under both (:func:`_check_reading`)."""
    freestream = freestream_components(v, beta, gamma)
    fields: list = []  # the vortex reading's field of the other pair, per wing
    _, inflow, hist = run_measured(
        angles, weights, frequency, beta, sweep, v, gamma, insect, options, keep_history=True,
        fields_out=fields,
    )  # fmt: skip
    if side == -1:
        hist = _mirror_run(angles, weights, frequency, beta, freestream, inflow, insect, options)
    n_w = insect.wings_per_pair
    wings = []
    for w, wing in enumerate((insect.fore, insect.hind)):
        a = angles[w][0]
        n_samples = a.shape[0]
        fraction = np.arange(n_samples) / n_samples
        offsets, upstream = (fields[w][0][0], fields[w][1][0]) if fields else (None, None)
        total_inflow = _total_inflow(inflow, w, freestream, options, upstream)
        aoa, rel_speed = _flow_angles(
            angles[w],
            weights[w][0],
            beta[0, w],
            freestream[0, w],
            total_inflow,
            wing,
            insect,
            options,
            side,
            offsets,
        )
        wings.append(
            WingHistory(
                cycle_fraction=fraction,
                time=fraction / frequency[0, w],
                sweep=np.rad2deg(a[:, 0]),
                elevation=np.rad2deg(a[:, 3]),
                pitch=np.rad2deg(a[:, 6]) if pitch is None else pitch[w],
                tip_path=_tip_path(a, beta[0, w], side),
                angle_of_attack=aoa,
                relative_speed=rel_speed,
                vertical_force=n_w * hist[0, w, :, 1],
                horizontal_force=n_w * hist[0, w, :, 0],
                lateral_force=hist[0, w, :, 2],
                aero_power=n_w * hist[0, w, :, 3],
                inertial_power=n_w * hist[0, w, :, 4],
                inflow=total_inflow,
            )
        )
    return StrokeHistory(fore=wings[0], hind=wings[1], result=result)


def _total_inflow(
    inflow: np.ndarray,
    w: int,
    freestream: np.ndarray,
    options: ModelOptions,
    upstream: np.ndarray | None = None,
) -> np.ndarray:
    """A wing's own induced velocity per annulus plus the upstream share [m/s] (none upstream
    where ``hover_inflow`` switches the wing's induced velocity off; ``freestream`` (1, 2, 2));
    ``upstream`` (n_blade,) the vortex reading's, which replaces the momentum readings' share."""
    if upstream is not None:
        return inflow[0, w] + upstream
    if (
        w == 1
        and options.induction == "coupled"
        and not inflow_switched_off(freestream[0, 1, 1], options)
    ):
        return inflow[0, w] + options.interference * inflow[0, 0]
    return inflow[0, w] + 0.0


def _element_frames(angles, weights, beta, spin_total, side):
    """Frame coefficients of a wing (one table) or of each blade element (a list of tables)."""
    n_time = angles.shape[1]
    out = []
    for a in angles:
        coef = np.empty((n_time, blade.N_COEF))
        blade.fill_frame_coefficients(a, weights, beta, spin_total, side, coef)
        out.append(coef)
    return out


def _mirror_run(angles, weights, frequency, beta, freestream, inflow, insect, options):
    """Per-sample histories of the mirror-image (left) wings, with the right wings' inflow
    imposed, (1, 2, n, 5)."""
    n_time = weights[0].shape[1]
    hist = np.zeros((1, 2, n_time, 5))
    out = np.empty(cycle.N_WING_OUT)
    scratch = np.empty((n_time, 5))
    settings = kernel_settings(insect, options, n_time)
    for w, wing in enumerate((insect.fore, insect.hind)):
        v_ext = _total_inflow(inflow, w, freestream, options)
        frames = _element_frames(angles[w], weights[w][0], beta[0, w], options.spin == "total", -1)
        if len(frames) == 1:
            tables = [wing_tables(wing, options.n_blade, insect.air_density)]
            parts = [(frames[0], tables[0], v_ext)]
        else:
            tables = element_tables(wing, options.n_blade, insect.air_density)
            parts = [(frames[j], tables[j], v_ext[j : j + 1]) for j in range(len(frames))]
        for coef, (nodes, consts), v_part in parts:
            wing_stroke = WingStroke(
                coef, nodes, consts, coefficient_tables(insect)[w], float(frequency[0, w]), 0.0,
                float(freestream[0, w, 0]), float(freestream[0, w, 1]), weights[w][0],
                np.empty(0),
            )  # fmt: skip
            cycle.wing_cycle(
                wing_stroke, settings, np.ascontiguousarray(v_part), False,
                np.empty(nodes.shape[0]), out, scratch,
            )  # fmt: skip
            hist[0, w] += scratch
    return hist


def _flow_angles(angles, weights, beta, freestream, inflow, wing, insect, options, side, offsets):
    """Area-weighted angle of attack [deg] and relative speed at r/R = 0.75 [m/s] over time;
    ``angles`` (1, n, 9) or (n_blade, n, 9) per element; ``freestream`` the wing's (V_t, V_n)
    [m/s]; ``offsets`` (n_blade, 2, n) the vortex reading's (u, v) offsets [m/s] or None."""
    n_time = angles.shape[1]
    frames = _element_frames(angles, weights, beta, options.spin == "total", side)
    nodes, _ = wing_tables(wing, options.n_blade, insect.air_density)
    r = nodes[:, cycle.N_R][None, :]
    vt = freestream[0]
    vn = freestream[1] + inflow[None, :]
    # the kernel's own formula, broadcast over (sample, annulus) through an index column
    index = np.arange(n_time)[:, None]
    if len(frames) == 1:
        u, v, _, _ = blade.relative_velocity.py_func(frames[0], index, r, vt, vn)
    else:
        u = np.empty((n_time, len(frames)))
        v = np.empty((n_time, len(frames)))
        for j, coef in enumerate(frames):
            uj, vj, _, _ = blade.relative_velocity.py_func(coef, index, r[:, j], vt, vn[:, j])
            u[:, j], v[:, j] = uj[:, 0], vj[:, 0]
    if offsets is not None:  # the other pair's field, as the kernel adds it (§5.8 item 5)
        u = u + offsets[:, 0].T
        v = v + offsets[:, 1].T
    area = nodes[:, cycle.N_CHORD] * nodes[:, cycle.N_WIDTH]
    aoa = np.rad2deg(np.arctan2(np.abs(v), np.abs(u)) @ area / area.sum())
    speed_nodes = np.hypot(u, v)
    r_hat = nodes[:, cycle.N_R] / wing.length
    rel = np.array([np.interp(0.75, r_hat, row) for row in speed_nodes])
    return aoa, rel
