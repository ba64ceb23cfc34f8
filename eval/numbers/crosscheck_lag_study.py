"""The cross-check's lag study (docs/crosscheck.md, "Findings"): the stored outputs of the
documented ``python -m eval crosscheck --grid lag-study`` run and of its convergence run at one
case, collected after they finished, and what they say about each slipstream reading: the sign
of the hind-wing's change at every grid point, and the lag of its largest loss against the
vortex lattice's."""

from __future__ import annotations

import contextlib
import math
import re
import tempfile
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from eval.crosscheck import report
from eval.crosscheck.case import Case, Resolution, base_stroke
from eval.numbers import framework
from eval.studies.report import table_head, table_row
from tandem_env.io.files import write_csv_atomic
from tandem_env.physics import DRAGONFLY

LAG_STUDY_OUT = Path("results") / "crosscheck-lag-study"
LAG_STUDY_COMMAND = (
    f"python -m eval crosscheck --grid lag-study --scheduler local:2 --out {LAG_STUDY_OUT}"
)
CONVERGENCE_OUT = Path("results") / "crosscheck-convergence"
CONVERGENCE_COMMAND = (
    f"python -m eval crosscheck --convergence --lags 0 --scheduler local:2 --out {CONVERGENCE_OUT}"
)
#: The run's small outputs kept where the docs include them: run's file -> the docs' copy.
LAG_STUDY_FILES: dict[str, Path] = {
    "crosscheck.csv": framework.ROOT / "docs" / "crosscheck" / "lag_study.csv",
    "crosscheck.png": framework.ROOT / "docs" / "figures" / "crosscheck_lag_study.png",
}

#: The generalisation grid's stored table (both wakes' rows) and its figure (the free wake's).
GENERALISATION_FILES: dict[str, Path] = {
    "crosscheck.csv": framework.ROOT / "docs" / "crosscheck" / "generalisation.csv",
    "crosscheck.png": framework.ROOT / "docs" / "figures" / "crosscheck_generalisation.png",
}


def typed(text: Any) -> Any:
    """A CSV cell's text as the run's value (``4x8`` and ``free`` stay text)."""
    for kind in (int, float):
        with contextlib.suppress(TypeError, ValueError):
            return kind(text)
    return text


