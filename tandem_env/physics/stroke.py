"""The 28 stroke parameters: the paper's Table 4 as data, named <-> vector, and the normalised map.

A physical stroke vector has 28 entries, 14 per wing, fore-wing first, each wing in the order
``f, φ_m, θ_m, η_m, φ_0, θ_0, η_0, Φ_φ, Φ_θ, Φ_η, K, N, C_η, β_m`` and in Table 4's units:
frequency in hertz, angles in degrees, K, N and C_η dimensionless.

The normalised vector a ∈ [-1, 1]^28 maps each continuous parameter linearly onto its range;
the discrete N is 1 where its coordinate is < 0 and 2 otherwise. Every environment and
optimiser uses exactly this map (``normalised_to_physical``).

The ranges are a flyer's (:class:`StrokeBounds`, ``Dragonfly.stroke_bounds``): Table 4's
(:data:`TABLE_4_BOUNDS`) unless an insect sets its own, within what the model's equations take
(:data:`MODEL_LIMITS`, the default of :func:`validate_physical`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import Any, NamedTuple

import numpy as np

from .checks import is_real, real_array, shown
from .xp import NUMPY, ArrayNamespace


class Parameter(NamedTuple):
    """One row of Table 4 for one wing."""

    name: str
    """Identifier used in named strokes (``fore_`` / ``hind_`` prefixed in 28-vectors)."""
    symbol: str
    """The paper's symbol."""
    unit: str
    """Unit of the physical value."""
    fore: tuple[float, float]
    """(low, high) bounds for the fore-wing."""
    hind: tuple[float, float]
    """(low, high) bounds for the hind-wing."""
    description: str


#: Table 4 of the paper, in the order of the stroke vector (per wing).
TABLE_4: tuple[Parameter, ...] = (
    Parameter("frequency", "f", "Hz", (30.0, 45.0), (30.0, 45.0), "wing-beat frequency (Eqs. 3-5)"),
    Parameter(
        "sweep_amplitude", "φ_m", "deg", (30.0, 60.0), (30.0, 60.0), "weaving amplitude (Eq. 3)"
    ),
    Parameter(
        "elevation_amplitude", "θ_m", "deg", (1.0, 20.0), (1.0, 20.0), "flapping amplitude (Eq. 4)"
    ),
    Parameter(
        "pitch_amplitude", "η_m", "deg", (1.0, 90.0), (1.0, 90.0), "pitching amplitude (Eq. 5)"
    ),
    Parameter(
        "sweep_offset", "φ_0", "deg", (-30.0, 30.0), (-30.0, 30.0), "mean weaving angle (Eq. 3)"
    ),
    Parameter(
        "elevation_offset", "θ_0", "deg", (5.0, 30.0), (-30.0, 5.0), "mean flapping angle (Eq. 4)"
    ),
    Parameter(
        "pitch_offset", "η_0", "deg", (-90.0, 90.0), (-90.0, 90.0), "mean pitch angle (Eq. 5)"
    ),
    Parameter(
        "sweep_phase", "Φ_φ", "deg", (-180.0, 180.0), (-180.0, 180.0), "weaving phase (Eq. 3)"
    ),
    Parameter(
        "elevation_phase", "Φ_θ", "deg", (-180.0, 180.0), (-180.0, 180.0), "flapping phase (Eq. 4)"
    ),
    Parameter(
        "pitch_phase", "Φ_η", "deg", (-180.0, 180.0), (-180.0, 180.0), "pitching phase (Eq. 5)"
    ),
    Parameter(
        "sweep_shape",
        "K",
        "-",
        (0.01, 1.0),
        (0.01, 1.0),
        "weaving waveform, sine -> triangle (Eq. 3)",
    ),
    Parameter(
        "elevation_harmonic",
        "N",
        "-",
        (1.0, 2.0),
        (1.0, 2.0),
        "flapping cycles per beat, 1 or 2 (Eq. 4)",
    ),
    Parameter(
        "pitch_shape",
        "C_η",
        "-",
        (0.01, 5.0),
        (0.01, 5.0),
        "pitching waveform, sine -> square (Eq. 5)",
    ),
    Parameter(
        "stroke_plane_angle", "β_m", "deg", (5.0, 30.0), (5.0, 30.0), "stroke-plane inclination"
    ),
)

