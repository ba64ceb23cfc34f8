"""The readings study: which reading of the paper reproduces which of its claims.

``python -m eval study readings [--preset quick|paper]``: the four paper studies under the
default reading, each single reading (:data:`SINGLES`) and the combinations their results
point to (:func:`combinations`), a reading continuing from the optima of those nearest it
(:class:`Continuation`; docs/reproduction.md, "Readings"). The parts: :mod:`.plan` (readings,
continuation, jobs), :mod:`.run` (the phases, the analysis, the outputs, the command line),
:mod:`.report` (the report and its matrix figure) and :mod:`.timing`."""

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
