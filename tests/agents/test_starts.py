"""A run's budget split into parts (agents/harness.py): ``starts`` independent searches, each
polished, and ``initial`` strokes polished directly (the readings' continuation).

Checked: one start is the plain run, stroke for stroke; the parts share the budget and never
exceed it; the record reports the best feasible part and lists every part; an initial stroke
that is already a constrained optimum stays one; an infeasible initial stroke is moved onto
the constraints by the polish (the analytic problem of test_polish.py); bad settings are
refused before any computation.
"""

from __future__ import annotations

import numpy as np
import pytest

from agents.harness import prepare, run
from agents.polish import MAX_STARTS, PolishConfig, polish, split_settings
from agents.records import SELECTION_INITIAL, SELECTION_INITIAL_POLISHED, STARTS
from tests.agents.test_polish import F_MARGIN, FIXED, FREE, ROUNDING, X_STAR, Counted, problem

BUDGET = 3_000
ACCELERATE_KWARGS = {"objective": "vertical", "progress": False}


def _run(config: dict, budget: int = BUDGET, seed: int = 0):
    return run(
        "cmaes", "accelerate", 60.0, budget, [seed], method_config=config, **ACCELERATE_KWARGS
    )[0]


def test_one_start_is_the_plain_run():
    plain, one = _run({}), _run({"starts": 1})
    assert one.objective == plain.objective
    assert one.normalised_stroke == plain.normalised_stroke
    assert one.history == plain.history
    assert STARTS not in one.results  # one part: nothing to list


def test_starts_share_the_budget_and_the_best_feasible_part_is_reported():
    record = _run({"starts": 3})
    parts = record.results[STARTS]
    assert [p["kind"] for p in parts] == ["search"] * 3
    assert len({p["seed"] for p in parts}) == 3 and parts[0]["seed"] == 0
    assert record.evaluations == sum(p["evaluations"] for p in parts) <= BUDGET
    best = max(p["reward"] for p in parts if p["feasible"])
    # each part within its share, but the reported one when the finish by autograd (on what
    # the parts left of the budget) certified it
    finished = ", then " in record.certificate["gradient"]
    for p in parts:
        if not (finished and p["reward"] == best):
            assert p["evaluations"] <= BUDGET // 3 + BUDGET % 3
    assert record.feasible and record.objective == pytest.approx(best, rel=1e-12)
    # the history runs over the whole budget, best so far never falling
    evaluations, values = np.array(record.history).T
    assert np.all(np.diff(evaluations) > 0) and np.all(np.diff(values) >= 0)
    assert evaluations[-1] > BUDGET // 3


def test_an_optimum_given_as_initial_stroke_is_kept_or_improved():
    found = _run({})
    again = _run({"initial": [found.normalised_stroke]}, seed=1)
    parts = again.results[STARTS]
    assert [p["kind"] for p in parts] == ["initial", "search"]
    initial = parts[0]
    assert initial["feasible"] and initial["selection"] in (
        SELECTION_INITIAL,
        SELECTION_INITIAL_POLISHED,
    )
    # a polished optimum polished again: within the polish's tolerance of where it was
    assert initial["reward"] >= found.objective * (1 - 1e-6)
    assert again.objective >= initial["reward"] * (1 - 1e-12)


def test_an_infeasible_start_is_moved_onto_the_constraint():
    x0 = np.full(28, 0.9)  # Σ_free x = 23.4 > 7.8: infeasible
    x0[list(FIXED)] = 0.5
    kept = polish(problem(Counted()), x0, 5_000, PolishConfig())
    assert kept.certificate.status == "failed: the start is infeasible" and not kept.feasible
    moved = polish(problem(Counted()), x0, 5_000, PolishConfig(), infeasible_start=True)
    assert moved.feasible and moved.certificate.status == "improved"
    assert moved.certificate.gain is None  # no feasible start to compare with
    np.testing.assert_allclose(moved.stroke[list(FREE)], X_STAR, atol=1e-6)
    assert moved.objective == pytest.approx(F_MARGIN, abs=ROUNDING + 1e-9)


@pytest.mark.parametrize(
    ("settings", "match"),
    [
        ({"starts": 0}, r"starts = 0; allowed: an integer >= 1 and <= 64$"),
        ({"starts": MAX_STARTS + 1}, r"starts = 65"),
        ({"starts": 2.5}, r"starts = 2.5"),
        ({"initial": [[0.0] * 28, [2.0] * 28]}, r"initial stroke value 2.0; allowed"),
        ({"initial": "abc"}, r"initial = 'abc'; allowed: a list of strokes"),
        ({"initial": [[0.0] * 28], "polish": "none"}, r"initial strokes are polished"),
    ],
)
def test_bad_settings_are_refused_naming_the_value(settings: dict, match: str):
    with pytest.raises(ValueError, match=match):
        split_settings("cmaes", settings)


def test_a_stroke_of_the_wrong_size_or_too_many_parts_is_refused_before_running():
    with pytest.raises(ValueError, match=r"initial stroke of length 3; allowed: 28 values"):
        prepare("cmaes", "accelerate", 60.0, 2_000, [0], method_config={"initial": [[0.0] * 3]})
    # each of 64 searches would get 15 evaluations: below one CMA-ES population (52)
    with pytest.raises(ValueError, match=r"smaller than one CMA-ES population \(52 points\)"):
        prepare("cmaes", "accelerate", 60.0, 1_000, [0], method_config={"starts": 64})