WING_NAMES: tuple[str, str] = ("fore", "hind")
N_PER_WING = len(TABLE_4)
N_PARAMETERS = 2 * N_PER_WING
#: Index of N (the discrete parameter) within one wing's 14 parameters.
HARMONIC_INDEX = 11
#: Names of the 28 entries, e.g. ``"fore_frequency"``.
PARAMETER_NAMES: tuple[str, ...] = tuple(f"{w}_{p.name}" for w in WING_NAMES for p in TABLE_4)
PARAMETER_UNITS: tuple[str, ...] = tuple(p.unit for _ in WING_NAMES for p in TABLE_4)
LOWER = np.array([getattr(p, w)[0] for w in WING_NAMES for p in TABLE_4])
"""Lower Table 4 bounds of the 28 physical parameters (Hz, deg, -)."""
UPPER = np.array([getattr(p, w)[1] for w in WING_NAMES for p in TABLE_4])
"""Upper Table 4 bounds of the 28 physical parameters (Hz, deg, -)."""
DISCRETE = np.zeros(N_PARAMETERS, dtype=bool)
DISCRETE[[HARMONIC_INDEX, N_PER_WING + HARMONIC_INDEX]] = True
_PER_WING_LIMITS: tuple[tuple[float, float], ...] = (
    (1.0, 1000.0),  # f [Hz]: a midge's 1000 Hz down to a large MAV's; f > 0 (Eqs. 3-5)
    (1.0, 90.0),  # φ_m [deg]: a sweep reaching the body's axis at most
    (0.0, 90.0),  # θ_m [deg]
    (0.0, 180.0),  # η_m [deg]
    (-90.0, 90.0),  # φ_0 [deg]
    (-90.0, 90.0),  # θ_0 [deg]
    (-180.0, 180.0),  # η_0 [deg]
    (-180.0, 180.0),  # Φ_φ [deg]: one turn
    (-180.0, 180.0),  # Φ_θ [deg]
    (-180.0, 180.0),  # Φ_η [deg]
    (0.01, 1.0),  # K [-]: arcsin(K sin)/arcsin(K) needs 0 < K <= 1 (Eq. 3)
    (1.0, 2.0),  # N [-]: 1 or 2 (Eq. 4)
    (0.01, 20.0),  # C_η [-]: tanh(C sin)/tanh(C) needs C > 0; 20 is a square wave (Eq. 5)
    (-90.0, 90.0),  # β_m [deg]: horizontal to vertical, either way
)
MODEL_LOWER = np.array([low for _ in WING_NAMES for low, _ in _PER_WING_LIMITS])
"""Lowest value of each of the 28 parameters the model's equations take (Hz, deg, -)."""
MODEL_UPPER = np.array([high for _ in WING_NAMES for _, high in _PER_WING_LIMITS])
"""Highest value of each of the 28 parameters the model's equations take (Hz, deg, -)."""


