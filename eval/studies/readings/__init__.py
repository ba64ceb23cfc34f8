"""The readings study: which reading of the paper reproduces which of its claims.

``python -m eval study readings [--preset quick|paper]``. For every reading
(:mod:`eval.studies.paper_reading`) the four paper studies (speed, power, kinematics, wing shape: the
``all`` suite) run under it with the preset's method and budgets, and their claims are judged by
the studies' own claim builders. The readings are

1. the single readings (:data:`SINGLES`): the documented default, then each open decision
   changed alone;
2. the combinations the singles point to (:func:`combinations`), derived from their results by
   a rule, not chosen by hand: the singles that each raised the count of agreeing claims over the
   default are combined, all together and as the pair of the best two, and the best of them is
   paired with each other single.

**Continuation** (:class:`Continuation`, on by default): the readings are small changes of the
model, so each reading's optimisation starts from the optima of the readings nearest it (a
single reading: the default's certified optimum of the same job, i.e. condition, objective,
planform and seed; a combination: its parts' optima), polished under the reading beside a
short global search of the method (itself polished), on a share of the preset's budget (the
harness's ``initial``, ``initial_share`` and ``starts`` settings); the best is reported. The
phases (:data:`PHASES`): the default's jobs in full; the bias check, which runs the jobs of the
check studies (``Continuation.check_studies``) at a few seeds of every single reading both
continued and in full (``continuation_check.csv``); the singles, where a reading's task whose
check falls short (:func:`full_tasks`) runs in full; the combinations. A reading of the search
itself (``Reading.search``) always runs in full.

All jobs of a phase go into one :func:`~agents.runner.run_jobs` call, so a job two
readings share (the same env keywords: e.g. every job but the horizontal accelerating ones of
the F̄_h reading, or any job of a reading that restates a default) runs once, and the default's
jobs are the ``all`` suite's own. Records are written as jobs finish; a killed run resumes in
any phase. Outputs under the output directory: ``readings.csv`` (one row per reading),
``readings_matrix.png`` (claims × readings; ``--format`` svg or pdf likewise), ``report.md``,
``continuation_check.csv``, ``readings_manifest.json`` (each reading's changes and verdicts,
the bias check, what ran in full, and every invocation's work, time and load) and, per reading, ``<name>/`` with that reading's study tables,
figures and report.
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
    reading_plan,
    single_readings,
    study_jobs,
)
from eval.studies.readings.result import ReadingResult
from eval.studies.readings.run import (
    CHECK_COLUMNS,
    check_summary,
    csv_rows,
    planned_phases,
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
    "check_jobs",
    "check_summary",
    "combinations",
    "continued_from",
    "csv_rows",
    "full_tasks",
    "optima_of",
    "planned_phases",
    "reading_by_name",
    "reading_jobs",
    "reading_plan",
    "run_readings",
    "single_readings",
    "study_jobs",
]
