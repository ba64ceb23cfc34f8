"""``python -m eval measured KINEMATICS.yaml``: a filmed insect's kinematics in, forces out
(:data:`DESCRIPTION`, docs/measured.md; complete files in ``examples/``)."""

from __future__ import annotations

import argparse
import csv
import io
import json
import math
import sys
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np

from tandem_env.io.datafile import DataFileError, read_text, read_yaml
from tandem_env.io.files import output_directory, write_text_atomic
from tandem_env.physics import (
    Dragonfly,
    MeasuredWing,
    ModelOptions,
    Result,
    StrokeHistory,
    measured_history,
)
from tandem_env.physics.insect import load_insect
from tandem_env.physics.measured import FOURIER_SAMPLES, MAX_SAMPLES

NAME = "measured"
HELP = "forces and power of measured wing kinematics (YAML: insect, kinematics, flight)"
DESCRIPTION = """\
Evaluate measured wing kinematics with the tandem-wing model. KINEMATICS.yaml gives
  insect:      optional; fields of the insect and of each wing (SI units), e.g. body_mass,
               fore: {length, mean_chord, mass, planform, coefficients}, hind: {...};
  flight:      speed [m/s], flight_path_angle [deg, + climbing], available_power [W/kg];
  options:     optional ModelOptions fields (n_blade, induction, ...);
  kinematics:  degrees (default true), n_samples (Fourier sampling, default 256), and for
               each of fore and hind: frequency [Hz], stroke_plane_angle (from the horizontal),
               then either Fourier series sweep/elevation/pitch: {mean: .., harmonics:
               [[amplitude, phase], ...]} (X = mean + sum a_k cos(2 pi k f t + phase_k)), or
               csv: FILE with columns: {time: .., sweep: .., elevation: .., pitch: ..};
               span-wise pitch: pitch_stations: [r/R, ...] with one pitch per station.
Angle conventions (sweep + forward, elevation + up, pitch 0 = chord normal to the stroke
plane, + leading edge forward) are in docs/measured.md. Writes into --out:
  NAME.json   inputs, cycle means (earth axes), per-wing histories over the cycle;
  NAME.png    vertical and horizontal force and power of each wing pair over the cycle."""
EPILOG = """\
example:
  python -m eval measured examples/forward_flight.yaml --out results/measured"""

DEFAULT_OUT = Path("results") / "measured"
ANGLES = ("sweep", "elevation", "pitch")
WINGS = ("fore", "hind")
#: The per-wing histories a record keeps (fields of the history of each wing pair).
WING_HISTORY = tuple(
    "cycle_fraction time sweep elevation pitch angle_of_attack vertical_force horizontal_force "
    "aero_power inertial_power".split()
)


class SpecError(ValueError):
    """A bad field in a kinematics file; the message names the field and what is allowed."""


@dataclass(frozen=True)
class MeasuredCase:
    """One measured flight: both wing pairs, the insect and the flight condition."""

    name: str
    description: str
    fore: MeasuredWing
    hind: MeasuredWing
    speed: float
    """V [m/s]."""
    flight_path_angle: float
    """γ [rad], + climbing."""
    available_power: float | None
    """[W/kg]; None: the insect's."""
    insect: Dragonfly
    options: ModelOptions


def _mapping(value: Any, where: str, allowed: tuple[str, ...] = ()) -> dict[str, Any]:
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise SpecError(f"{where} = {value!r}; allowed: a mapping of fields")
    if allowed:
        _take(value, allowed, where)
    return dict(value)


def _take(spec: Mapping[str, Any], allowed: tuple[str, ...], where: str) -> None:
    if unknown := sorted(set(spec) - set(allowed)):
        raise SpecError(f"{where}.{unknown[0]}: unknown field; allowed: {', '.join(allowed)}")