@dataclass(frozen=True)
class StrokeBounds:
    """The (low, high) bounds of a flyer's 28 stroke parameters, in Table 4's units and order
    (:data:`PARAMETER_NAMES`): the box its strokes are searched in, mapped onto [-1, 1]^28.

    Each pair lies within :data:`MODEL_LIMITS` with low < high; N keeps 1 to 2 (it is 1 or 2,
    chosen by the sign of its coordinate). :meth:`with_changes` gives bounds from a mapping of
    the parameters that differ (``{"fore_frequency": [15, 25]}``), :meth:`changes` the reverse.
    """

    lower: tuple[float, ...]
    """(28,) lower bounds [Hz, deg, -]."""
    upper: tuple[float, ...]
    """(28,) upper bounds [Hz, deg, -]."""

    def __post_init__(self) -> None:
        for name in ("lower", "upper"):
            value = getattr(self, name)
            arr = real_array(value, f"StrokeBounds.{name}", "28 finite numbers")
            if arr.shape != (N_PARAMETERS,):
                raise ValueError(
                    f"StrokeBounds.{name} has shape {arr.shape}; allowed: {N_PARAMETERS} "
                    "numbers in Table 4's order (tandem_env.PARAMETER_NAMES)"
                )
            object.__setattr__(self, name, tuple(float(v) for v in arr))
        for i, name in enumerate(PARAMETER_NAMES):
            low, high = self.lower[i], self.upper[i]
            unit = "" if PARAMETER_UNITS[i] == "-" else f" {PARAMETER_UNITS[i]}"
            limits = (MODEL_LOWER[i], MODEL_UPPER[i])
            if DISCRETE[i] and (low, high) != (1.0, 2.0):
                raise ValueError(
                    f"{name} bounds = [{low:g}, {high:g}]; allowed: [1, 2] (N is 1 or 2, "
                    "chosen by the sign of its coordinate)"
                )
            if not limits[0] <= low < high <= limits[1]:  # NaN fails too
                raise ValueError(
                    f"{name} bounds = [{shown(low, *limits)}, {shown(high, *limits)}]{unit}; "
                    f"allowed: {limits[0]:g} <= low < high <= {limits[1]:g}{unit} (what the "
                    "model's equations take, tandem_env.physics.stroke.MODEL_LIMITS)"
                )

    @property
    def lower_array(self) -> np.ndarray:
        """(28,) lower bounds, a new array (the bounds themselves are a value)."""
        return np.array(self.lower)

    @property
    def upper_array(self) -> np.ndarray:
        """(28,) upper bounds, a new array."""
        return np.array(self.upper)

    @property
    def label(self) -> str:
        """What the bounds are, for messages: ``"Table 4"``, ``"the model's limits"`` or
        ``"the insect's stroke bounds"``."""
        if self == TABLE_4_BOUNDS:
            return "Table 4"
        return "the model's limits" if self == MODEL_LIMITS else "the insect's stroke bounds"

    def with_changes(self, spec: Any, where: str = "stroke_bounds") -> StrokeBounds:
        """These bounds with the parameters ``spec`` gives: a mapping of names of
        :data:`PARAMETER_NAMES` to ``[low, high]``; ValueError naming the key and what is
        allowed."""
        if not isinstance(spec, Mapping):
            raise ValueError(
                f"{where} = {_short(spec)}; allowed: a mapping of stroke parameter names "
                "(fore_frequency, ...) to [low, high] in Table 4's units"
            )
        lower, upper = list(self.lower), list(self.upper)
        for key, pair in spec.items():
            if key not in PARAMETER_NAMES:
                raise ValueError(
                    f"{where}.{key}: unknown stroke parameter; allowed: "
                    f"{', '.join(PARAMETER_NAMES)}"
                )
            i = PARAMETER_NAMES.index(key)
            if not (
                isinstance(pair, list | tuple | np.ndarray)
                and len(pair) == 2
                and all(is_real(v) for v in pair)
            ):
                raise ValueError(
                    f"{where}.{key} = {_short(pair)}; allowed: [low, high], two numbers in "
                    f"{PARAMETER_UNITS[i]}"
                )
            lower[i], upper[i] = float(pair[0]), float(pair[1])
        try:
            return StrokeBounds(tuple(lower), tuple(upper))
        except ValueError as error:
            raise ValueError(f"{where}: {error}") from None

    def changes(self, base: StrokeBounds | None = None) -> dict[str, list[float]]:
        """The parameters whose bounds differ from ``base`` (default Table 4's), as
        ``{name: [low, high]}``: what :meth:`with_changes` of ``base`` takes back."""
        base = TABLE_4_BOUNDS if base is None else base
        return {
            name: [self.lower[i], self.upper[i]]
            for i, name in enumerate(PARAMETER_NAMES)
            if (self.lower[i], self.upper[i]) != (base.lower[i], base.upper[i])
        }


def _short(value: Any) -> str:
    text = " ".join(repr(value).split())
    return text if len(text) <= 80 else text[:77] + "..."


TABLE_4_BOUNDS = StrokeBounds(tuple(LOWER), tuple(UPPER))
"""The paper's Table 4: the default stroke bounds of every flyer."""
MODEL_LIMITS = StrokeBounds(tuple(MODEL_LOWER), tuple(MODEL_UPPER))
"""The widest bounds: what the model's equations take (:func:`validate_physical`'s default);
a flyer's own bounds lie within them."""
#: Entries given in degrees (converted to radians inside the model).
ANGULAR = np.array([u == "deg" for u in PARAMETER_UNITS])

#: Share of a parameter's Table 4 range within which a value counts as at that bound [-]
#: (:func:`bound_sides`): 0.3° of φ_m's 30-60°, 0.25° of β_m's 5-30°, 0.89° of η_m's 1-90°.
BOUND_TOLERANCE = 0.01
#: Entries that cannot sit at a bound: the phases (periodic, ±180° is one angle) and N
#: (discrete, always at one of its two values).
UNBOUNDED = DISCRETE | np.array([name.endswith("_phase") for name in PARAMETER_NAMES])


