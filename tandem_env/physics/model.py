"""The batched entry point: strokes (B, 28) and a flight condition -> performance (B,).

:func:`evaluate_numba` evaluates the model on the compiled numba kernel; every layer above
(environments, PSO, sweeps) calls it through ``tandem_env.evaluate`` (``backends``, which also
offers the torch port). It runs the whole batch in one compiled, parallel call (no Python loop
over strokes) and returns a :class:`Result` of (B,) arrays whose metric names are the ones the
environments put in ``info``. Flight performance follows Eqs. 17 and 22-27 as docs/model.md §7
decides.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, fields, replace
from functools import lru_cache
from typing import Any, NamedTuple

import numpy as np

from . import blade, clearance, cycle, interaction
from .bundle import Outputs, Settings, WingBatch
from .checks import real_array, shown
from .coefficients import PaperCoefficients
from .first_use import compile_notice
from .insect import DRAGONFLY, Dragonfly, Wing
from .kinematics import motion_grid, wing_params_radians
from .options import HOVER_NORMAL_SPEED, ModelOptions
from .stroke import N_PER_WING, validate_physical
from .xp import NUMPY, ArrayNamespace

DEFAULT_OPTIONS = ModelOptions()

#: The metrics every evaluation reports, in the order environments list them in ``info``.
METRIC_NAMES: tuple[str, ...] = (
    "lift_to_weight",
    "thrust",
    "drag",
    "power",
    "power_per_mass",
    "efficiency",
    "excess_vertical",
    "excess_horizontal",
    "excess_total",
    "excess_horizontal_literal",
    "mean_angle_of_attack",
)


@lru_cache(maxsize=64)
def wing_tables(wing: Wing, n_blade: int, air_density: float) -> tuple[np.ndarray, np.ndarray]:
    """Blade-element node table and constants of a wing (see ``cycle`` column constants).

    Nodes are Gauss-Legendre in x ∈ [0, 1] with r/R = sin(πy/2), y = 3x² − 2x³. The span
    integrands are not smooth in r: the induced velocity grows like sqrt(r) from the root and,
    on the tear-drop, falls like (1 − r/R)^¼ to the tip, where the chord itself goes like
    sqrt(1 − r/R). The map makes r ~ x² at the root and 1 − r/R ~ (1 − x)⁴ at the tip, which
    turns all of these into smooth functions of x, so Gauss-Legendre converges fast.
    """
    x, w = np.polynomial.legendre.leggauss(n_blade)
    x = 0.5 * (x + 1.0)
    w = 0.5 * w
    y = x * x * (3.0 - 2.0 * x)
    r_hat = np.sin(0.5 * np.pi * y)
    width = wing.length * 0.5 * np.pi * np.cos(0.5 * np.pi * y) * 6.0 * x * (1.0 - x) * w
    chord = wing.chord(r_hat)
    rho = air_density
    b_t = wing.thickness
    nodes = np.empty((n_blade, cycle.N_COLUMNS))
    nodes[:, cycle.N_R] = r_hat * wing.length
    nodes[:, cycle.N_CHORD] = chord
    nodes[:, cycle.N_WIDTH] = width
    nodes[:, cycle.N_M11] = 0.25 * np.pi * rho * b_t**2
    nodes[:, cycle.N_M22] = 0.25 * np.pi * rho * chord**2
    nodes[:, cycle.N_IA] = np.pi * rho * (chord**2 + b_t**2) ** 2 / 128.0
    nodes[:, cycle.N_DAMP] = np.pi * rho * chord**4 / 16.0
    span_inertia, pitch_inertia = node_inertia(wing, nodes)
    consts = np.empty(cycle.N_CONSTANTS)
    consts[cycle.K_CT] = wing.translational_coefficient
    consts[cycle.K_CD0] = wing.drag_coefficient_0
    consts[cycle.K_CD90] = wing.drag_coefficient_90
    consts[cycle.K_CR] = wing.rotational_coefficient
    consts[cycle.K_MU1] = wing.damping_linear
    consts[cycle.K_MU2] = wing.damping_quadratic
    consts[cycle.K_I_SPAN] = np.sum(span_inertia)
    consts[cycle.K_I_PITCH] = np.sum(pitch_inertia)
    nodes.setflags(write=False)
    consts.setflags(write=False)
    return nodes, consts


def node_inertia(wing: Wing, nodes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each blade element's share of the wing's inertia, (n_blade,) each [kg·m²].

    m'(r)·r²·dr (flapping of the pitch axis line) and m'(r)·c²/12·dr (thin-plate rotation about
    it), with mass per span m' = m_w·c/(c̄R) (docs/model.md §6); their sums are the wing's constants.
    """
    chord = nodes[:, cycle.N_CHORD]
    width = nodes[:, cycle.N_WIDTH]
    mass_per_span = wing.mass * chord / (wing.mean_chord * wing.length)
    return mass_per_span * nodes[:, cycle.N_R] ** 2 * width, mass_per_span * chord**2 / 12.0 * width


