"""One-pass prototype of the vortex reading on the lag study (docs/model.md §5.8, issue 41).

    python benchmarks/vortex_prototype.py --table
    python benchmarks/vortex_prototype.py --shed translational --descent 1 --core-growth 2.4e-3

From each pair's isolated solution (its momentum inflow, Γ(r, t) from Eq. 14) it builds each
pair's lifting line and prescribed periodic wake (``tandem_env.physics.vortex``), reads the
other pair's Biot-Savart velocity at a wing's three-quarter chord, and re-solves each pair's
own momentum inflow with that external field in every element velocity; ``--passes`` > 1
rebuilds both lattices from the re-solved pairs and repeats (Jacobi, not the design's
Gauss-Seidel). It prints, per lag-study point (docs/crosscheck/lag_study.csv), each pair's
change of cycle-mean vertical force against the free-wake UVLM's and, with ``--table``, the
§5.8 table's rows (today's mean and convected readings from the same file).
"""

from __future__ import annotations

import argparse
import csv
import time
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np

from eval.crosscheck.case import base_stroke, shifted_stroke
from tandem_env.physics import DRAGONFLY, ModelOptions, blade, cycle
from tandem_env.physics.bundle import Section
from tandem_env.physics.history import stroke_history
from tandem_env.physics.kinematics import fill_angles, wing_params_radians
from tandem_env.physics.model import wing_tables
from tandem_env.physics.vortex import (
    BOUND_VORTEX,
    COLLOCATION,
    ROOT_HALF_WIDTH,
    TRAILING_EDGE,
    lattice_segments,
    prescribed_wake,
    segment_velocity,
    wing_lines,
)
from tandem_env.physics.xp import NUMPY, on_namespace

LAG_STUDY = Path(__file__).resolve().parents[1] / "docs" / "crosscheck" / "lag_study.csv"
INSECT = DRAGONFLY
RHO = INSECT.air_density
N_BLADE = 24
MIRROR = np.array([1.0, -1.0, 1.0])  # right wing -> left wing (Y -> -Y)
RELATIVE_VELOCITY = on_namespace(blade.relative_velocity, NUMPY)
ELEMENT_FORCE = on_namespace(blade.element_force, NUMPY)  # the paper's coefficients


def _option(default: Any, text: str, least: float | None = None) -> Any:
    """A :class:`Variant` field: its default, its help (units in brackets), its lower bound."""
    return field(default=default, metadata={"help": text, "least": least})


@dataclass(frozen=True)
class Variant:
    """One prototype run's choices (docs/model.md §5.8; defaults: the prototype's settings)."""

    shed: str = _option("full", "circulation in the lattice: Eq. 14's or its translational part")
    descent: float = _option(1.0, "κ_w: the wake descends at κ_w·v̄ along z_s [-]", 0.0)
    core: float = _option(0.5e-3, "core radius r₀ [m]", 0.0)
    core_growth: float = _option(0.0, "g in r_c² = r₀² + g·age [m²/s]", 0.0)
    gamma_scale: float = _option(1.0, "factor on the shed circulation [-]")
    passes: int = _option(1, "inflow re-solves, each in the last pass's lattices' field", 1)
    n_wake: int = _option(48, "n_w: samples per beat, of the wake and the forces", 2)
    strips: int = _option(6, "N_s: circulation strips per wing", 1)
    read_points: int = _option(8, "M: stations reading the other pair's velocity", 2)
    beats: float = _option(1.5, "b: both pairs' wake length [beats]", 0.0)

    def __post_init__(self) -> None:
        if self.shed not in ("full", "translational"):
            raise ValueError(f"shed = {self.shed!r}; allowed: 'full' or 'translational'")
        for f in fields(self):
            least = f.metadata["least"]
            if least is not None and not getattr(self, f.name) >= least:
                raise ValueError(f"{f.name} = {getattr(self, f.name)!r}; allowed: >= {least}")
        if round(self.beats * self.n_wake) < 1:
            raise ValueError(f"beats = {self.beats!r}; allowed: at least one wake row (1/n_wake)")


