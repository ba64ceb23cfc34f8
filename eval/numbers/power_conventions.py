"""The power conventions' reading of the model on random strokes (deterministic: the test reruns
it)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from eval.numbers.framework import RANDOM_STROKES, Measurement, random_strokes, spaced

POWER_SPEEDS: tuple[float, ...] = (0.0, 1.0, 2.0)
"""Flight speeds [m/s] of the power-conventions reading."""


def measure() -> dict[str, Any]:
    """The ``"aerodynamic"`` power over the ``"absolute"`` and ``"elastic"`` ones on the random
    strokes (docs/model.md §6.3)."""
    import numpy as np

    import tandem_env as te

    strokes = random_strokes()
    rows = []
    for speed in POWER_SPEEDS:
        power = {
            kind: te.evaluate(strokes, speed, options=te.ModelOptions(power=kind)).power
            for kind in ("absolute", "elastic", "aerodynamic")
        }
        rows.append(
            {
                "speed": speed,
                "over_absolute_median": float(np.median(power["aerodynamic"] / power["absolute"])),
                "over_elastic_median": float(np.median(power["aerodynamic"] / power["elastic"])),
                "above_elastic_share": float(np.mean(power["aerodynamic"] > power["elastic"])),
            }
        )
    return {"random_strokes": RANDOM_STROKES, "seed": 0, "rows": rows}


def render(data: dict[str, Any]) -> str:
    rows = data["rows"]

    def listed(values: Sequence[str]) -> str:
        return ", ".join(values[:-1]) + " and " + values[-1]

    speeds = listed([f"{r['speed']:g}" for r in rows])
    absolute = listed([f"{r['over_absolute_median']:.2f}×" for r in rows])
    elastic = listed([f"{r['over_elastic_median']:.2f}×" for r in rows])
    above = listed([f"{100 * r['above_elastic_share']:.1f} %" for r in rows])
    return (
        f"On {spaced(data['random_strokes'])} random Table 4 strokes (seed {data['seed']}, other "
        f"options default) aerodynamic power is a median {absolute} the absolute power at "
        f"V = {speeds} m/s, {elastic} the elastic one, and exceeds the elastic one for {above} "
        "of the strokes "
        "(written by `python -m eval numbers --only power-conventions`).\n"
    )


MEASUREMENT = Measurement("power-conventions", measure, render)