@dataclass(frozen=True)
class Result:
    """Performance of a batch of strokes; every field is a (B,) array.

    Forces in newtons, power in watts, angles in degrees. "fore_"/"hind_" fields are one wing
    pair's contribution (N_w wings).
    """

    lift_to_weight: np.ndarray
    """L/W = N_w·(F̄_z,fore + F̄_z,hind)/(m·g) (Eq. 17) [-]: the vertical (earth-axis) force;
    with ``thrust_split="body"`` less the body drag's vertical part D_b·sin γ."""
    thrust: np.ndarray
    """T [N], horizontal (earth axes), per ``thrust_split`` (docs/model.md §7)."""
    drag: np.ndarray
    """D [N], horizontal (earth axes), per ``thrust_split``."""
    power: np.ndarray
    """P = P_fore + P_hind (Eq. 19) [W], each per ``options.power`` (docs/model.md §6.3)."""
    power_per_mass: np.ndarray
    """P/m [W/kg]."""
    efficiency: np.ndarray
    """η_level = T·V/P (Eq. 22) [-]; 0 where P = 0 or T ≤ 0; never clipped above 1."""
    excess_vertical: np.ndarray
    """F̄_v = (L − W)/W (Eqs. 23, 25) [-]."""
    excess_horizontal: np.ndarray
    """F̄_h = (T − D)/W (Eqs. 24, 26) [-]."""
    excess_total: np.ndarray
    """F̄_a = sqrt(F̄_v² + F̄_h²) of this stroke (Eq. 27) [-]."""
    excess_horizontal_literal: np.ndarray
    """(D_f + D_h)/W, Eq. 24 read literally (docs/model.md §7.6) [-]: the sum over all wings of
    the cycle mean of the rearward part of each wing's horizontal force, max(−F_x, 0), a
    magnitude (≥ 0) whatever ``thrust_split``; a reading, not the net force on the body."""
    mean_angle_of_attack: np.ndarray
    """Cycle- and area-weighted mean acute angle of attack, averaged over both wings [deg]."""
    efficiency_above_one: np.ndarray
    """η > 1 (possible with ``thrust_split="sign"``; never clipped, docs/model.md §7) (bool)."""
    induction_converged: np.ndarray
    """Every annulus's inflow solve met its tolerance (bool)."""
    induction_evaluations: np.ndarray
    """Most force sweeps any annulus needed [-]."""
    fore_lift_to_weight: np.ndarray
    hind_lift_to_weight: np.ndarray
    fore_horizontal_force: np.ndarray
    """Net mean horizontal force of the fore pair, + forward [N]."""
    hind_horizontal_force: np.ndarray
    fore_power: np.ndarray
    """Power of the fore pair [W]."""
    hind_power: np.ndarray
    fore_aero_power: np.ndarray
    """N_w·mean|P_aero| of the fore pair [W]."""
    hind_aero_power: np.ndarray
    fore_inertial_power: np.ndarray
    """N_w·mean|P_iner| of the fore pair [W]."""
    hind_inertial_power: np.ndarray
    fore_mean_angle_of_attack: np.ndarray
    """[deg]."""
    hind_mean_angle_of_attack: np.ndarray
    fore_inflow: np.ndarray
    """Area-weighted mean induced velocity of the fore-wing [m/s]."""
    hind_inflow: np.ndarray
    """Area-weighted mean own induced velocity of the hind-wing [m/s]."""
    speed: np.ndarray
    """Flight speed V [m/s], along the flight path."""
    flight_path_angle: np.ndarray
    """Flight-path angle γ [rad], + climbing."""
    available_power: np.ndarray
    """Available power per mass [W/kg]."""
    wing_gap: np.ndarray | None = None
    """The least distance between the fore- and hind-wing surfaces over the cycle [m]
    (:func:`~tandem_env.physics.clearance.gaps`), computed where the insect sets
    ``min_wing_gap`` (the tasks' constraint on it); None otherwise, and then in no dict."""
    wing_gap_next: np.ndarray | None = None
    """The distance at the next place where the wings come close [m]: the closest other local
    minimum of their distance over the cycle (``wing_gap`` + ``insect.MAX_WING_GAP`` where
    there is none), so that a constraint holds at each place the wings may touch; computed
    with ``wing_gap``."""
    options: ModelOptions = DEFAULT_OPTIONS
    """The options this result was computed with (thrust split, power convention, …)."""
    planform: str = "tear-drop"
    """The insect's planform (``"tear-drop"``, ``"real"`` or ``"mixed"``)."""

    def __len__(self) -> int:
        return int(self.lift_to_weight.shape[0])

    def metrics(self) -> dict[str, np.ndarray]:
        """The headline metrics (:data:`METRIC_NAMES`) as a dict of (B,) arrays."""
        return {name: getattr(self, name) for name in METRIC_NAMES}

    def as_dict(self) -> dict[str, np.ndarray]:
        """Every (B,) array field as a dict (the metadata ``options``, ``planform`` and an
        optional field not computed excluded)."""
        return {
            f.name: getattr(self, f.name)
            for f in fields(self)
            if f.name not in _METADATA and getattr(self, f.name) is not None
        }

    def row(self, index: int) -> dict[str, float | int | bool]:
        """Plain Python values of one stroke (for ``info`` dicts and JSON records)."""
        out: dict[str, float | int | bool] = {}
        for name, arr in self.as_dict().items():
            value = arr[index]
            if arr.dtype == bool:
                out[name] = bool(value)
            elif np.issubdtype(arr.dtype, np.integer):
                out[name] = int(value)
            else:
                out[name] = float(value)
        return out


