"""Cycle-averaged longitudinal point-mass dynamics of the insect (the SpeedChange env's motion).

Earth axes: x forward (horizontal), z up. The body is a point of mass m moving with forward speed
u and vertical speed w; its speed along the flight path is V = sqrt(u² + w²) and its flight-path
angle γ = atan2(w, u) (+ climbing). Over one wing-beat cycle of duration Δt the net force

    F = F_wings + D_body + W,                                                   (1)
    F_wings = (Σ F̄_x, Σ F̄_z)   the wings' cycle-mean forces in earth axes at (V, γ),
    D_body  = −½·ρ·V²·(C_D·S)_body · (cos γ, sin γ)   parasite drag, against the velocity,
    W       = (0, −m·g),

is held constant (the quasi-steady model gives cycle means only), and the state is advanced
exactly for a constant force (a zero-order hold on the force, i.e. explicit Euler in velocity)::

    u' = u + F_x/m·Δt,            w' = w + F_z/m·Δt,                             (2)
    x' = x + u·Δt + ½·F_x/m·Δt²,  h' = h + w·Δt + ½·F_z/m·Δt².                   (3)

The scheme is first order in Δt in how the force follows the velocity (evaluated at the cycle's
start) and exact for the motion under it; Eq. (3) is the trapezoidal rule on the velocity,
h' − h = ½(w + w')·Δt.
"""

from __future__ import annotations

import numpy as np

from ..physics import PARAMETER_NAMES, Dragonfly, Result

_FORE_FREQUENCY = PARAMETER_NAMES.index("fore_frequency")
_HIND_FREQUENCY = PARAMETER_NAMES.index("hind_frequency")


def flight_path(
    forward_speed: np.ndarray, vertical_speed: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(V [m/s], γ [rad]) of velocities (u, w) [m/s]: V = sqrt(u² + w²), γ = atan2(w, u)."""
    return np.hypot(forward_speed, vertical_speed), np.arctan2(vertical_speed, forward_speed)


def cycle_time(physical: np.ndarray) -> np.ndarray:
    """Duration of one step Δt = max(1/f_fore, 1/f_hind) [s] of physical strokes (B, 28).

    Each wing pair beats at its own frequency and the model's forces and powers are each pair's
    mean over its own cycle. The step lasts the longer of the two periods, so that both pairs
    complete at least one whole beat within it: the slower pair's mean is then never applied
    over a fraction of its beat, where its forces would be far from their mean.
    """
    return 1.0 / np.minimum(physical[:, _FORE_FREQUENCY], physical[:, _HIND_FREQUENCY])


def body_drag(speed: np.ndarray, insect: Dragonfly) -> np.ndarray:
    """Body parasite drag D_b = ½·ρ·V²·(C_D·S)_body [N] at speed V [m/s] (docs/model.md §1.5)."""
    return 0.5 * insect.air_density * speed**2 * insect.body_drag_area


def net_force(result: Result, insect: Dragonfly) -> tuple[np.ndarray, np.ndarray]:
    """Net force (F_x, F_z) [N] of Eq. (1) in earth axes, for strokes evaluated at
    ``result.speed`` and ``result.flight_path_angle``.

    The wing forces are the per-pair fields (``fore/hind_horizontal_force`` and
    ``fore/hind_lift_to_weight``), which do not depend on ``thrust_split``; with
    ``thrust_split="body"`` the result equals (F̄_h·W, F̄_v·W) exactly in exact arithmetic.
    """
    weight, gamma = insect.weight, result.flight_path_angle
    drag = body_drag(result.speed, insect)
    fx = result.fore_horizontal_force + result.hind_horizontal_force - drag * np.cos(gamma)
    lift = (result.fore_lift_to_weight + result.hind_lift_to_weight) * weight
    fz = lift - drag * np.sin(gamma) - weight
    return fx, fz


def advance(
    forward_speed: np.ndarray,
    vertical_speed: np.ndarray,
    distance: np.ndarray,
    altitude: np.ndarray,
    force_x: np.ndarray,
    force_z: np.ndarray,
    mass: float,
    dt: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Eqs. (2)-(3): (u', w', x', h') after Δt [s] under the constant force (F_x, F_z) [N];
    velocities in m/s, positions in m, mass in kg; every array (B,)."""
    ax, az = force_x / mass, force_z / mass
    return (
        forward_speed + ax * dt,
        vertical_speed + az * dt,
        distance + forward_speed * dt + 0.5 * ax * dt * dt,
        altitude + vertical_speed * dt + 0.5 * az * dt * dt,
    )