def bound_sides(
    strokes: np.ndarray | list | tuple, bounds: StrokeBounds = TABLE_4_BOUNDS
) -> np.ndarray:
    """Which bound (``bounds``, default Table 4's) each parameter of physical ``strokes`` (28,)
    or (B, 28) sits at: −1 within :data:`BOUND_TOLERANCE` of its range above the lower bound,
    +1 as close below the upper, 0 inside (always 0 for the :data:`UNBOUNDED` phases and N).
    Same shape, int."""
    arr, single = _as_batch(strokes, "strokes")
    low, high = bounds.lower_array, bounds.upper_array
    margin = BOUND_TOLERANCE * (high - low)
    sides = np.where(arr <= low + margin, -1, np.where(arr >= high - margin, 1, 0))
    sides[:, UNBOUNDED] = 0
    return sides[0] if single else sides


def describe_bounds(
    stroke: np.ndarray | list | tuple, bounds: StrokeBounds = TABLE_4_BOUNDS
) -> str:
    """The parameters of one physical stroke (28,) at a bound (``bounds``, default Table 4's;
    :func:`bound_sides`), e.g. ``"fore_sweep_amplitude=lower; hind_stroke_plane_angle=lower"``
    (empty: none)."""
    sides = bound_sides(np.asarray(stroke, float).reshape(N_PARAMETERS), bounds)
    return "; ".join(
        f"{name}={'lower' if side < 0 else 'upper'}"
        for name, side in zip(PARAMETER_NAMES, sides, strict=True)
        if side
    )


#: What a stroke argument may be, for messages.
_STROKE_SHAPES = (
    "real numbers of shape (28,) or (B, 28) with B >= 1 (14 parameters per wing, fore first)"
)


def _as_batch(x: np.ndarray | list | tuple, what: str) -> tuple[np.ndarray, bool]:
    """``x`` as a (B, 28) float array with B >= 1, and whether it was one stroke (28,).

    One message per failure, the same from every entry point (evaluate, validate_physical,
    normalised_to_physical, ...): non-numbers, ragged lists, wrong shapes, an empty batch.
    """
    arr = real_array(x, what, _STROKE_SHAPES)
    shape = arr.shape
    if arr.size == 0:
        raise ValueError(f"{what} is empty (shape {shape}); allowed: {_STROKE_SHAPES}")
    single = arr.ndim == 1
    if single:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != N_PARAMETERS:
        raise ValueError(f"{what} has shape {shape}; allowed: {_STROKE_SHAPES}")
    return arr, single


def _first_bad(mask: np.ndarray) -> tuple[int, int]:
    row, col = np.argwhere(mask)[0]
    return int(row), int(col)


#: Largest tolerance :func:`validate_physical` takes [Table 4 units]: a tenth of the smallest bound.
ATOL_MAX = 1e-3


