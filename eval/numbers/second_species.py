"""A second species (docs/envs.md, "A second species"): the documented level-flight ``eval
optimize`` for the paper's specimen and for ``--insect examples/orthetrum_cancellatum.yaml``,
over seeds, with the best seed's stroke."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from eval.numbers.framework import (
    Measurement,
    footer,
    optimize_command,
    run_seeds,
    seed_cells,
)

SPECIES_FILE = "examples/orthetrum_cancellatum.yaml"
SPECIES_ARGUMENTS: tuple[str, ...] = (
    "--task", "level", "--speed", "1.5", "--method", "cmaes", "--budget", "16000",
)  # fmt: skip
"""The condition and search, the README's level-flight comparison row (cmaes)."""
SPECIES_SEEDS: tuple[int, ...] = (0, 1, 2)
SPECIES_INSECTS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("the paper's specimen (*S. sanguineum* SSan2)", ()),
    ("*O. cancellatum* OC5", ("--insect", SPECIES_FILE)),
)
"""(label, the options that choose the insect) of each row."""

#: The best seed's metrics (heading, format) the table shows, then its stroke parameters.
SPECIES_METRICS: tuple[tuple[str, str, str], ...] = (
    ("lift_to_weight", "L/W", "{:.3f}"),
    ("power_per_mass", "P/m [W/kg]", "{:.1f}"),
)
SPECIES_PARAMETERS: tuple[str, ...] = (
    "frequency", "sweep_amplitude", "elevation_amplitude", "pitch_amplitude", "stroke_plane_angle",
)  # fmt: skip
"""Table 4 parameters shown per wing (fore / hind), with the paper's symbols."""


def _columns() -> list[tuple[str, str, str]]:
    """(name, heading, format) of each best-seed column."""
    from tandem_env.physics.stroke import TABLE_4

    table = {p.name: p for p in TABLE_4}
    units = {"deg": "°"}
    parameters = [
        (name, f"{table[name].symbol} [{units.get(table[name].unit, table[name].unit)}]", "{:.1f}")
        for name in SPECIES_PARAMETERS
    ]
    return [*SPECIES_METRICS, *parameters]


def run_species(insect: Sequence[str], seeds: Sequence[int]) -> list[dict[str, Any]]:
    """Run the documented command in a fresh folder; one summary row per seed (the record's
    objective, metrics, 28 stroke parameters, ``at_bounds`` and ``insect``)."""
    records = run_seeds((*insect, *SPECIES_ARGUMENTS), seeds)
    return [{**r.summary_row(), "feasible": bool(r.feasible)} for r in records]


def measure() -> dict[str, Any]:
    rows = [
        {
            "label": label,
            "command": optimize_command((*insect, *SPECIES_ARGUMENTS), SPECIES_SEEDS),
            "seeds": run_species(insect, SPECIES_SEEDS),
        }
        for label, insect in SPECIES_INSECTS
    ]
    return {"rows": rows}


def _stroke_cell(best: dict[str, Any], name: str, form: str) -> str:
    if name not in SPECIES_PARAMETERS:
        return form.format(best[name])
    return " / ".join(form.format(best[f"{wing}_{name}"]) for wing in ("fore", "hind"))


def render(data: dict[str, Any]) -> str:
    columns = _columns()
    headings = " | ".join(title for _, title, _ in columns)
    lines = [
        f"| insect | η, seeds {SPECIES_SEEDS[0]}-{SPECIES_SEEDS[-1]} | median | all feasible "
        f"| best seed: {headings} | time per seed |",
        "|---|---|---|---|" + "---|" * len(columns) + "---|",
    ]
    for row in data["rows"]:
        objectives, median, feasible, times = seed_cells(row["seeds"])
        best = max(row["seeds"], key=lambda s: s["objective"])
        cells = " | ".join(_stroke_cell(best, name, form) for name, _, form in columns)
        lines.append(
            f"| {row['label']} | {objectives} | {median} | {feasible} | {cells} | {times} |"
        )
    lines += [
        "",
        "Table 4 parameters are given fore / hind: f the wing-beat frequency, φ_m, θ_m and η_m "
        "the weaving, flapping and pitching amplitudes, β_m the stroke-plane inclination. The "
        "best seed's parameters at a Table 4 bound: "
        + "; ".join(
            f"{row['label']}: {max(row['seeds'], key=lambda s: s['objective'])['at_bounds']}"
            for row in data["rows"]
        )
        + ".",
    ]
    commands = (row["command"] for row in data["rows"])
    lines += footer(data, "second-species", *commands, heading="Each row's command:")
    return "\n".join(lines) + "\n"


MEASUREMENT = Measurement("second-species", measure, render)
