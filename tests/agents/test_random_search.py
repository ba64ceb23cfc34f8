"""Tests for agents.random_search: same interface, budget and record as PSO."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from agents.optimiser import FloatArray
from agents.pso import PSO, PSOConfig
from agents.random_search import RandomSearch, RandomSearchConfig

sys.path.insert(0, str(Path(__file__).parent))
from analytic_envs import drive


def neg_sphere(X: FloatArray) -> FloatArray:
    return -np.sum((X - 0.3) ** 2, axis=1)


def test_samples_are_uniform_in_the_box() -> None:
    opt = RandomSearch(3, RandomSearchConfig(max_evaluations=10_000), seed=0)
    stacked = np.concatenate(drive(opt, neg_sphere))
    assert stacked.shape == (250 * 40, 3)
    assert stacked.min() >= -1.0
    assert stacked.max() <= 1.0
    # 10 000 uniform samples: mean 0 and variance 1/3 to well within sampling error.
    np.testing.assert_allclose(stacked.mean(axis=0), 0.0, atol=0.03)
    np.testing.assert_allclose(stacked.var(axis=0), 1.0 / 3.0, atol=0.02)


@pytest.mark.parametrize(
    ("batch_size", "max_evaluations", "expected_sizes"),
    [(40, 100, [40, 40, 20]), (40, 80, [40, 40]), (5, 12, [5, 5, 2]), (1, 3, [1, 1, 1])],
)
def test_budget_never_exceeded(
    batch_size: int, max_evaluations: int, expected_sizes: list[int]
) -> None:
    config = RandomSearchConfig(batch_size=batch_size, max_evaluations=max_evaluations)
    opt = RandomSearch(2, config, seed=0)
    assert [len(X) for X in drive(opt, neg_sphere)] == expected_sizes
    assert opt.evaluations == sum(expected_sizes)
    assert opt.done
    with pytest.raises(RuntimeError, match="budget exhausted"):
        opt.ask()


def test_deterministic_per_seed() -> None:
    config = RandomSearchConfig(max_evaluations=800)
    a, b, c = (config.build(6, seed) for seed in (9, 9, 10))
    for optimiser in (a, b, c):
        drive(optimiser, neg_sphere)
    assert a.history == b.history
    np.testing.assert_array_equal(a.best_position, b.best_position)
    assert [v for _, v in a.history] != [v for _, v in c.history]


def test_same_interface_and_result_type_as_pso() -> None:
    rs_config = RandomSearchConfig(max_evaluations=1200)
    pso_config = PSOConfig(max_evaluations=1200)
    for opt in (RandomSearch(4, rs_config, seed=1), PSO(4, pso_config, seed=1)):
        drive(opt, neg_sphere)
        assert opt.evaluations == 1200
        assert len(opt.history) == 30
        assert opt.best_position is not None
        assert opt.best_fitness == max(best for _, best in opt.history)

        assert np.all(np.diff([best for _, best in opt.history]) >= 0.0)  # never falls
        assert opt.record() == opt.config.to_dict()
    record = rs_config.to_dict()
    assert record["algorithm"] == "random-search"
    assert "random search" in record["citation"]


def test_nan_fitness_is_never_best() -> None:
    opt = RandomSearch(2, RandomSearchConfig(max_evaluations=400), seed=0)
    drive(opt, lambda X: np.where(X[:, 0] > 0.0, np.nan, -np.abs(X[:, 0])))
    assert opt.best_position is not None
    assert opt.best_position[0] <= 0.0
    assert math.isfinite(opt.best_fitness)


def test_tell_requires_the_asked_batch() -> None:
    opt = RandomSearch(2, RandomSearchConfig(max_evaluations=80), seed=0)
    X = opt.ask()
    with pytest.raises(ValueError, match="unchanged"):
        opt.tell(X + 0.1, np.zeros(len(X)))


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"batch_size": 0, "max_evaluations": 1}, "batch_size = 0; allowed: an integer >= 1"),
        ({"batch_size": 2.0, "max_evaluations": 1}, "batch_size = 2.0; allowed: an integer >= 1"),
        (
            {"batch_size": 2**63, "max_evaluations": 1},
            r"batch_size = 9223372036854775808; allowed: .* <= 10,000$",
        ),
        ({"max_evaluations": -5}, "max_evaluations = -5; allowed: an integer >= 1"),
    ],
)
def test_bad_config_raises_helpful_error(kwargs: dict[str, object], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        RandomSearchConfig(**kwargs)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="max_evaluations"):
        RandomSearchConfig()  # type: ignore[call-arg]
