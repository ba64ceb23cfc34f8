"""The amortised policy beside PPO's and SAC's envelope policies (docs/training.md, "Scores at
the held-out conditions"): for each seed, one policy trained by the documented
``python -m train --algo amortised`` command (default settings), then asked through
``python -m train.envelope`` for its stroke at each held-out condition, scored against the
reference table exactly as the RL policies are (:mod:`eval.numbers.rl_baselines`).

On request only (``--only amortised-scores``): five training runs, two at a time, about half
an hour on 2 cores. It redraws the shared figure with the stored RL runs."""

from __future__ import annotations

import shlex
from typing import Any

from eval.numbers.framework import Measurement, machine_line
from eval.numbers.rl_baselines import ENV_ID, SEEDS, score_runs, score_table

ALGO = "amortised"


def train_command(seed: int | str) -> list[str]:
    """The documented amortised training command (``-f`` is added)."""
    return ["python", "-m", "train", "--algo", ALGO, "--env", ENV_ID, "--seed", str(seed),
            "--verbose", "0"]  # fmt: skip


def measure() -> dict[str, Any]:
    """Train and score every seed, two runs at a time."""
    tasks = [(train_command(seed), ALGO, 0, seed, "") for seed in SEEDS]
    return {"env_id": ENV_ID, "runs": score_runs("amortised-scores", tasks)}


def render(data: dict[str, Any]) -> str:
    return (
        score_table("training", [(ALGO, "regression + 600 gradient steps", data["runs"])]) + "\n\n"
        f"The same held-out speeds and scoring; `{shlex.join(train_command('SEED'))}` with seeds "
        f"{list(SEEDS)}, then `python -m train.envelope --conditions ...`. "
        f"{machine_line(data, 'amortised-scores')}\n"
    )


MEASUREMENT = Measurement("amortised-scores", measure, render, on_request=True)
