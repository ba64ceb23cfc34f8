"""Measured kinematics in, forces out: :class:`MeasuredWing` and :func:`evaluate_measured`.

A researcher's wing kinematics (digitised film, a paper's Fourier table, a CSV of samples) enter
as one :class:`MeasuredWing` per wing pair and run through the same compiled model as the
28-parameter strokes. Conventions (docs/measured.md has the figure and the mapping from
Ellington's and Azuma's angles):

* φ ``sweep``: in the stroke plane, 0 with the span normal to the body's long axis projected on
  the plane, + forward (towards the head);
* θ ``elevation``: out of the stroke plane, + towards the upper side (the stroke plane's normal
  ``z_s``);
* η ``pitch``: about the span, 0 with the chord normal to the stroke plane (leading edge up),
  + turning the leading edge forward: η = 90° − α on a forward (down-) stroke and
  α − 90° on a backward (up-) stroke for a geometric angle of attack α to the stroke plane;
* β ``stroke_plane_angle``: from the horizontal, + tilting the plane's forward edge down (a
  horizontal stroke plane is 0, a vertical one 90°); any angle, wrapped to (−π, π].

Angles are in radians; the constructors :meth:`MeasuredWing.from_fourier` and
:meth:`MeasuredWing.from_samples` take degrees by default.

Span-wise pitch: ``pitch`` of shape (n, k) gives η at ``pitch_stations`` (k,) in r/R, linearly
interpolated over the blade elements and held constant beyond the end stations. Each element
then has its own chord direction and rotation rate Ω = η̇(r) (circulation, added mass, power);
the blade elements are evaluated one by one (the inflow of each annulus is its own solve anyway)
and their force histories summed before the cycle means are taken.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np

from . import cycle
from .checks import count, flag, is_real, real_array, shown
from .insect import DRAGONFLY, Dragonfly, Wing
from .kinematics import spectral_derivatives
from .model import (
    DEFAULT_OPTIONS,
    Kept,
    Result,
    _performance,
    node_inertia,
    run_kernel,
    validate_conditions,
    wing_tables,
)
from .options import MAX_TIME_SAMPLES, ModelOptions

#: Fewest samples per cycle a measured series may have.
MIN_SAMPLES = 8
#: Samples per cycle of :meth:`MeasuredWing.from_fourier` unless told.
FOURIER_SAMPLES = 256
#: Most samples per cycle a measured series may have (the model's limit).
MAX_SAMPLES = MAX_TIME_SAMPLES
#: Relative tolerance on uniform sample times (:meth:`MeasuredWing.from_samples`).
TIME_TOLERANCE = 1e-3
#: A series one of whose sample-to-sample steps is more than this fraction of its total
#: variation over the cycle (the cycle closed) has a jump; :class:`MeasuredWing` warns [-].
#: A sampled sinusoid's largest step is at most 0.19 of it (8 samples; less with more).
JUMP_FRACTION = 0.25
#: A series with more than this share of its mean-square rate above the harmonics a smooth wing
#: motion has (:func:`unresolved_share`) is not smooth; :class:`MeasuredWing` warns [-]. A
#: triangle-wave sweep has 0.04-0.05, the sharpest pitch of Table 4 (C_η = 5) 0.03, a step smoothed
#: over 3 of 64 samples 0.29, over 1/64 of the cycle at any sampling 0.7.
UNRESOLVED_SHARE = 0.1
#: The harmonics a smooth wing motion lives in [-]: Table 4's sharpest waveforms, the triangle
#: sweep (K = 1) and the near-square pitch (C_η = 5), keep 96-97 % of their mean-square rate in
#: the first 10. Above them a series' rate is that of a step, however finely it is sampled:
#: ramped over 1/64 of the cycle it is 20 times a sinusoid's, and the power (∝ rate³) is
#: thousands of times the smooth stroke's.
SMOOTH_HARMONICS = 10
#: With ``degrees=True``, a sweep and pitch that never leave ±this [deg] look like radians
#: given as degrees (a stroke of a few degrees); the constructors warn.
RADIANS_AS_DEGREES = 2.0 * math.pi

_DEGREES_HINT = (
    "angles here are radians; these values look like degrees: convert with np.deg2rad, or use "
    "MeasuredWing.from_fourier / from_samples with degrees=True"
)


def wrap_angle(angle: float) -> float:
    """``angle`` [rad] wrapped to (−π, π]; angles already in that range are returned unchanged."""
    if -math.pi < angle <= math.pi:
        return angle
    return math.pi - (math.pi - angle) % (2.0 * math.pi)


def _series(name: str, value: Any, ndim: tuple[int, ...] = (1,)) -> np.ndarray:
    """A read-only float array from an array or a (nested) list; errors name the field."""
    shapes = " or ".join({1: "(n,)", 2: "(n, k)"}[d] for d in ndim)
    arr = np.array(
        real_array(value, f"MeasuredWing.{name}", f"an array or list of numbers, shape {shapes}")
    )
    if arr.ndim not in ndim:
        raise ValueError(f"MeasuredWing.{name} has shape {arr.shape}; allowed: {shapes}")
    if arr.ndim == 2 and arr.shape[1] == 0:
        raise ValueError(
            f"MeasuredWing.{name} has shape {arr.shape}, no columns; allowed: {shapes} with k >= 1"
        )
    bad = ~np.isfinite(arr)
    if bad.any():
        index = tuple(int(i) for i in np.argwhere(bad)[0])
        where = index[0] if len(index) == 1 else index
        raise ValueError(
            f"MeasuredWing.{name} has non-finite samples (first at {where}: {arr[index]}); "
            "allowed: finite values (fill gaps in the measurement first)"
        )
    arr.setflags(write=False)
    return arr


def _real(name: str, value: Any) -> float:
    if not is_real(value):
        raise ValueError(f"MeasuredWing.{name} = {value!r}; allowed: a finite number")
    return float(value)


@dataclass(frozen=True, eq=False)
class MeasuredWing:
    """One wing pair's measured kinematics over one cycle (e.g. digitised from high-speed film).

    Conventions of every angle (zero and positive direction) are in this module's docstring and
    in docs/measured.md; the sign of η matters (a flipped η pitches the leading edge down, and
    :func:`evaluate_measured` warns when the pitch looks flipped). Lists are accepted wherever an
    array is expected and are stored as read-only float arrays.
    """

    sweep: np.ndarray
    """φ(t) [rad], (n,) samples uniform over one cycle, t = 0 … (n − 1)/n·T."""
    elevation: np.ndarray
    """θ(t) [rad], same sampling."""
    pitch: np.ndarray
    """η(t) [rad], (n,), or (n, k) at the span stations ``pitch_stations``."""
    frequency: float
    """Wing-beat frequency f [Hz]."""
    stroke_plane_angle: float
    """β [rad] from the horizontal (give a climb as ``flight_path_angle``); any angle within one
    turn, stored wrapped to (−π, π]."""
    pitch_stations: np.ndarray | None = None
    """(k,) span stations r/R of the pitch columns, strictly increasing in [0, 1]; required
    with a 2-D ``pitch``."""

    def __post_init__(self) -> None:
        sweep = _series("sweep", self.sweep)
        elevation = _series("elevation", self.elevation)
        pitch = _series("pitch", self.pitch, ndim=(1, 2))
        n = sweep.shape[0]
        if not MIN_SAMPLES <= n <= MAX_SAMPLES:
            raise ValueError(
                f"MeasuredWing.sweep has {n} samples; allowed: at least {MIN_SAMPLES} and at most "
                f"{MAX_SAMPLES} per cycle (resample a longer series)"
            )
        for name, arr in (("elevation", elevation), ("pitch", pitch)):
            if arr.shape[0] != n:
                raise ValueError(
                    f"MeasuredWing.{name} has {arr.shape[0]} samples but sweep has {n}; allowed: "
                    "the same length (the same time samples over one cycle)"
                )
        stations = self._stations(pitch)
        frequency = _real("frequency", self.frequency)
        if not (math.isfinite(frequency) and 0.0 < frequency <= 1000.0):
            raise ValueError(
                f"MeasuredWing.frequency = {self.frequency!r} Hz; allowed: 0 < f <= 1000 Hz"
            )
        beta = _real("stroke_plane_angle", self.stroke_plane_angle)
        if not (math.isfinite(beta) and abs(beta) <= 2.0 * math.pi):
            raise ValueError(
                f"MeasuredWing.stroke_plane_angle = {self.stroke_plane_angle!r} rad; allowed: "
                f"finite, within one turn (|β| <= 2π; it is wrapped to (−π, π]); {_DEGREES_HINT}"
            )
        self._check_radians(sweep, elevation, pitch)
        for name, arr in (("sweep", sweep), ("elevation", elevation), ("pitch", pitch)):
            if not _warn_jumps(name, arr):
                _warn_unresolved(name, arr)
        for name, value in (
            ("sweep", sweep),
            ("elevation", elevation),
            ("pitch", pitch),
            ("frequency", frequency),
            ("stroke_plane_angle", wrap_angle(beta)),
            ("pitch_stations", stations),
        ):
            object.__setattr__(self, name, value)

    def _stations(self, pitch: np.ndarray) -> np.ndarray | None:
        if self.pitch_stations is None:
            if pitch.ndim == 2:
                raise ValueError(
                    f"MeasuredWing.pitch has shape {pitch.shape} (one column per span station) "
                    "but pitch_stations is not given; allowed: pitch_stations of shape "
                    f"({pitch.shape[1]},) in r/R"
                )
            return None
        stations = _series("pitch_stations", self.pitch_stations)
        k = 1 if pitch.ndim == 1 else pitch.shape[1]
        if stations.shape[0] != k:
            raise ValueError(
                f"MeasuredWing.pitch_stations has {stations.shape[0]} entries but pitch has {k} "
                "column(s); allowed: one station per pitch column"
            )
        if np.any(np.diff(stations) <= 0.0):
            raise ValueError(
                f"MeasuredWing.pitch_stations = {stations.tolist()} are not in order; allowed: "
                "strictly increasing r/R"
            )
        if stations[0] < 0.0 or stations[-1] > 1.0:
            raise ValueError(
                f"MeasuredWing.pitch_stations = {stations.tolist()}; allowed: r/R from 0 to 1"
            )
        return stations

    @staticmethod
    def _check_radians(sweep: np.ndarray, elevation: np.ndarray, pitch: np.ndarray) -> None:
        """Reject angles that are plainly degrees given as radians (see the messages)."""
        stroke = float(sweep.max() - sweep.min())
        if stroke > math.pi or np.abs(sweep).max() > 2.0 * math.pi:
            raise ValueError(
                f"MeasuredWing.sweep spans {sweep.min():.4g} to {sweep.max():.4g} rad; allowed: "
                f"a stroke of at most π rad (180°) peak to peak; {_DEGREES_HINT}"
            )
        if np.abs(elevation).max() > 0.5 * math.pi:
            raise ValueError(
                f"MeasuredWing.elevation reaches {np.abs(elevation).max():.4g} rad; allowed: "
                f"|θ| <= π/2 rad (90°); {_DEGREES_HINT}"
            )
        if np.abs(pitch).max() > 2.0 * math.pi:
            raise ValueError(
                f"MeasuredWing.pitch reaches {np.abs(pitch).max():.4g} rad; allowed: "
                f"|η| <= 2π rad; {_DEGREES_HINT}"
            )

    # --- constructors --------------------------------------------------------------------
    @classmethod
    def from_fourier(
        cls,
        frequency: float,
        sweep: tuple[float, Sequence[tuple[float, float]]],
        elevation: tuple[float, Sequence[tuple[float, float]]],
        pitch: tuple[float, Sequence[tuple[float, float]]]
        | Sequence[tuple[float, Sequence[tuple[float, float]]]],
        stroke_plane_angle: float,
        *,
        n_samples: int = FOURIER_SAMPLES,
        degrees: bool = True,
        pitch_stations: Sequence[float] | np.ndarray | None = None,
    ) -> MeasuredWing:
        """A wing from Fourier series, X(t) = mean + Σ_k a_k·cos(2πk·f·t + ψ_k).

        Each angle is ``(mean, [(a_1, ψ_1), (a_2, ψ_2), …])``, harmonic k = 1, 2, … in order
        (give amplitude 0 for a missing one); with ``pitch_stations`` (k,), ``pitch`` is a list
        of k such series, one per station. ``degrees``: means, amplitudes, phases and
        ``stroke_plane_angle`` in degrees (else radians). Sampled at ``n_samples`` points
        t = i/(n·f); the series must have fewer than n/2 harmonics (Nyquist).
        """
        n_samples = count(n_samples, "from_fourier: n_samples", MIN_SAMPLES, MAX_SAMPLES)
        degrees = flag(degrees, "from_fourier: degrees")
        unit = "deg" if degrees else "rad"
        if pitch_stations is None:
            pitch_series = [_fourier_series("pitch", pitch, unit)]
        else:
            if (
                not isinstance(pitch, (list, tuple))
                or len(pitch) == 0
                or not all(isinstance(p, (list, tuple)) and len(p) == 2 for p in pitch)
                or _looks_like_one_series(pitch)
            ):
                raise ValueError(
                    "from_fourier: with pitch_stations, pitch must be a list of series "
                    "[(mean, [(amplitude, phase), …]), …], one per station; got "
                    f"{pitch!r}"
                )
            pitch_series = [_fourier_series(f"pitch[{i}]", p, unit) for i, p in enumerate(pitch)]
        series = {
            "sweep": _fourier_series("sweep", sweep, unit),
            "elevation": _fourier_series("elevation", elevation, unit),
        }
        for name, (mean, harmonics) in [
            *series.items(),
            *((f"pitch[{i}]", p) for i, p in enumerate(pitch_series)),
        ]:
            if len(harmonics) >= n_samples / 2:
                raise ValueError(
                    f"from_fourier: {name} has {len(harmonics)} harmonics; allowed: fewer than "
                    f"n_samples/2 = {n_samples / 2:g} (raise n_samples)"
                )
            if not degrees:
                size = max([abs(mean), *(abs(a) for a, _ in harmonics)])
                if size > 2.0 * math.pi:
                    raise ValueError(
                        f"from_fourier: {name} has a mean or amplitude of {shown(size, 2 * math.pi)} "
                        "rad; allowed: "
                        "at most 2π rad; these look like degrees: pass degrees=True"
                    )
        to_rad = np.deg2rad if degrees else np.asarray
        sampled = {
            name: to_rad(fourier_samples(*s, n_samples, degrees=degrees))
            for name, s in series.items()
        }
        pitch_samples = np.stack(
            [to_rad(fourier_samples(*p, n_samples, degrees=degrees)) for p in pitch_series], axis=1
        )
        if degrees:
            _warn_radians("from_fourier", sampled["sweep"], pitch_samples)
        beta = _real("stroke_plane_angle", stroke_plane_angle)
        return cls(
            sweep=sampled["sweep"],
            elevation=sampled["elevation"],
            pitch=pitch_samples[:, 0] if pitch_stations is None else pitch_samples,
            frequency=frequency,
            stroke_plane_angle=math.radians(beta) if degrees else beta,
            pitch_stations=pitch_stations,
        )

    @classmethod
    def from_samples(
        cls,
        time: Sequence[float] | np.ndarray,
        sweep: Sequence[float] | np.ndarray,
        elevation: Sequence[float] | np.ndarray,
        pitch: Sequence[float] | np.ndarray,
        stroke_plane_angle: float,
        *,
        frequency: float,
        degrees: bool = True,
        pitch_stations: Sequence[float] | np.ndarray | None = None,
    ) -> MeasuredWing:
        """A wing from time-stamped samples over one cycle (a CSV of digitised angles).

        ``time`` [s] must be uniform and span one cycle of ``frequency`` f [Hz]: either open
        (t_0 … t_0 + (n − 1)/n·T) or closed (the last sample at t_0 + T repeats the first and is
        dropped). The cycle fraction counts from t_0. ``degrees``: angles and
        ``stroke_plane_angle`` in degrees (else radians). ``pitch``: (n,) or (n, k) with
        ``pitch_stations``.
        """
        degrees = flag(degrees, "from_samples: degrees")
        t = _series("time", time)
        freq = _real("frequency", frequency)
        if not (math.isfinite(freq) and freq > 0.0):
            raise ValueError(f"from_samples: frequency = {frequency!r} Hz; allowed: f > 0")
        arrays = {
            "sweep": _series("sweep", sweep),
            "elevation": _series("elevation", elevation),
            "pitch": _series("pitch", pitch, ndim=(1, 2)),
        }
        for name, arr in arrays.items():
            if arr.shape[0] != t.shape[0]:
                raise ValueError(
                    f"from_samples: {name} has {arr.shape[0]} samples but time has {t.shape[0]}; "
                    "allowed: one angle per time sample"
                )
        if t.shape[0] < MIN_SAMPLES + 1:
            raise ValueError(
                f"from_samples: {t.shape[0]} samples; allowed: at least {MIN_SAMPLES + 1}"
            )
        step = np.diff(t)
        mean_step = float(step.mean())
        off = np.abs(step - mean_step) > TIME_TOLERANCE * abs(mean_step)
        if mean_step <= 0.0 or off.any():
            i = int(np.flatnonzero(off)[0]) if off.any() else 0
            raise ValueError(
                f"from_samples: time is not uniform (step {i}: {step[i]:.6g} s, mean step "
                f"{mean_step:.6g} s); allowed: increasing, uniformly spaced samples (within "
                f"{TIME_TOLERANCE:g} of the step; resample non-uniform data first)"
            )
        period = 1.0 / freq
        n = t.shape[0]
        if abs(n * mean_step - period) <= TIME_TOLERANCE * period:
            keep = n
        elif abs((n - 1) * mean_step - period) <= TIME_TOLERANCE * period:
            keep = n - 1  # closed cycle: the last sample is the first one again
        else:
            raise ValueError(
                f"from_samples: {n} samples every {mean_step:.6g} s span {n * mean_step:.6g} s "
                f"(open) or {(n - 1) * mean_step:.6g} s (closed), but one cycle at "
                f"frequency = {freq:g} Hz is {period:.6g} s; allowed: samples over exactly one "
                "cycle"
            )
        to_rad = np.deg2rad if degrees else np.asarray
        if degrees:
            _warn_radians("from_samples", to_rad(arrays["sweep"]), to_rad(arrays["pitch"]))
        beta = _real("stroke_plane_angle", stroke_plane_angle)
        return cls(
            sweep=to_rad(arrays["sweep"][:keep]),
            elevation=to_rad(arrays["elevation"][:keep]),
            pitch=to_rad(arrays["pitch"][:keep]),
            frequency=freq,
            stroke_plane_angle=math.radians(beta) if degrees else beta,
            pitch_stations=pitch_stations,
        )

    # --- derived quantities ------------------------------------------------------------------
    @property
    def n_samples(self) -> int:
        """Samples per cycle [-]."""
        return int(self.sweep.shape[0])

    @property
    def sweep_amplitude(self) -> float:
        """Half the peak-to-peak sweep [rad] (sets the swept sector of the inflow model)."""
        return 0.5 * float(self.sweep.max() - self.sweep.min())

    @property
    def twisted(self) -> bool:
        """True if the pitch varies along the span (a 2-D pitch whose columns differ)."""
        return self.pitch.ndim == 2 and not np.all(self.pitch == self.pitch[:, :1])

    def uniform_pitch(self) -> np.ndarray:
        """η(t) [rad] of an untwisted wing (a 2-D pitch with equal columns gives its first)."""
        if self.twisted:
            raise ValueError("this MeasuredWing is twisted: use pitch_at(r_hat)")
        return self.pitch if self.pitch.ndim == 1 else self.pitch[:, 0]

    def station_weights(self, r_hat: np.ndarray) -> np.ndarray:
        """(m, k) weights that interpolate the station pitches linearly to ``r_hat`` (m,) [r/R],
        held constant beyond the end stations."""
        r_hat = np.asarray(r_hat, dtype=float)
        stations = self.pitch_stations if self.pitch_stations is not None else np.zeros(1)
        eye = np.eye(stations.shape[0])
        return np.stack([np.interp(r_hat, stations, row) for row in eye], axis=1)

    def pitch_at(self, r_hat: np.ndarray | float) -> np.ndarray:
        """η(t) [rad] at span positions r/R: (n,) for a scalar, (n, m) for (m,) positions."""
        if self.pitch.ndim == 1:
            r = np.asarray(r_hat, dtype=float)
            return self.pitch if r.ndim == 0 else np.repeat(self.pitch[:, None], r.size, 1)
        r = np.atleast_1d(np.asarray(r_hat, dtype=float))
        eta = self.pitch @ self.station_weights(r).T
        return eta[:, 0] if np.ndim(r_hat) == 0 else eta

    def angle_history(self, r_hat: np.ndarray | None = None) -> np.ndarray:
        """φ, φ̇, φ̈, θ, θ̇, θ̈, η, η̇, η̈ by spectral differentiation [rad, rad/s, rad/s²].

        (n, 9) for an untwisted wing; for a twisted one (m, n, 9), one history per blade element
        at ``r_hat`` (m,) [r/R] (the station rates are interpolated like the angles: both are
        linear in the samples).
        """
        out = np.empty((self.n_samples, 9))
        out[:, 0:3] = spectral_derivatives(self.sweep, self.frequency)
        out[:, 3:6] = spectral_derivatives(self.elevation, self.frequency)
        if not self.twisted:
            out[:, 6:9] = spectral_derivatives(self.uniform_pitch(), self.frequency)
            return out
        if r_hat is None:
            raise ValueError("a twisted MeasuredWing needs the blade elements' r/R")
        stations = spectral_derivatives(self.pitch, self.frequency)  # (n, 3, k)
        weights = self.station_weights(r_hat)  # (m, k)
        per_element = np.repeat(out[None], weights.shape[0], axis=0)
        per_element[:, :, 6:9] = np.einsum("tck,mk->mtc", stations, weights)
        return per_element

    def pitch_sign_correlation(self) -> float:
        """Correlation of the sweep rate φ̇ with sin η at r/R = 0.75 over the cycle [-].

        Positive for a wing that pitches its leading edge up on both half-strokes in our
        convention (η > 0 sweeping forward, η < 0 sweeping back); strongly negative values mean
        the pitch probably has the opposite sign convention. 0 for a wing that does not sweep.
        """
        dphi = spectral_derivatives(self.sweep, self.frequency)[:, 1]
        s = np.sin(self.pitch_at(0.75))
        norm = math.sqrt(float(np.sum(dphi**2) * np.sum(s**2)))
        return float(np.sum(dphi * s) / norm) if norm > 0.0 else 0.0


def _warn_jumps(name: str, series: np.ndarray) -> bool:
    """Warn if a periodic series (n,) or (n, k) [rad] jumps between two samples; whether it did.

    A jump (an angle wrapped by 360°, a sign flip, a gap, the cycle not closing) has no
    derivative: spectral differentiation turns it into huge rates, so the power (∝ rate³) and
    forces come out absurd (P/m of 10⁴ W/kg) without any other sign.
    """
    columns = series.reshape(series.shape[0], -1)
    steps = np.abs(np.diff(columns, axis=0, append=columns[:1]))  # the last step closes the cycle
    variation = steps.sum(axis=0)
    largest = steps.max(axis=0)
    bad = np.flatnonzero(largest > JUMP_FRACTION * np.where(variation > 0, variation, np.inf))
    if bad.size:
        j = int(bad[0])
        i = int(np.argmax(steps[:, j]))
        where = f"{name}[:, {j}]" if series.ndim == 2 else name
        warnings.warn(
            f"MeasuredWing.{where} jumps by {math.degrees(largest[j]):.4g}° from sample {i} to "
            f"{(i + 1) % series.shape[0]} ({largest[j] / variation[j]:.0%} of its whole variation "
            "over the cycle): the derivatives, forces and power of a discontinuous series are "
            "meaningless; unwrap angles (np.unwrap), fill gaps and give exactly one cycle",
            UserWarning,
            stacklevel=4,
        )
    return bool(bad.size)


def smooth_band(n_samples: int) -> float:
    """The highest harmonic a smooth series of ``n_samples`` per cycle has its rate in
    (:func:`unresolved_share`): n/4, the lower half of what the samples resolve, and at most
    :data:`SMOOTH_HARMONICS`, what a wing's motion holds however finely it is sampled."""
    return min(n_samples / 4, SMOOTH_HARMONICS)


