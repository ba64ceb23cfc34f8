"""The documented ``eval optimize`` commands over seeds: the comparison of methods (README
"Optimise strokes", docs/harness.md) and a second species (docs/envs.md, "A second species":
the level-flight command for the paper's specimen and for ``--insect
examples/orthetrum_cancellatum.yaml``, with the best seed's stroke)."""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any

from eval.compare import relative_spread
from eval.numbers import framework
from tandem_env.physics.stroke import TABLE_4


@dataclass(frozen=True)
class ComparisonRow:
    """One condition of the documented comparison: the same ``eval optimize`` for each method."""

    label: str
    symbol: str
    arguments: tuple[str, ...]
    """``eval optimize`` arguments besides ``--method``, ``--seeds`` and ``--out``."""


COMPARISON_ROWS: tuple[ComparisonRow, ...] = (
    ComparisonRow(
        "accelerating 60 W/kg, 12 000 evaluations",
        "F̄_v",
        ("--task", "accelerate", "--power", "60", "--objective", "vertical", "--budget", "12000"),
    ),
    ComparisonRow(
        "level 1.5 m/s, 16 000 evaluations",
        "η",
        ("--task", "level", "--speed", "1.5", "--budget", "16000"),
    ),
)
COMPARISON_METHODS: tuple[str, ...] = ("cmaes", "pso")
COMPARISON_SEEDS: tuple[int, ...] = (0, 1, 2, 3)

SPECIES_FILE = "examples/orthetrum_cancellatum.yaml"
SPECIES_ARGUMENTS = tuple("--task level --speed 1.5 --method cmaes --budget 16000".split())
"""The condition and search, the README's level-flight comparison row (cmaes)."""
SPECIES_SEEDS: tuple[int, ...] = (0, 1, 2)
SPECIES_INSECTS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("the paper's specimen (*S. sanguineum* SSan2)", ()),
    ("*O. cancellatum* OC5", ("--insect", SPECIES_FILE)),
)
"""(label, the options that choose the insect) of each row."""
#: The best seed's metrics (heading, format) the table shows, then its stroke parameters.
SPECIES_METRICS = (("lift_to_weight", "L/W", "{:.3f}"), ("power_per_mass", "P/m [W/kg]", "{:.1f}"))
SPECIES_PARAMETERS: tuple[str, ...] = tuple(
    "frequency sweep_amplitude elevation_amplitude pitch_amplitude stroke_plane_angle".split()
)
"""Table 4 parameters shown per wing (fore / hind), with the paper's symbols."""


def _arguments(row: ComparisonRow, method: str) -> tuple[str, ...]:
    return (*row.arguments, "--method", method)


def run_optimize(row: ComparisonRow, method: str, seeds: Sequence[int]) -> list[dict[str, Any]]:
    """Run the documented command in a fresh folder; one ``{seed, objective, ...}`` per seed."""
    return [
        {"seed": r.seed, "objective": r.objective, "feasible": bool(r.feasible)}
        | {"evaluations": r.evaluations, "wall_time_s": r.wall_time}
        for r in framework.run_seeds(_arguments(row, method), seeds)
    ]


def run_species(insect: Sequence[str], seeds: Sequence[int]) -> list[dict[str, Any]]:
    """Run the documented command in a fresh folder; one summary row per seed (the record's
    objective, metrics, 28 stroke parameters, ``at_bounds`` and ``insect``)."""
    records = framework.run_seeds((*insect, *SPECIES_ARGUMENTS), seeds)
    return [{**r.summary_row(), "feasible": bool(r.feasible)} for r in records]


def _rows(data: dict[str, Any]) -> Iterator[tuple[dict[str, Any], list[dict[str, Any]]]]:
    """Each stored row with that row under every BLAS kernel (the machine's own first)."""
    views = list(framework.kernel_views(data).values())
    for i, row in enumerate(data["rows"]):
        yield row, [view["rows"][i] for view in views]


def _table(
    data: dict[str, Any], name: str, head: list[str], cells: Callable[..., str], note: str = ""
) -> str:
    """The region of an optimisation measurement: ``head`` (header and rule), a line per row
    (``cells(row, the row under every kernel, its seed_cells)``), ``note``, the kernels and
    the commands."""
    lines = [
        *head,
        *(cells(r, k, framework.seed_cells([x["seeds"] for x in k])) for r, k in _rows(data)),
    ]
    lines += [x for text in (note, framework.kernels_line(data)) if text for x in ("", text)]
    commands = (row["command"] for row in data["rows"])
    lines += framework.footer(data, name, *commands, heading="Each row's command:")
    return "\n".join(lines) + "\n"


