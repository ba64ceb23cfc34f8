"""The resolution study at the defaults (deterministic: the test reruns it)."""

from __future__ import annotations

from typing import Any

from eval.numbers.framework import Benchmark, Measurement
from eval.studies.report import table_head, table_row

CONVERGENCE = Benchmark(("benchmarks/convergence.py", "--resolutions", "128x24"))
CONVERGENCE_BOUND_PERCENT = 0.5
"""The defaults' bound on the error of forces and power against the refined run [%] (§11.4)."""
#: The columns: each result's field and its title.
CONVERGENCE_COLUMNS = {"lift_to_weight": "L/W", "thrust": "T", "drag": "D", "power": "P"}


def render(data: dict[str, Any]) -> str:
    rows = sorted(data["rows"], key=lambda r: (r["speed"] == 0.0, r["speed"]))  # hover last

    def cell(error: dict[str, float]) -> str:
        text = f"{error['median']:.1g} % / {error['max']:.2g} %"
        if error["max"] > CONVERGENCE_BOUND_PERCENT:  # the few strokes beyond it: how few
            text += f" (p95 {error['p95']:.2g} %)"
        return text

    lines = table_head(
        ["V [m/s]", *(f"{title} median / max" for title in CONVERGENCE_COLUMNS.values())]
    )
    for r in rows:
        speed = "0 (hover)" if r["speed"] == 0.0 else f"{r['speed']:.1f}"
        cells = (cell(r["error_percent"][name]) for name in CONVERGENCE_COLUMNS)
        lines.append(table_row([speed, *cells]))
    lines += [
        "",
        f"{data['strokes']} random strokes (seed {data['seed']}), n_time = {rows[0]['n_time']}, "
        f"n_blade = {rows[0]['n_blade']} against {4 * rows[0]['n_time']} and "
        f"{4 * rows[0]['n_blade']}; written by `python -m eval numbers --only convergence` from:",
        "",
        f"    {data['command']}",
    ]
    return "\n".join(lines) + "\n"


MEASUREMENT = Measurement("convergence", CONVERGENCE.run, render)
