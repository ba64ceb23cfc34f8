"""The cross-check's comparison: the model's side, the table (CSV and Markdown) and the figure.

Each pair's cycle-mean vertical force changes because the other pair is there, in percent of
its force without it: the vortex-lattice solver's (UVLM) tandem − that pair alone, and the
model's ("ours") coupled − ``induction="isolated"`` for each slipstream reading, the hind-wing's
phases shifted by the lag (docs/crosscheck.md).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, get_args

import numpy as np

from eval.figures import PALETTE, plt, save
from eval.studies.report import table_head, table_row
from tandem_env.io.files import write_csv_atomic, write_text_atomic
from tandem_env.physics import PARAMETER_NAMES, Dragonfly, ModelOptions, evaluate
from tandem_env.physics.options import Slipstream

from .case import PAIRS, Case, Resolution, Run, base_stroke, shifted_stroke

#: The model's slipstream readings, each compared with the solver.
READINGS: tuple[str, ...] = tuple(get_args(Slipstream))
#: The files a cross-check writes into ``--out``.
TABLE_CSV = "crosscheck.csv"
TABLE_MD = "crosscheck.md"
FIGURE = "crosscheck.png"
#: The vortex lattice's series (dark grey: black marks the paper's own statements in the
#: project's figures; the readings take the Okabe-Ito hues of ``eval.figures.PALETTE``).
UVLM_COLOUR = "0.25"


def ours(case: Case, insect: Dragonfly) -> dict[str, Any]:
    """The model's vertical force of each pair [N], isolated and per reading, at each lag:
    ``{"isolated": {"fore": (L,), "hind": (L,)}, reading: {...}}``."""
    strokes = np.array([shifted_stroke(np.asarray(case.stroke), lag) for lag in case.lags])
    flyer = replace(insect, root_spacing=case.spacing, root_drop=case.drop)
    out: dict[str, Any] = {}
    options = {"isolated": ModelOptions(induction="isolated")}
    for name, option in (options | {r: ModelOptions(slipstream=r) for r in READINGS}).items():
        result = evaluate(strokes, case.speed, insect=flyer, options=option)
        out[name] = {p: getattr(result, f"{p}_lift_to_weight") * flyer.weight for p in PAIRS}
    return out


def stroke_changes(case: Case) -> str:
    """The case's stroke as its changes from the base stroke, ``name=value`` joined by spaces
    (empty for the base stroke)."""
    base = base_stroke()
    return " ".join(
        f"{name}={value:g}"
        for name, value, was in zip(PARAMETER_NAMES, case.stroke, base, strict=True)
        if value != was
    )


def _percent(value: float, reference: float) -> float:
    return 100.0 * (value - reference) / reference if reference != 0.0 else math.nan


def model_cells(mine: Mapping[str, Any], index: int) -> dict[str, float]:
    """The model's columns of lag ``index`` of :func:`ours`' ``mine``: each pair's isolated
    force [mN], then each reading's change of it [%]."""
    alone = {pair: float(mine["isolated"][pair][index]) for pair in PAIRS}
    out = {f"ours_isolated_{pair}_mN": 1e3 * alone[pair] for pair in PAIRS}
    for reading in READINGS:
        for pair in PAIRS:
            value = float(mine[reading][pair][index])
            out[f"ours_{reading}_{pair}_change_pct"] = _percent(value, alone[pair])
    return out


@dataclass(frozen=True)
class Planned:
    """A case at one resolution, with its runs and its clearance at each lag [m]."""

    case: Case
    resolution: Resolution
    runs: Mapping[str, Run]
    clearance: Mapping[float, Mapping[str, float]]


def rows(
    planned: Sequence[Planned], results: Mapping[Run, Mapping[str, Any]], insect: Dragonfly
) -> list[dict[str, Any]]:
    """One row per case, resolution and lag (forces in mN, changes in %)."""
    out = []
    model = {case: ours(case, insect) for case in dict.fromkeys(p.case for p in planned)}
    for plan in planned:
        mine = model[plan.case]
        alone = {pair: results[plan.runs[pair]][pair]["vertical"] for pair in PAIRS}
        for index, lag in enumerate(plan.case.lags):
            tandem = results[plan.runs[f"tandem {lag:g}"]]
            both = {pair: tandem[pair]["vertical"] for pair in PAIRS}
            row: dict[str, Any] = {
                "stroke_changes": stroke_changes(plan.case),
                "speed_m_s": plan.case.speed,
                "spacing_mm": round(1e3 * plan.case.spacing, 3),
                "drop_mm": round(1e3 * plan.case.drop, 3),
                "lag_deg": lag,
                **{k: getattr(plan.resolution, k) for k in ("steps_per_beat", "panels", "beats")},
                "wake": plan.runs["fore"].wake,
                "clearance_mm": round(1e3 * plan.clearance[lag]["pairs"], 2),
            }
            for pair in PAIRS:
                row[f"uvlm_{pair}_alone_mN"] = 1e3 * alone[pair]
                row[f"uvlm_{pair}_tandem_mN"] = 1e3 * both[pair]
            row |= {f"uvlm_{p}_change_pct": _percent(both[p], alone[p]) for p in PAIRS}
            row |= model_cells(mine, index)
            row["uvlm_tandem_wall_s"] = round(tandem["wall_time"], 1)
            out.append(row)
    return out


