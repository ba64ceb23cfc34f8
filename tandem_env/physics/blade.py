"""Wing frames and blade-element forces (Eqs. 6-16), compiled with numba.

Frames (our convention, pinned by tests/physics/test_invariants.py). The stroke-plane frame
(x_s, y_s, z_s) has y_s along the right wing's span at φ = θ = 0, z_s the stroke-plane normal on
the upper side, and x_s = y_s × z_s pointing forward and down the stroke plane. The stroke plane
is tilted forward by β from the horizontal, so that in earth axes (X forward, Y right, Z up)
x_s = (cos β, 0, −sin β) and z_s = (sin β, 0, cos β): a tilted stroke plane leans its mean force
forward (thrust), and the free stream has the normal component V_n = V·sin β ≥ 0 (docs/model.md §5).

The wing frame is R = R_z(−φ)·R_x(θ)·R_y(η) applied to the base frame e_s = y_s (span),
e_c = z_s (chord), e_n = e_s × e_c = x_s (chord normal): φ sweeps the span forward, θ lifts the
tip out of the stroke plane, η pitches about the span. At η = 0 the chord is normal to the stroke
plane (90° angle of attack in a pure sweep); η = ±90° lays it in the plane. This is the
paper's Eq. 6 order (β, θ, φ, η), written with rotations whose signs we derive rather than copy
(docs/model.md §4: the paper's R_η and R_β differ in sign pattern). The angular velocity is
ω = −φ̇·z_s + θ̇·R_z(−φ)x_s + η̇·e_s, and every frame vector moves as ė = ω × e, so all
velocities and accelerations below are exact and analytic.

Element forces (per unit span, chord frame components (c, n) along (e_c, e_n)), with (u, v) the
element's velocity relative to the air and (u̇, v̇) the rates of those components (Berman & Wang
2007, the paper's Eqs. 11-15):

    Γ  = −C_t·c·u·v/|U| + ½·C_r·Ω·c²               (Eq. 14; −½C_t|U|c·sin 2α with sin 2α = 2uv/|U|²)
    F_C = ρΓ·(−v, u)                                  (Eq. 11)
    F_AM = (m₂₂·v·Ω − m₁₁·u̇, −m₁₁·u·Ω − m₂₂·v̇)        (Eq. 12 with Berman & Wang's sign on m₂₂·a_v;
                                                       the paper's + is a typo, docs/model.md §4)
    F_V = −½ρc·C_D(α)·|U|·(u, v), C_D = C_d(0)cos²α + C_d(π/2)sin²α          (Eq. 13)
    M   = (m₁₁ − m₂₂)·u·v − I_a·Ω̇ − (1/16)πρc⁴(μ₁f + μ₂|Ω|)·Ω               (about the mid-chord)

Ω is the section's rotation rate: η̇ by default (the paper's and Berman & Wang's choice), or the
true spin about the span ω·e_s = η̇ − φ̇·sin θ (option ``spin="total"``).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .coefficients import PAPER, force_coefficients
from .xp import BRANCH_FREE, select

# Columns of the per-sample frame coefficients (one row per time sample).
C_AU = 0  # ė_s·e_c            [1/s]   chordwise flapping velocity per unit radius
C_AV = 1  # ė_s·e_n            [1/s]
C_BU = 2  # ë_s·e_c + ė_s·ė_c  [1/s²]  rate of the chordwise component, per unit radius
C_BV = 3  # ë_s·e_n + ė_s·ė_n  [1/s²]
C_ECX = 4  # e_c·x_s            stroke-frame components used with the free stream
C_ECZ = 5  # e_c·z_s
C_ENX = 6
C_ENZ = 7
C_DECX = 8  # ė_c·x_s            [1/s]
C_DECZ = 9
C_DENX = 10
C_DENZ = 11
C_SPIN = 12  # Ω                  [rad/s]
C_DSPIN = 13  # Ω̇                 [rad/s²]
C_WEIGHT = 14  # dτ/ds             quadrature weight
C_ECXE = 15  # e_c·X_earth (forward)
C_ENXE = 16
C_ECZE = 17  # e_c·Z_earth (up)
C_ENZE = 18
C_KIN = 19  # ė_s·ë_s           [1/s³]  (d/dt of ½|ė_s|², for the inertial power)
C_ECY = 20  # e_c·Y (lateral)
C_ENY = 21
N_COEF = 22


@njit(cache=True)
def _cross(a0, a1, a2, b0, b1, b2):
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@njit(cache=True)
def fill_frame_coefficients(angles, weight, beta, spin_total, side, out):
    """Per-sample frame coefficients of one wing (see the column constants above).

    ``angles``: (n, 9) φ, φ̇, φ̈, θ, θ̇, θ̈, η, η̇, η̈; ``weight``: (n,) quadrature weights;
    ``beta``: stroke-plane angle [rad]; ``spin_total``: use ω·e_s instead of η̇ for Ω;
    ``side``: +1 right wing, −1 its mirror image (the left wing; used by the symmetry tests).
    Writes ``out`` (n, N_COEF): :func:`frame_columns` of every sample.
    """
    cb = np.cos(beta)
    sb = np.sin(beta)
    for k in range(angles.shape[0]):
        columns = frame_columns(angles, k, weight, cb, sb, spin_total, side)
        for c in range(N_COEF):
            out[k, c] = columns[c]


@njit(cache=True)
def frame_columns(angles, k, weight, cb, sb, spin_total, side):
    """The frame coefficients of sample k, a tuple in column order (C_AU … C_ENY): ``angles``
    [k, :] φ, φ̇, φ̈, θ, θ̇, θ̈, η, η̇, η̈ [rad, rad/s, rad/s²], ``weight`` [k] its quadrature
    weight, ``cb``, ``sb`` cos β, sin β of the stroke-plane angle, ``spin_total`` and ``side``
    as for :func:`fill_frame_coefficients` (on tensors, k = ``...``: every sample at once).
    """
    phi = angles[k, 0]
    dphi = angles[k, 1]
    ddphi = angles[k, 2]
    th = angles[k, 3]
    dth = angles[k, 4]
    ddth = angles[k, 5]
    eta = angles[k, 6]
    deta = angles[k, 7]
    ddeta = angles[k, 8]
    cf = np.cos(phi)
    sf = np.sin(phi)
    ct = np.cos(th)
    st = np.sin(th)
    ce = np.cos(eta)
    se = np.sin(eta)
    # frame vectors in stroke-plane axes
    es0, es1, es2 = ct * sf, ct * cf, st
    ec0, ec1, ec2 = se * cf - st * ce * sf, -se * sf - st * ce * cf, ct * ce
    en0, en1, en2 = ce * cf + st * se * sf, -ce * sf + st * se * cf, -ct * se
    # angular velocity and acceleration
    w0 = dth * cf + deta * es0
    w1 = -dth * sf + deta * es1
    w2 = -dphi + deta * es2
    des0, des1, des2 = _cross(w0, w1, w2, es0, es1, es2)
    dec0, dec1, dec2 = _cross(w0, w1, w2, ec0, ec1, ec2)
    den0, den1, den2 = _cross(w0, w1, w2, en0, en1, en2)
    a0 = ddth * cf - dth * dphi * sf + ddeta * es0 + deta * des0
    a1 = -ddth * sf - dth * dphi * cf + ddeta * es1 + deta * des1
    a2 = -ddphi + ddeta * es2 + deta * des2
    x0, x1, x2 = _cross(a0, a1, a2, es0, es1, es2)
    y0, y1, y2 = _cross(w0, w1, w2, des0, des1, des2)
    dd0, dd1, dd2 = x0 + y0, x1 + y1, x2 + y2
    if spin_total:
        spin = w0 * es0 + w1 * es1 + w2 * es2
        dspin = a0 * es0 + a1 * es1 + a2 * es2  # ω·ė_s = 0
    else:
        spin = deta
        dspin = ddeta
    if side < 0:
        # Mirror through the x-z plane: polar vectors flip y; e_n = e_s × e_c, an axial
        # combination, flips x and z; the spin about the span changes sign.
        es1, des1, dd1, ec1, dec1 = -es1, -des1, -dd1, -ec1, -dec1
        en0, en2, den0, den2 = -en0, -en2, -den0, -den2
        spin, dspin = -spin, -dspin
    return (
        des0 * ec0 + des1 * ec1 + des2 * ec2,  # C_AU
        des0 * en0 + des1 * en1 + des2 * en2,  # C_AV
        dd0 * ec0 + dd1 * ec1 + dd2 * ec2 + des0 * dec0 + des1 * dec1 + des2 * dec2,  # C_BU
        dd0 * en0 + dd1 * en1 + dd2 * en2 + des0 * den0 + des1 * den1 + des2 * den2,  # C_BV
        ec0,  # C_ECX
        ec2,  # C_ECZ
        en0,  # C_ENX
        en2,  # C_ENZ
        dec0,  # C_DECX
        dec2,  # C_DECZ
        den0,  # C_DENX
        den2,  # C_DENZ
        spin,  # C_SPIN
        dspin,  # C_DSPIN
        weight[k],  # C_WEIGHT
        # earth axes: X = cos β·x_s + sin β·z_s, Z = −sin β·x_s + cos β·z_s, Y = y_s
        ec0 * cb + ec2 * sb,  # C_ECXE
        en0 * cb + en2 * sb,  # C_ENXE
        -ec0 * sb + ec2 * cb,  # C_ECZE
        -en0 * sb + en2 * cb,  # C_ENZE
        des0 * dd0 + des1 * dd1 + des2 * dd2,  # C_KIN
        ec1,  # C_ECY
        en1,  # C_ENY
    )


@njit(cache=True)
def relative_velocity(coef, k, r, v_tangential, v_normal):
    """(u, v, u̇, v̇) of the element at radius r [m], sample k, relative to the air [m/s, m/s²].

    The air moves past the insect at −V along the flight path plus the induced inflow −v_i·z_s,
    so the wing-minus-air velocity is r·ė_s + (V_t, 0, V_n + v_i) in stroke-plane axes;
    ``v_normal`` is V_n + v_i (the total normal inflow).
    """
    u = r * coef[k, C_AU] + v_tangential * coef[k, C_ECX] + v_normal * coef[k, C_ECZ]
    v = r * coef[k, C_AV] + v_tangential * coef[k, C_ENX] + v_normal * coef[k, C_ENZ]
    du = r * coef[k, C_BU] + v_tangential * coef[k, C_DECX] + v_normal * coef[k, C_DECZ]
    dv = r * coef[k, C_BV] + v_tangential * coef[k, C_DENX] + v_normal * coef[k, C_DENZ]
    return u, v, du, dv


@njit(cache=True, error_model=BRANCH_FREE)
def element_speed(u, v):
    """|U| of the relative velocity (u, v) [m/s], 1 for a still element (which has no
    translational circulation and no drag, whatever this is): the one square root of an
    element's force, kept by the force sweep for its slope (``induction.normal_force_slope``)."""
    speed2 = u * u + v * v
    return np.sqrt(select(speed2 > 0.0, speed2, 1.0))