def unresolved_share(series: np.ndarray) -> np.ndarray:
    """The share of a periodic series' mean-square rate above :func:`smooth_band` [-], per
    column.

    By Parseval the mean square of the rate dX/dt is the sum over harmonics k of k²·|c_k|²
    (times (2πf)²). A smooth motion has its rate in the first few harmonics (a sinusoid 0, a
    triangle-wave sweep 0.04-0.05 above the 10th); a step, a feature a few samples wide or
    sample-to-sample noise puts a large share above them, and then the rate, the forces and
    the power (∝ rate³) follow the step or the sampling, not a wing's motion.
    (n, k) -> (k,); (n,) -> (1,).
    """
    columns = series.reshape(series.shape[0], -1)
    n = columns.shape[0]
    coefficients = np.fft.rfft(columns, axis=0)[1:]
    k = np.arange(1, coefficients.shape[0] + 1)[:, None]
    if n % 2 == 0:  # the Nyquist harmonic is counted once, not twice
        coefficients[-1] *= 0.5
    energy = k**2 * np.abs(coefficients) ** 2
    total = energy.sum(axis=0)
    upper = energy[k[:, 0] > smooth_band(n)].sum(axis=0)
    return np.divide(upper, total, out=np.zeros_like(total), where=total > 0)


def _warn_unresolved(name: str, series: np.ndarray) -> None:
    """Warn if the samples do not resolve a series' rate (:func:`unresolved_share`)."""
    share = unresolved_share(series)
    bad = np.flatnonzero(share > UNRESOLVED_SHARE)
    if bad.size:
        j = int(bad[0])
        where = f"{name}[:, {j}]" if series.ndim == 2 else name
        warnings.warn(
            f"MeasuredWing.{where}: {share[j]:.0%} of its mean-square rate lies in harmonics "
            f"above {smooth_band(series.shape[0]):g} (allowed: at most {UNRESOLVED_SHARE:.0%}; "
            f"n/4 of its {series.shape[0]} samples, at most {SMOOTH_HARMONICS}, where a smooth "
            "wing motion has its rate): it is not smooth (a step, a feature a few samples wide, "
            "or noise), so its rates, forces and power follow the step or the sampling, not a "
            "wing's motion; give smooth, periodic kinematics (e.g. a Fourier series of at most "
            f"{SMOOTH_HARMONICS} harmonics)",
            UserWarning,
            stacklevel=4,
        )


