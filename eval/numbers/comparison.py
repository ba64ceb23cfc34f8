"""The comparison of methods (README "Optimise strokes", docs/harness.md): the documented
``eval optimize`` for each method and condition, over seeds."""

from __future__ import annotations

import statistics
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from eval.compare import relative_spread
from eval.numbers.framework import (
    machine_line,
    run_command,
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


def optimize_command(row: ComparisonRow, method: str, seeds: Sequence[int]) -> list[str]:
    """The documented command (without ``--out``) for one row and method."""
    return [
        "python",
        "-m",
        "eval",
        "optimize",
        *row.arguments,
        "--method",
        method,
        "--seeds",
        *map(str, seeds),
    ]


def run_optimize(row: ComparisonRow, method: str, seeds: Sequence[int]) -> list[dict[str, Any]]:
    """Run the documented command in a fresh folder; one ``{seed, objective, ...}`` per seed."""
    from agents.store import read_record_files

    with tempfile.TemporaryDirectory(prefix="tandem-numbers-") as out:
        # --no-cache: measured now (its wall times too), not copied from an earlier run
        run_command([*optimize_command(row, method, seeds), "--out", out, "--no-cache"])
        records = sorted(read_record_files([out]), key=lambda r: r.seed)
    if [r.seed for r in records] != list(seeds):
        raise RuntimeError(f"expected records of seeds {list(seeds)}, found {records!r}")
    return [
        {
            "seed": r.seed,
            "objective": r.objective,
            "feasible": bool(r.feasible),
            "evaluations": r.evaluations,
            "wall_time_s": r.wall_time,
        }
        for r in records
    ]


def measure_comparison() -> dict[str, Any]:
    rows = []
    for row in COMPARISON_ROWS:
        for method in COMPARISON_METHODS:
            seeds = run_optimize(row, method, COMPARISON_SEEDS)
            rows.append(
                {
                    "label": row.label,
                    "symbol": row.symbol,
                    "method": method,
                    "command": " ".join(optimize_command(row, method, COMPARISON_SEEDS)),
                    "seeds": seeds,
                }
            )
    return {"rows": rows}


def render_comparison(data: dict[str, Any]) -> str:
    lines = [
        "| condition | method | objective, seeds 0-3 | median | spread | all feasible | time per seed |",
        "|---|---|---|---|---|---|---|",
    ]
    for row in data["rows"]:
        values = [s["objective"] for s in row["seeds"]]
        times = [s["wall_time_s"] for s in row["seeds"]]
        lines.append(
            f"| {row['label']} ({row['symbol']}) | `{row['method']}` | "
            f"{', '.join(f'{v:.4f}' for v in values)} | **{statistics.median(values):.3f}** | "
            f"{100 * relative_spread(values):.1f} % | {'yes' if all(s['feasible'] for s in row['seeds']) else 'no'} | "
            f"{min(times):.1f}-{max(times):.1f} s |"
        )
    lines += ["", machine_line(data, "comparison"), "", "Each row's command:", ""]
    lines += [f"    {row['command']}" for row in data["rows"]]
    return "\n".join(lines) + "\n"