def model_columns(rows: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """The stored rows with the model's columns (``ours_*``: isolated forces, each slipstream
    reading's changes) computed afresh by the model as it is (``eval.crosscheck.report.ours``),
    the solver's columns as stored: a new or changed reading without rerunning the solver."""
    out = [dict(row) for row in rows]
    for key in dict.fromkeys(report.case_of(r) for r in rows):
        mine = [r for r in out if report.case_of(r) == key]
        lags = tuple(float(r["lag_deg"]) for r in mine)
        case = Case(tuple(base_stroke()), key[0], 1e-3 * key[1], 1e-3 * key[2], lags)
        model = report.ours(case, DRAGONFLY)
        for index, row in enumerate(mine):
            row.update(report.model_cells(model, index))
    return out


def generalisation_columns(rows: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """:func:`model_columns` for the generalisation grid's stored rows: each wake's rows are
    the grid's cases at their lags in the grid's order (``eval.crosscheck.cli.GRIDS``), checked
    against each row's stroke, speed and lag; SystemExit where they are not."""
    from eval.crosscheck.cli import GRIDS

    cases = [point.case(DRAGONFLY, {}, None) for point in GRIDS["generalisation"].points]
    model = {case: report.ours(case, DRAGONFLY) for case in cases}
    planned = [(case, index) for case in cases for index in range(len(case.lags))]
    out = [dict(row) for row in rows]
    for wake in dict.fromkeys(row["wake"] for row in out):
        mine = [row for row in out if row["wake"] == wake]
        stored = [(r["stroke_changes"], float(r["speed_m_s"]), float(r["lag_deg"])) for r in mine]
        if stored != [(report.stroke_changes(c), c.speed, c.lags[i]) for c, i in planned]:
            raise SystemExit(
                f"{GENERALISATION_FILES['crosscheck.csv']}: the {wake} wake's rows are not the "
                "generalisation grid's; rerun `python -m eval crosscheck --grid generalisation` "
                "(docs/crosscheck.md)"
            )
        for row, (case, index) in zip(mine, planned, strict=True):
            row.update(report.model_cells(model[case], index))
    return out


def refresh(
    files: Mapping[str, Path],
    columns: Callable[[list[dict[str, str]]], list[dict[str, Any]]],
    draw: Callable[[Path, list[dict[str, Any]]], Any],
) -> list[dict[str, Any]]:
    """Rewrite a stored table (``files``: the docs' copies) with the model's columns afresh
    (``columns`` of its rows) and redraw its figure: ``draw(folder, typed rows)`` writes it into
    a scratch folder, as ``python -m eval crosscheck`` does into its ``--out``; the rows."""
    rows = columns(framework.read_rows(files["crosscheck.csv"]))
    write_csv_atomic(files["crosscheck.csv"], rows)
    with tempfile.TemporaryDirectory() as folder:
        draw(Path(folder), [{k: typed(v) for k, v in row.items()} for row in rows])
        framework.copy_outputs(Path(folder), {"crosscheck.png": files["crosscheck.png"]})
    return rows


def measure() -> dict[str, Any]:
    """Collect the finished lag study in :data:`LAG_STUDY_OUT` (about an hour on 2 idle cores:
    run :data:`LAG_STUDY_COMMAND` first) and copy its table and figure into the docs. Without
    that folder, recompute the model's columns (:func:`model_columns`) on the stored study's
    rows and write them into the docs' table and figure (the solver not rerun), and the
    generalisation grid's likewise (:func:`generalisation_columns`; its figure the free
    wake's)."""
    table = LAG_STUDY_OUT / "crosscheck.csv"
    if not table.is_file() and LAG_STUDY_FILES["crosscheck.csv"].is_file():
        stored = framework.load("crosscheck-lag-study")

        def lag_figure(folder: Path, rows: list[dict[str, Any]]) -> None:
            # the stored study ran before --wake existed, on the free wake
            report.write_figure(folder, [{"wake": "free", **r} for r in rows], base=Resolution())

        def free_wake(folder: Path, rows: list[dict[str, Any]]) -> None:
            report.write_scatter(folder, table=[r for r in rows if r["wake"] == "free"])

        rows = refresh(LAG_STUDY_FILES, model_columns, lag_figure)
        refresh(GENERALISATION_FILES, generalisation_columns, free_wake)
        return {**stored, "rows": rows, "model_refreshed": True}
    if not table.is_file():
        raise SystemExit(f"{LAG_STUDY_OUT} holds no finished lag study; run `{LAG_STUDY_COMMAND}`")
    rows = framework.read_rows(table)
    if not (CONVERGENCE_OUT / "crosscheck.csv").is_file():
        raise SystemExit(f"{CONVERGENCE_OUT} holds no convergence run; run `{CONVERGENCE_COMMAND}`")
    cases = {report.case_of(row) for row in rows}
    if len(cases) != 4 or len(rows) != 32:
        raise SystemExit(
            f"{table} has {len(rows)} rows in {len(cases)} cases, not the lag study's 32 in 4; "
            f"run `{LAG_STUDY_COMMAND}`"
        )
    framework.copy_outputs(LAG_STUDY_OUT, LAG_STUDY_FILES)
    return {
        "command": LAG_STUDY_COMMAND,
        "rows": rows,
        "convergence_command": CONVERGENCE_COMMAND,
        "convergence": framework.read_rows(CONVERGENCE_OUT / "crosscheck.csv"),
    }


def readings(rows: Sequence[Mapping[str, Any]]) -> list[str]:
    """The model's slipstream readings the table holds, in its column order."""
    found = (re.fullmatch(r"ours_(.+)_hind_change_pct", c) for c in rows[0])
    return [m[1] for m in found if m]


def largest_loss_lag(lags: Sequence[float], changes: Sequence[float]) -> float | None:
    """The lag [deg] of the most negative change, or None where every lag gives the same."""
    if max(changes) - min(changes) < 1e-9:
        return None
    return lags[min(range(len(changes)), key=changes.__getitem__)]


def lag_distance(a: float, b: float) -> float:
    """Distance between two lags on the circle [deg], 0 to 180."""
    return abs((a - b + 180.0) % 360.0 - 180.0)


def first_harmonic_phase(lags: Sequence[float], changes: Sequence[float]) -> float:
    """The lag [deg] at which the first harmonic of the change over the lag is lowest (the
    equally spaced lags' discrete Fourier coefficient), robust to one noisy point."""
    c = sum(v * math.cos(math.radians(g)) for g, v in zip(lags, changes, strict=True))
    s = sum(v * math.sin(math.radians(g)) for g, v in zip(lags, changes, strict=True))
    return (math.degrees(math.atan2(s, c)) + 180.0) % 360.0


def summary(rows: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """Per case and per reading: the sign agreement with the UVLM, the lag of the largest loss
    and its first harmonic's phase, against the UVLM's."""
    out = []
    for case in dict.fromkeys(report.case_of(r) for r in rows):
        mine = [r for r in rows if report.case_of(r) == case]
        mine.sort(key=lambda r: float(r["lag_deg"]))
        lags = [float(r["lag_deg"]) for r in mine]
        uvlm = [float(r["uvlm_hind_change_pct"]) for r in mine]
        uvlm_loss = largest_loss_lag(lags, uvlm)
        entry: dict[str, Any] = {
            "case": case,
            "lags": lags,
            "uvlm": uvlm,
            "uvlm_fore": [float(r["uvlm_fore_change_pct"]) for r in mine],
            "uvlm_loss_lag": uvlm_loss,
            "uvlm_phase": first_harmonic_phase(lags, uvlm),
            "readings": {},
        }
        for reading in readings(rows):
            ours = [float(r[f"ours_{reading}_hind_change_pct"]) for r in mine]
            loss = largest_loss_lag(lags, ours)
            phase = first_harmonic_phase(lags, ours)
            entry["readings"][reading] = {
                "changes": ours,
                "same_sign": sum((a < 0) == (b < 0) for a, b in zip(ours, uvlm, strict=True)),
                "loss_lag": loss,
                "loss_lag_off": None if loss is None else lag_distance(loss, uvlm_loss),
                "phase_off": None if loss is None else lag_distance(phase, entry["uvlm_phase"]),
            }
        out.append(entry)
    return out


def targets(rows: Sequence[Mapping[str, Any]]) -> dict[str, dict[str, Any]]:
    """Per reading, the lag study's target quantities: signs of the hind and fore change
    shared with the UVLM, their RMS differences [points]
    (:func:`~eval.crosscheck.report.agreement_numbers`), and the cases whose largest hind loss
    lies within 45° of the UVLM's."""
    out = {}
    entries = summary(rows)
    for reading in readings(rows):
        offs = [e["readings"][reading]["loss_lag_off"] for e in entries]
        within = sum(off is not None and off <= 45.0 for off in offs)
        out[reading] = {"points": len(rows), "cases": len(entries), "within": within}
        for pair in ("hind", "fore"):
            rms, sign = report.agreement_numbers(rows, reading, pair)
            out[reading] |= {f"{pair}_rms": rms, f"{pair}_sign": sign}
    return out


def case_label(case: tuple[float, float, float]) -> str:
    return f"V = {case[0]:g} m/s, d = {case[1]:g} mm"


def render(data: dict[str, Any]) -> str:
    rows = data["rows"]
    entries = summary(rows)
    names = readings(rows)
    lags = entries[0]["lags"]
    heads = [x for e in entries for x in (f"{case_label(e['case'])}: UVLM", *names)]
    lines = [
        f"Written by `{data['command']}` (its `crosscheck.csv`, copied to "
        "[`docs/crosscheck/lag_study.csv`](crosscheck/lag_study.csv)). The hind-wing's change "
        "of vertical force due to the fore-wing [%], at each lag ΔΦ (+: the hind-wing leads); "
        "the mean reading gives one value at every lag:",
        "",
        *table_head(["lag ΔΦ", *heads]),
    ]
    for i, lag in enumerate(lags):
        columns = [[e["uvlm"], *(e["readings"][n]["changes"] for n in names)] for e in entries]
        lines.append(table_row([f"{lag:g}°", *(f"{c[i]:+.1f}" for cs in columns for c in cs)]))
    compared = [f"`{n}`: same sign, largest loss at (off)" for n in names]
    lines += [
        "",
        "Against the UVLM, case by case: the lags (of 8) where a reading has the UVLM's sign of "
        "the hind-wing change, and the lag of its largest hind-wing loss (the first harmonic's "
        "lowest point in brackets) and how far it lies from the UVLM's:",
        "",
        *table_head(["case", "UVLM: hind, largest loss at", "UVLM: fore", *compared]),
    ]
    for e in entries:
        cells = [
            case_label(e["case"]),
            f"{min(e['uvlm']):+.1f} to {max(e['uvlm']):+.1f} %, "
            f"{e['uvlm_loss_lag']:g}° ({e['uvlm_phase']:.0f}°)",
            f"{min(e['uvlm_fore']):+.1f} to {max(e['uvlm_fore']):+.1f} %",
        ]
        for n in names:
            r = e["readings"][n]
            where = (
                "any lag (none depends on it)"
                if r["loss_lag"] is None
                else f"{r['loss_lag']:g}° ({r['loss_lag_off']:g}° off; harmonic {r['phase_off']:.0f}° off)"
            )
            cells.append(f"{r['same_sign']}/8, {where}")
        lines.append(table_row(cells))
    lines += [
        "",
        "Each reading against the lag study's targets for a phase-resolved reading "
        "(docs/crosscheck.md, *The rule*): the hind-wing's sign at 32/32, its largest loss "
        "within 45° of the UVLM's in 4/4 cases, its RMS difference ≤ 6 points; the fore-wing's "
        "RMS ≤ 4 points and sign at ≥ 28/32:",
        "",
        "| reading | hind: sign | hind: largest loss within 45° | hind: RMS [points] | "
        "fore: RMS [points] | fore: sign |",
        "|---|---|---|---|---|---|",
    ]
    lines += [
        f"| `{name}` | {t['hind_sign']}/{t['points']} | {t['within']}/{t['cases']} | "
        f"{t['hind_rms']:.1f} | {t['fore_rms']:.1f} | {t['fore_sign']}/{t['points']} |"
        for name, t in targets(rows).items()
    ]
    if data.get("model_refreshed"):
        lines += [
            "",
            "The model's columns were recomputed on the stored solver rows by `python -m eval "
            "numbers --only crosscheck-lag-study` (the solver was not rerun), and the figure "
            "drawn from them.",
        ]
    lines += [
        "",
        f"The UVLM's convergence at one case (V = 1 m/s, lag 0°, the dragonfly's spacing), "
        f"`{data['convergence_command']}`: the change of each pair's vertical force at each "
        "resolution run (3 beats each; the loads from the last):",
        "",
        "| steps per beat | panels (chordwise x spanwise) | UVLM hind | UVLM fore | tandem run [s] |",
        "|---|---|---|---|---|",
    ]
    lines += [
        f"| {row['steps_per_beat']} | {row['panels']} | "
        f"{float(row['uvlm_hind_change_pct']):+.1f} % | {float(row['uvlm_fore_change_pct']):+.1f} % | "
        f"{float(row['uvlm_tandem_wall_s']):.0f} |"
        for row in data["convergence"]
    ]
    return "\n".join(lines) + "\n"


MEASUREMENT = framework.Measurement("crosscheck-lag-study", measure, render, on_request=True)
