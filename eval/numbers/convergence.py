"""The model's numbers that the test reruns (deterministic): the resolution study at the
defaults (docs/model.md §11.4) and its readings on random Table 4 strokes, the rotational
coefficient's (§1.3) and the power conventions' (§6.3); and the reference optima
(docs/reference.md): the packaged table as the document shows it (made by ``python -m eval
reference``)."""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np

import tandem_env
from eval.numbers.framework import Benchmark, Measurement, spaced
from eval.reference import reference_markdown
from eval.studies.report import table_head, table_row
from tandem_env.envs.reference import reference_path

CONVERGENCE = Benchmark(("benchmarks/convergence.py", "--resolutions", "128x24"))
CONVERGENCE_BOUND_PERCENT = 0.5
"""The defaults' bound on the error of forces and power against the refined run [%] (§11.4)."""
#: The columns: each result's field and its title.
CONVERGENCE_COLUMNS = {"lift_to_weight": "L/W", "thrust": "T", "drag": "D", "power": "P"}


def render_convergence(data: dict[str, Any]) -> str:
    rows = sorted(data["rows"], key=lambda r: (r["speed"] == 0.0, r["speed"]))  # hover last

    def cell(error: dict[str, float]) -> str:
        text = f"{error['median']:.1g} % / {error['max']:.2g} %"
        if error["max"] > CONVERGENCE_BOUND_PERCENT:  # the few strokes beyond it: how few
            text += f" (p95 {error['p95']:.2g} %)"
        return text

    heads = [f"{title} median / max" for title in CONVERGENCE_COLUMNS.values()]
    lines = table_head(["V [m/s]", *heads])
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


ROTATION_SPEEDS: tuple[float, ...] = (0.0, 1.5)
"""Flight speeds [m/s] of the rotational-coefficient reading (hover and 1.5 m/s)."""
POWER_SPEEDS: tuple[float, ...] = (0.0, 1.0, 2.0)
"""Flight speeds [m/s] of the power-conventions reading."""
RANDOM_STROKES = 1000
"""Random Table 4 strokes (uniform in the normalised box, seed 0) of the readings."""


def on_random_strokes(
    speeds: tuple[float, ...], row: Callable[[np.ndarray, float], dict[str, Any]]
) -> dict[str, Any]:
    """A reading's data: ``row(strokes, speed)`` of the random strokes at each of ``speeds``."""
    box = np.random.default_rng(0).uniform(-1.0, 1.0, (RANDOM_STROKES, 28))
    strokes = tandem_env.normalised_to_physical(box)
    rows = [{"speed": speed, **row(strokes, speed)} for speed in speeds]
    return {"random_strokes": RANDOM_STROKES, "seed": 0, "rows": rows}


def measure_rotation() -> dict[str, Any]:
    """L/W with the paper's C_r = π over L/W with π/2 (both wings), for the random strokes that
    lift at least half the weight with π."""
    insect = tandem_env.DRAGONFLY
    c_r = {"rotational_coefficient": math.pi / 2}
    half = replace(insect, fore=replace(insect.fore, **c_r), hind=replace(insect.hind, **c_r))

    def row(strokes: np.ndarray, speed: float) -> dict[str, Any]:
        paper = tandem_env.evaluate(strokes, speed, insect=insect).lift_to_weight
        lifting = paper >= 0.5
        halved = tandem_env.evaluate(strokes[lifting], speed, insect=half).lift_to_weight
        ratio = paper[lifting] / halved
        p5, p95 = np.percentile(ratio, [5, 95])
        median = float(np.median(ratio))
        return {"strokes": int(lifting.sum()), "median": median, "p5": float(p5), "p95": float(p95)}

    return on_random_strokes(ROTATION_SPEEDS, row)


def render_rotation(data: dict[str, Any]) -> str:
    hover, forward = data["rows"]
    return (
        f"On {spaced(data['random_strokes'])} random Table 4 strokes (seed {data['seed']}, "
        f"default options) that lift at least half the weight with C_r = π ({hover['strokes']} "
        f"in hover, {forward['strokes']} at {forward['speed']:g} m/s), L/W with C_r = π is a "
        f"median {hover['median']:.2f}× its value with C_r = π/2 in hover and "
        f"{forward['median']:.2f}× at {forward['speed']:g} m/s (5th-95th percentiles "
        f"{hover['p5']:.2f}-{hover['p95']:.1f}× and {forward['p5']:.2f}-{forward['p95']:.1f}×; "
        "`evaluate` with `rotational_coefficient` replaced on both wings, written by `python -m "
        "eval numbers --only rotational-coefficient`).\n"
    )


def measure_power() -> dict[str, Any]:
    """The aerodynamic power over the absolute and elastic ones on the random strokes."""

    def row(strokes: np.ndarray, speed: float) -> dict[str, Any]:
        absolute, elastic, aero = (
            tandem_env.evaluate(strokes, speed, options=tandem_env.ModelOptions(power=kind)).power
            for kind in ("absolute", "elastic", "aerodynamic")
        )
        return {
            "over_absolute_median": float(np.median(aero / absolute)),
            "over_elastic_median": float(np.median(aero / elastic)),
            "above_elastic_share": float(np.mean(aero > elastic)),
        }

    return on_random_strokes(POWER_SPEEDS, row)


def render_power(data: dict[str, Any]) -> str:
    def listed(key: str, form: str) -> str:
        values = [form.format(row[key]) for row in data["rows"]]
        return ", ".join(values[:-1]) + " and " + values[-1]

    return (
        f"On {spaced(data['random_strokes'])} random Table 4 strokes (seed {data['seed']}, other "
        "options default) aerodynamic power is a median "
        f"{listed('over_absolute_median', '{:.2f}×')} the absolute power at V = {listed('speed', '{:g}')} m/s, "
        f"{listed('over_elastic_median', '{:.2f}×')} the elastic one, and exceeds the elastic one "
        f"for {listed('above_elastic_share', '{:.1%}').replace('%', ' %')} of the strokes "
        "(written by `python -m eval numbers --only power-conventions`).\n"
    )


def measure_reference() -> dict[str, Any]:
    """The packaged reference table, as it is."""
    return json.loads(reference_path().read_text(encoding="utf-8"))


MEASUREMENTS = (
    Measurement("convergence", CONVERGENCE.run, render_convergence),
    Measurement("rotational-coefficient", measure_rotation, render_rotation),
    Measurement("power-conventions", measure_power, render_power),
    Measurement("reference-table", measure_reference, reference_markdown),
)
