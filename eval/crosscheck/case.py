"""The cross-check's cases: which strokes the vortex-lattice mapping supports, the wings'
clearance, the resolution, and the runs a case needs (docs/crosscheck.md).

Everything here is plain numpy: it validates a case before any solver is imported, so bad
input is refused at once, with or without the ``uvlm`` extra.

Frames (docs/crosscheck.md, "The mapping"). The solver's geometry axes G are X aft, Y right,
Z up; its Y-Z plane is the stroke plane, whose upper normal z_s (docs/model.md §4.1) is −X_G
and whose forward in-plane direction x_s is +Z_G. The free stream comes along the flight path
(level flight), so the project's earth axes are, in G, forward X_E = (−sin β, 0, cos β) and up
Z_E = (−cos β, 0, −sin β). A wing's sweep φ is the solver's first intrinsic angle (about X) and
its pitch η the second (about the swept span y'); elevation has no place in that order and is
zero in the solver.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import asdict, dataclass, replace
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from tandem_env.physics import PARAMETER_NAMES, TABLE_4_BOUNDS, Dragonfly, Wing, validate_physical

#: Record format of one solver run (``OUT/records/<key>.json``).
RUN_FORMAT = "tandem_env.crosscheck-run/1"

#: Largest sweep shape K and pitch shape C_η the mapping takes [-]: the solver moves each angle
#: as a pure sine, and at 0.1 the project's waveforms (Eqs. 3, 5) differ from a sine by under
#: 0.15 % of their amplitude (tests/eval/test_crosscheck.py checks it).
MAX_SHAPE = 0.1
#: Largest elevation |θ| over the cycle, θ_m + |θ_0| [deg]: the solver has no elevation (it is
#: zero there), so only strokes whose elevation is as small as Table 4 allows are compared:
#: its least fore-wing elevation is θ_m = 1° about θ_0 = 5°.
MAX_ELEVATION = 6.0
#: Largest |base| + amplitude of the sweep and the pitch [deg]: the solver keeps each of a
#: wing's angles within ±90°.
MAX_ANGLE = 90.0
#: Smallest distance between the fore and hind wings over the cycle [m]: closer than this the
#: bound vortex rings of one pass within a panel's chord (c̄/4 ≈ 1.5 mm at the default 4
#: chordwise panels) of the other's, where the lattice's induced velocities are not resolved;
#: wings that intersect (a distance of 0) cannot be solved at all.
MIN_CLEARANCE = 1.0e-3
#: Span stations of the solver's wing [r/R]: the chord at the tip of the tear-drop is zero,
#: which the solver refuses, so the outermost station is 0.98 R.
STATIONS = (0.0, 0.3, 0.55, 0.75, 0.9, 0.98)
#: Distance of each wing root from the body's mid-plane [m]: half the thorax's width (4 mm
#: across, docs/model.md §1.5). The solver splits a symmetric wing whose root lies off the
#: plane into a right and a left wing, each with its own motion; at 1 mm the root chords of the
#: base case's hind pair (9.8 mm long, pitching ±50° while sweeping ±35°) would swing across
#: the plane into each other.
ROOT_OFFSET = 2.0e-3
#: The two pairs' keys, fore first.
PAIRS = ("fore", "hind")
#: The solver's wakes (``--wake``), the default first: ``"free"`` moves each wake panel with
#: the local flow (wake on wake); ``"prescribed"`` carries it by the free stream alone
#: (Ptera Software's ``run(prescribed_wake=True)``: no self-induction, about 5-10x cheaper).
WAKES = ("free", "prescribed")

#: Samples of the clearance check: instants per beat, points along the span and the chord.
_CLEARANCE_SAMPLES = (96, 48, 12)


def _wrap(angle: float) -> float:
    """An angle [deg] wrapped to (−180, 180], as the solver takes phases."""
    wrapped = math.fmod(angle + 180.0, 360.0)
    wrapped = wrapped + 360.0 if wrapped <= 0.0 else wrapped
    return round(wrapped - 180.0, 12)


@dataclass(frozen=True)
class Resolution:
    """The solver's resolution: time steps per beat, panels per wing and beats run."""

    steps_per_beat: int = 48
    """Time steps per wing beat [-] (the issue's exploratory runs moved 5 % from 32 to 48)."""
    chordwise: int = 4
    """Chordwise panels per wing [-] (uniform)."""
    spanwise: int = 8
    """Spanwise panels per wing [-], shared among the segments between :data:`STATIONS`."""
    beats: int = 3
    """Beats run [-]; the loads are the mean over the last one (the wake of the first two)."""

    def __post_init__(self) -> None:
        for name, option, low, high in (
            ("steps_per_beat", "--steps-per-beat", 4, 256),
            ("chordwise", "--panels (chordwise)", 1, 16),
            ("spanwise", "--panels (spanwise)", len(STATIONS) - 1, 64),
            ("beats", "--beats", 2, 8),
        ):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
                raise ValueError(f"{option} {value!r}; allowed: a whole number {low} to {high}")

    @property
    def panels(self) -> str:
        return f"{self.chordwise}x{self.spanwise}"

    def label(self) -> str:
        return f"{self.steps_per_beat} steps/beat, {self.panels} panels, {self.beats} beats"

    def segment_panels(self) -> tuple[int, ...]:
        """Spanwise panels of each segment between :data:`STATIONS`, in proportion to its
        length (largest remainders), at least one each: 8 gives the (2, 2, 2, 1, 1) of the
        exploratory runs."""
        lengths = np.diff(STATIONS)
        share = lengths / lengths.sum() * (self.spanwise - len(lengths))
        counts = np.floor(share).astype(int) + 1
        left = self.spanwise - int(counts.sum())
        for index in np.argsort(-(share - np.floor(share)), kind="stable")[:left]:
            counts[index] += 1
        return tuple(int(c) for c in counts)

    def refined(self) -> tuple[Resolution, ...]:
        """This resolution and the ones that check its convergence: 2/3 and 4/3 of its time
        steps, and 1.5x chordwise by 2x spanwise panels (48 steps, 4x8: 32, 64 and 6x16)."""
        steps = [max(4, round(self.steps_per_beat * k)) for k in (2 / 3, 4 / 3)]
        chordwise = min(16, math.ceil(1.5 * self.chordwise))
        finer = replace(self, chordwise=chordwise, spanwise=min(64, 2 * self.spanwise))
        return (self, *(replace(self, steps_per_beat=s) for s in steps), finer)