TABLE = (
    ("Eq. 14", "0 (the free stream alone)", Variant(descent=0.0)),
    ("Eq. 14", "1", Variant(descent=1.0)),
    ("Eq. 14", "2", Variant(descent=2.0)),
    ("Eq. 14", "2, r_c = 8 mm", Variant(descent=2.0, core=8e-3)),
    ("translational part only", "0", Variant("translational", 0.0)),
    ("translational part only", "1", Variant("translational", 1.0)),
    ("translational part only", "1.5", Variant("translational", 1.5)),
    (
        "translational part only, r_c growing to 4 mm per beat",
        "1",
        Variant("translational", core_growth=5.9e-4),
    ),
    (
        "translational part only, r_c growing to 8 mm per beat",
        "1",
        Variant("translational", core_growth=2.4e-3),
    ),
    (
        "the same, shed Γ × 1.35",
        "1",
        Variant("translational", core_growth=2.4e-3, gamma_scale=1.35),
    ),
)
"""docs/model.md §5.8's rows: the lattice's Γ, κ_w, the variant."""


@dataclass
class Pair:
    """One pair of one stroke, isolated, and its current inflow and element velocities."""

    wing: Any
    params: np.ndarray  # (14,) Hz/rad
    section: Section  # the elements, (N_BLADE,) arrays (cycle.section_at)
    coef: np.ndarray  # (n, blade.N_COEF) frame coefficients on the uniform grid
    v_tangential: float  # V_t [m/s]
    v_normal: float  # V_n [m/s]
    inflow: np.ndarray  # (N_BLADE,) v_i [m/s]
    u: np.ndarray  # (n, N_BLADE) chordwise and normal velocity relative to the air [m/s]
    v: np.ndarray

    @property
    def r(self) -> np.ndarray:
        """Element radii [m]."""
        return self.section.r


def isolated_pairs(stroke: np.ndarray, speed: float, n: int) -> list[Pair]:
    """The fore and hind pairs of ``stroke`` flying level at ``speed`` [m/s], on n uniform
    samples, with their isolated momentum inflow."""
    history = stroke_history(stroke, speed, options=ModelOptions(induction="isolated"), n_samples=n)
    pairs = []
    for w, wing in enumerate((INSECT.fore, INSECT.hind)):
        params = wing_params_radians(stroke[w * 14 : (w + 1) * 14])
        nodes, consts = wing_tables(wing, N_BLADE, RHO)
        section = cycle.section_at.py_func(nodes, slice(None), consts, RHO)
        angles = np.empty((n, 9))
        fill_angles(params, 2 * np.pi * np.arange(n) / n, angles)
        coef = np.empty((n, blade.N_COEF))
        blade.fill_frame_coefficients(angles, np.ones(n), params[13], False, 1, coef)
        beta, inflow = params[13], (history.fore, history.hind)[w].inflow
        pair = Pair(wing, params, section, coef, speed * np.cos(beta), speed * np.sin(beta),
                    inflow, None, None)  # fmt: skip
        pair.u, pair.v, _, _ = velocities(pair, inflow, None)
        pairs.append(pair)
    return pairs