_METADATA = ("options", "planform")
#: The fields computed only where asked (None otherwise): the wings' least distance, and their
#: distance at the next place they come close.
OPTIONAL_FIELDS = ("wing_gap", "wing_gap_next")

# --- the flight condition's limits (the one home: envs, history and studies use these) --------
#: Flight speeds V the model accepts [m/s]: forward flight (V >= 0), up to ten times the
#: paper's fastest (2 m/s).
SPEED_LIMITS: tuple[float, float] = (0.0, 20.0)
#: Available powers per body mass the model accepts [W/kg]: more than a factor of ten either
#: side of the paper's 50-90 W/kg (30-60 % flight muscle at 150 W/kg), and a power given in W
#: instead of W/kg is refused (the specimen's 90 W/kg is 0.011 W).
AVAILABLE_POWER_LIMITS: tuple[float, float] = (1.0, 1000.0)
#: Largest |flight-path angle| [rad]: the body moves forward (V ≥ 0), climbing or descending.
MAX_FLIGHT_PATH_ANGLE = 0.5 * np.pi
#: The most strokes one batched evaluation is offered by the layers above [-]: 10 000 strokes
#: take under 0.5 GB. An optimiser's round, a vector env's envs and a speed-change evaluation's
#: episodes are each one such batch, and each is limited by this.
MAX_BATCH_STROKES = 10_000


def check_model_inputs(insect: Any, options: Any) -> None:
    """ValueError unless ``insect`` is a Dragonfly and ``options`` a ModelOptions (both
    backends' evaluation checks these first)."""
    if not isinstance(insect, Dragonfly):
        raise ValueError(f"insect must be a Dragonfly; got {type(insect).__name__}")
    if not isinstance(options, ModelOptions):
        raise ValueError(f"options must be a ModelOptions; got {type(options).__name__}")


