"""The quick preset's cost (README "Reproduce the paper", docs/reproduction.md "Presets and
what they cost"): the documented ``python -m eval study all`` run into an empty folder, timed
as a whole process, with its jobs and model evaluations read back from the records it wrote.

It is the one figure the documents give for the quick preset's time; every other mention
points here."""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import Any

from eval.numbers.framework import Measurement, at_load, machine_line, minutes, run_command, spaced

QUICK_PRESET_COMMAND: tuple[str, ...] = ("python", "-m", "eval", "study", "all")
"""The documented command (quick preset, CMA-ES, serially); ``--out`` and ``--quiet`` are
added, and ``--no-cache`` so that no stored job from an earlier run shortens it."""


def measure() -> dict[str, Any]:
    """Run the quick preset into an empty folder: wall time [s], jobs, model evaluations."""
    from agents.store import RecordStore

    with tempfile.TemporaryDirectory(prefix="tandem-numbers-") as out:
        wall = run_command([*QUICK_PRESET_COMMAND, "--out", out, "--quiet", "--no-cache"])
        records = RecordStore(Path(out)).records()
    return {
        "command": " ".join(QUICK_PRESET_COMMAND),
        "wall_s": round(wall, 1),
        "jobs": len(records),
        "evaluations": int(sum(r.evaluations for r in records)),
    }


def render(data: dict[str, Any]) -> str:
    return (
        f"`{data['command']}` (the quick preset: CMA-ES, serially, {data['jobs']} "
        f"optimisations, {spaced(data['evaluations'])} model evaluations, into an empty folder "
        f"with the record cache off) took **{minutes(data['wall_s'])}** wall clock {at_load(data)} (longer on a busier machine). "
        f"{machine_line(data, 'quick-preset')}\n"
    )


MEASUREMENT = Measurement("quick-preset", measure, render)