@njit(cache=True, error_model=BRANCH_FREE)
def translational_terms(u, v, speed, chord, ct, cd0, cd90, rho, table=None):
    """The translational bound circulation Γ_t [m²/s] (Eq. 14) and the viscous force's factor
    [N·s/m²] (Eq. 13: F_V = −factor·(u, v)) of an element of chord ``chord`` [m] moving at
    (u, v) [m/s], |U| = ``speed`` > 0. ``table``: the wing's force-coefficient model
    (``coefficients``; omitted or ``[PAPER]``: the paper's, Γ_t = −C_t·c·u·v/|U| and the factor
    ½ρc·(C_d(0)·u² + C_d(π/2)·v²)/|U| from ``ct``, ``cd0``, ``cd90``); any other model's C_L(α),
    C_D(α): Γ_t = −½·c·|U|·C_L·sign(v), the factor ½ρc·C_D·|U|. The kernel's forces
    (:func:`element_force_at`) and the vortex reading's shed circulation
    (``interaction.circulation``) both take Γ_t from here."""
    paper = True
    if table is not None:
        paper = table[0] == PAPER
    if paper:
        gamma = -(ct * chord * u * v / speed)
        drag = 0.5 * rho * chord * (cd0 * u * u + cd90 * v * v) / speed
    else:  # numba only: the torch backend takes the paper's coefficients
        lift_coefficient, drag_coefficient = force_coefficients(u, v, table)
        side = 1.0 if v > 0.0 else (-1.0 if v < 0.0 else 0.0)
        gamma = -(0.5 * chord * speed * lift_coefficient * side)
        drag = 0.5 * rho * chord * drag_coefficient * speed
    return gamma, drag