def validate_conditions(
    speed: float | np.ndarray | None,
    available_power: float | np.ndarray | None,
    flight_path_angle: float | np.ndarray | None,
    batch: int,
    insect: Dragonfly,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The flight condition as validated (batch,) arrays: speed V [m/s] within
    :data:`SPEED_LIMITS` (default 0), available power [W/kg] within
    :data:`AVAILABLE_POWER_LIMITS` (default the insect's maximum) and flight-path angle γ [rad]
    within ±:data:`MAX_FLIGHT_PATH_ANGLE` (default 0). Each is a real scalar or one value per
    stroke; a bad one raises ValueError naming it, its value and what is allowed."""
    speed = _broadcast_condition(speed, batch, "speed", "m/s", *SPEED_LIMITS, 0.0)
    power = _broadcast_condition(
        available_power,
        batch,
        "available_power",
        "W/kg",
        *AVAILABLE_POWER_LIMITS,
        insect.max_power_per_mass,
    )
    gamma = _broadcast_condition(
        flight_path_angle,
        batch,
        "flight_path_angle",
        "rad",
        -MAX_FLIGHT_PATH_ANGLE,
        MAX_FLIGHT_PATH_ANGLE,
        0.0,
    )
    return speed, power, gamma


def _broadcast_condition(
    value: float | np.ndarray | None,
    batch: int,
    name: str,
    unit: str,
    low: float,
    high: float,
    default: float,
) -> np.ndarray:
    """A flight condition as a (batch,) float array: a real scalar, or one value per stroke,
    each finite and within [low, high]; ``default`` when None."""
    if value is None:
        value = default
    allowed = (
        f"a real number or a ({batch},) array of them (one per stroke), finite, "
        f"{low:g} to {high:g} {unit}"
    )
    arr = real_array(value, name, allowed)
    if arr.ndim == 0:
        arr = np.full(batch, float(arr))
    if arr.shape != (batch,):
        raise ValueError(f"{name} has shape {arr.shape}; allowed: {allowed}")
    bad = ~np.isfinite(arr) | (arr < low) | (arr > high)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        where = name if np.ndim(value) == 0 else f"{name}[{i}]"
        raise ValueError(f"{where} = {shown(arr[i], low, high)} {unit}; allowed: {allowed}")
    return arr


def stroke_plane_speeds(
    speed: Any, beta: Any, flight_path_angle: Any, xp: ArrayNamespace = NUMPY
) -> tuple[Any, Any]:
    """The body's velocity in a wing's stroke-plane axes, (V_t, V_n) [m/s], in the array
    namespace ``xp`` (numpy or torch); the arguments broadcast against each other.

    The body moves at ``speed`` V [m/s] along its flight path, inclined by the flight-path angle
    γ [rad] (+ climbing) to the horizontal; ``beta`` is the wing's stroke-plane angle β [rad]
    from the horizontal (earth axes, docs/model.md "Conventions"). With x_s = (cos β, 0, −sin β)
    and z_s = (sin β, 0, cos β) in earth axes and the velocity V·(cos γ, 0, sin γ):
    V_t = V·cos(β + γ), V_n = V·sin(β + γ). Only β + γ, the stroke plane's angle to the path,
    enters the flow; β alone sets the projection of the forces onto earth axes.
    """
    angle = beta + flight_path_angle
    return speed * xp.cos(angle), speed * xp.sin(angle)


def freestream_components(
    speed: np.ndarray, beta: np.ndarray, flight_path_angle: np.ndarray
) -> np.ndarray:
    """(V_t, V_n) [m/s] of both wings (:func:`stroke_plane_speeds`) as the kernel takes them,
    shape (B, 2, 2), of ``speed`` (B,) [m/s], ``beta`` (B, 2) and ``flight_path_angle`` (B,)
    [rad]."""
    tangential, normal = stroke_plane_speeds(speed[:, None], beta, flight_path_angle[:, None])
    return np.stack([tangential, normal], axis=-1)


def inflow_switched_off(
    normal_speed: Any, options: ModelOptions, xp: ArrayNamespace = NUMPY
) -> Any:
    """Bool, shaped like ``normal_speed``: the wings that have no induced velocity whatever
    ``options.induction``, in the array namespace ``xp`` (numpy or torch).

    With ``hover_inflow="none"`` these are the wings whose free stream has no component normal
    to their stroke plane, |V_n| < :data:`~tandem_env.physics.options.HOVER_NORMAL_SPEED`
    [m/s] (in practice V = 0): the paper's inflow v_z·(1 + a) (Eqs. 20-21) read literally is
    zero there (docs/model.md §5.5). ``normal_speed``: V_n [m/s] (:func:`stroke_plane_speeds`).
    With ``"momentum"`` (the default) none.
    """
    if options.hover_inflow == "momentum":
        return xp.zeros_bool(normal_speed)
    return xp.abs(normal_speed) < HOVER_NORMAL_SPEED


def coefficient_tables(insect: Dragonfly) -> tuple[np.ndarray | None, np.ndarray | None]:
    """The wings' force-coefficient tables for the kernel (``coefficients``): ``(None, None)``
    when both use the paper's model, which keeps the default path's compiled code as it was."""
    if all(isinstance(w.coefficients, PaperCoefficients) for w in (insect.fore, insect.hind)):
        return None, None
    return insect.fore.coefficients.table(), insect.hind.coefficients.table()


def kernel_settings(insect: Dragonfly, options: ModelOptions, n_time: int) -> Settings:
    """The kernel's :class:`~tandem_env.physics.bundle.Settings` of ``options`` (the induction
    mode, C_hf, the spin, the inflow solve's tolerance and cap, the slipstream), the insect's air
    and roots, and the Fourier tables of ``n_time`` samples per cycle."""
    mode = {"none": cycle.MODE_NONE, "isolated": cycle.MODE_ISOLATED, "coupled": cycle.MODE_COUPLED}
    return Settings(
        mode[options.induction], options.interference, options.spin == "total", options.tolerance,
        options.max_evaluations, options.slipstream == "convected", True, 3,
        np.empty(0, np.int64), insect.air_density, insect.root_spacing, insect.root_drop,
        *cycle.fourier_tables(n_time),
    )  # fmt: skip


class StrokeMotion(NamedTuple):
    """What the phase-resolved slipstreams read of a parametric stroke (:func:`run_kernel`)."""

    phases: np.ndarray | None
    """(B, 2, n_time) each wing's sample phases ϑ = 2πft [rad], or None (uniform)."""
    params: tuple[np.ndarray, np.ndarray] | None
    """Each wing's (B, 14) parameters [Hz, rad, -] (the vortex reading), or None."""


class Kept(NamedTuple):
    """What :func:`run_kernel` keeps besides the cycle means and the inflow."""

    history: bool = False
    """The per-sample histories of each wing (``Outputs.history``)."""
    fields: list | None = None
    """A list that receives, under the vortex reading, each wing's field of the other pair
    (``interaction.kernel_reading``'s ``fields_out``), or None."""


def run_kernel(
    angles,
    weights,
    frequency,
    beta,
    sweep,
    speed,
    flight_path_angle,
    insect: Dragonfly,
    options: ModelOptions,
    keep: Kept | None = None,
    tables: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = None,
    motion: StrokeMotion | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Run the compiled cycle on prepared angle histories (the step below :func:`evaluate_numba`).

    ``angles``/``weights``: per wing, (B, n_time, 9) angle histories and (B, n_time) quadrature
    weights; ``frequency``, ``beta``, ``sweep``: (B, 2) [Hz, rad, rad]; ``speed`` (B,) [m/s];
    ``flight_path_angle`` (B,) [rad]. Returns the per-wing cycle means (B, 2, N_WING_OUT), the
    inflow per annulus (B, 2, n_blade) [m/s] and, with ``keep.history``, the per-sample earth-axis
    F_x, F_z, F_y [N] and P_aero, P_iner [W] of one wing (B, 2, n_time, 5). ``tables``
    replaces the insect's (nodes, constants) of the fore- and hind-wing (:func:`wing_tables`),
    e.g. by single blade elements. ``motion`` (:class:`StrokeMotion`; None: neither part):
    ``phases``, (B, 2, n_time) each wing's sample phases ϑ = 2πft [rad]
    (``kinematics.motion_grid``), read by the phase-resolved slipstreams only; ``None``:
    uniform samples 2πk/n_time (measured kinematics). The convected slipstream follows
    the whole fore-wing's loading, so it refuses ``tables`` (wings evaluated element by element).
    ``params``: each wing's (B, 14) parameters [Hz, rad, -], which the vortex reading
    (``options.slipstream="vortex"``, docs/model.md §5.8; ``interaction``) reads to place the
    wings; without them (measured kinematics, uniform samples) it places them by their angle
    histories. It refuses ``tables`` (a wing evaluated element by element has no one lifting
    line); ``keep.fields`` receives its field of each pair on the other (:class:`Kept`; None:
    the cycle means and the inflow only).
    """
    keep = Kept() if keep is None else keep
    phases, params = (None, None) if motion is None else motion
    convected = options.slipstream == "convected"
    vortex = options.slipstream == "vortex" and options.phase_resolved()
    if vortex and tables is not None:
        raise ValueError(
            'ModelOptions.slipstream = "vortex" needs whole wings (it places each pair\'s '
            "lifting line and wake); wings evaluated element by element (span-wise twist) "
            'allow: slipstream = "mean"'
        )
    if convected and tables is not None:
        raise ValueError(
            'ModelOptions.slipstream = "convected" needs whole wings (it follows the fore-wing\'s '
            "span-integrated loading); wings evaluated element by element (span-wise twist) "
            'allow: slipstream = "mean"'
        )
    if tables is None:
        tables = (
            *wing_tables(insect.fore, options.n_blade, insect.air_density),
            *wing_tables(insect.hind, options.n_blade, insect.air_density),
        )
    batch, n_time = weights[0].shape
    outputs = Outputs(
        np.empty((batch, 2, cycle.N_WING_OUT)),
        np.empty((batch, 2, tables[0].shape[0])),
        np.empty((batch if keep.history else 0, 2, n_time, 5)),
    )
    freestream = freestream_components(speed, beta, flight_path_angle)
    off = inflow_switched_off(freestream[:, :, 1], options)
    if not (convected or vortex):
        phases = np.empty((0, 2, n_time))
    elif phases is None:
        phases = np.broadcast_to(2.0 * np.pi * np.arange(n_time) / n_time, (batch, 2, n_time))
    fore, hind = (
        WingBatch(
            *(np.ascontiguousarray(a) for a in (angles[w], weights[w])),
            *(np.ascontiguousarray(a[:, w], dtype=float) for a in (frequency, beta, sweep)),
            *(np.ascontiguousarray(freestream[:, w, i]) for i in (0, 1)),
            np.ascontiguousarray(off[:, w]),
            np.ascontiguousarray(phases[:, w], dtype=float),
            tables[2 * w],
            tables[2 * w + 1],
            coefficient_tables(insect)[w],
            np.empty((0, 2, 1, n_time)),
            np.empty((0, tables[2 * w].shape[0])),
            np.zeros((tables[2 * w].shape[0], 1)),
            np.empty((0, n_time, blade.N_COEF)),
        )
        for w in (0, 1)
    )
    settings = kernel_settings(insect, options, n_time)

    def run(
        wings: tuple[WingBatch, WingBatch],
        pairs: int = 3,
        rows: np.ndarray | None = None,
        into: Outputs | None = None,
    ) -> Outputs:
        # the vortex reading's passes solve one pair on some of the strokes (``rows``), into
        # the rows of its first pass's outputs (``into``)
        out = outputs if into is None else into
        if vortex and into is None:  # each pass keeps its history, whose means come at the end
            out = Outputs(*(np.empty((len(wings[0].weight), *a.shape[1:])) for a in outputs))
        count = len(wings[0].weight) if rows is None else len(rows)
        chosen = settings._replace(pairs=pairs, rows=settings.rows if rows is None else rows)
        with compile_notice():  # the first call compiles the kernels: say so once
            cycle.tandem_cycle(count, *wings, chosen, out)
        return out

    if not vortex:
        return run((fore, hind))
    # the vortex reading (docs/model.md §5.8): each pair's own inflow as if isolated, the other
    # pair's field in its element velocities, passes to a fixed point
    # (the cycle means only of the pass at which each stroke stops: from its history)
    settings = settings._replace(mode=cycle.MODE_ISOLATED, means=False)
    scale = np.where(off.any(1), 0.0, options.interference)
    result = interaction.kernel_reading(
        (fore, hind), params, phases, run, speed, flight_path_angle, scale, insect,
        options.spin == "total", keep.fields,
    )  # fmt: skip
    cycle.history_means(
        len(result.history), result.history, fore.weight, hind.weight, settings.cos_table,
        settings.sin_table, result.means,
    )  # fmt: skip
    return result if keep.history else result._replace(history=outputs.history)


def _performance(
    out: np.ndarray,
    speed: np.ndarray,
    flight_path_angle: np.ndarray,
    available_power: np.ndarray,
    insect: Dragonfly,
    options: ModelOptions,
) -> Result:
    """The :class:`Result` of the compiled kernel's per-wing cycle means ``out``
    (B, 2, N_WING_OUT): :func:`flight_performance` on numpy."""

    def means(key: str) -> np.ndarray:
        return out[:, :, getattr(cycle, f"W_{key}")]

    values = flight_performance(
        means, speed, flight_path_angle, available_power, insect, options, NUMPY
    )
    return Result(**values, options=options, planform=insect.planform)


def flight_performance(
    means: Callable[[str], Any],
    speed: Any,
    flight_path_angle: Any,
    available_power: Any,
    insect: Dragonfly,
    options: ModelOptions,
    xp: ArrayNamespace,
) -> dict[str, Any]:
    """The flight performance of a batch (Eqs. 17 and 22-27, docs/model.md §7), every
    :class:`Result` array field by name, in the array namespace ``xp`` (numpy or torch).

    ``means(key)``: the (B, 2) per-wing cycle means (fore, hind) of one wing of each pair, keyed
    by the kernel's ``cycle.W_<key>`` column names (``"FZ"``, ``"FX"``, ``"THRUST"``, ``"DRAG"``
    [N], ``"P_AERO"``, ``"P_INER"``, ``"P_ELASTIC"``, ``"P_AERO_POSITIVE"`` [W], ``"AOA"``
    [rad], ``"CONVERGED"``, ``"EVALS"``, ``"INFLOW"`` [m/s]); ``speed`` [m/s],
    ``flight_path_angle`` [rad] and ``available_power`` [W/kg] (B,).
    """
    n_w = insect.wings_per_pair
    weight = insect.weight
    fz = means("FZ") * n_w
    fx = means("FX") * n_w
    lift = fz.sum(1)
    # the wings' own rearward ("drag") forces D_f + D_h, whatever the thrust/drag reading
    wing_drag = n_w * means("DRAG").sum(1)
    if options.thrust_split == "sign":
        thrust = n_w * means("THRUST").sum(1)
        drag = wing_drag
    else:
        thrust = fx.sum(1)
        # The body's parasite drag acts against its velocity, along the flight path: its
        # horizontal part is D and its vertical part counts against the lift.
        body_drag = 0.5 * insect.air_density * speed**2 * insect.body_drag_area
        drag = body_drag * xp.cos(flight_path_angle)
        lift = lift - body_drag * xp.sin(flight_path_angle)
    aero = n_w * means("P_AERO")
    inertial = n_w * means("P_INER")
    if options.power == "absolute":
        wing_power = aero + inertial
    elif options.power == "elastic":
        wing_power = n_w * means("P_ELASTIC")
    else:
        wing_power = n_w * means("P_AERO_POSITIVE")
    power = wing_power.sum(1)
    powered = power > 0.0
    # the inner where keeps 0/0 out of the values and out of autograd's backward pass
    efficiency = xp.where(
        powered, xp.maximum(thrust, 0.0) * speed / xp.where(powered, power, 1.0), 0.0
    )
    lift_to_weight = lift / weight
    excess_vertical = lift_to_weight - 1.0
    excess_horizontal = (thrust - drag) / weight
    aoa = xp.rad2deg(means("AOA"))
    return {
        "lift_to_weight": lift_to_weight,
        "thrust": thrust,
        "drag": drag,
        "power": power,
        "power_per_mass": power / insect.body_mass,
        "efficiency": efficiency,
        "excess_vertical": excess_vertical,
        "excess_horizontal": excess_horizontal,
        "excess_total": xp.hypot(excess_vertical, excess_horizontal),
        "excess_horizontal_literal": wing_drag / weight,
        "mean_angle_of_attack": aoa.mean(1),
        "efficiency_above_one": efficiency > 1.0,
        "induction_converged": xp.all_along(means("CONVERGED") > 0.5, 1),
        "induction_evaluations": xp.as_int64(xp.max_along(means("EVALS"), 1)),
        "fore_lift_to_weight": fz[:, 0] / weight,
        "hind_lift_to_weight": fz[:, 1] / weight,
        "fore_horizontal_force": fx[:, 0],
        "hind_horizontal_force": fx[:, 1],
        "fore_power": wing_power[:, 0],
        "hind_power": wing_power[:, 1],
        "fore_aero_power": aero[:, 0],
        "hind_aero_power": aero[:, 1],
        "fore_inertial_power": inertial[:, 0],
        "hind_inertial_power": inertial[:, 1],
        "fore_mean_angle_of_attack": aoa[:, 0],
        "hind_mean_angle_of_attack": aoa[:, 1],
        "fore_inflow": means("INFLOW")[:, 0],
        "hind_inflow": means("INFLOW")[:, 1],
        "speed": speed,
        "flight_path_angle": flight_path_angle,
        "available_power": available_power,
    }


def parametric_kernel_inputs(
    physical: np.ndarray, n_time: int, with_phases: bool = True
) -> tuple[list[np.ndarray], list[np.ndarray], np.ndarray, np.ndarray, np.ndarray, StrokeMotion]:
    """The compiled kernel's inputs of a batch of physical strokes (B, 28) in Table 4 units
    (validated: ``stroke.validate_physical``), on ``n_time`` samples of the motion-following grid:
    ``angles``, ``weights``, ``frequency``, ``beta``, ``sweep`` as :func:`run_kernel` takes them
    (per wing (B, n_time, 9) angle histories (φ, φ̇, φ̈, θ, θ̇, θ̈, η, η̇, η̈) and (B, n_time)
    quadrature weights, ``kinematics.fill_angle_history``; (B, 2) [Hz, rad, rad]) and the
    :class:`StrokeMotion`: ``phases`` (B, 2, n_time) [rad] (``kinematics.motion_grid``; with
    ``with_phases`` False, (0, 2, n_time): only the phase-resolved slipstreams read them, and
    they cost 5 % of a call) and each wing's (B, 14) parameters in radians.
    The step of :func:`evaluate_numba` between validation and :func:`run_kernel`.
    """
    batch = physical.shape[0]
    angles, weights, frequency, beta, sweep = (
        [],
        [],
        np.empty((batch, 2)),
        np.empty((batch, 2)),
        np.empty((batch, 2)),
    )
    phases = np.empty((batch if with_phases else 0, 2, n_time))
    wings = []
    for w in range(2):
        params = np.ascontiguousarray(
            wing_params_radians(physical[:, w * N_PER_WING : (w + 1) * N_PER_WING])
        )
        wings.append(params)
        a = np.empty((batch, n_time, 9))
        wt = np.empty((batch, n_time))
        cycle.fill_angle_batch(batch, params, n_time, a, wt)
        angles.append(a)
        weights.append(wt)
        frequency[:, w] = params[:, 0]
        beta[:, w] = params[:, 13]
        sweep[:, w] = params[:, 1]
        if with_phases:
            phases[:, w] = motion_grid(params, n_time)[0]
    return angles, weights, frequency, beta, sweep, StrokeMotion(phases, tuple(wings))


def evaluate_numba(
    strokes: np.ndarray,
    speed: float | np.ndarray = 0.0,
    available_power: float | np.ndarray | None = None,
    *,
    flight_path_angle: float | np.ndarray = 0.0,
    insect: Dragonfly = DRAGONFLY,
    options: ModelOptions = DEFAULT_OPTIONS,
) -> Result:
    """Evaluate one wing-beat cycle of each stroke in a batch on the compiled numba kernel
    (``tandem_env.evaluate``'s default backend, :func:`~tandem_env.physics.backends.evaluate`).

    Parameters
    ----------
    strokes : (B, 28) or (28,) array
        Physical strokes in Table 4 units (Hz, deg, -), fore-wing first; see ``stroke``.
    speed : float or (B,) array
        Flight speed V [m/s], 0 to 20 (:data:`SPEED_LIMITS`), along the flight path.
    available_power : float or (B,) array, optional
        Available power per body mass [W/kg], 1 to 1000 (:data:`AVAILABLE_POWER_LIMITS`), the
        cap of the power constraint in both flight modes; default the insect's maximum (60 %
        muscle × 150 W/kg = 90 W/kg).
    flight_path_angle : float or (B,) array
        Flight-path angle γ [rad], + climbing, −π/2 to π/2: the free stream comes from the
        direction of the body's velocity V·(cos γ, sin γ). The stroke-plane angle stays measured
        from the horizontal and every force is reported in earth axes (L vertical, T and D
        horizontal). The default 0 is level flight.
    insect : Dragonfly
        The insect (wings, planform, masses, air); default the paper's specimen.
    options : ModelOptions
        Resolution, inflow model and conventions.

    Returns
    -------
    Result
        (B,) arrays (a single stroke gives B = 1).

    Raises
    ------
    ValueError
        For strokes outside Table 4, non-finite values, wrong shapes, or a bad condition.
    """
    check_model_inputs(insect, options)
    physical = validate_physical(strokes)
    batch = physical.shape[0]
    v, p_avail, gamma = validate_conditions(
        speed, available_power, flight_path_angle, batch, insect
    )
    angles, weights, frequency, beta, sweep, motion = parametric_kernel_inputs(
        physical, options.n_time, options.slipstream != "mean"
    )
    out, _, _ = run_kernel(
        angles, weights, frequency, beta, sweep, v, gamma, insect, options, motion=motion
    )
    result = _performance(out, v, gamma, p_avail, insect, options)
    if insect.min_wing_gap is None:
        return result
    gaps = clearance.gaps(physical, insect)
    return replace(result, **dict(zip(OPTIONAL_FIELDS, gaps, strict=True)))
