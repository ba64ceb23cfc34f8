"""A second species (docs/envs.md, "A second species"): the documented level-flight ``eval
optimize`` for the paper's specimen and for ``--insect examples/orthetrum_cancellatum.yaml``,
over seeds, with the best seed's stroke."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from eval.numbers.framework import (
    Measurement,
    agreed,
    footer,
    kernel_views,
    kernels_line,
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


def _stroke_cell(bests: Sequence[dict[str, Any]], name: str, form: str) -> str:
    """The best seed's ``name`` (fore / hind for a stroke parameter), at the digits every BLAS
    kernel's best seed gives."""
    if name not in SPECIES_PARAMETERS:
        return agreed([best[name] for best in bests], form)
    return " / ".join(
        agreed([best[f"{wing}_{name}"] for best in bests], form) for wing in ("fore", "hind")
    )


def _bounds_text(rows: Sequence[dict[str, Any]]) -> str:
    """The best seed's parameters at a bound (``at_bounds``, ``name=side; ...``) under every
    BLAS kernel (``rows``: one condition's row per kernel), then those at a bound under some."""
    best = [max(row["seeds"], key=lambda s: s["objective"])["at_bounds"] for row in rows]
    each = [[item for item in text.split("; ") if item] for text in best]
    common = [item for item in each[0] if all(item in other for other in each)]
    some = sorted({item for items in each for item in items} - set(common))
    tail = f" (under some kernels also {'; '.join(some)})" if some else ""
    return "; ".join(common) + tail


def render(data: dict[str, Any]) -> str:
    columns = _columns()
    headings = " | ".join(title for _, title, _ in columns)
    lines = [
        f"| insect | η, seeds {SPECIES_SEEDS[0]}-{SPECIES_SEEDS[-1]} | median | all feasible "
        f"| best seed: {headings} | time per seed |",
        "|---|---|---|---|" + "---|" * len(columns) + "---|",
    ]
    views = list(kernel_views(data).values())
    for i, row in enumerate(data["rows"]):
        by_kernel = [view["rows"][i]["seeds"] for view in views]
        objectives, median, feasible, times = seed_cells(by_kernel)
        bests = [max(seeds, key=lambda s: s["objective"]) for seeds in by_kernel]
        cells = " | ".join(_stroke_cell(bests, name, form) for name, _, form in columns)
        lines.append(
            f"| {row['label']} | {objectives} | {median} | {feasible} | {cells} | {times} |"
        )
    lines += [
        "",
        "Table 4 parameters are given fore / hind: f the wing-beat frequency, φ_m, θ_m and η_m "
        "the weaving, flapping and pitching amplitudes, β_m the stroke-plane inclination. The "
        "best seed's parameters at a Table 4 bound: "
        + "; ".join(
            f"{row['label']}: {_bounds_text([view['rows'][i] for view in views])}"
            for i, row in enumerate(data["rows"])
        )
        + ".",
        "",
        kernels_line(data),
    ]
    commands = (row["command"] for row in data["rows"])
    lines += footer(data, "second-species", *commands, heading="Each row's command:")
    return "\n".join(lines) + "\n"


MEASUREMENT = Measurement("second-species", measure, render, blas_dependent=True)
