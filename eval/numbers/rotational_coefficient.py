"""The rotational coefficient's reading of the model on random strokes (deterministic: the test
reruns it)."""

from __future__ import annotations

from typing import Any

from eval.numbers.framework import RANDOM_STROKES, Measurement, random_strokes, spaced

ROTATION_SPEEDS: tuple[float, ...] = (0.0, 1.5)
"""Flight speeds [m/s] of the rotational-coefficient reading (hover and 1.5 m/s)."""


def measure() -> dict[str, Any]:
    """L/W with the paper's C_r = π over L/W with π/2 (both wings), for the random strokes that
    lift at least half the weight with π (docs/model.md §1.3)."""
    import math
    from dataclasses import replace

    import numpy as np

    import tandem_env as te

    strokes = random_strokes()
    insect = te.DRAGONFLY
    half = replace(
        insect,
        fore=replace(insect.fore, rotational_coefficient=math.pi / 2),
        hind=replace(insect.hind, rotational_coefficient=math.pi / 2),
    )
    rows = []
    for speed in ROTATION_SPEEDS:
        paper = te.evaluate(strokes, speed, insect=insect).lift_to_weight
        lifting = paper >= 0.5
        ratio = paper[lifting] / te.evaluate(strokes[lifting], speed, insect=half).lift_to_weight
        p5, p95 = np.percentile(ratio, [5, 95])
        rows.append(
            {
                "speed": speed,
                "strokes": int(lifting.sum()),
                "median": float(np.median(ratio)),
                "p5": float(p5),
                "p95": float(p95),
            }
        )
    return {"random_strokes": RANDOM_STROKES, "seed": 0, "rows": rows}


def render(data: dict[str, Any]) -> str:
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


MEASUREMENT = Measurement("rotational-coefficient", measure, render)
