"""Scores and tables that refuse nonsense: ``normalised_score``'s inputs, ``reference``'s
condition and the reference table's contents, each refused with the value (and the file) at
fault and what is allowed, before any score is given."""

from __future__ import annotations

import copy
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import tandem_env
import tandem_env.envs.reference as reference_module
from tandem_env.envs.reference import (
    ReferenceTable,
    load_reference_table,
    normalised_score,
    reference_path,
)
from tandem_env.envs.registration import LEVEL_FLIGHT_ID

PACKAGED = json.loads(reference_path().read_text(encoding="utf-8"))


# --- normalised_score -------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("args", "match"),
    [
        # an infeasible stroke's violation is a sum of violations, >= 0: -3 would score +300
        ((0.5, 0.4, False, -3.0), r"violation = -3.0; allowed: numbers >= 0"),
        ((0.5, 0.4, [False, True], [np.nan, 0.0]), r"violation = nan; allowed: numbers >= 0"),
        ((0.5, 0.4, "no", 0.0), r"feasible = 'no'; allowed: booleans"),
        ((0.5, 0.4, [1, 0], [0.0, 1.0]), r"feasible = \[1, 0\]; allowed: booleans"),
        ((0.5, np.inf, True, 0.0), r"objective = inf; allowed: finite where the stroke is"),
        ((0.5, [0.4, -np.inf], True, 0.0), r"objective = -inf; allowed: finite"),
        ((np.inf, 0.4, True, 0.0), r"reference = inf; allowed: finite or NaN"),
        ((0.5, "0.4", True, 0.0), r"objective = '0.4' is a string"),
    ],
)
def test_scores_of_what_no_stroke_can_be_are_refused(args: tuple[Any, ...], match: str) -> None:
    with pytest.raises(ValueError, match=match):
        normalised_score(*args)


def test_scores_read_only_what_decides_them() -> None:
    # an infeasible stroke's objective (NaN, inf) is not read; a feasible one's violation is not
    scores = normalised_score(
        [0.5, 0.5, 0.5, 0.5], [0.4, np.nan, np.inf, 0.5], [True, False, False, True],
        [np.nan, 0.5, np.inf, 0.0],
    )  # fmt: skip
    np.testing.assert_array_equal(scores, [80.0, -50.0, -100.0, 100.0])
    assert np.isnan(normalised_score(np.nan, 0.4, True, 0.0))  # outside the grid: no score


# --- reference's condition ----------------------------------------------------------------------
@pytest.mark.parametrize(
    ("condition", "match"),
    [
        (True, r"condition = True is a boolean; allowed: finite real numbers"),
        ("1.0", r"condition = '1.0' is a string"),
        (1 + 0j, r"condition = \(1\+0j\) is a complex number"),
        (np.nan, r"condition = nan is not finite or outside the reference grid"),
        ([1.0, np.inf], r"is not finite or outside the reference grid"),
    ],
)
def test_a_condition_is_a_finite_real(condition: Any, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        tandem_env.reference(LEVEL_FLIGHT_ID, condition)


# --- the table's contents -------------------------------------------------------------------------
def _damaged(change: Any) -> dict[str, Any]:
    data = copy.deepcopy(PACKAGED)
    change(data)
    return data


def _point(data: dict[str, Any], key: str, value: Any, k: int = 3) -> None:
    data["series"][0]["points"][k][key] = value


@pytest.mark.parametrize(
    ("change", "match"),
    [
        (lambda d: _point(d, "objective", float("nan")), r"at 0.625: objective nan, feasible True"),
        (lambda d: _point(d, "objective", -0.4), r"objective -0.4.*finite objective above 0"),
        (lambda d: _point(d, "objective", 0), r"objective 0, feasible True"),
        (lambda d: _point(d, "feasible", "yes"), r"feasible 'yes'; allowed: feasible true or"),
        (lambda d: _point(d, "condition", 0.6), r"conditions \[.*0\.6.*\]; allowed: increasing"),
        (lambda d: d["series"][0]["points"].reverse(), r"allowed: increasing points of the grid"),
        (lambda d: _point(d, "normalised_stroke", [0.0] * 27), r"shape \(27,\); allowed: 28"),
        (lambda d: _point(d, "normalised_stroke", [np.nan] * 28), r"allowed: 28 finite numbers"),
        (lambda d: d["series"][0]["points"].pop(4), r"not a feasible optimum at every point"),
        (lambda d: d["series"].pop(), r"series .*resultant real: missing or repeated"),
        (lambda d: d["series"].append(d["series"][0]), r"series repeated: missing or repeated"),
        (lambda d: d["series"][0].pop("points"), r"no 'points'; allowed: a table python -m"),
        (lambda d: d["series"][0].update(objective="speed"), r"not a task and objective of"),
        (lambda d: d.update(format="other/1"), r"not a reference table of format"),
    ],
)
def test_a_damaged_table_is_refused_naming_the_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, change: Any, match: str
) -> None:
    damaged = tmp_path / "reference_optima.json"
    damaged.write_text(json.dumps(_damaged(change)), encoding="utf-8")
    monkeypatch.setattr(reference_module, "reference_path", lambda: damaged)
    load_reference_table.cache_clear()
    try:
        with pytest.raises(ValueError, match=match) as info:
            load_reference_table()
    finally:
        load_reference_table.cache_clear()
    assert str(info.value).startswith(f"{damaged}: not a readable reference table")


@pytest.mark.parametrize("text", ["{not json", "[" * 100_000, b"\xff\xfe"])
def test_a_table_that_is_not_json_is_refused_naming_the_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, text: str | bytes
) -> None:
    damaged = tmp_path / "reference_optima.json"
    damaged.write_bytes(text if isinstance(text, bytes) else text.encode())
    monkeypatch.setattr(reference_module, "reference_path", lambda: damaged)
    load_reference_table.cache_clear()
    try:
        with pytest.raises(ValueError, match=f"{damaged}: not a readable reference table"):
            load_reference_table()
    finally:
        load_reference_table.cache_clear()


def test_the_packaged_table_is_complete_and_a_partial_one_reads_without_complete() -> None:
    assert len(load_reference_table().series) == 8
    partial = _damaged(lambda d: d["series"][0]["points"].pop(4))
    assert len(ReferenceTable.from_dict(partial).series) == 8
