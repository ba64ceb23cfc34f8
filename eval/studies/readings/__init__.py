"""The readings study: which reading of the paper reproduces which of its claims.

``python -m eval study readings [--preset quick|paper]``: the four paper studies (the ``all``
suite) run under every reading (:mod:`eval.studies.paper_reading`), the single readings
(:data:`SINGLES`) and then the combinations their results point to (:func:`combinations`), and
their claims are judged by the studies' own claim builders. By default a reading continues from
the optima of the readings nearest it, with a measured bias check (:class:`Continuation`,
:data:`~eval.studies.readings.plan.PHASES`). What the phases run, what is shared and what is
written: docs/reproduction.md, "Readings". The parts: :mod:`.plan` (readings, continuation,
jobs), :mod:`.run` (the phases, the analysis, the outputs), :mod:`.report`, :mod:`.figure`,
:mod:`.result`, :mod:`.campaign` (the command line) and :mod:`.timing`.
"""

from __future__ import annotations

from eval.studies.readings.plan import (
    ALIASES,
    CHECK_CSV,
    CSV_COLUMNS,
    MANIFEST,
    SINGLES,
    Continuation,
    check_jobs,
    combinations,
    continued_from,
    full_tasks,
    optima_of,
    reading_by_name,
    reading_jobs,
    single_readings,
    study_jobs,
)
from eval.studies.readings.result import ReadingResult
from eval.studies.readings.run import (
    CHECK_COLUMNS,
    ReadingsPlan,
    check_summary,
    csv_rows,
    run_readings,
)

__all__ = [
    "ALIASES",
    "CHECK_COLUMNS",
    "CHECK_CSV",
    "CSV_COLUMNS",
    "MANIFEST",
    "SINGLES",
    "Continuation",
    "ReadingResult",
    "ReadingsPlan",
    "check_jobs",
    "check_summary",
    "combinations",
    "continued_from",
    "csv_rows",
    "full_tasks",
    "optima_of",
    "reading_by_name",
    "reading_jobs",
    "run_readings",
    "single_readings",
    "study_jobs",
]