@njit(cache=True, error_model=BRANCH_FREE)
def element_force(u, v, du, dv, spin, section, table=None):
    """Aerodynamic force per unit span (F_c, F_n) [N/m] on one blade element (Eqs. 11-14):
    :func:`element_force_at` at its :func:`element_speed`."""
    return element_force_at(u, v, du, dv, spin, section, element_speed(u, v), table)


@njit(cache=True, error_model=BRANCH_FREE)
def element_force_at(u, v, du, dv, spin, section, speed, table=None):
    """Aerodynamic force per unit span (F_c, F_n) [N/m] on one blade element (Eqs. 11-14) whose
    :func:`element_speed` ``speed`` [m/s] is known.

    Circulatory + added mass + viscous; the wing's own inertia is not an aerodynamic force
    (docs/model.md §4.9). ``section``: the element and its wing's coefficients
    (:class:`~tandem_env.physics.bundle.Section`). ``table``: the wing's force-coefficient model
    (``coefficients``; omitted or ``[PAPER]``: the paper's C_t·sin 2α and
    C_d(0)cos²α + C_d(π/2)sin²α from ``section``'s ``ct``, ``cd0``, ``cd90``); any other model
    replaces them by its C_L(α), C_D(α) (:func:`translational_terms`).
    """
    chord = section.chord
    m11 = section.m11
    m22 = section.m22
    rho = section.rho
    moving = u * u + v * v > 0.0  # a still element has no translational circulation and no drag
    gamma = 0.5 * section.cr * spin * chord * chord
    fc = m22 * v * spin - m11 * du
    fn = -m11 * u * spin - m22 * dv
    translational, factor = translational_terms(
        u, v, speed, chord, section.ct, section.cd0, section.cd90, rho, table
    )
    gamma += select(moving, translational, 0.0)
    drag = select(moving, factor, 0.0)
    fc -= drag * u
    fn -= drag * v
    fc -= rho * gamma * v
    fn += rho * gamma * u
    return fc, fn