#: The Markdown table's columns: heading, CSV column and format (the readings' follow).
COLUMNS = [
    *[("V [m/s]", "speed_m_s", "{:g}"), ("d [mm]", "spacing_mm", "{:g}")],
    *[("h [mm]", "drop_mm", "{:g}"), ("lag [deg]", "lag_deg", "{:g}")],
    *[("steps/beat", "steps_per_beat", "{}"), ("panels", "panels", "{}"), ("wake", "wake", "{}")],
    ("clearance [mm]", "clearance_mm", "{:.2f}"),
    *[(f"UVLM {p}", f"uvlm_{p}_change_pct", "{:+.1f} %") for p in ("hind", "fore")],
]


def markdown(table: Sequence[Mapping[str, Any]]) -> str:
    """The rows as a Markdown table: vertical-force changes [%] of each pair (and the stroke's
    changes, where a row has some)."""
    columns = [("stroke", "stroke_changes", "{}")] * any(r["stroke_changes"] for r in table)
    columns += COLUMNS + [
        (f"ours {r} {p}", f"ours_{r}_{p}_change_pct", "{:+.1f} %")
        for r in READINGS
        for p in ("hind", "fore")
    ]
    cells = [
        [form.format(row[key]) if row[key] != "" else "base" for _, key, form in columns]
        for row in table
    ]
    return "\n".join([*table_head([c[0] for c in columns]), *map(table_row, cells)]) + "\n"


def agreement_numbers(
    table: Sequence[Mapping[str, Any]], reading: str, pair: str
) -> tuple[float, int]:
    """The RMS of ours (``reading``) − UVLM change of ``pair`` over the rows [percentage
    points] and how many rows' changes have the UVLM's sign (cells: numbers or their text)."""
    ours = np.array([float(row[f"ours_{reading}_{pair}_change_pct"]) for row in table])
    uvlm = np.array([float(row[f"uvlm_{pair}_change_pct"]) for row in table])
    return float(np.sqrt(np.mean((ours - uvlm) ** 2))), int(np.sum(np.sign(ours) == np.sign(uvlm)))


def agreement(table: Sequence[Mapping[str, Any]]) -> str:
    """Per reading, over the rows: :func:`agreement_numbers` of each pair, a Markdown table."""
    pairs = ("hind", "fore")
    lines = table_head(
        ["reading", *(f"RMS {p} − UVLM" for p in pairs), *(f"{p} sign agrees" for p in pairs)]
    )
    for reading in READINGS:
        numbers = [agreement_numbers(table, reading, pair) for pair in pairs]
        cells = [reading, *(f"{rms:.1f} pp" for rms, _ in numbers)]
        lines.append(table_row([*cells, *(f"{same}/{len(table)}" for _, same in numbers)]))
    return "\n".join(lines) + "\n"


def write_table(out_dir: Path, table: Sequence[Mapping[str, Any]]) -> tuple[Path, Path]:
    write_csv_atomic(out_dir / TABLE_CSV, table)
    intro = (
        "Change of each pair's cycle-mean vertical force due to the other pair, in % of the "
        "pair's force without it: UVLM tandem − alone; ours each slipstream reading − "
        "isolated. Columns of every force: crosscheck.csv.\n\n"
    )
    text = intro + markdown(table) + "\nEach reading against the UVLM over these rows:\n\n"
    write_text_atomic(out_dir / TABLE_MD, text + agreement(table))
    return out_dir / TABLE_CSV, out_dir / TABLE_MD


def case_of(row: Mapping[str, Any]) -> tuple[float, float, float]:
    """(speed [m/s], spacing [mm], drop [mm]) of a row (numbers or their CSV text)."""
    return (float(row["speed_m_s"]), float(row["spacing_mm"]), float(row["drop_mm"]))