def _warn_radians(where: str, sweep: np.ndarray, pitch: np.ndarray) -> None:
    """Warn if angles given in degrees [now rad] look like radians (see RADIANS_AS_DEGREES)."""
    limit = math.radians(RADIANS_AS_DEGREES)
    size = max(float(np.abs(sweep).max()), float(np.abs(pitch).max()))
    if 0.0 < size <= limit:
        warnings.warn(
            f"{where}: with degrees=True the sweep and pitch never exceed "
            f"{math.degrees(size):.3g}°: these look like radians; pass degrees=False (a "
            "kinematics file: degrees: false) if they are",
            UserWarning,
            stacklevel=3,
        )


#: Below this :meth:`MeasuredWing.pitch_sign_correlation`, :func:`evaluate_measured` warns.
PITCH_SIGN_WARNING = -0.5


def _looks_like_one_series(value: Any) -> bool:
    """(mean, harmonics) itself rather than a list of such pairs."""
    return len(value) == 2 and isinstance(value[0], (int, float, np.integer, np.floating))


def _fourier_series(name: str, value: Any, unit: str) -> tuple[float, list[tuple[float, float]]]:
    """(mean, [(amplitude, phase), …]) checked, as floats; errors name the field."""
    usage = (
        f"from_fourier: {name} must be (mean, [(amplitude_1, phase_1), (amplitude_2, phase_2), "
        f"…]) in {unit}"
    )
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        raise ValueError(f"{usage}; got {value!r}")
    mean, harmonics = value
    try:
        mean = float(mean)
        pairs = [(float(a), float(p)) for a, p in np.asarray(harmonics, dtype=float).reshape(-1, 2)]
    except (TypeError, ValueError):
        raise ValueError(f"{usage}; got {value!r}") from None
    if np.ndim(harmonics) != 2 and len(pairs) > 0:
        raise ValueError(f"{usage}; got harmonics {harmonics!r}")
    if not all(math.isfinite(x) for x in (mean, *(c for pair in pairs for c in pair))):
        raise ValueError(f"from_fourier: {name} has a non-finite coefficient: {value!r}")
    return mean, pairs