@njit(cache=True)
def element_moment(u, v, spin, dspin, section, frequency):
    """Aerodynamic pitching moment per unit span about the mid-chord axis [N·m/m] of the
    element ``section`` at flapping frequency ``frequency`` [Hz].

    Munk moment, added inertia and rotational damping (Berman & Wang 2007); the circulatory
    and viscous forces act at the pitch axis (docs/model.md §4).
    """
    return (
        (section.m11 - section.m22) * u * v
        - section.inertia_a * dspin
        - section.damping * (section.mu1 * frequency + section.mu2 * abs(spin)) * spin
    )


@njit(cache=True)
def element_power(coef, k, fc, fn, moment, section):
    """Power per unit span the element ``section`` delivers to the air at sample k [W/m]: minus
    its aerodynamic force (F_c, F_n) [N/m] times its flapping velocity r·ė_s, minus its moment
    [N·m/m] times its rotation rate Ω (``coef``, ``k`` as for :func:`relative_velocity`)."""
    return -(section.r * (fc * coef[k, C_AU] + fn * coef[k, C_AV]) + moment * coef[k, C_SPIN])


@njit(cache=True)
def shed_force(coef, k, u, v, du, dv, fc, fn, section):
    """The part of the element force (F_c, F_n) [N/m] at relative velocity (u, v, u̇, v̇) that the
    wing sheds into its wake, along the stroke-plane normal z_s [N/m]: the force less its added
    mass (Eq. 12), which is not shed (docs/model.md §5.7)."""
    spin = coef[k, C_SPIN]
    shed_c = fc - section.m22 * v * spin + section.m11 * du
    shed_n = fn + section.m11 * u * spin + section.m22 * dv
    return shed_c * coef[k, C_ECZ] + shed_n * coef[k, C_ENZ]


