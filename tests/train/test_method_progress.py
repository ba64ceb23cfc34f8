"""The harness's ``ppo`` method reports its progress to the end and says what budget it leaves."""

from __future__ import annotations

from typing import ClassVar

import pytest

import agents.harness
from agents.harness import run


class _Bar:
    """Stands in for the harness's progress bar and keeps every position it was moved to."""

    positions: ClassVar[list[int]] = []

    def __init__(self, total: int, description: str, enabled: bool = True) -> None:
        self.total = total

    def update(self, iteration: int, evaluations: int, best: float) -> None:
        _Bar.positions.append(evaluations)

    def __enter__(self) -> _Bar:
        return self

    def __exit__(self, *exc: object) -> None:
        pass


def test_ppo_progress_ends_at_the_evaluations_spent_and_says_the_rest(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setattr(agents.harness, "ProgressBar", _Bar)
    _Bar.positions = []
    settings = {"n_envs": 16, "n_steps": 4, "batch_size": 64}
    [record] = run("ppo", "level", 1.5, budget=200, seeds=[0], method_config=settings)
    # budget - 1 = 199 training steps, rounded down to whole iterations of 4 x 16 = 64: 192,
    # plus the final deterministic stroke: 193 evaluations; the bar ends there (it ended at 1,
    # the harness evaluator's own count of the final stroke).
    assert record.evaluations == 193
    assert _Bar.positions[-1] == 193
    assert _Bar.positions[:3] == [16, 32, 48]  # every vector step of training
    assert record.config["method"]["budget_unused"] == 7
    err = capsys.readouterr().err
    assert (
        "ppo: budget 200 -> 192 training steps (whole PPO iterations of 64 env steps, n_envs 16) "
        "+ 1 final evaluation; 7 evaluations stay unused"
    ) in err


def test_no_word_when_the_budget_is_used(capsys: pytest.CaptureFixture[str]) -> None:
    settings = {"n_envs": 16, "n_steps": 4, "batch_size": 64}
    [record] = run("ppo", "level", 1.5, budget=129, seeds=[0], method_config=settings)
    assert record.evaluations == 129 and record.config["method"]["budget_unused"] == 0
    assert "unused" not in capsys.readouterr().err
