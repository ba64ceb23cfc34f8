"""A new optimiser is one file plus one registration line: this file declares a toy one (a
hill climber with a shrinking step) and runs it through the harness and ``eval optimize``."""

from __future__ import annotations

import sys
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from agents.harness import run
from agents.methods import available_methods, get_method, preset_batch_setting, register_optimiser
from agents.optimiser import LOWER, UPPER, AskTellOptimiser, FloatArray, SeedLike, check_int
from agents.store import load_records

sys.path.insert(0, str(Path(__file__).parent))
from analytic_envs import ACTION_LOG, DIM, optimum, register_analytic

register_analytic()


@dataclass(frozen=True, kw_only=True)
class HillClimbConfig:
    """A (1, λ) hill climber: ``batch_size`` Gaussian steps of size ``step`` around the best point
    so far; the step halves after a batch that found nothing better."""

    max_evaluations: int
    batch_size: int = 16
    step: float = 0.5

    def __post_init__(self) -> None:
        check_int("max_evaluations", self.max_evaluations, minimum=1)
        check_int("batch_size", self.batch_size, minimum=1)

    citation = "toy hill climber (tests/agents/test_toy_optimiser.py)"

    def to_dict(self) -> dict[str, Any]:
        return {"algorithm": "hill-climb", **asdict(self), "citation": self.citation}

    def build(self, dim: int, seed: SeedLike = None) -> HillClimb:
        return HillClimb(dim, self, seed)


class HillClimb(AskTellOptimiser):
    def __init__(self, dim: int, config: HillClimbConfig, seed: SeedLike = None) -> None:
        super().__init__(dim, config.batch_size, config, seed)
        self._centre = np.zeros(dim)
        self._step = config.step

    def _propose(self, n: int) -> FloatArray:
        steps = self._rng.normal(0.0, self._step, (n, self.dim))
        return np.clip(self._centre + steps, LOWER, UPPER)

    def _observe(self, X: FloatArray, fitness: FloatArray) -> None:
        if fitness.max() > self.best_fitness:  # the base class counts the batch after this
            self._centre = X[np.argmax(fitness)]
        else:
            self._step /= 2.0


register_optimiser("hill-climb", HillClimbConfig, batch="batch_size")  # the one line


def test_the_toy_is_a_method_with_its_configs_settings() -> None:
    assert "hill-climb" in available_methods()
    assert preset_batch_setting("hill-climb") == "batch_size"
    method = get_method("hill-climb", {"swarm_size": 8, "step": 0.25})
    assert method.config(100) == HillClimbConfig(max_evaluations=100, batch_size=8, step=0.25)
    with pytest.raises(ValueError, match=r"unknown setting\(s\) \['steps'\]; allowed: batch_size"):
        get_method("hill-climb", {"steps": 1})
    with pytest.raises(ValueError, match=r"batch_size must be an integer >= 1, got 0"):
        get_method("hill-climb", {"batch_size": 0})


def test_the_toy_runs_through_the_harness() -> None:
    ACTION_LOG.clear()
    (record,) = run("hill-climb", "sphere", 0.3, 2000, [0], progress=False)
    assert record.evaluations == 2000 and record.history[-1][0] == 2000
    assert [e for e, _ in record.history[:3]] == [16, 32, 48]  # one batch per round
    assert record.config["method"]["algorithm"] == "hill-climb"
    # Measured, seeds 0-3: reward -4e-6 to -1.4e-5, farthest coordinate 0.0016 from the
    # optimum; random search at this budget: reward -4.5 to -5.5.
    assert record.reward > -1e-4
    np.testing.assert_allclose(record.normalised_stroke, optimum(0.3), atol=0.01)
    assert all(np.all(np.abs(a) <= 1.0) for a in ACTION_LOG)
    assert len(record.normalised_stroke) == DIM


def test_the_toy_runs_through_eval_optimize(tmp_path: Path) -> None:
    from eval.__main__ import main

    out = tmp_path / "toy"
    argv = ["optimize", "--task", "sphere", "--shift", "0.3", "--method", "hill-climb"]
    argv += ["--budget", "160", "--seeds", "0", "1", "--out", str(out), "--quiet"]
    assert main([*argv, "--method-config", "step=0.3"]) == 0
    records = load_records([out])
    assert sorted(r.seed for r in records) == [0, 1]
    assert all(r.evaluations == 160 and r.config["method"]["step"] == 0.3 for r in records)
