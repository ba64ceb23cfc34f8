"""The readings study: which reading of the paper reproduces which of its claims."""

from __future__ import annotations

from eval.studies.readings.plan import (
    ALIASES,
    MANIFEST,
    SINGLES,
    Continuation,
    ReadingResult,
    check_jobs,
    combinations,
    full_tasks,
    reading_by_name,
    reading_jobs,
)
from eval.studies.readings.run import ReadingsPlan, run_readings

__all__ = [
    "ALIASES",
    "MANIFEST",
    "SINGLES",
    "Continuation",
    "ReadingResult",
    "ReadingsPlan",
    "check_jobs",
    "combinations",
    "full_tasks",
    "reading_by_name",
    "reading_jobs",
    "run_readings",
]
