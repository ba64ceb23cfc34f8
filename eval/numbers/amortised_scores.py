"""The amortised policy beside PPO's and SAC's envelope policies (docs/training.md, "Scores at
the held-out conditions"): for each seed, one policy trained by the documented
``python -m train --algo amortised`` command (default settings), then asked through
``python -m train.envelope`` for its stroke at each held-out condition, scored against the
reference table exactly as the RL policies are (:mod:`eval.numbers.rl_baselines`).

On request only (``--only amortised-scores``): five training runs, two at a time, about half
an hour on 2 cores. It redraws the shared figure with the stored RL runs."""

from __future__ import annotations

import shlex
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

from eval.numbers.framework import ROOT, Measurement, machine_line
from eval.numbers.rl_baselines import (
    ENV_ID,
    FIGURE,
    SEEDS,
    TABLE_HEAD,
    score_run,
    score_text,
    summary,
    write_figure,
)

ALGO = "amortised"


def train_command(seed: int | str) -> list[str]:
    """The documented amortised training command (``-f`` is added)."""
    return ["python", "-m", "train", "--algo", ALGO, "--env", ENV_ID, "--seed", str(seed),
            "--verbose", "0"]  # fmt: skip


def measure() -> dict[str, Any]:
    """Train and score every seed, two runs at a time."""
    with tempfile.TemporaryDirectory(prefix="tandem-numbers-") as tmp:
        folder = Path(tmp)
        with ThreadPoolExecutor(max_workers=2) as pool:
            runs = list(
                pool.map(lambda seed: score_run(train_command(seed), ALGO, 0, seed, folder), SEEDS)
            )
    write_figure(ROOT / FIGURE, {"amortised-scores": runs})
    return {"env_id": ENV_ID, "runs": runs}


def render(data: dict[str, Any]) -> str:
    median, worst, flies, seconds = summary(data["runs"])
    return (
        TABLE_HEAD.format(training="training") + "\n"
        f"| amortised | regression + 600 gradient steps | {len(data['runs'])} | "
        f"{score_text(median)} | {score_text(worst)} | {100 * flies:.0f} % | "
        f"{seconds:.0f} s |\n\n"
        f"The same held-out speeds and scoring; `{shlex.join(train_command('SEED'))}` with seeds "
        f"{list(SEEDS)}, then `python -m train.envelope --conditions ...`. "
        f"{machine_line(data, 'amortised-scores')}\n"
    )


MEASUREMENT = Measurement("amortised-scores", measure, render, on_request=True)