def validate_physical(
    strokes: np.ndarray | list | tuple,
    atol: float = 1e-9,
    bounds: StrokeBounds | None = None,
) -> np.ndarray:
    """Check a (B, 28) or (28,) physical stroke array against ``bounds`` and return it as
    (B, 28): a flyer's (``insect.stroke_bounds``, :data:`TABLE_4_BOUNDS` for the paper's), or
    by default :data:`MODEL_LIMITS`, what the model's equations take for any flyer
    (``tandem_env.evaluate`` checks the insect's own bounds first).

    Raises
    ------
    ValueError
        Naming the first offending parameter, its value and the allowed range: non-finite
        values, values outside the bounds (beyond ``atol``), N other than 1 or 2, wrong shapes.
    """
    bounds = MODEL_LIMITS if bounds is None else bounds
    if not isinstance(bounds, StrokeBounds):
        raise ValueError(f"bounds = {_short(bounds)}; allowed: a StrokeBounds or None")
    lower, upper = bounds.lower_array, bounds.upper_array
    if not is_real(atol) or not 0.0 <= atol <= ATOL_MAX:
        raise ValueError(
            f"atol = {atol!r}; allowed: a number from 0 to {ATOL_MAX:g} (a rounding tolerance "
            "in Table 4 units; the smallest Table 4 bound is 0.01)"
        )
    arr, _ = _as_batch(strokes, "strokes")
    bad = ~np.isfinite(arr)
    if bad.any():
        row, col = _first_bad(bad)
        raise ValueError(
            f"stroke {row}: {PARAMETER_NAMES[col]} = {float(arr[row, col])} is not finite; "
            f"allowed range {lower[col]:g} to {upper[col]:g} {PARAMETER_UNITS[col]}"
        )
    outside = (arr < lower - atol) | (arr > upper + atol)
    if outside.any():
        row, col = _first_bad(outside)
        raise ValueError(
            f"stroke {row}: {PARAMETER_NAMES[col]} = "
            f"{shown(arr[row, col], lower[col], upper[col])} {PARAMETER_UNITS[col]} is "
            f"outside {bounds.label}: allowed {lower[col]:g} to {upper[col]:g} "
            f"{PARAMETER_UNITS[col]}"
        )
    harmonic = arr[:, DISCRETE]
    not_integer = (harmonic != 1.0) & (harmonic != 2.0)
    if not_integer.any():
        row, k = _first_bad(not_integer)
        col = int(np.flatnonzero(DISCRETE)[k])
        raise ValueError(
            f"stroke {row}: {PARAMETER_NAMES[col]} = {float(arr[row, col]):g} must be exactly 1 or 2"
        )
    return arr


def normalised_to_physical(
    action: np.ndarray | list | tuple, bounds: StrokeBounds = TABLE_4_BOUNDS
) -> np.ndarray:
    """Map normalised strokes a ∈ [-1, 1]^28 to physical strokes (Table 4 units) within
    ``bounds`` (a flyer's ``insect.stroke_bounds``; default Table 4's).

    Continuous parameters: x = low + (a + 1)/2·(high − low). Discrete N: 1 where a < 0, else 2.
    Accepts (28,) or (B, 28); returns the same shape. Raises ``ValueError`` for non-finite
    values or values outside [-1, 1] (clip first if that is what you want).
    """
    arr, single = _as_batch(action, "action")
    if not np.all(np.isfinite(arr)):
        row, col = _first_bad(~np.isfinite(arr))
        raise ValueError(
            f"action {row}: {PARAMETER_NAMES[col]} = {float(arr[row, col])} is not finite; "
            "allowed: finite numbers in [-1, 1]"
        )
    outside = np.abs(arr) > 1.0 + 1e-9
    if outside.any():
        row, col = _first_bad(outside)
        raise ValueError(
            f"action {row}: {PARAMETER_NAMES[col]} = {shown(arr[row, col], -1, 1)} is outside "
            "[-1, 1]; "
            "allowed: numbers in [-1, 1] (clip first if that is what you want)"
        )
    physical = map_normalised(np.clip(arr, -1.0, 1.0), bounds=bounds)
    return physical[0] if single else physical


def map_normalised(
    action: Any, xp: ArrayNamespace = NUMPY, bounds: StrokeBounds = TABLE_4_BOUNDS
) -> Any:
    """The map of :func:`normalised_to_physical` without its checks, on a (B, 28) array of
    ``action`` in [-1, 1] in the array namespace ``xp`` (numpy or torch, differentiable there):
    x = low + (a + 1)/2·(high − low), N = 1 where a < 0, else 2 (``bounds``: default Table 4's)."""
    low = xp.constant_like(bounds.lower_array, action)
    high = xp.constant_like(bounds.upper_array, action)
    continuous = low + 0.5 * (action + 1.0) * (high - low)
    harmonic = xp.where(action < 0.0, 1.0, 2.0)
    return xp.where(xp.constant_like(DISCRETE, action) > 0.5, harmonic, continuous)


def physical_to_normalised(
    strokes: np.ndarray | list | tuple, bounds: StrokeBounds = TABLE_4_BOUNDS
) -> np.ndarray:
    """Inverse of :func:`normalised_to_physical` for physical strokes within ``bounds``
    (default Table 4's).

    N = 1 maps to −0.5 and N = 2 to +0.5 (the middle of each half), so that
    ``normalised_to_physical(physical_to_normalised(x, b), b) == x``.
    """
    arr = validate_physical(strokes, bounds=bounds)
    single = np.ndim(strokes) == 1
    low, high = bounds.lower_array, bounds.upper_array
    action = 2.0 * (arr - low) / (high - low) - 1.0
    action[:, DISCRETE] = np.where(arr[:, DISCRETE] < 1.5, -0.5, 0.5)
    return action[0] if single else action