def fourier_samples(
    mean: float, harmonics: Sequence[tuple[float, float]], n: int, *, degrees: bool = False
) -> np.ndarray:
    """X_i = mean + Σ_k a_k·cos(2πk·i/n + ψ_k), i = 0 … n − 1 (t = i/(n·f)).

    The samples are in the unit of ``mean`` and the amplitudes; the phases ψ_k are in degrees
    if ``degrees``, else radians.
    """
    phase = 2.0 * np.pi * np.arange(n) / n
    out = np.full(n, float(mean))
    for k, (amplitude, offset) in enumerate(harmonics, start=1):
        out += amplitude * np.cos(k * phase + (math.radians(offset) if degrees else offset))
    return out


# --- evaluation --------------------------------------------------------------------------------


def _describe(value: Any) -> str:
    """A short, one-line description of a wrong argument for an error message."""
    if isinstance(value, np.ndarray):
        return f"an array of shape {value.shape}"
    text = " ".join(repr(value).split())
    return text if len(text) <= 60 else text[:57] + "..."


def _check_inputs(fore: Any, hind: Any, insect: Any, options: Any) -> None:
    for name, value in (("fore", fore), ("hind", hind)):
        if not isinstance(value, MeasuredWing):
            raise ValueError(
                f"evaluate_measured: {name} = {_describe(value)}; allowed: a MeasuredWing (e.g. "
                "MeasuredWing(sweep, elevation, pitch, frequency, stroke_plane_angle) or "
                "MeasuredWing.from_fourier(...))"
            )
    if not isinstance(insect, Dragonfly):
        raise ValueError(f"evaluate_measured: insect = {_describe(insect)}; allowed: a Dragonfly")
    if not isinstance(options, ModelOptions):
        raise ValueError(
            f"evaluate_measured: options = {_describe(options)}; allowed: a ModelOptions"
        )
    if fore.n_samples != hind.n_samples:
        raise ValueError(
            f"evaluate_measured: fore has {fore.n_samples} samples per cycle and hind "
            f"{hind.n_samples}; allowed: the same number (resample one, or give both the same "
            "n_samples in from_fourier)"
        )
    for name, wing in (("fore", fore), ("hind", hind)):
        corr = wing.pitch_sign_correlation()
        if corr < PITCH_SIGN_WARNING:
            warnings.warn(
                f"evaluate_measured: the {name}-wing's pitch η runs against its sweep rate "
                f"(correlation of φ̇ and sin η = {corr:.2f}): in this model η > 0 turns the "
                "leading edge forward, so η > 0 on the forward stroke and η < 0 on the backward "
                "stroke pitch the leading edge up (docs/measured.md). If your source measures "
                "pitch the other way, pass −η.",
                UserWarning,
                stacklevel=3,
            )


