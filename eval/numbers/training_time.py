"""The README's first training command's cost (README "Train PPO and SAC stroke policies"):
``python -m train`` with PPO on level flight for 200 000 steps, run into an empty log folder
and timed as a whole process."""

from __future__ import annotations

import tempfile
from typing import Any

from eval.numbers.framework import Measurement, at_load, machine_line, minutes, run_command

TRAINING_COMMAND: tuple[str, ...] = tuple(
    "python -m train --algo ppo --env TandemWing/LevelFlight-v0 --timesteps 200000 --seed 0 "
    "--env-kwargs speed=1.5".split()
)
"""The README's command; ``-f`` (an empty log folder) is added."""


def measure() -> dict[str, Any]:
    """Run the README's PPO command into an empty log folder: wall time [s]."""
    with tempfile.TemporaryDirectory(prefix="tandem-numbers-") as logs:
        wall = run_command([*TRAINING_COMMAND, "-f", logs])
    return {"command": " ".join(TRAINING_COMMAND), "wall_s": round(wall, 1)}


def render(data: dict[str, Any]) -> str:
    return (
        f"`{data['command']}` took **{minutes(data['wall_s'])}** wall clock {at_load(data)} into an "
        f"empty log folder (training, its periodic evaluations and checkpoints; longer on a "
        f"busier machine). "
        f"{machine_line(data, 'training-time')}\n"
    )


MEASUREMENT = Measurement("training-time", measure, render)