@dataclass(frozen=True)
class WingStroke:
    """The 14 stroke parameters of one wing (Eqs. 3-5), in Table 4's units."""

    frequency: float
    """f [Hz]."""
    sweep_amplitude: float
    """φ_m, weaving amplitude [deg]."""
    elevation_amplitude: float
    """θ_m, flapping amplitude [deg]."""
    pitch_amplitude: float
    """η_m, pitching amplitude [deg]."""
    sweep_offset: float
    """φ_0 [deg]."""
    elevation_offset: float
    """θ_0 [deg]."""
    pitch_offset: float
    """η_0 [deg]."""
    sweep_phase: float
    """Φ_φ [deg]."""
    elevation_phase: float
    """Φ_θ [deg]."""
    pitch_phase: float
    """Φ_η [deg]."""
    sweep_shape: float
    """K [-], 0.01 (sinusoid) to 1 (triangle wave)."""
    elevation_harmonic: int
    """N [-], 1 or 2 flapping cycles per beat."""
    pitch_shape: float
    """C_η [-], 0.01 (sinusoid) to 5 (near square wave)."""
    stroke_plane_angle: float
    """β_m, stroke-plane inclination to the flight path [deg]."""

    def to_vector(self) -> np.ndarray:
        return np.array([float(getattr(self, f.name)) for f in fields(self)])


@dataclass(frozen=True)
class Stroke:
    """A named physical stroke of both wings. Validated against :data:`MODEL_LIMITS` (any
    flyer's) at construction; its normalised form is Table 4's."""

    fore: WingStroke
    hind: WingStroke

    def __post_init__(self) -> None:
        validate_physical(self.to_vector())

    def to_vector(self) -> np.ndarray:
        """The (28,) physical vector, fore-wing first."""
        return np.concatenate([self.fore.to_vector(), self.hind.to_vector()])

    @classmethod
    def from_vector(cls, vector: np.ndarray | list | tuple) -> Stroke:
        arr = validate_physical(vector)
        if arr.shape[0] != 1:
            raise ValueError(
                f"Stroke.from_vector takes one stroke of shape (28,); got {np.shape(vector)}"
            )
        values = arr[0]

        def wing(chunk: np.ndarray) -> WingStroke:
            kwargs = {p.name: float(v) for p, v in zip(TABLE_4, chunk, strict=True)}
            kwargs["elevation_harmonic"] = int(kwargs["elevation_harmonic"])
            return WingStroke(**kwargs)

        return cls(fore=wing(values[:N_PER_WING]), hind=wing(values[N_PER_WING:]))

    def to_normalised(self) -> np.ndarray:
        return physical_to_normalised(self.to_vector())

    @classmethod
    def from_normalised(cls, action: np.ndarray | list | tuple) -> Stroke:
        return cls.from_vector(normalised_to_physical(action))

    def to_dict(self) -> dict[str, float]:
        """Flat ``{"fore_frequency": ..., ...}`` mapping (units in :data:`PARAMETER_UNITS`)."""
        return strokes_to_dicts(self.to_vector()[None, :])[0]


def strokes_to_dicts(strokes: np.ndarray) -> list[dict[str, float]]:
    """Named physical parameters for each row of a (B, 28) physical array."""
    arr, _ = _as_batch(strokes, "strokes")
    out = []
    for row in arr:
        d = {name: float(v) for name, v in zip(PARAMETER_NAMES, row, strict=True)}
        for name in (PARAMETER_NAMES[HARMONIC_INDEX], PARAMETER_NAMES[N_PER_WING + HARMONIC_INDEX]):
            d[name] = int(d[name])
        out.append(d)
    return out


def table_4_markdown() -> str:
    """Table 4 as a Markdown table (for docs and reports)."""
    lines = ["| parameter | symbol | unit | fore-wing | hind-wing |", "|---|---|---|---|---|"]
    for p in TABLE_4:
        lines.append(
            f"| {p.name} | {p.symbol} | {p.unit} | {p.fore[0]:g} to {p.fore[1]:g} | {p.hind[0]:g} to {p.hind[1]:g} |"
        )
    return "\n".join(lines)