@njit(cache=True)
def earth_forces(coef, k, span_c, span_n):
    """A wing's force at sample k in earth axes, (F_x forward, F_z up, F_y lateral) [N] (Eq. 16),
    of the span integrals ``span_c``, ``span_n`` of its chordwise and chord-normal element forces
    [N] (``coef``, ``k`` as for :func:`relative_velocity`)."""
    return (
        span_c * coef[k, C_ECXE] + span_n * coef[k, C_ENXE],
        span_c * coef[k, C_ECZE] + span_n * coef[k, C_ENZE],
        span_c * coef[k, C_ECY] + span_n * coef[k, C_ENY],
    )


@njit(cache=True)
def inertial_power(coef, k, span_inertia, pitch_inertia):
    """P_iner of a wing at sample k [W]: d/dt of its kinetic energy, the flapping of the pitch
    axis (``span_inertia`` ∫m'r² dr) plus the rotation about it (``pitch_inertia`` ∫m'c²/12 dr)
    [kg·m²] (docs/model.md §6.2)."""
    return span_inertia * coef[k, C_KIN] + pitch_inertia * coef[k, C_SPIN] * coef[k, C_DSPIN]


@njit(cache=True, error_model=BRANCH_FREE)
def acute_angle(along, across):
    """atan(|across| / |along|) ∈ [0, π/2] [rad], to 2e-8 rad without a libm call.

    The mean angle of attack needs this once per element and sample; a polynomial after
    range reduction to |z| ≤ tan(π/8) is several times cheaper than atan2 there.
    """
    x = abs(along)
    y = abs(across)
    still = (x == 0.0) & (y == 0.0)
    swap = y > x
    small = select(swap, x, y)
    big = select(swap, y, x)
    # z = small/big in [0, 1], reduced with atan z = π/4 + atan((z − 1)/(z + 1)) above
    # tan(π/8): one division either way
    reduce = small > 0.41421356237309503 * big
    z = select(reduce, small - big, small) / select(still, 1.0, select(reduce, small + big, big))
    z2 = z * z
    # odd Taylor series of atan to z¹⁵: |error| < 2e-8 rad for |z| <= tan(π/8)
    poly = z * (
        1.0
        + z2
        * (
            -1.0 / 3.0
            + z2
            * (
                1.0 / 5.0
                + z2
                * (
                    -1.0 / 7.0
                    + z2 * (1.0 / 9.0 + z2 * (-1.0 / 11.0 + z2 * (1.0 / 13.0 - z2 * (1.0 / 15.0))))
                )
            )
        )
    )
    angle = select(reduce, 0.7853981633974483 + poly, poly)
    return select(still, 0.0, select(swap, 1.5707963267948966 - angle, angle))
