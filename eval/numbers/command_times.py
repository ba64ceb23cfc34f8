"""What two documented commands cost, each run into an empty folder and timed as a whole
process: the quick preset (the one figure the documents give for its time) and the README's
first training command."""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import Any

from eval.numbers import framework as fw

QUICK_PRESET_COMMAND: tuple[str, ...] = ("python", "-m", "eval", "study", "all")
"""The documented command; ``--out``, ``--quiet`` and ``--no-cache`` are added."""
TRAINING_COMMAND: tuple[str, ...] = tuple(
    "python -m train --algo ppo --env TandemWing/LevelFlight-v0 --timesteps 200000 --seed 0 "
    "--env-kwargs speed=1.5".split()
)
"""The README's command; ``-f`` (an empty log folder) is added."""


def measure_quick_preset() -> dict[str, Any]:
    """Run the quick preset into an empty folder: wall time [s], jobs, model evaluations."""
    from agents.store import RecordStore

    with tempfile.TemporaryDirectory(prefix="tandem-numbers-") as out:
        wall = fw.run_command([*QUICK_PRESET_COMMAND, "--out", out, "--quiet", "--no-cache"])
        records = RecordStore(Path(out)).records()
    return {
        "command": " ".join(QUICK_PRESET_COMMAND),
        "wall_s": round(wall, 1),
        "jobs": len(records),
        "evaluations": int(sum(r.evaluations for r in records)),
    }


def measure_training() -> dict[str, Any]:
    """Run the README's PPO command into an empty log folder: wall time [s]."""
    with tempfile.TemporaryDirectory(prefix="tandem-numbers-") as logs:
        wall = fw.run_command([*TRAINING_COMMAND, "-f", logs])
    return {"command": " ".join(TRAINING_COMMAND), "wall_s": round(wall, 1)}


def _took(data: dict[str, Any], name: str, what: str, where: str) -> str:
    """The sentence of a timed command: ``what`` it is, then its time and ``where`` it ran."""
    return (
        f"`{data['command']}` {what}took **{fw.minutes(data['wall_s'])}** wall clock {fw.at_load(data)} "
        f"{where}. {fw.machine_line(data, name)}\n"
    )


def render_quick_preset(data: dict[str, Any]) -> str:
    what = (
        f"(the quick preset: CMA-ES, serially, {data['jobs']} optimisations, "
        f"{fw.spaced(data['evaluations'])} model evaluations, into an empty folder with the record "
        "cache off) "
    )
    return _took(data, "quick-preset", what, "(longer on a busier machine)")


def render_training(data: dict[str, Any]) -> str:
    what = "training, its periodic evaluations and checkpoints; longer on a busier machine"
    return _took(data, "training-time", "", f"into an empty log folder ({what})")


MEASUREMENTS = (
    fw.Measurement("quick-preset", measure_quick_preset, render_quick_preset),
    fw.Measurement("training-time", measure_training, render_training),
)