def measured_inputs(
    fore: MeasuredWing, hind: MeasuredWing, insect: Dragonfly, options: ModelOptions
) -> tuple[list[np.ndarray], list[np.ndarray], np.ndarray, np.ndarray, np.ndarray]:
    """Kernel inputs of a measured pair (B = 1): angles, weights, frequency, β, sweep.

    The angles of an untwisted wing are (1, n, 9); of a twisted one (n_blade, n, 9), one history
    per blade element of the insect's wing (:func:`run_measured`).
    """
    angles, weights = [], []
    for wing, geometry in ((fore, insect.fore), (hind, insect.hind)):
        if wing.twisted:
            nodes, _ = wing_tables(geometry, options.n_blade, insect.air_density)
            angles.append(wing.angle_history(nodes[:, cycle.N_R] / geometry.length))
        else:
            angles.append(wing.angle_history()[None])
        weights.append(np.ones((1, wing.n_samples)))
    frequency = np.array([[fore.frequency, hind.frequency]])
    beta = np.array([[fore.stroke_plane_angle, hind.stroke_plane_angle]])
    sweep = np.array([[fore.sweep_amplitude, hind.sweep_amplitude]])
    return angles, weights, frequency, beta, sweep


@lru_cache(maxsize=32)
def element_tables(wing: Wing, n_blade: int, air_density: float) -> list[tuple[np.ndarray, ...]]:
    """(nodes, constants) of each blade element of a wing alone: one-row node tables and the
    wing's constants with that element's share of the inertia (:func:`model.node_inertia`)."""
    nodes, consts = wing_tables(wing, n_blade, air_density)
    span_inertia, pitch_inertia = node_inertia(wing, nodes)
    out = []
    for j in range(n_blade):
        c = consts.copy()
        c[cycle.K_I_SPAN] = span_inertia[j]
        c[cycle.K_I_PITCH] = pitch_inertia[j]
        row = np.ascontiguousarray(nodes[j : j + 1])
        for a in (row, c):
            a.setflags(write=False)
        out.append((row, c))
    return out


