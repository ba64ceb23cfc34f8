"""The comparison of methods (README "Optimise strokes", docs/harness.md): the documented
``eval optimize`` for each method and condition, over seeds."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from eval.compare import relative_spread
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


def _arguments(row: ComparisonRow, method: str) -> tuple[str, ...]:
    return (*row.arguments, "--method", method)


def run_optimize(row: ComparisonRow, method: str, seeds: Sequence[int]) -> list[dict[str, Any]]:
    """Run the documented command in a fresh folder; one ``{seed, objective, ...}`` per seed."""
    return [
        {
            "seed": r.seed,
            "objective": r.objective,
            "feasible": bool(r.feasible),
            "evaluations": r.evaluations,
            "wall_time_s": r.wall_time,
        }
        for r in run_seeds(_arguments(row, method), seeds)
    ]


def measure() -> dict[str, Any]:
    rows = [
        {
            "label": row.label,
            "symbol": row.symbol,
            "method": method,
            "command": optimize_command(_arguments(row, method), COMPARISON_SEEDS),
            "seeds": run_optimize(row, method, COMPARISON_SEEDS),
        }
        for row in COMPARISON_ROWS
        for method in COMPARISON_METHODS
    ]
    return {"rows": rows}


def render(data: dict[str, Any]) -> str:
    lines = [
        "| condition | method | objective, seeds 0-3 | median | spread | all feasible | time per seed |",
        "|---|---|---|---|---|---|---|",
    ]
    views = list(kernel_views(data).values())
    for i, row in enumerate(data["rows"]):
        by_kernel = [view["rows"][i]["seeds"] for view in views]
        objectives, median, feasible, times = seed_cells(by_kernel)
        spreads = [100 * relative_spread([s["objective"] for s in seeds]) for seeds in by_kernel]
        lines.append(
            f"| {row['label']} ({row['symbol']}) | `{row['method']}` | {objectives} | {median} | "
            f"{agreed(spreads, '{:.1f}')} % | {feasible} | {times} |"
        )
    lines += ["", kernels_line(data)]
    commands = (row["command"] for row in data["rows"])
    lines += footer(data, "comparison", *commands, heading="Each row's command:")
    return "\n".join(lines) + "\n"


MEASUREMENT = Measurement("comparison", measure, render, blas_dependent=True)