def _number(value: Any, where: str, unit: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise SpecError(f"{where} = {value!r}; allowed: a finite number [{unit}]")
    return float(value)


def _series(value: Any, where: str) -> tuple[float, list[tuple[float, float]]]:
    """A Fourier series as {mean, harmonics} or [mean, [[a, phase], ...]]."""
    if isinstance(value, Mapping):
        series = _mapping(value, where, ("mean", "harmonics"))
        mean, harmonics = series.get("mean", 0.0), series.get("harmonics", [])
    elif isinstance(value, (list, tuple)) and len(value) == 2:
        mean, harmonics = value
    else:
        msg = f"{where} = {value!r}; allowed: {{mean: M, harmonics: [[amplitude, phase], ...]}}"
        raise SpecError(msg)
    mean = _number(mean, f"{where}.mean", "deg or rad")
    if not isinstance(harmonics, (list, tuple)):
        raise SpecError(f"{where}.harmonics = {harmonics!r}; allowed: [[amplitude, phase], ...]")
    pairs = []
    for k, pair in enumerate(harmonics):
        at = f"{where}.harmonics[{k}]"
        if not isinstance(pair, (list, tuple)) or len(pair) != 2:
            raise SpecError(f"{at} = {pair!r}; allowed: [amplitude, phase] of harmonic {k + 1}")
        pairs.append(
            (_number(pair[0], f"{at}[0]", "amplitude"), _number(pair[1], f"{at}[1]", "phase"))
        )
    return mean, pairs


def _read_csv(path: Path, where: str) -> dict[str, np.ndarray]:
    table = f"{where}.csv {str(path)!r}"  # how every message names the file
    try:  # a missing file too: read_text says it cannot be read, and why
        text = read_text(path, f"{where}.csv")
        reader = csv.reader(io.StringIO(text, newline=""))
        rows = [row for row in reader if row and not row[0].lstrip().startswith("#")]
    except DataFileError as error:
        raise SpecError(str(error)) from None
    except csv.Error as exc:
        raise SpecError(f"{table}: not CSV ({exc})") from None
    if len(rows) < 2:
        raise SpecError(f"{table}: needs a header row and samples")
    if len(rows) - 1 > MAX_SAMPLES + 1:  # before parsing a huge file (a closed cycle: + 1)
        raise SpecError(
            f"{table} has {len(rows) - 1} samples; allowed: at most {MAX_SAMPLES} per cycle "
            "(resample it)"
        )
    header = [h.strip() for h in rows[0]]
    if repeated := sorted({h for h in header if header.count(h) > 1}):
        raise SpecError(
            f"{table}: column {repeated[0]!r} appears {header.count(repeated[0])} times in the "
            "header; allowed: distinct column names"
        )
    data: dict[str, list[float]] = {h: [] for h in header}
    for line, row in enumerate(rows[1:], start=2):
        if len(row) != len(header):
            raise SpecError(
                f"{table} row {line} has {len(row)} values and the header {len(header)}; "
                "allowed: one value per column"
            )
        for h, cell in zip(header, row, strict=True):
            try:
                data[h].append(float(cell))
            except ValueError:
                msg = f"{table} row {line}, column {h!r}: {cell!r} is not a number"
                raise SpecError(msg) from None
    return {h: np.asarray(v) for h, v in data.items()}


def _column(data: dict[str, np.ndarray], name: Any, where: str) -> np.ndarray:
    """Column ``name`` of ``data``; a list of names: those columns side by side, (n, k)."""
    if isinstance(name, list):
        return np.stack([_column(data, n, where) for n in name], axis=1)
    if not isinstance(name, str) or name not in data:
        raise SpecError(f"{where} = {name!r}: not a column; allowed: one of {sorted(data)}")
    return data[name]


def _measured_wing(
    spec: Any, where: str, degrees: bool, n_samples: int, folder: Path
) -> MeasuredWing:
    spec = _mapping(spec, where)
    is_csv = "csv" in spec
    extra = ("csv", "columns") if is_csv else ANGLES
    _take(spec, ("frequency", "stroke_plane_angle", "pitch_stations", *extra), where)
    for key in ("frequency", "stroke_plane_angle"):
        if key not in spec:
            raise SpecError(f"{where}.{key}: missing; allowed: a number")
    frequency = _number(spec["frequency"], f"{where}.frequency", "Hz")
    beta = _number(spec["stroke_plane_angle"], f"{where}.stroke_plane_angle", "deg")
    stations = spec.get("pitch_stations")
    try:
        if not is_csv:
            if missing := [a for a in ANGLES if a not in spec]:
                raise SpecError(
                    f"{where}.{missing[0]}: missing; allowed: a Fourier series, or give csv: "
                    "and columns: instead"
                )
            if stations is None:
                pitch = _series(spec["pitch"], f"{where}.pitch")
            elif not isinstance(spec["pitch"], (list, tuple)):
                msg = f"{where}.pitch: with pitch_stations, a list of series, one per station"
                raise SpecError(msg)
            else:
                pitch = [_series(p, f"{where}.pitch[{i}]") for i, p in enumerate(spec["pitch"])]
            return MeasuredWing.from_fourier(
                frequency,
                _series(spec["sweep"], f"{where}.sweep"),
                _series(spec["elevation"], f"{where}.elevation"),
                pitch,
                beta,
                n_samples=n_samples,
                degrees=degrees,
                pitch_stations=stations,
            )
        data = _read_csv(folder / str(spec["csv"]), where)
        columns = _mapping(spec.get("columns"), f"{where}.columns", ("time", *ANGLES))
        angles = [_column(data, columns.get(a, a), f"{where}.columns.{a}") for a in ANGLES]
        if "time" in columns or "time" in data:
            time = _column(data, columns.get("time", "time"), f"{where}.columns.time")
        else:
            # No time column: the samples are one open cycle, t_i = i/(n f). One constructor for
            # both, so a table without times gets the same checks and warnings (radians given as
            # degrees) as one with them.
            n = len(angles[0])
            time = np.arange(n) / (n * frequency) if frequency > 0 else np.arange(n, dtype=float)
        return MeasuredWing.from_samples(
            time, *angles, beta, frequency=frequency, degrees=degrees, pitch_stations=stations
        )
    except SpecError:
        raise
    except ValueError as exc:
        raise SpecError(f"{where}: {exc}") from None


def load_case(path: str | Path) -> MeasuredCase:
    """Read a kinematics file (format: this module's DESCRIPTION and docs/measured.md)."""
    path = Path(path)
    try:  # a missing file too (read_yaml says so)
        spec = read_yaml(
            path,
            "kinematics file",
            "a mapping with flight, kinematics (fore, hind) and optionally insect, options, "
            "description (docs/measured.md)",
        )
    except DataFileError as error:
        raise SpecError(str(error)) from None
    spec = _mapping(spec, str(path))
    _take(spec, ("description", "insect", "flight", "options", "kinematics"), "file")
    flight = _mapping(
        spec.get("flight"), "flight", ("speed", "flight_path_angle", "available_power")
    )
    kinematics = _mapping(spec.get("kinematics"), "kinematics", ("degrees", "n_samples", *WINGS))
    degrees = kinematics.get("degrees", True)
    if not isinstance(degrees, bool):
        raise SpecError(f"kinematics.degrees = {degrees!r}; allowed: true or false")
    n_samples = kinematics.get("n_samples", FOURIER_SAMPLES)
    wings = [
        _measured_wing(kinematics.get(w), f"kinematics.{w}", degrees, n_samples, path.parent)
        for w in WINGS
    ]
    gamma = _number(flight.get("flight_path_angle", 0.0), "flight.flight_path_angle", "deg")
    try:  # what differs from the paper's specimen, read as --insect and the env keyword read it
        insect = load_insect(_mapping(spec.get("insect"), "insect"))
    except ValueError as exc:
        raise SpecError(str(exc)) from None
    speed = _number(flight.get("speed", 0.0), "flight.speed", "m/s")
    power = flight.get("available_power")
    if power is not None:
        power = _number(power, "flight.available_power", "W/kg")
    # The model options are checked last (after the flight's numbers), as they always were.
    options = _mapping(spec.get("options"), "options", tuple(f.name for f in fields(ModelOptions)))
    try:
        model_options = ModelOptions(**options)
    except (TypeError, ValueError) as exc:
        raise SpecError(f"options: {exc}") from None
    gamma = math.radians(gamma) if degrees else gamma
    description = str(spec.get("description", ""))
    return MeasuredCase(path.stem, description, *wings, speed, gamma, power, insect, model_options)


def summary(history: StrokeHistory, insect: Dragonfly) -> dict[str, dict[str, float]]:
    """L/W, T, D [N], P [W], P/m [W/kg] per wing pair and in total (earth axes)."""
    r: Result = history.result
    keys = ("lift_to_weight", "thrust", "drag", "power", "power_per_mass")
    out = {}
    for name in WINGS:
        thrust, drag = getattr(history, name).thrust_and_drag()
        power, lift = (float(getattr(r, f"{name}_{k}")[0]) for k in ("power", "lift_to_weight"))
        mine = (lift, thrust, drag, power, power / insect.body_mass)
        out[name] = dict(zip(keys, mine, strict=True))
    out["total"] = {key: float(getattr(r, key)[0]) for key in keys}
    return out


def format_summary(case: MeasuredCase, history: StrokeHistory) -> str:
    r = history.result
    rows = summary(history, case.insect)
    lines = [
        f"{case.name}: {case.description}".rstrip(": "),
        f"V = {case.speed:g} m/s, flight path {math.degrees(case.flight_path_angle):+.1f}° "
        f"(forces in earth axes: L vertical, T and D horizontal), "
        f"stroke planes {math.degrees(case.fore.stroke_plane_angle):.1f}° / "
        f"{math.degrees(case.hind.stroke_plane_angle):.1f}° from the horizontal",
        f"{'':10} {'L/W':>7} {'T [mN]':>8} {'D [mN]':>8} {'P [mW]':>8} {'P/m [W/kg]':>11}",
    ]
    for name, label in (("fore", "fore pair"), ("hind", "hind pair"), ("total", "total")):
        row = rows[name]
        lines.append(
            f"{label:10} {row['lift_to_weight']:7.3f} {1e3 * row['thrust']:8.3f} "
            f"{1e3 * row['drag']:8.3f} {1e3 * row['power']:8.3f} {row['power_per_mass']:11.1f}"
        )
    if case.options.thrust_split == "body":
        body = "total T is the net horizontal wing force and D the body drag (thrust_split=body)"
        lines.append(body)
    if not r.induction_converged[0]:
        lines.append("WARNING: the inflow solve did not converge on every annulus")
    lines.append(f"mean angle of attack {r.mean_angle_of_attack[0]:.1f}°")
    return "\n".join(lines)


def record(case: MeasuredCase, history: StrokeHistory, source: Path) -> dict[str, Any]:
    """The JSON record: inputs, cycle means, per-wing summary and histories."""
    return {
        "source": str(source),
        "description": case.description,
        "flight": {
            "speed_m_s": case.speed,
            "flight_path_angle_deg": math.degrees(case.flight_path_angle),
            "available_power_W_kg": float(history.result.available_power[0]),
        },
        "stroke_plane_angle_deg": {
            w: math.degrees(getattr(case, w).stroke_plane_angle) for w in WINGS
        },
        "frequency_Hz": {w: getattr(case, w).frequency for w in WINGS},
        "options": case.options.to_dict(),
        "insect": {
            "body_mass_kg": case.insect.body_mass,
            "planform": case.insect.planform,
            "coefficients": {w: type(getattr(case.insect, w).coefficients).__name__ for w in WINGS},
        },
        "axes": "earth: lift vertical, thrust/drag/horizontal force horizontal (+ forward)",
        "units": "N, W, W/kg, deg; histories per wing pair (N_w wings)",
        "summary": summary(history, case.insect),
        "result": history.result.row(0),
        "histories": {
            w: {k: np.asarray(getattr(getattr(history, w), k)).tolist() for k in WING_HISTORY}
            for w in WINGS
        },
    }


def plot(case: MeasuredCase, history: StrokeHistory, path: Path) -> Path:
    """Vertical and horizontal force and power of each wing pair over its cycle."""
    from eval.figures import WING_COLORS, plt, save

    fig, axes = plt.subplots(3, 1, figsize=(6.4, 7.2), sharex=True)
    weight = case.insect.weight
    for name, color in WING_COLORS.items():
        w = getattr(history, name)
        power = w.aero_power + w.inertial_power
        for ax, y in zip(axes, (w.vertical_force, w.horizontal_force, power), strict=True):
            ax.plot(w.cycle_fraction, 1e3 * y, color=color, label=f"{name} pair")
    if case.fore.frequency == case.hind.frequency and case.fore.n_samples == case.hind.n_samples:
        x = history.fore.cycle_fraction
        for ax, key in zip(axes, ("vertical_force", "horizontal_force"), strict=False):
            total = getattr(history.fore, key) + getattr(history.hind, key)
            ax.plot(x, 1e3 * total, color="k", lw=1.0, label="both pairs")
    axes[0].axhline(1e3 * weight, color="0.4", lw=0.8, ls="--", label="weight")
    for ax, label in zip(
        axes, ("vertical force [mN]", "horizontal force [mN], + forward", "power [mW]"), strict=True
    ):
        ax.axhline(0.0, color="0.7", lw=0.6)
        ax.set_ylabel(label, fontsize=8)
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("t/T (each wing pair over its own cycle)")
    axes[0].legend(fontsize=7, loc="best")
    r = history.result
    fig.suptitle(
        f"{case.name}: V = {case.speed:g} m/s, γ = {math.degrees(case.flight_path_angle):+.0f}°, "
        f"L/W = {r.lift_to_weight[0]:.2f}, P/m = {r.power_per_mass[0]:.0f} W/kg",
        fontsize=9,
    )
    return save(fig, path)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("kinematics", metavar="KINEMATICS.yaml", help="the kinematics file")
    text = f"folder for NAME.json and NAME.png (default {DEFAULT_OUT})"
    parser.add_argument("--out", default=str(DEFAULT_OUT), help=text)


def main(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    source = Path(args.kinematics)
    out = Path(args.out)
    try:
        output_directory(args.out)  # before any work: a file or a read-only folder is refused now
    except ValueError as exc:
        parser.error(str(exc))
    # The model's warnings (a jump in a series, radians given as degrees, a flipped pitch)
    # are part of the answer: one line each, with the file named, not Python's file:line.
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            case = load_case(source)
            flight = dict(flight_path_angle=case.flight_path_angle, insect=case.insect)
            inputs = (case.fore, case.hind, case.speed, case.available_power)
            history = measured_history(*inputs, **flight, options=case.options)
        except ValueError as exc:  # a bad field (SpecError) or a stroke the model refuses
            parser.error(f"{source}: {exc}")
    for warning in caught:
        print(f"{parser.prog}: warning: {source}: {warning.message}", file=sys.stderr)
    print(format_summary(case, history))
    json_path, png_path = (out / f"{case.name}.{suffix}" for suffix in ("json", "png"))
    for path in (json_path, png_path):
        if path.exists():
            print(f"replacing {path}", file=sys.stderr)
    # Unique temporary names and an atomic rename: concurrent runs into one folder never mix
    # their files (the last one to finish wins, whole).
    write_text_atomic(json_path, json.dumps(record(case, history, source), indent=1) + "\n")
    plot(case, history, png_path)
    print(f"wrote {json_path} and {png_path}", file=sys.stderr)
    return 0
