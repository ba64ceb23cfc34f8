"""Force-coefficient models of a blade element: C_L(α), C_D(α) over 0-180° (one per wing).

The blade-element force (``blade.element_force``, Eqs. 11-14) has a translational circulation
and a viscous drag that depend on the angle of attack α. A model gives the two coefficients:

    Γ_t = −½·c·|U|·C_L(α)·sign(v)          (the paper: C_L = C_t·sin 2α, Eq. 14)
    F_V = −½·ρ·c·C_D(α)·|U|·(u, v)           (the paper: C_D = C_d(0)cos²α + C_d(π/2)sin²α, Eq. 13)

with (u, v) the element's velocity relative to the air along the chord e_c and its normal e_n,
and α = atan2(|v|, u) ∈ [0°, 180°] the angle between the chord (+e_c) and the motion. The lift
ρΓ_t·(−v, u) is normal to the motion; C_L > 0 means lift on the side the leading edge is tilted
to, whichever edge leads. A flat plate is symmetric about its chord line (v → −v mirrors the
force) and, in the fitted models, front to back: at α > 90° the −e_c edge leads, so
C_L(α) = −C_L(180° − α) and C_D(α) = C_D(180° − α), the angle measured from the leading edge.
The paper's sin 2α and cos²α/sin²α forms have that symmetry already.

Models (frozen, validated, hashable so that a ``Wing`` can carry one):

* :class:`PaperCoefficients`: the paper's (default; C_t from the aspect ratio unless overridden);
* :class:`SinusoidalFit`: C_L = a + b·sin(cα − d), C_D = e − f·cos(gα − h), α from the leading
  edge in degrees; :meth:`SinusoidalFit.dickinson_1999` is Dickinson, Lehmann & Sane's (1999)
  robotic-wing fit;
* :class:`TabulatedCoefficients`: C_L(α), C_D(α) tables, linearly interpolated in the compiled
  kernel.

Each model writes a flat float table (``model.table()``), appended to the wing's constants
(``model.wing_tables``) and read by :func:`force_coefficients` inside the kernel. Layout:
``[PAPER]``; ``[FIT, a, b, c, d, e, f, g, h]`` (phases in radians); ``[TABLE, m, α₁…α_m [rad],
C_L₁…C_L_m, C_D₁…C_D_m]`` over 0…π, or ``LEADING_EDGE_TABLE`` and the same over 0…π/2.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import Any, ClassVar, Union

import numpy as np
from numba import njit

# Model codes: the first entry of a model's kernel table.
PAPER = 0.0
FIT = 1.0
TABLE = 2.0  # over 0-180°
LEADING_EDGE_TABLE = 3.0  # over 0-90° from the leading edge, folded like FIT


#: Largest |C_L| and C_D a model may give [-]: measured plates and insect wings stay below 4
#: (C_D(90°) ≈ 3.5 at most); 10 refuses a slip of units or sign, not a measurement.
MAX_COEFFICIENT = 10.0


def _check_curves(owner: str, lift: np.ndarray, drag: np.ndarray, alpha: np.ndarray) -> None:
    """ValueError naming the angle where |C_L| or C_D leaves [0, :data:`MAX_COEFFICIENT`]."""
    for name, values, low in (("C_L", lift, -MAX_COEFFICIENT), ("C_D", drag, 0.0)):
        bad = np.flatnonzero((values < low) | (values > MAX_COEFFICIENT))
        if bad.size:
            i = int(bad[0])
            raise ValueError(
                f"{owner} gives {name} = {values[i]:.4g} at α = {alpha[i]:g}°; allowed: "
                f"{low:g} <= {name} <= {MAX_COEFFICIENT:g} (measured wings stay below 4)"
            )


def _real(owner: str, name: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{owner}.{name} = {value!r}; allowed: a finite number")
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"{owner}.{name} = {value!r}; allowed: a finite number")
    return value


@dataclass(frozen=True)
class PaperCoefficients:
    """The paper's coefficients (Eqs. 13-14): C_L = C_t·sin 2α, C_D = C_d(0)cos²α + C_d(π/2)sin²α.

    C_d(0) and C_d(π/2) are the wing's ``drag_coefficient_0`` and ``drag_coefficient_90``.
    """

    translational: float | None = None
    """C_t override [-]; ``None``: C_t = C_Lα/2 from the aspect ratio (Helmbold, docs/model.md §1)."""

    name: ClassVar[str] = "paper"

    def __post_init__(self) -> None:
        if self.translational is not None:
            value = _real("PaperCoefficients", "translational", self.translational)
            if not 0.0 <= value <= 10.0:
                raise ValueError(
                    f"PaperCoefficients.translational = {value!r}; allowed: C_t from 0 to 10 "
                    "(C_L = C_t·sin 2α; thin-aerofoil theory gives C_t = π)"
                )
            object.__setattr__(self, "translational", value)

    def table(self) -> np.ndarray:
        """The kernel table ``[PAPER]`` (C_t, C_d(0), C_d(π/2) travel in the wing's constants)."""
        return np.array([PAPER])


PAPER_COEFFICIENTS = PaperCoefficients()
"""The default model: the paper's, C_t from the aspect ratio."""


@dataclass(frozen=True)
class SinusoidalFit:
    """C_L = a + b·sin(c·α − d), C_D = e − f·cos(g·α − h), α [deg] from the leading edge, 0-90°.

    Beyond 90° the other edge leads: C_L(α) = −C_L(180° − α), C_D(α) = C_D(180° − α).
    :meth:`dickinson_1999` gives Dickinson, Lehmann & Sane (1999); a = 0, b = C_t, c = 2, d = 0,
    e − f = C_d(0), e + f = C_d(π/2), g = 2, h = 0 is the paper's model.
    """

    lift_offset: float
    """a [-]."""
    lift_amplitude: float
    """b [-]."""
    lift_rate: float
    """c [-] (multiplies α)."""
    lift_phase: float
    """d [deg]."""
    drag_offset: float
    """e [-]."""
    drag_amplitude: float
    """f [-]."""
    drag_rate: float
    """g [-]."""
    drag_phase: float
    """h [deg]."""
    source: str = ""
    """Where the fit comes from (for records and plots)."""

    name: ClassVar[str] = "sinusoidal"

    def __post_init__(self) -> None:
        for f in fields(self):
            if f.name != "source":
                object.__setattr__(
                    self, f.name, _real("SinusoidalFit", f.name, getattr(self, f.name))
                )
        lead = np.linspace(0.0, 90.0, 181)
        if np.any(self.drag(lead) < 0.0):
            raise ValueError(
                f"SinusoidalFit gives C_D < 0 between 0° and 90° (min {self.drag(lead).min():.3g}); "
                "allowed: drag_offset − drag_amplitude·cos(…) >= 0 everywhere"
            )
        _check_curves("SinusoidalFit", self.lift(lead), self.drag(lead), lead)

    @classmethod
    def dickinson_1999(cls) -> SinusoidalFit:
        """Dickinson, Lehmann & Sane (1999, Science 284: 1954), robotic *Drosophila* wing:
        C_L = 0.225 + 1.58·sin(2.13α − 7.20°), C_D = 1.92 − 1.55·cos(2.04α − 9.82°)."""
        return cls(0.225, 1.58, 2.13, 7.20, 1.92, 1.55, 2.04, 9.82, "Dickinson et al. 1999")

    def _lead(self, alpha_deg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        alpha = np.asarray(alpha_deg, dtype=float)
        return np.where(alpha <= 90.0, alpha, 180.0 - alpha), np.where(alpha <= 90.0, 1.0, -1.0)

    def lift(self, alpha_deg: np.ndarray | float) -> np.ndarray:
        """C_L at α [deg], 0-180° (reference values for plots and checks; the kernel has its own)."""
        lead, sign = self._lead(alpha_deg)
        return sign * (
            self.lift_offset
            + self.lift_amplitude * np.sin(np.deg2rad(self.lift_rate * lead - self.lift_phase))
        )

    def drag(self, alpha_deg: np.ndarray | float) -> np.ndarray:
        """C_D at α [deg], 0-180°."""
        lead, _ = self._lead(alpha_deg)
        return self.drag_offset - self.drag_amplitude * np.cos(
            np.deg2rad(self.drag_rate * lead - self.drag_phase)
        )

    def table(self) -> np.ndarray:
        """``[FIT, a, b, c, d, e, f, g, h]`` with the phases in radians."""
        return np.array(
            [
                FIT,
                self.lift_offset,
                self.lift_amplitude,
                self.lift_rate,
                math.radians(self.lift_phase),
                self.drag_offset,
                self.drag_amplitude,
                self.drag_rate,
                math.radians(self.drag_phase),
            ]
        )


def _float_tuple(owner: str, name: str, value: Any) -> tuple[float, ...]:
    if isinstance(value, (str, bytes, Mapping)) or value is None:
        raise ValueError(f"{owner}.{name} = {value!r}; allowed: a 1-D sequence of numbers")
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{owner}.{name}: {exc}; allowed: a 1-D sequence of numbers") from None
    if arr.ndim != 1 or arr.shape[0] < 2:
        raise ValueError(
            f"{owner}.{name} has shape {arr.shape}; allowed: a 1-D sequence of at least 2 numbers"
        )
    if not np.all(np.isfinite(arr)):
        i = int(np.flatnonzero(~np.isfinite(arr))[0])
        raise ValueError(f"{owner}.{name}[{i}] = {arr[i]}; allowed: finite numbers")
    return tuple(float(x) for x in arr)


@dataclass(frozen=True)
class TabulatedCoefficients:
    """Tabulated C_L(α), C_D(α), linearly interpolated in α (in the compiled kernel).

    ``alpha`` [deg] increases from 0 to 180 (the full range, the −e_c edge leading beyond 90°),
    or from 0 to 90: then α is measured from whichever edge leads, as in :class:`SinusoidalFit`
    (C_L(α) = −C_L(180° − α), C_D(α) = C_D(180° − α) beyond 90°; a C_L(90°) ≠ 0 changes sign
    there). Lists and arrays are accepted and stored as tuples.
    """

    alpha: tuple[float, ...]
    """Angles of attack [deg], strictly increasing, from 0 to 90 or 180."""
    lift: tuple[float, ...]
    """C_L at each angle [-]."""
    drag: tuple[float, ...]
    """C_D at each angle [-], >= 0."""
    source: str = ""
    """Where the table comes from."""

    name: ClassVar[str] = "table"

    def __post_init__(self) -> None:
        owner = "TabulatedCoefficients"
        alpha = _float_tuple(owner, "alpha", self.alpha)
        lift = _float_tuple(owner, "lift", self.lift)
        drag = _float_tuple(owner, "drag", self.drag)
        if not len(alpha) == len(lift) == len(drag):
            raise ValueError(
                f"{owner}: alpha, lift and drag have {len(alpha)}, {len(lift)} and {len(drag)} "
                "entries; allowed: the same number"
            )
        a = np.asarray(alpha)
        if np.any(np.diff(a) <= 0.0):
            i = int(np.flatnonzero(np.diff(a) <= 0.0)[0])
            raise ValueError(
                f"{owner}.alpha is not strictly increasing at index {i + 1} "
                f"({a[i]} then {a[i + 1]} deg); allowed: increasing angles"
            )
        if a[0] != 0.0 or a[-1] not in (90.0, 180.0):
            hint = " (these look like radians: give degrees)" if a[-1] < 4.0 else ""
            raise ValueError(
                f"{owner}.alpha runs from {a[0]} to {a[-1]} deg; allowed: from 0 to 90 or from "
                f"0 to 180 deg{hint}"
            )
        if min(drag) < 0.0:
            raise ValueError(f"{owner}.drag has C_D = {min(drag)} < 0; allowed: C_D >= 0")
        _check_curves(owner, np.asarray(lift), np.asarray(drag), a)
        object.__setattr__(self, "alpha", alpha)
        object.__setattr__(self, "lift", lift)
        object.__setattr__(self, "drag", drag)

    @property
    def from_leading_edge(self) -> bool:
        """True for a 0-90° table (α from the leading edge, folded beyond 90°)."""
        return self.alpha[-1] == 90.0

    def _lookup(self, alpha_deg: np.ndarray | float, values: tuple[float, ...], odd: bool):
        alpha = np.asarray(alpha_deg, dtype=float)
        if not self.from_leading_edge:
            return np.interp(alpha, self.alpha, values)
        lead = np.where(alpha <= 90.0, alpha, 180.0 - alpha)
        sign = np.where(alpha <= 90.0, 1.0, -1.0) if odd else 1.0
        return sign * np.interp(lead, self.alpha, values)

    def lift_at(self, alpha_deg: np.ndarray | float) -> np.ndarray:
        """C_L at α [deg], 0-180° (reference values for plots and checks)."""
        return self._lookup(alpha_deg, self.lift, odd=True)

    def drag_at(self, alpha_deg: np.ndarray | float) -> np.ndarray:
        """C_D at α [deg], 0-180°."""
        return self._lookup(alpha_deg, self.drag, odd=False)

    def table(self) -> np.ndarray:
        """``[TABLE or LEADING_EDGE_TABLE, m, α [rad], C_L, C_D]``."""
        code = LEADING_EDGE_TABLE if self.from_leading_edge else TABLE
        return np.concatenate(
            [[code, float(len(self.alpha))], np.deg2rad(self.alpha), self.lift, self.drag]
        )


CoefficientModel = Union[PaperCoefficients, SinusoidalFit, TabulatedCoefficients]  # noqa: UP007

#: Model names for :func:`coefficient_model` (and the ``model:`` key of the CLI's YAML).
COEFFICIENT_MODELS: tuple[str, ...] = ("paper", "dickinson1999", "sinusoidal", "table")


def coefficient_model(spec: Any) -> CoefficientModel:
    """A coefficient model from a model object, a name, or a mapping ``{"model": name, …}``.

    ``"paper"`` (optional ``translational``), ``"dickinson1999"``, ``"sinusoidal"`` (the eight
    :class:`SinusoidalFit` fields), ``"table"`` (``alpha``, ``lift``, ``drag``).
    """
    if isinstance(spec, (PaperCoefficients, SinusoidalFit, TabulatedCoefficients)):
        return spec
    if isinstance(spec, str):
        spec = {"model": spec}
    if not isinstance(spec, Mapping):
        raise ValueError(
            f"coefficients = {spec!r}; allowed: a model object, one of {COEFFICIENT_MODELS}, or "
            "a mapping with a 'model' key"
        )
    params = dict(spec)
    name = params.pop("model", None)
    makers: dict[str, Any] = {
        "paper": PaperCoefficients,
        "dickinson1999": lambda **kw: SinusoidalFit.dickinson_1999(),
        "sinusoidal": SinusoidalFit,
        "table": TabulatedCoefficients,
    }
    if name not in makers:
        raise ValueError(
            f"coefficients.model = {name!r} is not a known force-coefficient model; "
            f"allowed: {', '.join(COEFFICIENT_MODELS)}"
        )
    if name == "dickinson1999" and params:
        raise ValueError(
            f"coefficients.model = 'dickinson1999' takes no parameters; got {sorted(params)} "
            "(use model: sinusoidal to give your own fit)"
        )
    try:
        return makers[name](**params)
    except TypeError as exc:
        raise ValueError(f"coefficients (model {name!r}): {exc}") from None


@njit(cache=True)
def coefficients_and_rates(alpha, table):
    """(C_L, C_D, dC_L/dα, dC_D/dα) of a non-paper model at α ∈ [0, π] [-, -, 1/rad, 1/rad].

    The rates are exact: a fit's in closed form, a table's the slope of the segment holding α
    (one-sided at a node); at α > 90° of a fit or 0-90° table they follow the fold,
    dC_L/dα(α) = C_L'(π − α) and dC_D/dα(α) = −C_D'(π − α). The inflow solver's slope
    (``induction.normal_force_rate_model``) uses them; :func:`force_coefficients` the values.
    """
    if table[0] == FIT:
        half_pi = 0.5 * np.pi
        lead = alpha if alpha <= half_pi else np.pi - alpha
        lift_phase = table[3] * lead - table[4]
        drag_phase = table[7] * lead - table[8]
        cl = table[1] + table[2] * np.sin(lift_phase)
        cd = table[5] - table[6] * np.cos(drag_phase)
        lift_rate = table[2] * table[3] * np.cos(lift_phase)  # d/d(lead)
        drag_rate = table[6] * table[7] * np.sin(drag_phase)
        if alpha > half_pi:
            cl = -cl
            drag_rate = -drag_rate
        return cl, cd, lift_rate, drag_rate
    sign = 1.0
    if table[0] == LEADING_EDGE_TABLE and alpha > 0.5 * np.pi:
        alpha = np.pi - alpha
        sign = -1.0
    m = int(table[1])
    # the segment [α_i, α_i+1] holding α, by bisection (the table's angles start at index 2)
    lo = 0
    hi = m - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if table[2 + mid] <= alpha:
            lo = mid
        else:
            hi = mid
    a0 = table[2 + lo]
    width = table[2 + hi] - a0
    t = (alpha - a0) / width
    t = min(max(t, 0.0), 1.0)
    lift_step = table[2 + m + hi] - table[2 + m + lo]
    drag_step = table[2 + 2 * m + hi] - table[2 + 2 * m + lo]
    cl = table[2 + m + lo] + t * lift_step
    cd = table[2 + 2 * m + lo] + t * drag_step
    # folded (sign −1): C_L = −C_L(π − α) has rate +C_L', C_D = C_D(π − α) has rate −C_D'
    return sign * cl, cd, lift_step / width, sign * drag_step / width


@njit(cache=True)
def force_coefficients(u, v, table):
    """(C_L, C_D) of a non-paper model at α = atan2(|v|, u) ∈ [0, π] (see the module docstring)."""
    cl, cd, _, _ = coefficients_and_rates(np.arctan2(abs(v), u), table)
    return cl, cd


def coefficient_spec(model: CoefficientModel) -> dict[str, Any]:
    """The mapping :func:`coefficient_model` builds ``model`` from: ``{"model": name, …fields}``
    (plain data: tuples as lists), e.g. for a YAML file or a record."""
    spec: dict[str, Any] = {"model": model.name}
    for f in fields(model):
        value = getattr(model, f.name)
        spec[f.name] = list(value) if isinstance(value, tuple) else value
    return spec