def write_scatter(out_dir: Path, table: Sequence[Mapping[str, Any]]) -> Path:
    """Each row's change of each pair: ours (each reading) against the UVLM's, with the line
    where they agree (a grid of many strokes, one or two lags each)."""
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.8))
    for ax, pair in zip(axes, ("hind", "fore"), strict=True):
        uvlm = [row[f"uvlm_{pair}_change_pct"] for row in table]
        for i, reading in enumerate(READINGS):
            ours = [row[f"ours_{reading}_{pair}_change_pct"] for row in table]
            ax.plot(uvlm, ours, "o", color=PALETTE[i], label=f"ours ({reading})")
        low, high = min(ax.get_xlim()[0], ax.get_ylim()[0]), max(ax.get_xlim()[1], ax.get_ylim()[1])
        ax.plot([low, high], [low, high], color="0.6", lw=0.8, label="agreement")
        ax.axhline(0.0, color="0.85", lw=0.8)
        ax.axvline(0.0, color="0.85", lw=0.8)
        ax.set(xlabel=f"UVLM {pair}-wing change [%]", ylabel=f"ours {pair}-wing change [%]")
        ax.set_title(f"{pair}-wing vertical force change, {len(table)} points", fontsize=9)
        ax.legend(fontsize=7)
    fig.tight_layout()
    return save(fig, out_dir / FIGURE, crop=False)


def write_figure(out_dir: Path, table: Sequence[Mapping[str, Any]], base: Resolution) -> Path:
    """Per case, the changes against the lag at ``base`` resolution (left) and the solver's
    hind- and fore-wing change at each resolution run (right: its convergence)."""
    cases = list(dict.fromkeys(case_of(r) for r in table))
    size = (11, 3.6 * len(cases))
    fig, axes = plt.subplots(len(cases), 2, figsize=size, squeeze=False, width_ratios=(2, 1))
    for (left, right), key in zip(axes, cases, strict=True):
        mine = [r for r in table if case_of(r) == key]
        res = (base.steps_per_beat, base.panels, base.beats)
        main = [r for r in mine if (r["steps_per_beat"], r["panels"], r["beats"]) == res] or mine
        lags = [r["lag_deg"] for r in main]
        # hind-wing: solid lines, filled circles and x; fore-wing: dashed, open circles and +
        for pair, ls, mfc, mark in (("hind", "-", UVLM_COLOUR, "x"), ("fore", "--", "white", "+")):
            uvlm = [r[f"uvlm_{pair}_change_pct"] for r in main]
            left.plot(lags, uvlm, "o" + ls, color=UVLM_COLOUR, mfc=mfc, label=f"UVLM {pair}")
            for i, reading in enumerate(READINGS):
                y = [r[f"ours_{reading}_{pair}_change_pct"] for r in main]
                left.plot(lags, y, mark + ls, color=PALETTE[i], label=f"ours ({reading}) {pair}")
        left.axhline(0.0, color="0.7", lw=0.8)
        left.set_xticks(lags)
        left.set_xlabel("lag ΔΦ: the hind-wing's phase lead [deg]")
        left.set_ylabel("vertical force change [%]")
        first = main[0]
        left.set_title(
            f"V = {key[0]:g} m/s, d = {key[1]:g} mm, h = {key[2]:g} mm "
            f"({first['steps_per_beat']} steps/beat, {first['panels']} panels, "
            f"{first['beats']} beats, {first['wake']} wake)",
            fontsize=9,
        )
        resolutions = sorted(
            dict.fromkeys((r["steps_per_beat"], r["panels"]) for r in mine),
            key=lambda sp: (math.prod(int(n) for n in sp[1].split("x")), sp[0]),
        )
        if len(resolutions) > 1:
            for j, lag in enumerate(dict.fromkeys(r["lag_deg"] for r in mine)):
                series = sorted(
                    (r for r in mine if r["lag_deg"] == lag),
                    key=lambda r: resolutions.index((r["steps_per_beat"], r["panels"])),
                )
                x = [resolutions.index((r["steps_per_beat"], r["panels"])) for r in series]
                for pair, marker in (("hind", "o-"), ("fore", "s--")):
                    change = [r[f"uvlm_{pair}_change_pct"] for r in series]
                    colour = PALETTE[j % len(PALETTE)]
                    right.plot(x, change, marker, color=colour, label=f"{pair}, lag {lag:g}")
            right.set_xticks(range(len(resolutions)))
            right.set_xticklabels([f"{s}/beat\n{p}" for s, p in resolutions], fontsize=7)
            right.set_ylabel("UVLM change [%]")
            right.legend(fontsize=6)
            right.set_title("UVLM convergence (steps per beat, panels)", fontsize=9)
        else:  # one resolution, said in the title (--convergence runs 3 more)
            right.axis("off")
    # One legend above the panels, off the data (every panel has the same series).
    handles, labels = axes[0][0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="upper center", ncol=3, fontsize=8, frameon=False)
    fig.tight_layout(rect=(0.0, 0.0, 1.0, 1.0 - 0.5 / fig.get_figheight()))  # legend: 0.5 inch
    return save(fig, out_dir / FIGURE, crop=False)
