"""Parameters pinned at Table 4 bounds: the rule (more than half the feasible seeds within
tandem_env.BOUND_TOLERANCE of a bound), the summary CSVs' column and the report's section."""

from __future__ import annotations

from typing import Any

import numpy as np

from eval.studies import report
from eval.studies.tables import (
    PINNED_SHARE,
    pinned,
    pinned_parameters,
    spread_summary_rows,
    table4_bounds,
)
from tandem_env import LOWER, PARAMETER_NAMES, UPPER

MIDDLE = 0.5 * (LOWER + UPPER)
FORE_SWEEP, HIND_SWEEP = (PARAMETER_NAMES.index(f"{w}_sweep_amplitude") for w in ("fore", "hind"))


def _row(seed: int, feasible: bool = True, **at: float) -> dict[str, Any]:
    stroke = MIDDLE.copy()
    for name, value in at.items():
        stroke[PARAMETER_NAMES.index(name)] = value
    return {
        "method": "cmaes",
        "task": "level",
        "objective": "efficiency",
        "planform": "tear-drop",
        "condition": 1.5,
        "condition_unit": "m/s",
        "seed": seed,
        "feasible": feasible,
        "objective_value": 0.1 * seed,
        "key": f"k{seed}",
        "sweep_amplitude": 0.5 * (stroke[FORE_SWEEP] + stroke[HIND_SWEEP]),
        **dict(zip(PARAMETER_NAMES, stroke.tolist(), strict=True)),
    }


AT_30 = {"fore_sweep_amplitude": 30.0, "hind_sweep_amplitude": 30.1}  # 0.1° is inside 1 %


def test_pinned_needs_more_than_half_the_feasible_seeds_at_one_bound() -> None:
    assert PINNED_SHARE == 0.5
    two_of_three = [_row(0, **AT_30), _row(1, **AT_30), _row(2)]
    assert pinned(two_of_three, "fore_sweep_amplitude") == "lower"
    assert pinned(two_of_three, "sweep_amplitude") == "lower"  # both wings at 30°
    assert pinned(two_of_three, "fore_frequency") == ""
    assert pinned([_row(0, **AT_30), _row(1), _row(2)], "sweep_amplitude") == ""
    # the infeasible seeds do not count: one of one feasible seed is pinned
    assert pinned([_row(0, **AT_30), _row(1, False), _row(2, False)], "sweep_amplitude") == "lower"
    # a mean of both wings is pinned only where both are
    fore_only = [_row(k, fore_sweep_amplitude=30.0) for k in range(3)]
    assert pinned(fore_only, "fore_sweep_amplitude") == "lower"
    assert pinned(fore_only, "sweep_amplitude") == ""
    assert pinned([_row(k, fore_stroke_plane_angle=30.0) for k in range(2)],
                  "fore_stroke_plane_angle") == "upper"  # fmt: skip
    assert pinned(two_of_three, "efficiency") == ""  # not a stroke parameter


def test_bounds_of_the_parameter_panels() -> None:
    assert table4_bounds("sweep_amplitude") == (30.0, 60.0)
    assert table4_bounds("stroke_plane_angle") == (5.0, 30.0)
    assert table4_bounds("pitch_amplitude") == (1.0, 90.0)
    assert table4_bounds("fore_sweep_phase") is None  # periodic: no bound to sit at
    assert table4_bounds("efficiency") is None


def test_summary_and_report_flag_pinned_parameters() -> None:
    rows = [_row(0, **AT_30), _row(1, **AT_30), _row(2)]
    summary = spread_summary_rows(
        rows, ["sweep_amplitude", "fore_sweep_amplitude", "fore_frequency"]
    )
    assert [r["pinned"] for r in summary] == ["lower", "lower", ""]
    found = pinned_parameters([*rows, *rows])  # the same records in two studies count once
    assert [(r["parameter"], r["bound"], r["value"]) for r in found] == [
        ("fore_sweep_amplitude", "lower", 30.0),
        ("hind_sweep_amplitude", "lower", 30.0),
    ]
    assert np.isclose(found[0]["share"], 2 / 3)
    text = "\n".join(report.pinned_section(rows))
    assert "`fore_sweep_amplitude` at its lower bound 30: level efficiency, tear-drop (cmaes) " \
        "at 1.5 (67%) m/s" in text  # fmt: skip
    assert "- none" in "\n".join(report.pinned_section([_row(0)]))
