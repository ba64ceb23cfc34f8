"""A toy study in one file, as docs/architecture.md says a study is added: ``NAME``, ``TITLE``,
``jobs(plan)`` and ``analyse(plan, records, out_dir)``. Its one registry line is
``STUDIES[toy_study.NAME] = toy_study`` (in eval/studies/__init__.py for a real study;
tests/eval/test_toy_study.py adds it for the test).

It optimises level flight at two speeds and writes, beside the shared tidy tables, the best
objective over seeds at each speed.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from agents.jobs import Job
from agents.records import Record
from eval.studies.base import StudyOutput, StudyPlan, write_tables
from tandem_env.io.files import write_csv_atomic

NAME = "toy"
TITLE = "Toy: best level-flight objective at two speeds"
SPEEDS = (1.25, 2.0)


def jobs(plan: StudyPlan) -> list[Job]:
    return plan.jobs("level", SPEEDS)


def analyse(plan: StudyPlan, records: Mapping[Job, Record], out_dir: Path) -> StudyOutput:
    rows, files = write_tables(NAME, records, out_dir, ("objective_value",))
    best = [
        {
            "speed": speed,
            "best_objective": max(r["objective_value"] for r in rows if r["condition"] == speed),
        }
        for speed in SPEEDS
    ]
    path = out_dir / NAME / "best.csv"
    write_csv_atomic(path, best)
    return StudyOutput(NAME, TITLE, rows, figures=[], claims=[], files=[*files, path])