def measure_comparison() -> dict[str, Any]:
    rows = [
        {"label": row.label, "symbol": row.symbol, "method": method}
        | {
            "command": framework.optimize_command(_arguments(row, method), COMPARISON_SEEDS),
            "seeds": run_optimize(row, method, COMPARISON_SEEDS),
        }
        for row in COMPARISON_ROWS
        for method in COMPARISON_METHODS
    ]
    return {"rows": rows}


def render_comparison(data: dict[str, Any]) -> str:
    def cells(row: dict, by_kernel: list, seed: tuple[str, ...]) -> str:
        objectives, median, feasible, times = seed
        spreads = [100 * relative_spread([s["objective"] for s in r["seeds"]]) for r in by_kernel]
        return (
            f"| {row['label']} ({row['symbol']}) | `{row['method']}` | {objectives} | {median} | "
            f"{framework.agreed(spreads, '{:.1f}')} % | {feasible} | {times} |"
        )

    head = [
        "| condition | method | objective, seeds 0-3 | median | spread | all feasible | time per seed |",
        "|---|---|---|---|---|---|---|",
    ]
    return _table(data, "comparison", head, cells)


def measure_species() -> dict[str, Any]:
    rows = [
        {
            "label": label,
            "command": framework.optimize_command((*insect, *SPECIES_ARGUMENTS), SPECIES_SEEDS),
            "seeds": run_species(insect, SPECIES_SEEDS),
        }
        for label, insect in SPECIES_INSECTS
    ]
    return {"rows": rows}


def _best(seeds: Sequence[dict[str, Any]]) -> dict[str, Any]:
    return max(seeds, key=lambda s: s["objective"])


def _stroke_cell(bests: Sequence[dict[str, Any]], name: str, form: str) -> str:
    """The best seed's ``name`` (fore / hind for a parameter) at the digits every kernel gives."""
    if name not in SPECIES_PARAMETERS:
        return framework.agreed([best[name] for best in bests], form)
    return " / ".join(
        framework.agreed([best[f"{wing}_{name}"] for best in bests], form)
        for wing in ("fore", "hind")
    )


def _bounds_text(rows: Sequence[dict[str, Any]]) -> str:
    """The best seed's parameters at a bound (``at_bounds``, ``name=side; ...``) under every
    BLAS kernel (``rows``: one condition's row per kernel), then those at a bound under some."""
    each = [[item for item in _best(row["seeds"])["at_bounds"].split("; ") if item] for row in rows]
    common = [item for item in each[0] if all(item in other for other in each)]
    some = sorted({item for items in each for item in items} - set(common))
    tail = f" (under some kernels also {'; '.join(some)})" if some else ""
    return "; ".join(common) + tail


def render_species(data: dict[str, Any]) -> str:
    shown = {p.name: f"{p.symbol} [{'°' if p.unit == 'deg' else p.unit}]" for p in TABLE_4}
    parameters = [(n, shown[n], "{:.1f}") for n in SPECIES_PARAMETERS]
    columns = [*SPECIES_METRICS, *parameters]  # (name, heading, format) of each best-seed column

    def cells(row: dict, by_kernel: list, seed: tuple[str, ...]) -> str:
        objectives, median, feasible, times = seed
        bests = [_best(kernel_row["seeds"]) for kernel_row in by_kernel]
        best = " | ".join(_stroke_cell(bests, name, form) for name, _, form in columns)
        return f"| {row['label']} | {objectives} | {median} | {feasible} | {best} | {times} |"

    headings = " | ".join(title for _, title, _ in columns)
    bounds = "; ".join(f"{row['label']}: {_bounds_text(rows)}" for row, rows in _rows(data))
    head = [
        f"| insect | η, seeds {SPECIES_SEEDS[0]}-{SPECIES_SEEDS[-1]} | median | all feasible "
        f"| best seed: {headings} | time per seed |",
        "|---|---|---|---|" + "---|" * len(columns) + "---|",
    ]
    note = (
        "Table 4 parameters are given fore / hind: f the wing-beat frequency, φ_m, θ_m and η_m "
        "the weaving, flapping and pitching amplitudes, β_m the stroke-plane inclination. The "
        f"best seed's parameters at a Table 4 bound: {bounds}."
    )
    return _table(data, "second-species", head, cells, note)


MEASUREMENTS = (
    framework.Measurement("comparison", measure_comparison, render_comparison, blas_dependent=True),
    framework.Measurement("second-species", measure_species, render_species, blas_dependent=True),
)
