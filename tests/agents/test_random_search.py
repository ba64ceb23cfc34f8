"""Tests for agents.random_search: same interface, budget and result type as PSO."""

from __future__ import annotations

import math

import numpy as np
import pytest

from agents.optimiser import AskTellOptimiser, FloatArray, OptimisationResult, maximise, minimise
from agents.pso import PSO, PSOConfig
from agents.random_search import RandomSearch, RandomSearchConfig


def neg_sphere(X: FloatArray) -> FloatArray:
    return -np.sum((X - 0.3) ** 2, axis=1)


def run_ask_tell(opt: AskTellOptimiser, objective) -> list[FloatArray]:
    batches = []
    while not opt.done:
        X = opt.ask()
        batches.append(X)
        opt.tell(X, objective(X))
    return batches


def test_samples_are_uniform_in_the_box() -> None:
    opt = RandomSearch(3, RandomSearchConfig(iterations=250), seed=0)
    stacked = np.concatenate(run_ask_tell(opt, neg_sphere))
    assert stacked.shape == (250 * 40, 3)
    assert stacked.min() >= -1.0
    assert stacked.max() <= 1.0
    # 10 000 uniform samples: mean 0 and variance 1/3 to well within sampling error.
    np.testing.assert_allclose(stacked.mean(axis=0), 0.0, atol=0.03)
    np.testing.assert_allclose(stacked.var(axis=0), 1.0 / 3.0, atol=0.02)


@pytest.mark.parametrize(
    ("batch_size", "iterations", "max_evaluations", "expected_sizes"),
    [
        (40, None, 100, [40, 40, 20]),
        (40, 2, None, [40, 40]),
        (5, 10, 12, [5, 5, 2]),
        (1, 3, None, [1, 1, 1]),
    ],
)
def test_budget_never_exceeded(
    batch_size: int, iterations: int | None, max_evaluations: int | None, expected_sizes: list[int]
) -> None:
    config = RandomSearchConfig(
        batch_size=batch_size, iterations=iterations, max_evaluations=max_evaluations
    )
    opt = RandomSearch(2, config, seed=0)
    assert [len(X) for X in run_ask_tell(opt, neg_sphere)] == expected_sizes
    assert opt.evaluations == sum(expected_sizes)
    assert opt.done
    with pytest.raises(RuntimeError, match="budget exhausted"):
        opt.ask()
    assert maximise(neg_sphere, 2, config, seed=0).evaluations == sum(expected_sizes)


def test_deterministic_per_seed() -> None:
    config = RandomSearchConfig(iterations=20)
    a = maximise(neg_sphere, 6, config, seed=9)
    b = maximise(neg_sphere, 6, config, seed=9)
    c = maximise(neg_sphere, 6, config, seed=10)
    np.testing.assert_array_equal(a.history, b.history)
    np.testing.assert_array_equal(a.best_position, b.best_position)
    assert not np.array_equal(a.history[:, 1], c.history[:, 1])


def test_same_interface_and_result_type_as_pso() -> None:
    rs_config = RandomSearchConfig(iterations=30)
    pso_config = PSOConfig(iterations=30)
    for opt in (RandomSearch(4, rs_config, seed=1), PSO(4, pso_config, seed=1)):
        run_ask_tell(opt, neg_sphere)
        assert opt.evaluations == 1200
        assert len(opt.history) == 30
        assert opt.best_position is not None
        assert opt.best_fitness == max(best for _, best in opt.history)

    result = minimise(lambda X: -neg_sphere(X), 4, rs_config, seed=1)
    assert isinstance(result, OptimisationResult)
    assert result.sense == "minimise"
    assert result.config == rs_config.to_dict()
    assert result.config["algorithm"] == "random-search"
    assert "random search" in result.config["citation"]
    assert np.all(np.diff(result.history[:, 1]) <= 0.0)  # best-so-far never rises


def test_nan_fitness_is_never_best() -> None:
    opt = RandomSearch(2, RandomSearchConfig(iterations=10), seed=0)
    run_ask_tell(opt, lambda X: np.where(X[:, 0] > 0.0, np.nan, -np.abs(X[:, 0])))
    assert opt.best_position is not None
    assert opt.best_position[0] <= 0.0
    assert math.isfinite(opt.best_fitness)


def test_tell_requires_the_asked_batch() -> None:
    opt = RandomSearch(2, RandomSearchConfig(iterations=2), seed=0)
    X = opt.ask()
    with pytest.raises(ValueError, match="unchanged"):
        opt.tell(X + 0.1, np.zeros(len(X)))


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"batch_size": 0, "iterations": 1}, "batch_size must be an integer >= 1"),
        ({"batch_size": 2.0, "iterations": 1}, "batch_size must be an integer >= 1"),
        ({}, "no budget given: set iterations and/or max_evaluations"),
        ({"max_evaluations": -5}, "max_evaluations must be an integer >= 1"),
    ],
)
def test_bad_config_raises_helpful_error(kwargs: dict[str, object], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        RandomSearchConfig(**kwargs)  # type: ignore[arg-type]


def test_describe_includes_citation() -> None:
    config = RandomSearchConfig(max_evaluations=100)
    assert config.citation in config.describe()
    assert "max_evaluations = 100" in config.describe()
