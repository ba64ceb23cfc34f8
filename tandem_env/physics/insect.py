"""The dragonfly and its wings: frozen, validated dataclasses with units.

Defaults are the paper's specimen (Faisal & Filippone 2016, Tables 1 and 3), Wakeling (1997)
*Sympetrum sanguineum* male "SSan2"; values the paper does not give follow docs/model.md §1.
Planforms are the tear-drop of Eq. 1 and the real dragonfly wing of Eq. 2 / Table 2.

Another insect enters as a mapping of the fields that differ from the specimen (YAML or a dict,
SI units, wings nested under ``fore`` / ``hind``): :func:`load_insect` reads one (a mapping, a
YAML file or a :class:`Dragonfly`), :func:`insect_mapping` writes an insect back as its
canonical mapping (only what differs, so the specimen is ``{}``), :func:`describe_insect` says
it in one line. Every field of :class:`Dragonfly` and :class:`Wing` is a key, read from the
dataclasses (a field added there is a key without a change here).
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field, fields, replace
from typing import Any, Literal, NamedTuple, Union

import numpy as np

from ..io.datafile import DataFileError, read_yaml
from .checks import is_integer, is_real, shown
from .coefficients import (
    PAPER_COEFFICIENTS,
    CoefficientModel,
    PaperCoefficients,
    SinusoidalFit,
    TabulatedCoefficients,
    coefficient_model,
    coefficient_spec,
)
from .stroke import PARAMETER_NAMES, TABLE_4_BOUNDS, StrokeBounds

Planform = Literal["tear-drop", "real"]
PLANFORMS: tuple[str, ...] = ("tear-drop", "real")

#: Table 2 quintic coefficients (a..f, ascending powers of r/R) of the real wing's edges,
#: both axes normalised by the wing length R. Rows are a, b, c, d, e, f (the text garbles the
#: row labels, docs/model.md §2).
REAL_WING_EDGES: dict[str, tuple[tuple[float, ...], tuple[float, ...]]] = {
    "fore": (
        (0.0154, 0.4146, -0.4984, -2.6774, 6.7850, -4.0250),
        (-0.0273, -1.0711, 3.1849, -5.5107, 5.2309, -1.8304),
    ),
    "hind": (
        (0.0321, -0.0206, 0.9173, -4.0000, 6.8385, -3.7509),
        (-0.0144, -2.6763, 7.6848, -8.9040, 4.5981, -0.7086),
    ),
}


class Limit(NamedTuple):
    """The range a field of :class:`Wing` or :class:`Dragonfly` may take, and why."""

    low: float
    high: float
    unit: str
    why: str
    open_low: bool = False
    """True: the value must exceed ``low`` (a length or a mass cannot be 0)."""


#: The range of each number of a wing (:class:`Wing`), one home for the checks and messages.
#: The model is for insects and flapping MAVs: wings up to 1 m long; a wing's thickness is
#: further limited to a tenth of its mean chord (:data:`MAX_THICKNESS_RATIO`).
WING_LIMITS: dict[str, Limit] = {
    "mean_chord": Limit(0.0, 1.0, "m", "an insect's or a flapping MAV's wing", True),
    "length": Limit(0.0, 1.0, "m", "an insect's or a flapping MAV's wing", True),
    "drag_coefficient_0": Limit(0.0, 1.0, "", "a plate edge-on: 0.1-0.3 at insect scale"),
    "drag_coefficient_90": Limit(0.0, 5.0, "", "a plate broadside: 1.2-3.5"),
    "rotational_coefficient": Limit(0.0, 10.0, "", "π in theory (docs/model.md §1)"),
    "mass": Limit(0.0, 1.0, "kg", "a wing of at most 1 m"),
    "thickness": Limit(0.0, 1.0, "m", "a thin plate"),
    "damping_linear": Limit(0.0, 10.0, "", "0.2 in Berman & Wang 2007"),
    "damping_quadratic": Limit(0.0, 10.0, "", "0.2 in Berman & Wang 2007"),
}
#: The range of each number of the insect (:class:`Dragonfly`).
DRAGONFLY_LIMITS: dict[str, Limit] = {
    "body_mass": Limit(0.0, 10.0, "kg", "an insect or a flapping MAV", True),
    "gravity": Limit(0.0, 30.0, "m/s²", "Mars 3.7, the Earth 9.81, Jupiter 24.8", True),
    "air_density": Limit(0.0, 100.0, "kg/m³", "Mars 0.02, sea level 1.225, Venus 65", True),
    "body_drag_area": Limit(0.0, 1.0, "m²", "a body of at most 1 m across"),
    "flight_muscle_ratio": Limit(0.0, 1.0, "", "a share of the body mass", True),
    "muscle_specific_power": Limit(0.0, 1000.0, "W/kg", "insect flight muscle: 50-250", True),
    "root_spacing": Limit(0.0, 1.0, "m", "a body of at most 1 m"),
    "root_drop": Limit(0.0, 1.0, "m", "a body of at most 1 m"),
}
#: The largest least distance between the wings a flyer may ask for [m]: a body of at most 1 m.
MAX_WING_GAP = 1.0
#: Thickest wing, as a share of its mean chord [-]: the blade elements are thin plates (the
#: specimen's is 3.5 µm on a 5.88 mm chord, 0.06 %).
MAX_THICKNESS_RATIO = 0.1
#: Most coefficients of each edge of the real planform: Eq. 2 is a quintic (Table 2).
MAX_EDGE_COEFFICIENTS = 6


def _check_limits(owner: Any, limits: Mapping[str, Limit]) -> None:
    """ValueError naming the first field of ``owner`` outside its :class:`Limit`, its value
    and the allowed range, in the order of ``limits``."""
    for name, limit in limits.items():
        value = getattr(owner, name)
        high = limit.high
        why = limit.why
        if name == "thickness" and is_real(owner.mean_chord):
            high = min(high, MAX_THICKNESS_RATIO * owner.mean_chord)
            why = f"a thin plate: at most {MAX_THICKNESS_RATIO:g} of the mean chord"
        ok = is_real(value) and math.isfinite(value) and value <= high
        ok = ok and (value > limit.low if limit.open_low else value >= limit.low)
        if not ok:
            shown_value = (
                f"{shown(value, limit.low, high)} {limit.unit}".rstrip()
                if is_real(value)
                else repr(value)
            )
            low_side = f"{limit.low:g} <" if limit.open_low else f"{limit.low:g} <="
            raise ValueError(
                f"{type(owner).__name__}.{name} = {shown_value}"
                + f"; allowed: {low_side} {name} <= {high:g} {limit.unit}".rstrip()
                + f" ({why})"
            )


def _edges(value: Any) -> tuple[tuple[float, ...], tuple[float, ...]] | None:
    """``real_edges`` as a pair of tuples of floats, or ValueError naming what is allowed."""
    if value is None:
        return None
    allowed = (
        f"allowed: None or (upper, lower), two sequences of 1 to {MAX_EDGE_COEFFICIENTS} finite "
        "numbers each (Eq. 2's coefficients, ascending powers of r/R)"
    )
    if not (
        isinstance(value, list | tuple | np.ndarray)
        and len(value) == 2
        and all(
            isinstance(edge, list | tuple | np.ndarray)
            and 1 <= len(edge) <= MAX_EDGE_COEFFICIENTS
            and all(is_real(c) and math.isfinite(c) for c in edge)
            for edge in value
        )
    ):
        text = " ".join(repr(value).split())
        raise ValueError(f"Wing.real_edges = {text[:80]}; {allowed}")
    upper, lower = (tuple(float(c) for c in edge) for edge in value)
    return upper, lower


def helmbold_lift_slope(aspect_ratio: float, section_slope: float = 2.0 * math.pi) -> float:
    """Lift-curve slope C_Lα [1/rad] of a wing of aspect ratio AR (Helmbold's equation).

    C_Lα = π·AR / (1 + sqrt((π·AR/a₀)² + 1)), the "extended lifting line" form the paper
    adapts from Taha et al. (docs/model.md §1), with a₀ = 2π the section lift slope.
    """
    return (
        math.pi
        * aspect_ratio
        / (1.0 + math.sqrt((math.pi * aspect_ratio / section_slope) ** 2 + 1.0))
    )


@dataclass(frozen=True)
class Wing:
    """One wing of a pair (the left and right wings are mirror images).

    Coefficients follow the paper's Table 3; C_t comes from the aspect ratio (docs/model.md §1).
    """

    mean_chord: float
    """Mean chord c̄ [m] (paper Table 1)."""
    length: float
    """Wing length R, root to tip [m] (paper Table 1)."""
    drag_coefficient_0: float
    """C_d(0), drag coefficient at zero angle of attack [-] (Table 3)."""
    drag_coefficient_90: float
    """C_d(π/2), drag coefficient at 90° angle of attack [-] (Table 3)."""
    rotational_coefficient: float = math.pi
    """C_r, rotational-circulation coefficient [-] (Table 3; π, docs/model.md §1)."""
    mass: float = 0.0
    """Mass of one wing m_w [kg] (Wakeling 1997)."""
    thickness: float = 3.5e-6
    """Wing thickness b_t [m] (from mass, area and cuticle density, docs/model.md §1)."""
    planform: Planform = "tear-drop"
    """Chord distribution: ``"tear-drop"`` (Eq. 1) or ``"real"`` (Eq. 2, Table 2)."""
    real_edges: tuple[tuple[float, ...], tuple[float, ...]] | None = None
    """(upper, lower) quintic coefficients of Eq. 2 [-], ascending powers of r/R; required for
    the real planform."""
    damping_linear: float = 0.2
    """μ₁, linear rotational-damping coefficient [-] (Berman & Wang 2007)."""
    damping_quadratic: float = 0.2
    """μ₂, quadratic rotational-damping coefficient [-] (Berman & Wang 2007)."""
    coefficients: CoefficientModel = PAPER_COEFFICIENTS
    """Force-coefficient model C_L(α), C_D(α) (``coefficients``): the paper's by default; a name
    (``"dickinson1999"``) or a mapping ``{"model": …}`` is converted on construction."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "coefficients", coefficient_model(self.coefficients))
        _check_limits(self, WING_LIMITS)
        object.__setattr__(self, "real_edges", _edges(self.real_edges))
        if not isinstance(self.planform, str) or self.planform not in PLANFORMS:
            raise ValueError(f"Wing.planform = {self.planform!r}; allowed: {PLANFORMS}")
        if self.mean_chord >= self.length:
            raise ValueError(
                f"Wing.mean_chord = {self.mean_chord} m is not below Wing.length = {self.length} m; "
                "a blade-element wing must be longer than it is wide"
            )
        if self.planform == "real":
            if self.real_edges is None:
                raise ValueError(
                    "Wing.real_edges must give (upper, lower) coefficients for planform='real'"
                )
            probe = np.linspace(0.0, 1.0, 201)
            width = self._real_width(probe)
            if not np.all(np.isfinite(width)) or np.any(width[1:-1] <= 0.0):
                raise ValueError(
                    "Wing.real_edges give a chord <= 0 inside the span (upper edge below lower edge); "
                    "the planform must have a positive chord on 0 < r/R < 1"
                )

    # --- derived geometry -------------------------------------------------------------------
    @property
    def aspect_ratio(self) -> float:
        """Single-wing aspect ratio AR = R / c̄ [-]."""
        return self.length / self.mean_chord

    @property
    def translational_coefficient(self) -> float:
        """C_t = C_Lα / 2 [-], so that C_L(α) = C_t·sin 2α (docs/model.md §1), or the paper model's
        override (``PaperCoefficients(translational=…)``)."""
        model = self.coefficients
        if isinstance(model, PaperCoefficients) and model.translational is not None:
            return model.translational
        return 0.5 * helmbold_lift_slope(self.aspect_ratio)

    def force_coefficients(self, alpha_deg: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
        """(C_L, C_D) of this wing's model at α [deg], 0-180 (``coefficients`` conventions).

        For plots and reports; the compiled kernel evaluates the same model itself.
        """
        alpha = np.asarray(alpha_deg, dtype=float)
        model = self.coefficients
        if isinstance(model, PaperCoefficients):
            rad = np.deg2rad(alpha)
            lift = self.translational_coefficient * np.sin(2.0 * rad)
            drag = (
                self.drag_coefficient_0 * np.cos(rad) ** 2
                + self.drag_coefficient_90 * np.sin(rad) ** 2
            )
            return lift, drag
        if isinstance(model, SinusoidalFit):
            return model.lift(alpha), model.drag(alpha)
        return model.lift_at(alpha), model.drag_at(alpha)

    def _real_width(self, r_hat: np.ndarray) -> np.ndarray:
        assert self.real_edges is not None
        upper, lower = (np.asarray(c, dtype=float) for c in self.real_edges)
        return np.polynomial.polynomial.polyval(r_hat, upper - lower)

    def chord(self, r_hat: np.ndarray | float) -> np.ndarray:
        """Local chord c(r) [m] at normalised radius r/R (Eq. 1 or Eq. 2)."""
        r_hat = np.asarray(r_hat, dtype=float)
        if self.planform == "tear-drop":
            return 4.0 * self.mean_chord / math.pi * np.sqrt(np.clip(1.0 - r_hat**2, 0.0, None))
        return self.length * self._real_width(r_hat)

    @property
    def area(self) -> float:
        """Planform area of one wing [m²] (exact for the tear-drop, Gauss-Legendre otherwise)."""
        if self.planform == "tear-drop":
            return self.mean_chord * self.length
        x, w = np.polynomial.legendre.leggauss(8)
        return float(self.length * np.sum(0.5 * w * self.chord(0.5 * (x + 1.0))))

    def with_planform(self, planform: Planform, edges: tuple | None = None) -> Wing:
        """Same wing with another planform (keeps c̄ and R, so area and span are equal)."""
        return replace(
            self, planform=planform, real_edges=edges if edges is not None else self.real_edges
        )


def _default_fore() -> Wing:
    return Wing(
        mean_chord=5.88e-3,
        length=27.85e-3,
        drag_coefficient_0=0.12,
        drag_coefficient_90=2.71,
        mass=0.75e-6,
        thickness=3.5e-6,
        real_edges=REAL_WING_EDGES["fore"],
    )


def _default_hind() -> Wing:
    return Wing(
        mean_chord=7.68e-3,
        length=26.90e-3,
        drag_coefficient_0=0.14,
        drag_coefficient_90=2.85,
        mass=0.85e-6,
        thickness=3.5e-6,
        real_edges=REAL_WING_EDGES["hind"],
    )


@dataclass(frozen=True)
class Dragonfly:
    """The insect: body, the fore- and hind-wing pairs, and the air (docs/model.md §1).

    ``Dragonfly()`` is the paper's specimen; ``Dragonfly.with_planform("real")`` gives both
    wings the real dragonfly planform of Eq. 2 with the same area and span.
    """

    fore: Wing = field(default_factory=_default_fore)
    """Fore-wing (one of a left/right pair)."""
    hind: Wing = field(default_factory=_default_hind)
    """Hind-wing (one of a left/right pair)."""
    body_mass: float = 121.9e-6
    """Total mass m [kg] (paper §II.D)."""
    wings_per_pair: int = 2
    """N_w, wings per pair [-]: left and right, lateral forces cancel, the others double."""
    gravity: float = 9.81
    """Gravitational acceleration g [m/s²]."""
    air_density: float = 1.225
    """Air density ρ [kg/m³]."""
    body_drag_area: float = 12.5e-6
    """Body parasite drag area (C_D·S)_body [m²], used by ``thrust_split="body"`` only:
    a thorax 4 mm across (frontal area π·(2 mm)² ≈ 12.6 mm²) with C_D ≈ 1 (docs/model.md §1)."""
    flight_muscle_ratio: float = 0.6
    """Flight-muscle mass over body mass [-] (Marden 2000; paper §II.F)."""
    muscle_specific_power: float = 150.0
    """Available muscle power per muscle mass [W/kg] (Wakeling & Ellington 1997)."""
    root_spacing: float = 8.8e-3
    """Distance from the fore-wing root to the hind-wing root along the body axis [m], + hind
    aft: 1.5 fore-wing mean chords, as in the dragonfly models of Sun & Lan (2004) and Wang &
    Sun (2005) (docs/model.md §1.7). Used by ``ModelOptions.slipstream="convected"`` (the
    wake's travel time) and :func:`~tandem_env.physics.clearance.wing_clearance`."""
    root_drop: float = 9.0e-3
    """How far the hind-wing root sits below the fore-wing root, normal to the body axis [m]:
    enough to keep the model's flat stroke planes apart (docs/model.md §1.7)."""
    stroke_bounds: StrokeBounds = TABLE_4_BOUNDS
    """The bounds of this flyer's 28 stroke parameters [Hz, deg, -]: the box its strokes are
    searched in (the env's action map, the optimisers' box) and :func:`tandem_env.evaluate`
    checks. Table 4's unless set; in a mapping or file, the parameters that differ
    (``stroke_bounds: {fore_frequency: [15, 25]}``, :meth:`StrokeBounds.with_changes`)."""
    min_wing_gap: float | None = None
    """The least distance [m] the fore- and hind-wing surfaces keep over a cycle: constraints
    of every flight task (``wing_gap_violation``, ``wing_gap_next_violation``), the model
    reporting the distances as ``Result.wing_gap`` and ``wing_gap_next``
    (:func:`~tandem_env.physics.clearance.gaps`); None, the paper's specimen: no such
    constraint, and none computed (docs/model.md §5.8, *The wings meet*, *Kept apart*)."""

    def __post_init__(self) -> None:
        if not isinstance(self.fore, Wing) or not isinstance(self.hind, Wing):
            raise ValueError("Dragonfly.fore and Dragonfly.hind must be Wing instances")
        if not isinstance(self.stroke_bounds, StrokeBounds):
            raise ValueError(
                f"Dragonfly.stroke_bounds = {self.stroke_bounds!r}; allowed: a StrokeBounds "
                "(in a mapping or file: {name: [low, high]} of the parameters that differ)"
            )
        _check_limits(self, DRAGONFLY_LIMITS)
        if self.min_wing_gap is not None:
            gap = self.min_wing_gap
            if not (is_real(gap) and math.isfinite(gap) and 0.0 < gap <= MAX_WING_GAP):
                raise ValueError(
                    f"Dragonfly.min_wing_gap = {gap!r}; allowed: None (no constraint) or a "
                    f"distance 0 < min_wing_gap <= {MAX_WING_GAP:g} m"
                )
            object.__setattr__(self, "min_wing_gap", float(gap))
        if not is_integer(self.wings_per_pair) or self.wings_per_pair not in (1, 2):
            raise ValueError(f"Dragonfly.wings_per_pair = {self.wings_per_pair!r}; allowed: 1 or 2")
        object.__setattr__(self, "wings_per_pair", int(self.wings_per_pair))
        wings = self.wings_per_pair * (self.fore.mass + self.hind.mass)
        if wings >= self.body_mass:
            raise ValueError(
                f"Dragonfly: the {2 * self.wings_per_pair} wings weigh {wings:.4g} kg, not less "
                f"than Dragonfly.body_mass = {self.body_mass:.4g} kg; allowed: wings lighter than "
                "the whole insect (body_mass is the total mass, wings included)"
            )

    def to_dict(self) -> dict[str, Any]:
        """The fields as JSON takes them (``tandem_env.io.files.to_jsonable``), without
        ``stroke_bounds`` where they are Table 4's and without ``min_wing_gap`` where it is
        None: a flyer that keeps the paper's bounds and sets no gap has the JSON, the
        fingerprints and the reference scores it had before they could be set."""
        unset = {"stroke_bounds": TABLE_4_BOUNDS, "min_wing_gap": None}
        return {
            f.name: getattr(self, f.name)
            for f in fields(self)
            if f.name not in unset or getattr(self, f.name) != unset[f.name]
        }

    @property
    def weight(self) -> float:
        """W = m·g [N]."""
        return self.body_mass * self.gravity

    @property
    def max_power_per_mass(self) -> float:
        """Available power per body mass [W/kg]: muscle ratio × muscle power (90 W/kg, §II.F)."""
        return self.flight_muscle_ratio * self.muscle_specific_power

    def with_planform(self, planform: Planform) -> Dragonfly:
        """Both wings with the given planform (same c̄, R: equal area and span)."""
        if planform not in PLANFORMS:
            raise ValueError(f"planform = {planform!r}; allowed: {PLANFORMS}")
        return replace(
            self, fore=self.fore.with_planform(planform), hind=self.hind.with_planform(planform)
        )

    def with_coefficients(
        self, fore: CoefficientModel | str | None = None, hind: CoefficientModel | str | None = None
    ) -> Dragonfly:
        """The same insect with other force-coefficient models (``None`` keeps a wing's model)."""
        return replace(
            self,
            fore=self.fore if fore is None else replace(self.fore, coefficients=fore),
            hind=self.hind if hind is None else replace(self.hind, coefficients=hind),
        )

    @property
    def planform(self) -> str:
        """The wings' planform if both share one, else ``"mixed"``."""
        return self.fore.planform if self.fore.planform == self.hind.planform else "mixed"


DRAGONFLY = Dragonfly()
"""The paper's specimen with tear-drop wings (the default insect)."""


# --- an insect as data (YAML files, env keywords, record keys) --------------------------------
InsectSource = Union[Dragonfly, Mapping[str, Any], str, os.PathLike]  # noqa: UP007
"""What :func:`load_insect` takes: an insect, a mapping of its fields, or a YAML file's path."""

#: What an insect mapping holds, for messages.
INSECT_FORMAT = (
    "a mapping of Dragonfly fields (SI units), the wings' under fore: and hind: "
    "(docs/envs.md, Another insect)"
)


def _plain_tuple(value: Any) -> Any:
    """Lists (as YAML and JSON give them) as tuples, the dataclasses' sequence type."""
    if isinstance(value, list | tuple):
        return tuple(_plain_tuple(v) for v in value)
    return value


def _with_fields(base: Any, spec: Any, where: str) -> Any:
    """``base`` (a Dragonfly or a Wing) with the fields ``spec`` gives; a field holding a
    :class:`Wing` takes a nested mapping. Errors name the key (``where.key``) and what is
    allowed."""
    if not isinstance(spec, Mapping):
        kind = type(base).__name__
        raise ValueError(f"{where} = {spec!r}; allowed: a mapping of {kind} fields (SI units)")
    allowed = tuple(f.name for f in fields(base))
    changes: dict[str, Any] = {}
    for key, value in spec.items():
        if key not in allowed:
            raise ValueError(
                f"{where}.{key}: unknown field; allowed: {', '.join(allowed)} (docs/envs.md)"
            )
        current = getattr(base, key)
        if isinstance(current, Wing):
            changes[key] = _with_fields(current, value, f"{where}.{key}")
        elif isinstance(current, StrokeBounds) and not isinstance(value, StrokeBounds):
            changes[key] = current.with_changes(value, f"{where}.{key}")
        elif isinstance(value, Mapping) and key == "coefficients":
            changes[key] = dict(value)  # Wing converts it (coefficient_model)
        elif isinstance(current, float) and isinstance(value, int) and not isinstance(value, bool):
            changes[key] = float(value)  # one canonical form: 1 and 1.0 are one insect
        else:
            changes[key] = _plain_tuple(value)
    try:
        return replace(base, **changes)
    except (TypeError, ValueError) as error:
        raise ValueError(f"{where}: {error}") from None


def load_insect(source: InsectSource, where: str = "insect") -> Dragonfly:
    """The insect ``source`` describes: a :class:`Dragonfly` (returned as it is), a mapping of
    the fields that differ from the paper's specimen (:data:`DRAGONFLY`), or the path of a YAML
    file holding such a mapping (read with the safe loader).

    Raises ValueError naming the key or value and what is allowed (an unknown key lists the
    fields), before any model call.
    """
    if isinstance(source, Dragonfly):
        return source
    allowed = (
        f"allowed: a tandem_env.Dragonfly, {INSECT_FORMAT}, or the path of a YAML file holding one"
    )
    if isinstance(source, str | os.PathLike):
        path = os.fspath(source)
        if not os.path.isfile(path):
            raise ValueError(f"{where} = {path!r}: no such file; {allowed}")
        try:
            return _with_fields(DRAGONFLY, read_yaml(path, f"{where} file", INSECT_FORMAT), where)
        except ValueError as error:  # DataFileError names the file already
            if isinstance(error, DataFileError):
                raise ValueError(str(error)) from None
            raise ValueError(f"{where} file {path!r}: {error}") from None
    if not isinstance(source, Mapping):
        raise ValueError(f"{where} = {source!r}; {allowed}")
    return _with_fields(DRAGONFLY, source, where)


def _field_value(value: Any) -> Any:
    """A field's value as plain data (tuples as lists, a coefficient model as its mapping)."""
    if isinstance(value, PaperCoefficients | SinusoidalFit | TabulatedCoefficients):
        return coefficient_spec(value)
    if isinstance(value, tuple):
        return [_field_value(v) for v in value]
    return value


def _differences(obj: Any, base: Any) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for f in fields(obj):
        value, reference = getattr(obj, f.name), getattr(base, f.name)
        if value == reference:
            continue
        if isinstance(value, Wing):
            out[f.name] = _differences(value, reference)
        elif isinstance(value, StrokeBounds):
            out[f.name] = value.changes(reference)
        else:
            out[f.name] = _field_value(value)
    return out


def insect_mapping(insect: Dragonfly) -> dict[str, Any]:
    """The canonical mapping of ``insect``: the fields that differ from the paper's specimen,
    as plain data (``{}`` for the specimen itself); :func:`load_insect` of it gives ``insect``
    back. Record keys hold it (a study's default insect leaves every key as it was)."""
    if not isinstance(insect, Dragonfly):
        raise ValueError(f"insect = {insect!r}; allowed: a tandem_env.Dragonfly")
    return _differences(insect, DRAGONFLY)


def describe_insect(insect: InsectSource) -> str:
    """One line naming the insect: the paper's specimen, or what differs from it (SI units)."""
    changes = insect_mapping(load_insect(insect))
    if not changes:
        return "the paper's specimen (Sympetrum sanguineum, Wakeling 1997)"

    def flat(mapping: Mapping[str, Any], prefix: str = "") -> list[str]:
        items = []
        for key, value in mapping.items():
            if isinstance(value, Mapping) and key != "coefficients":
                items += flat(value, f"{prefix}{key}.")
            elif isinstance(value, Mapping):
                items.append(f"{prefix}{key} = {value['model']}")
            elif isinstance(value, float):
                items.append(f"{prefix}{key} = {value:.4g}")
            elif key in PARAMETER_NAMES:  # a stroke bound
                items.append(f"{prefix}{key} = {value[0]:g} to {value[1]:g}")
            elif isinstance(value, list):
                items.append(f"{prefix}{key} = (given)")
            else:
                items.append(f"{prefix}{key} = {value}")
        return items

    return "the paper's specimen but " + ", ".join(flat(changes)) + " (SI units)"