def to_stroke_axes(pair: Pair, w: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Earth-axes velocity (..., 3) [m/s] in the pair's stroke-plane axes (x_s, y, z_s)."""
    cb, sb = np.cos(pair.params[13]), np.sin(pair.params[13])
    return w[..., 0] * cb - w[..., 2] * sb, w[..., 1], w[..., 0] * sb + w[..., 2] * cb


def velocities(pair: Pair, inflow: np.ndarray, external: np.ndarray | None) -> tuple:
    """u, v, u̇, v̇ (n, N_BLADE) of every element [m/s, m/s²] with its own inflow (N_BLADE,)
    and the external air velocity (n, N_BLADE, 3) in earth axes [m/s] (its rate neglected)."""
    k = np.arange(pair.coef.shape[0])[:, None]
    vn = pair.v_normal + np.atleast_2d(inflow)
    u, v, du, dv = RELATIVE_VELOCITY(pair.coef, k, pair.r[None], pair.v_tangential, vn)
    if external is not None:
        wx, wy, wz = to_stroke_axes(pair, external)
        col = lambda name: pair.coef[:, getattr(blade, name)][:, None]  # noqa: E731
        u = u - (wx * col("C_ECX") + wy * col("C_ECY") + wz * col("C_ECZ"))
        v = v - (wx * col("C_ENX") + wy * col("C_ENY") + wz * col("C_ENZ"))
    return u, v, du, dv


def circulation(pair: Pair, u: np.ndarray, v: np.ndarray, rotational: bool = True) -> np.ndarray:
    """Eq. 14's Γ (n, N_BLADE) [m²/s], or its translational part −C_t·c·u·v/|U|."""
    sec = pair.section
    gamma = -sec.ct * sec.chord * u * v / np.sqrt(u * u + v * v)
    if rotational:
        gamma = gamma + 0.5 * sec.cr * pair.coef[:, blade.C_SPIN][:, None] * sec.chord**2
    return gamma


def element_forces(pair: Pair, u, v, du, dv) -> tuple[np.ndarray, np.ndarray]:
    """Chordwise and normal force per unit span (n, N_BLADE) [N/m]: the kernel's Eqs. 11-14."""
    return ELEMENT_FORCE(u, v, du, dv, pair.coef[:, blade.C_SPIN][:, None], pair.section)


def vertical_force(pair: Pair, inflow: np.ndarray, external: np.ndarray | None) -> float:
    """Cycle-mean vertical force of the pair [N]."""
    fc, fn = element_forces(pair, *velocities(pair, inflow, external))
    fz = fc * pair.coef[:, blade.C_ECZE][:, None] + fn * pair.coef[:, blade.C_ENZE][:, None]
    return INSECT.wings_per_pair * (fz * pair.section.width).sum(1).mean()


def solve_inflow(pair: Pair, external: np.ndarray | None) -> np.ndarray:
    """The pair's momentum inflow per annulus (§5.2) [m/s] with the external field in its
    element velocities and its cycle mean along z_s in the upstream V_n' (bisection)."""
    r, sweep = pair.r, pair.params[1]
    upstream = pair.v_normal - (
        0.0 if external is None else to_stroke_axes(pair, external)[2].mean(0)
    )

    def excess(vi: np.ndarray) -> np.ndarray:
        fc, fn = element_forces(pair, *velocities(pair, vi, external))
        c = pair.coef
        normal = (fc * c[:, blade.C_ECZ][:, None] + fn * c[:, blade.C_ENZ][:, None]).mean(0)
        return normal - 4.0 * RHO * sweep * r * vi * np.sqrt(
            pair.v_tangential**2 + (upstream + vi) ** 2
        )

    lo, hi = np.zeros_like(r), np.full_like(r, 5.0)
    active = excess(lo) > 0
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        up = excess(mid) > 0
        lo, hi = np.where(up, mid, lo), np.where(up, hi, mid)
    return np.where(active, 0.5 * (lo + hi), 0.0)


def disc_mean(pair: Pair) -> float:
    """v̄: the disc mean of the pair's inflow (§5.7) [m/s]."""
    weight = pair.r * pair.section.width
    return float(np.sum(pair.inflow * weight) / np.sum(weight))


def lattice(pair: Pair, root: np.ndarray, speed: float, var: Variant) -> tuple:
    """Both wings' segments (n, S, 2, 3) [m], circulations (n, S) [m²/s] and cores (S,) [m]."""
    n, wing = pair.coef.shape[0], pair.wing
    frac = np.linspace(0.0, 1.0, var.strips + 1)
    tau, p = 2 * np.pi * np.arange(n)[None] / n, pair.params[None]
    bound = wing_lines(p, tau, frac, wing.length, wing.chord(frac), BOUND_VORTEX, root)
    edge = wing_lines(p, tau, frac, wing.length, wing.chord(frac), TRAILING_EDGE, root)
    gamma = var.gamma_scale * circulation(pair, pair.u, pair.v, var.shed == "full")
    mids, r_hat = 0.5 * (frac[1:] + frac[:-1]), pair.r / wing.length
    strip = np.array([np.interp(mids, r_hat, g) for g in gamma])[None]  # (1, n, N_s)
    beta = pair.params[13]
    carried_by = np.array([-speed, 0.0, 0.0]) - var.descent * disc_mean(pair) * np.array(
        [np.sin(beta), 0.0, np.cos(beta)]
    )
    rows, dt = round(var.beats * n), 1.0 / (pair.params[0] * n)
    age = np.arange(rows + 1) * dt
    nodes, rings = prescribed_wake(bound, edge, strip, (age[:, None] * carried_by)[None])
    seg, g = lattice_segments(nodes[0], rings[0])
    # each segment's age: rows (row k released k − 1 samples ago), then the trailed segments
    k = np.arange(rows + 2)
    along = np.repeat(np.maximum(k - 1, 0) * dt, var.strips)
    between = np.repeat(np.maximum(k[:-1] - 0.5, 0) * dt, var.strips + 1)
    core = np.sqrt(var.core**2 + var.core_growth * np.concatenate([along, between]))
    return np.concatenate([seg, seg * MIRROR], 1), np.concatenate([g, -g], 1), np.tile(core, 2)


def induced(target: Pair, source: tuple, root: np.ndarray, var: Variant) -> np.ndarray:
    """The source lattice's velocity (n, N_BLADE, 3) [m/s] at the target's elements: read at M
    three-quarter-chord stations, interpolated linearly in r."""
    n, wing = target.coef.shape[0], target.wing
    frac = np.linspace(0.02, 0.98, var.read_points)
    tau = 2 * np.pi * np.arange(n)[None] / n
    points = wing_lines(
        target.params[None], tau, frac, wing.length, wing.chord(frac), COLLOCATION, root
    )
    w = segment_velocity(*source[:2], points[0], source[2])  # (n, M, 3)
    r_hat = target.r / wing.length
    return np.stack([[np.interp(r_hat, frac, w[i, :, c]) for i in range(n)] for c in range(3)], -1)


def stroke_changes(speed: float, spacing: float, drop: float, lag: float, var: Variant) -> dict:
    """Each pair's change of cycle-mean vertical force [%] at one lag-study point (spacing, drop
    [m], lag [deg]), and the hind-wing's area- and cycle-mean vertical w_e [m/s]."""
    stroke = shifted_stroke(base_stroke(), lag)
    roots = (np.array([0.0, ROOT_HALF_WIDTH, 0.0]), np.array([-spacing, ROOT_HALF_WIDTH, -drop]))
    pairs = isolated_pairs(stroke, speed, var.n_wake)
    isolated = [vertical_force(p, p.inflow, None) for p in pairs]
    for step in range(var.passes):
        lattices = [lattice(p, root, speed, var) for p, root in zip(pairs, roots, strict=True)]
        fields_ = [induced(pairs[w], lattices[1 - w], roots[w], var) for w in (0, 1)]
        if step == 0:
            area = pairs[1].section.chord * pairs[1].section.width
            downwash = float((fields_[1][..., 2] * area).sum(1).mean() / area.sum())
        inflows = [solve_inflow(p, f) for p, f in zip(pairs, fields_, strict=True)]
        for p, vi, f in zip(pairs, inflows, fields_, strict=True):
            p.inflow = vi
            p.u, p.v, _, _ = velocities(p, vi, f)
    change = [100 * (vertical_force(p, p.inflow, f) / iso - 1)
              for p, f, iso in zip(pairs, fields_, isolated, strict=True)]  # fmt: skip
    return {"fore": change[0], "hind": change[1], "downwash": downwash}


def lag_study() -> dict[tuple[float, float, float], list[dict[str, str]]]:
    """The lag study's rows by case (speed [m/s], spacing, drop [mm]), in the file's order."""
    cases: dict[tuple[float, float, float], list[dict[str, str]]] = {}
    with LAG_STUDY.open(newline="") as handle:
        for row in csv.DictReader(handle):
            key = tuple(float(row[k]) for k in ("speed_m_s", "spacing_mm", "drop_mm"))
            cases.setdefault(key, []).append(row)
    return cases


def run(var: Variant, cases: dict) -> dict[tuple, dict[str, np.ndarray]]:
    """The variant's changes [%] and the hind-wing's mean vertical w_e [m/s] per case, by lag."""
    out = {}
    for (speed, spacing, drop), rows in cases.items():
        res = [
            stroke_changes(speed, spacing * 1e-3, drop * 1e-3, float(r["lag_deg"]), var)
            for r in rows
        ]
        out[(speed, spacing, drop)] = {k: np.array([x[k] for x in res]) for k in res[0]}
    return out


FLAT = 0.05
"""A lag pattern swinging less than this [points] has none (today's mean reading): no largest
loss, no correlation."""


def uvlm(rows: list[dict[str, str]], side: str) -> np.ndarray:
    """The free-wake UVLM's change of ``side`` (hind, fore) [%] by lag."""
    return np.array([float(r[f"uvlm_{side}_change_pct"]) for r in rows])


def first_harmonic(change: np.ndarray, lags: np.ndarray) -> float:
    """Lag [deg] of the largest loss of the lag pattern's first harmonic (lags [deg] evenly
    spaced over a beat)."""
    phase = np.angle(-np.sum(change * np.exp(-1j * np.radians(lags))))
    return float(np.degrees(phase) % 360)


def apart(a: float, b: float) -> float:
    """Angle between two lags [deg], 0-180."""
    return min(abs(a - b) % 360, 360 - abs(a - b) % 360)


def correlation(ours: np.ndarray, target: np.ndarray, flat: float = FLAT) -> str:
    """The lag patterns' correlation, "—" where ours swings no more than ``flat``."""
    return "—" if np.ptp(ours) <= flat else f"{np.corrcoef(ours, target)[0, 1]:+.2f}"


def rms(errors: Any) -> str:
    """Root mean square [points]."""
    return f"{np.sqrt(np.mean(np.square(errors))):.1f}"


def metrics(ours: dict, cases: dict) -> list[str]:
    """The §5.8 table's cells from ``ours`` (per case: hind, fore changes [%] by lag)."""
    signs, errors, within, corr, fore_signs, fore_errors = 0, [], 0, {}, 0, []
    for key, rows in cases.items():
        lags = np.array([float(r["lag_deg"]) for r in rows])
        hind, fore = ours[key]["hind"], ours[key]["fore"]
        signs += int(np.sum(np.sign(hind) == np.sign(uvlm(rows, "hind"))))
        fore_signs += int(np.sum(np.sign(fore) == np.sign(uvlm(rows, "fore"))))
        errors += list(hind - uvlm(rows, "hind"))
        fore_errors += list(fore - uvlm(rows, "fore"))
        largest = lags[np.argmin(hind)], lags[np.argmin(uvlm(rows, "hind"))]
        within += np.ptp(hind) >= FLAT and apart(*largest) <= 45
        corr[key] = correlation(hind, uvlm(rows, "hind"))
        if key == (1.0, 8.8, 9.0):
            mean = f"{hind.mean():.1f} / {uvlm(rows, 'hind').mean():.1f}"
    order = sorted(cases, key=lambda k: (k[1], k[0]))  # 0.5, 1, 2 m/s; then 1 m/s farther apart
    n = len(errors)
    correlations = ", ".join(corr[k] for k in order)
    return [f"{signs}/{n}", rms(errors), f"{within}/{len(cases)}", correlations, mean,
            f"{fore_signs}/{n}", rms(fore_errors)]  # fmt: skip


def table_line(cells: list[str]) -> str:
    """A Markdown table line, minus signs as in the docs."""
    return ("| " + " | ".join(cells) + " |").replace("-", "−")


HEADER = (
    "| lattice's Γ | wake descent κ_w | hind: UVLM's sign | hind: RMS [points] | largest hind "
    "loss within 45° of the UVLM's | hind lag pattern's correlation with the UVLM's (0.5, 1, 2 m/s; "
    "1 m/s at 11.76 mm) | hind lag-mean, ours / UVLM's, 1 m/s [%] | fore: UVLM's sign | "
    "fore: RMS [points] |\n|---|---|---|---|---|---|---|---|---|"
)


def today(cases: dict, reading: str) -> dict:
    """The model's present ``reading`` (mean, convected) from the lag-study file, as ``run``'s."""
    return {key: {side: np.array([float(r[f"ours_{reading}_{side}_change_pct"]) for r in rows])
                  for side in ("hind", "fore")} for key, rows in cases.items()}  # fmt: skip


def pattern(ours: np.ndarray, target: np.ndarray, lags: np.ndarray) -> str:
    """One side's lag pattern against the UVLM's: range, RMS, correlation, timing."""
    h, u = first_harmonic(ours, lags), first_harmonic(target, lags)
    return (
        f"{ours.min():+.1f} to {ours.max():+.1f} %"
        f" (UVLM {target.min():+.1f} to {target.max():+.1f}),"
        f" RMS {rms(ours - target)}, correlation {correlation(ours, target)}, largest loss at"
        f" {lags[np.argmin(ours)]:.0f}° (UVLM {lags[np.argmin(target)]:.0f}°), first harmonics"
        f" {apart(h, u):.0f}° apart"
    )


def details(ours: dict, cases: dict) -> str:
    """Per case and lag: ours against the UVLM's, the patterns, and the hind-wing's vertical w_e
    (area and cycle mean, first pass)."""
    lines = []
    for key, rows in cases.items():
        lags = np.array([float(r["lag_deg"]) for r in rows])
        x, uh, uf = ours[key], uvlm(rows, "hind"), uvlm(rows, "fore")
        lines.append(f"V = {key[0]} m/s, d = {key[1]} mm, D = {key[2]} mm")
        lines.append(
            "  lag [deg] | hind: ours, UVLM [%] | fore: ours, UVLM [%] | hind's w_e,Z [m/s]"
        )
        for i, lag in enumerate(lags):
            hind, fore = (
                f"{x['hind'][i]:+6.1f} {uh[i]:+6.1f}",
                f"{x['fore'][i]:+6.1f} {uf[i]:+6.1f}",
            )
            lines.append(f"  {lag:4.0f} | {hind} | {fore} | {x['downwash'][i]:+.3f}")
        w = x["downwash"]
        lines += [
            f"  hind: {pattern(x['hind'], uh, lags)}",
            f"  fore: {pattern(x['fore'], uf, lags)}",
            f"  hind's w_e,Z: {w.min():+.2f} to {w.max():+.2f} m/s, most downwash at"
            f" {lags[np.argmin(w)]:.0f}°, correlation with the UVLM's hind change"
            f" {correlation(w, uh, 0.0)}",
        ]
    return "\n".join(lines)


def parse(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line; ``--table`` ignores the variant's options."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--table", action="store_true", help="run docs/model.md §5.8's rows")
    for f in fields(Variant):
        parser.add_argument(
            "--" + f.name.replace("_", "-"),
            type=type(f.default),
            default=f.default,
            help=f"{f.metadata['help']} (default {f.default})",
        )
    args = parser.parse_args(argv)
    try:
        args.variant = Variant(**{f.name: getattr(args, f.name) for f in fields(Variant)})
    except ValueError as error:
        parser.error(str(error))
    return args


def main(argv: list[str] | None = None) -> None:
    """Print the table, or one variant's details and table line."""
    args = parse(argv)
    cases = lag_study()
    start = time.perf_counter()
    if args.table:
        print(HEADER)
        for gamma, descent, var in TABLE:
            print(table_line([gamma, descent, *metrics(run(var, cases), cases)]), flush=True)
        for reading in ("mean", "convected"):
            cells = metrics(today(cases, reading), cases)
            print(table_line([f"(today: the {reading} reading)", "", *cells]))
    else:
        ours = run(args.variant, cases)
        print(details(ours, cases))
        print(HEADER + "\n" + table_line(["", "", *metrics(ours, cases)]))
    print(f"({time.perf_counter() - start:.0f} s)")


if __name__ == "__main__":
    main()
