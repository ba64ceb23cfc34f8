"""The one best-stroke rule: feasible first, then the higher reward, the earlier on ties."""

from __future__ import annotations

import numpy as np
import pytest

from agents.selection import NOTHING, BestStroke, best_index, is_better, rank

NAN, INF = float("nan"), float("inf")


def test_a_feasible_stroke_beats_a_higher_infeasible_reward() -> None:
    assert best_index([False, True, False], [5.0, 0.1, 9.0]) == 1
    assert is_better(True, -3.0, False, 100.0)
    assert not is_better(False, 100.0, True, -3.0)


def test_among_equal_feasibility_the_higher_reward_wins() -> None:
    assert best_index([True, True, True], [0.2, 0.7, 0.5]) == 1
    assert best_index([False, False], [-4.0, -1.0]) == 1  # all infeasible: best reward
    assert is_better(False, -1.0, False, -4.0)


def test_ties_go_to_the_earlier_stroke() -> None:
    assert best_index([True, False, True, True], [0.5, 0.9, 0.5, 0.5]) == 0
    assert best_index([False, False, False], [0.3, 0.3, 0.1]) == 0
    assert not is_better(True, 0.5, True, 0.5)  # the incumbent stays
    best = BestStroke()
    assert best.offer([True, True], [0.5, 0.5]) == 0
    assert best.offer([True], [0.5]) is None


def test_nan_and_minus_inf_rank_below_every_real_reward_whatever_the_flag() -> None:
    assert rank(True, NAN) == rank(True, -INF) == NOTHING  # counted as infeasible, -inf
    assert best_index([True, False], [NAN, -50.0]) == 1
    assert best_index([True, True, False], [-INF, NAN, -1e300]) == 2
    assert best_index([True, False], [NAN, NAN]) == 0  # nothing usable: every stroke ties
    assert not is_better(True, NAN, False, -50.0)
    assert is_better(False, -50.0, True, NAN)
    assert not is_better(True, NAN, NOTHING.feasible, NOTHING.reward)  # never beats nothing


def test_best_stroke_keeps_the_winner_over_batches() -> None:
    best = BestStroke()
    assert not best.found and best.rank == NOTHING
    assert best.offer([True, False], [NAN, -INF]) is None and not best.found
    assert best.offer([False, False], [0.2, 0.1]) == 0
    assert (best.feasible, best.reward) == (False, 0.2)
    assert best.offer([False, True], [0.9, 0.3]) == 1  # first feasible stroke
    assert best.offer([False, True], [0.8, 0.25]) is None
    assert best.offer([True, False], [0.5, 0.95]) == 0
    assert best.found and (best.feasible, best.reward) == (True, 0.5)


def test_best_index_agrees_with_offering_strokes_one_by_one() -> None:
    rng = np.random.default_rng(0)
    for _ in range(200):
        n = int(rng.integers(1, 12))
        feasible = rng.random(n) < 0.4
        reward = rng.choice([-1.0, 0.0, 0.5, 1.0, NAN, -INF], size=n)
        one_by_one = BestStroke()
        chosen = None
        for i in range(n):
            if one_by_one.offer(feasible[i : i + 1], reward[i : i + 1]) is not None:
                chosen = i
        i = best_index(feasible, reward)
        assert chosen == (i if rank(feasible[i], reward[i]).beats(NOTHING) else None)


def test_bad_shapes_are_refused() -> None:
    with pytest.raises(ValueError, match="same shape"):
        best_index([], [])
    with pytest.raises(ValueError, match="same shape"):
        best_index([True], [1.0, 2.0])


def test_the_optimisers_running_best_is_the_rule_without_constraints() -> None:
    from agents.optimiser import Tally

    tally = Tally()
    points = np.arange(6.0).reshape(3, 2)
    tally.add(points, [NAN, -INF, NAN])
    assert tally.best_point is None and tally.best_value == -INF
    tally.add(points, [1.0, 2.0, 2.0])
    tally.add(points, [2.0, NAN, 0.0])  # a tie keeps the earlier point
    assert tally.best_value == 2.0 and np.array_equal(tally.best_point, points[1])
    assert tally.history == [(3, -INF), (6, 2.0), (9, 2.0)] and tally.iterations == 3