def parse_panels(text: str) -> dict[str, int]:
    """``"CxS"`` (chordwise x spanwise panels per wing) as the :class:`Resolution`'s
    ``chordwise`` and ``spanwise``; ValueError otherwise."""
    parts = str(text).lower().split("x")
    if len(parts) != 2 or not all(p.strip().isdigit() for p in parts):
        raise ValueError(f"--panels {text!r}; allowed: CxS, chordwise by spanwise panels, e.g. 4x8")
    return {"chordwise": int(parts[0]), "spanwise": int(parts[1])}


@dataclass(frozen=True)
class WingMotion:
    """One wing pair as the solver sees it: its planform at :data:`STATIONS` and its motion."""

    length: float
    """Wing length R [m]."""
    chords: tuple[float, ...]
    """Chord c(r) at each station [m] (docs/model.md §2)."""
    frequency: float
    """f [Hz]."""
    sweep: tuple[float, float, float]
    """(φ_m, φ_0, Φ_φ) [deg]: φ = φ_0 + φ_m·sin(2πft + Φ_φ)."""
    pitch: tuple[float, float, float]
    """(η_m, η_0, Φ_η) [deg]: η = η_0 + η_m·sin(2πft + Φ_η)."""

    def angles(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(φ, η) [rad] at times ``t`` [s]."""
        beat = 2 * np.pi * self.frequency * t
        sweep, pitch = (
            np.radians(base + amplitude * np.sin(beat + np.radians(phase)))
            for amplitude, base, phase in (self.sweep, self.pitch)
        )
        return sweep, pitch


def wing_motion(wing: Wing, stroke: np.ndarray, pair: str, lag: float = 0.0) -> WingMotion:
    """The solver's motion of one pair of the (28,) ``stroke``, its phases shifted by ``lag``
    [deg] (the hind-wing's, for the tandem at that lag)."""
    p = dict(zip(PARAMETER_NAMES, stroke, strict=True))
    g = lambda name: float(p[f"{pair}_{name}"])  # noqa: E731
    return WingMotion(
        length=wing.length,
        chords=tuple(float(c) for c in wing.chord(np.asarray(STATIONS))),
        frequency=g("frequency"),
        sweep=(g("sweep_amplitude"), g("sweep_offset"), _wrap(g("sweep_phase") + lag)),
        pitch=(g("pitch_amplitude"), g("pitch_offset"), _wrap(g("pitch_phase") + lag)),
    )


def shifted_stroke(stroke: np.ndarray, lag: float) -> np.ndarray:
    """``stroke`` with the hind-wing's sweep and pitch phases shifted by ``lag`` [deg] and its
    elevation phase by N·lag: the hind-wing's motion delayed by −lag/360 of a beat."""
    out = np.array(stroke, dtype=float)
    harmonic = out[PARAMETER_NAMES.index("hind_elevation_harmonic")]
    for name, factor in (("sweep_phase", 1.0), ("pitch_phase", 1.0), ("elevation_phase", harmonic)):
        index = PARAMETER_NAMES.index(f"hind_{name}")
        out[index] = _wrap(out[index] + factor * lag)
    return out


def check_family(stroke: np.ndarray) -> np.ndarray:
    """The (28,) ``stroke`` if the mapping supports it; ValueError naming the value otherwise.

    Supported: a Table 4 stroke within :data:`MAX_SHAPE`, :data:`MAX_ELEVATION` and
    :data:`MAX_ANGLE`, with the same frequency and stroke-plane angle on both pairs (one free
    stream sets both planes' tilt, and the run's length is a whole number of both beats)."""
    arr = validate_physical(stroke, bounds=TABLE_4_BOUNDS)  # the specimen's strokes
    if arr.shape[0] != 1:
        raise ValueError(f"one stroke of 28 parameters; got shape {np.shape(stroke)}")
    p = dict(zip(PARAMETER_NAMES, arr[0], strict=True))
    for pair in PAIRS:
        for name, symbol in (("sweep_shape", "K"), ("pitch_shape", "C_η")):
            if (value := p[f"{pair}_{name}"]) > MAX_SHAPE:
                raise ValueError(
                    f"{pair}_{name} ({symbol}) = {value:g}: the vortex-lattice mapping moves each "
                    f"angle as a sine; allowed: {symbol} <= {MAX_SHAPE:g} (a sinusoidal waveform)"
                )
        elevation = p[f"{pair}_elevation_amplitude"] + abs(p[f"{pair}_elevation_offset"])
        if elevation > MAX_ELEVATION + 1e-9:
            raise ValueError(
                f"{pair} elevation reaches {elevation:g} deg (elevation_amplitude "
                f"{p[f'{pair}_elevation_amplitude']:g} + |elevation_offset| "
                f"{abs(p[f'{pair}_elevation_offset']):g}): the solver has no elevation; allowed: "
                f"elevation_amplitude + |elevation_offset| <= {MAX_ELEVATION:g} deg (Table 4's "
                "least: 1 about 5)"
            )
        for name in ("sweep", "pitch"):
            reach = p[f"{pair}_{name}_amplitude"] + abs(p[f"{pair}_{name}_offset"])
            if reach > MAX_ANGLE:
                raise ValueError(
                    f"{pair} {name} reaches {reach:g} deg ({name}_amplitude + |{name}_offset|); "
                    f"allowed: at most {MAX_ANGLE:g} deg (the solver's range of an angle)"
                )
    for name, unit in (("frequency", "Hz"), ("stroke_plane_angle", "deg")):
        fore, hind = p[f"fore_{name}"], p[f"hind_{name}"]
        if fore != hind:
            raise ValueError(
                f"fore_{name} = {fore:g} {unit} and hind_{name} = {hind:g} {unit}; allowed: equal "
                "values (the vortex-lattice mapping has one beat and one free stream for both)"
            )
    return arr[0]


#: The issue's exploratory case: Table 1 wings, f = 37 Hz, sweep ±35°, pitch ±50° leading the
#: sweep by 90°, β = 15°, sinusoidal waveforms, the least elevation Table 4 allows.
BASE_WING = {
    "frequency": 37.0,
    "sweep_amplitude": 35.0,
    "elevation_amplitude": 1.0,
    "pitch_amplitude": 50.0,
    "sweep_offset": 0.0,
    "elevation_offset": 0.0,
    "pitch_offset": 0.0,
    "sweep_phase": 0.0,
    "elevation_phase": 0.0,
    "pitch_phase": 90.0,
    "sweep_shape": 0.01,
    "elevation_harmonic": 1.0,
    "pitch_shape": 0.01,
    "stroke_plane_angle": 15.0,
}
#: Elevation offsets of the base case [deg]: the fore-wing's least in Table 4, none on the
#: hind-wing (its range holds 0).
BASE_ELEVATION_OFFSET = {"fore": 5.0, "hind": 0.0}


def base_stroke(**overrides: float) -> np.ndarray:
    """The base case's (28,) stroke with named parameters (``fore_sweep_amplitude=40``) replaced."""
    values = {f"{pair}_{name}": value for pair in PAIRS for name, value in BASE_WING.items()}
    values |= {f"{pair}_elevation_offset": v for pair, v in BASE_ELEVATION_OFFSET.items()}
    if unknown := sorted(set(overrides) - set(values)):
        msg = f"--stroke: unknown parameter(s) {unknown}; allowed: {', '.join(PARAMETER_NAMES)}"
        raise ValueError(msg)
    values.update({k: float(v) for k, v in overrides.items()})
    return np.array([values[name] for name in PARAMETER_NAMES])


@dataclass(frozen=True)
class Case:
    """One flight condition and geometry of the tandem, at one or more fore/hind lags."""

    stroke: tuple[float, ...]
    """The (28,) stroke, Table 4 units; lag 0 is this stroke as it is."""
    speed: float
    """Flight speed V [m/s], level flight."""
    spacing: float
    """Fore root to hind root along the body axis, + aft [m]."""
    drop: float
    """Hind root below the fore root [m]."""
    lags: tuple[float, ...]
    """Shifts of the hind-wing's phases [deg] (:func:`shifted_stroke`); with equal fore and
    hind phases, the project's ΔΦ = Φ_φ,hind − Φ_φ,fore (> 0: the hind-wing leads)."""

    @property
    def label(self) -> str:
        where = f"d = {1e3 * self.spacing:.1f} mm, h = {1e3 * self.drop:.1f} mm"
        return f"V = {self.speed:g} m/s, {where}"


@dataclass(frozen=True)
class Run:
    """One solver run: one pair alone or the tandem at one lag, at one resolution.

    Plain numbers only: the key hashes them (with the format and the solver's version), and a
    worker needs nothing else."""

    kind: str
    """``"fore"``, ``"hind"`` (alone) or ``"tandem"``."""
    speed: float
    """V [m/s]."""
    stroke_plane_angle: float
    """β [deg], both pairs."""
    air_density: float
    """ρ [kg/m³]."""
    fore: WingMotion | None
    hind: WingMotion | None
    spacing: float
    """d [m] (tandem only; 0 alone)."""
    drop: float
    """h [m] (tandem only; 0 alone)."""
    lag: float
    """Hind phase shift [deg] (tandem only; 0 alone)."""
    resolution: Resolution
    root_offset: float = ROOT_OFFSET
    wake: str = WAKES[0]
    """The solver's wake, one of :data:`WAKES`."""

    def key(self, solver_version: str) -> str:
        fields = asdict(self)
        if self.wake == WAKES[0]:
            # The default wake is left out, so runs stored before the choice existed keep
            # their keys (and are reused); any other wake is another record.
            del fields["wake"]
        keyed = {"format": RUN_FORMAT, "solver": solver_version, "run": fields}
        return hashlib.sha256(json.dumps(keyed, sort_keys=True).encode()).hexdigest()[:20]

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Run:
        """Inverse of ``dataclasses.asdict`` after JSON (lists for tuples); TypeError or
        ValueError for anything else."""
        fields = dict(data)
        for pair in PAIRS:
            if fields[pair] is not None:
                wing = {k: tuple(v) if isinstance(v, list) else v for k, v in fields[pair].items()}
                fields[pair] = WingMotion(**wing)
        fields["resolution"] = Resolution(**fields["resolution"])
        return cls(**fields)

    def label(self) -> str:
        what = f"tandem, lag {self.lag:g} deg" if self.kind == "tandem" else f"{self.kind} alone"
        wake = "" if self.wake == WAKES[0] else f", {self.wake} wake"
        return f"{what}, V = {self.speed:g} m/s ({self.resolution.label()}{wake})"


def case_runs(
    case: Case, insect: Dragonfly, resolution: Resolution, wake: str = WAKES[0]
) -> dict[str, Run]:
    """The runs of ``case`` at ``resolution`` with the solver's ``wake`` (:data:`WAKES`):
    ``"fore"``, ``"hind"`` (alone; a time shift of a pair alone changes no cycle mean, so one
    each) and ``"tandem <lag>"`` per lag."""
    if wake not in WAKES:
        raise ValueError(f"--wake {wake!r}; allowed: {', '.join(WAKES)}")
    stroke = np.asarray(case.stroke)
    common = {
        "speed": case.speed,
        "stroke_plane_angle": float(stroke[PARAMETER_NAMES.index("fore_stroke_plane_angle")]),
        "air_density": insect.air_density,
        "resolution": resolution,
        "wake": wake,
    }
    motions = {pair: wing_motion(getattr(insect, pair), stroke, pair) for pair in PAIRS}
    alone = {"spacing": 0.0, "drop": 0.0, "lag": 0.0, **common}
    runs = {  # each pair alone: the other is None
        pair: Run(pair, **{p: motions[p] if p == pair else None for p in PAIRS}, **alone)
        for pair in PAIRS
    }
    for lag in case.lags:
        hind = wing_motion(insect.hind, stroke, "hind", lag)
        where = {"spacing": case.spacing, "drop": case.drop, "lag": lag}
        runs[f"tandem {lag:g}"] = Run("tandem", fore=motions["fore"], hind=hind, **where, **common)
    return runs


def earth_axes(beta_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """The project's forward X_E and up Z_E in the solver's geometry axes (module docstring)."""
    b = math.radians(beta_deg)
    return np.array([-math.sin(b), 0.0, math.cos(b)]), np.array([-math.cos(b), 0.0, -math.sin(b)])


def hind_position(spacing: float, drop: float, beta_deg: float) -> np.ndarray:
    """The hind pair's origin relative to the fore pair's in geometry axes [m]."""
    forward, up = earth_axes(beta_deg)
    return -spacing * forward - drop * up


def wing_surface(
    motion: WingMotion, origin: np.ndarray, t: np.ndarray, offset: float, samples: tuple[int, int]
) -> np.ndarray:
    """Points of a right wing's flat surface at times ``t`` [s], (len(t), n_span·n_chord, 3) [m],
    its root ``offset`` [m] from the mid-plane.

    The wing pitches about its straight mid-chord line (docs/model.md §2.4), which sweeps about
    the stroke-plane normal through the root; the rotation is the solver's intrinsic x-y'
    (sweep φ about X, then pitch η about the swept span)."""
    n_span, n_chord = samples
    span = np.linspace(0.0, STATIONS[-1], n_span)
    chord = np.interp(span, STATIONS, motion.chords)
    along = (np.linspace(0.0, 1.0, n_chord)[None, :] - 0.5) * chord[:, None]  # from mid-chord
    x, y = along.ravel(), np.repeat(span * motion.length, n_chord)
    phi, eta = motion.angles(np.asarray(t, dtype=float))
    ce, se = np.cos(eta)[:, None], np.sin(eta)[:, None]
    cp, sp = np.cos(phi)[:, None], np.sin(phi)[:, None]
    # R_X(φ)·R_Y(η)·(x, y, 0)
    points = np.stack([ce * x, cp * y + sp * se * x, sp * y - cp * se * x], axis=-1)
    return points + (np.asarray(origin) + np.array([0.0, offset, 0.0]))


def clearances(case: Case, insect: Dragonfly) -> dict[float, dict[str, float]]:
    """Per lag, the least distance over the beat [m] between the fore and hind wings on each
    side (``"pairs"``) and between the left and right wings of a pair, twice the least distance
    of a wing from the mid-plane (``"left_right"``; negative where they cross), of the solver's
    geometry (elevation zero). Sampled at :data:`_CLEARANCE_SAMPLES` (instants per beat, span, chord)."""
    n_time, n_span, n_chord = _CLEARANCE_SAMPLES
    stroke = np.asarray(case.stroke)
    beta = float(stroke[PARAMETER_NAMES.index("fore_stroke_plane_angle")])
    fore = wing_motion(insect.fore, stroke, "fore")
    t = np.arange(n_time) / (n_time * fore.frequency)
    fore_points = wing_surface(fore, np.zeros(3), t, ROOT_OFFSET, (n_span, n_chord))
    behind = hind_position(case.spacing, case.drop, beta)
    out = {}
    for lag in case.lags:
        hind = wing_motion(insect.hind, stroke, "hind", lag)
        hind_points = wing_surface(hind, behind, t, ROOT_OFFSET, (n_span, n_chord))
        least = min(
            float(cKDTree(hind_points[k]).query(fore_points[k])[0].min()) for k in range(n_time)
        )
        mid = float(min(fore_points[..., 1].min(), hind_points[..., 1].min()))
        out[lag] = {"pairs": least, "left_right": 2.0 * mid}
    return out


def check_geometry(case: Case, insect: Dragonfly) -> dict[float, dict[str, float]]:
    """:func:`clearances` of ``case``, or ValueError naming the lag, the distance and the
    least allowed (:data:`MIN_CLEARANCE`, between any two wings)."""
    found = clearances(case, insect)
    for lag, gaps in found.items():
        if gaps["pairs"] < MIN_CLEARANCE:
            raise ValueError(
                f"{case.label}, lag {lag:g} deg: the fore and hind wings come within "
                f"{1e3 * gaps['pairs']:.2f} mm of each other over the beat; allowed: at least "
                f"{1e3 * MIN_CLEARANCE:g} mm (a larger --drop or --spacing, or smaller amplitudes)"
            )
        if gaps["left_right"] < MIN_CLEARANCE:
            raise ValueError(
                f"{case.label}: the root chords of a pair's left and right wings come within "
                f"{1e3 * gaps['left_right']:.2f} mm of each other (negative: they cross the "
                f"body's mid-plane); allowed: at least {1e3 * MIN_CLEARANCE:g} mm (smaller sweep "
                "or pitch amplitudes)"
            )
    return found