def run_measured(
    angles: list[np.ndarray],
    weights: list[np.ndarray],
    frequency: np.ndarray,
    beta: np.ndarray,
    sweep: np.ndarray,
    speed: np.ndarray,
    flight_path_angle: np.ndarray,
    insect: Dragonfly,
    options: ModelOptions,
    keep_history: bool = False,
    fields_out: list | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`model.run_kernel` for a measured pair, twisted wings included (same outputs;
    ``fields_out`` as it takes it, for untwisted wings).

    Untwisted wings run the kernel as they are. With a twisted wing, each blade element j of
    both wings runs alone (the fore- and hind-wing's element j together, so the slipstream
    coupling of annulus j is kept) with its own pitch history; the per-sample forces and powers
    are sums over the elements, and the cycle means are taken of those sums
    (:func:`cycle.cycle_means`), exactly as the kernel does for a whole wing.
    """
    if all(a.shape[0] == 1 for a in angles):
        return run_kernel(
            angles, weights, frequency, beta, sweep, speed, flight_path_angle, insect, options,
            keep=Kept(history=bool(keep_history), fields=fields_out),
        )  # fmt: skip
    n_blade = options.n_blade
    n_time = weights[0].shape[1]
    fore_tables = element_tables(insect.fore, n_blade, insect.air_density)
    hind_tables = element_tables(insect.hind, n_blade, insect.air_density)
    history = np.zeros((1, 2, n_time, 5))
    inflow = np.empty((1, 2, n_blade))
    out = np.empty((1, 2, cycle.N_WING_OUT))
    aoa = np.zeros(2)
    mean_inflow = np.zeros(2)
    area = np.zeros(2)
    converged = np.ones(2, dtype=bool)
    evaluations = np.zeros(2)
    work = np.zeros((2, 2))  # force sweeps and slopes, all elements together
    for j in range(n_blade):
        element = [a[j : j + 1] if a.shape[0] > 1 else a for a in angles]
        tables = (*fore_tables[j], *hind_tables[j])
        out_j, inflow_j, history_j = run_kernel(
            element, weights, frequency, beta, sweep, speed, flight_path_angle, insect, options,
            keep=Kept(history=True), tables=tables,
        )  # fmt: skip
        history += history_j
        inflow[0, :, j] = inflow_j[0, :, 0]
        for w, (nodes, _) in enumerate((fore_tables[j], hind_tables[j])):
            a_j = nodes[0, cycle.N_CHORD] * nodes[0, cycle.N_WIDTH]
            area[w] += a_j
            aoa[w] += out_j[0, w, cycle.W_AOA] * a_j
            mean_inflow[w] += inflow_j[0, w, 0] * a_j
            converged[w] &= out_j[0, w, cycle.W_CONVERGED] > 0.5
            evaluations[w] = max(evaluations[w], out_j[0, w, cycle.W_EVALS])
            work[w] += out_j[0, w, [cycle.W_SWEEPS, cycle.W_SLOPES]]
    cos_table, sin_table = cycle.fourier_tables(n_time)
    for w in range(2):
        cycle.cycle_means(history[0, w], weights[w][0], out[0, w], cos_table, sin_table)
        out[0, w, cycle.W_AOA] = aoa[w] / area[w]
        out[0, w, cycle.W_INFLOW] = mean_inflow[w] / area[w]
        out[0, w, cycle.W_CONVERGED] = 1.0 if converged[w] else 0.0
        out[0, w, cycle.W_EVALS] = evaluations[w]
        out[0, w, [cycle.W_SWEEPS, cycle.W_SLOPES]] = work[w]
    return out, inflow, history if keep_history else np.empty((0, 2, n_time, 5))


def evaluate_measured(
    fore: MeasuredWing,
    hind: MeasuredWing,
    speed: float = 0.0,
    available_power: float | None = None,
    *,
    flight_path_angle: float = 0.0,
    insect: Dragonfly = DRAGONFLY,
    options: ModelOptions = DEFAULT_OPTIONS,
) -> Result:
    """Forces and power of measured kinematics (B = 1), by the same compiled model.

    Parameters
    ----------
    fore, hind : MeasuredWing
        Each wing pair's kinematics over one of its cycles, with the same number of samples
        (the cycle is sampled as given; ``options.n_time`` is not used). Derivatives are
        spectral (the series are periodic).
    speed : float
        Flight speed V [m/s], 0 to 20, along the flight path.
    available_power : float, optional
        Available power per body mass [W/kg] for the power constraint; default the insect's.
    flight_path_angle : float
        γ [rad], + climbing, −π/2 to π/2: the body moves along V·(cos γ, sin γ) in earth axes.
        Each wing's ``stroke_plane_angle`` stays measured from the horizontal, as biologists
        report it; the flow sees the stroke plane at β + γ to the path.
    insect : Dragonfly
        Geometry, masses, planform and each wing's force-coefficient model.
    options : ModelOptions
        Resolution along the span, inflow model and conventions.

    Returns
    -------
    Result
        B = 1. Every force is in earth axes: ``lift_to_weight`` is the vertical force over the
        weight, ``thrust``, ``drag`` and ``*_horizontal_force`` are horizontal (+ forward).

    Warns
    -----
    UserWarning
        If a wing's pitch runs against its sweep rate (likely the opposite η sign convention).
    """
    _check_inputs(fore, hind, insect, options)
    v, p_avail, gamma = validate_conditions(speed, available_power, flight_path_angle, 1, insect)
    angles, weights, frequency, beta, sweep = measured_inputs(fore, hind, insect, options)
    out, _, _ = run_measured(angles, weights, frequency, beta, sweep, v, gamma, insect, options)
    return _performance(out, v, gamma, p_avail, insect, options)
