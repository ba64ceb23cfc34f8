"""The readings study: which reading of the paper reproduces which of its claims.

``python -m eval study readings [--preset quick|paper]``: the four paper studies under the
default reading, each single reading (:data:`SINGLES`) and the combinations their results
point to (:func:`combinations`), a reading continuing from the optima of those nearest it
(:class:`Continuation`; docs/reproduction.md, "Readings"). The parts: :mod:`.plan` (readings,
continuation, jobs), :mod:`.run` (the phases, the analysis, the outputs, the command line),
:mod:`.report` (the report and its matrix figure) and :mod:`.timing`."""

from __future__ import annotations

from eval.studies.readings.plan import ALIASES as ALIASES
from eval.studies.readings.plan import MANIFEST as MANIFEST
from eval.studies.readings.plan import SINGLES as SINGLES
from eval.studies.readings.plan import Continuation as Continuation
from eval.studies.readings.plan import ReadingResult as ReadingResult
from eval.studies.readings.plan import check_jobs as check_jobs
from eval.studies.readings.plan import combinations as combinations
from eval.studies.readings.plan import full_tasks as full_tasks
from eval.studies.readings.plan import reading_by_name as reading_by_name
from eval.studies.readings.plan import reading_jobs as reading_jobs
from eval.studies.readings.run import ReadingsPlan as ReadingsPlan
from eval.studies.readings.run import run_readings as run_readings
