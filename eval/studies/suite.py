"""Run studies: gather their jobs, run the missing ones once, analyse, write the report."""

from __future__ import annotations

import os
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from agents.runner import RunSummary, executor_spec, have_records, load_records, run_jobs
from eval import report
from eval.studies import PAPER_STUDIES, STUDIES
from eval.studies.base import StudyOutput, StudyPlan
from tandem_env.io.files import write_json_atomic


@dataclass(frozen=True)
class SuiteResult:
    outputs: list[StudyOutput]
    """The studies asked for, analysed."""
    run: RunSummary
    report: Path | None
    wall_time: float
    """Seconds for the whole call, analysis included [s]."""


def expand(names: Sequence[str]) -> list[str]:
    """``all`` -> the paper's studies; otherwise the names, validated, duplicates dropped."""
    out: list[str] = []
    for name in names:
        chosen = list(PAPER_STUDIES) if name == "all" else [name]
        for n in chosen:
            if n not in STUDIES:
                raise ValueError(f"unknown study {n!r}; allowed: all, {', '.join(STUDIES)}")
            if n not in out:
                out.append(n)
    return out


def run_studies(
    names: Sequence[str],
    plan: StudyPlan,
    out_dir: str | os.PathLike[str],
    *,
    scheduler: str | None = None,
    workers: int = 1,
    progress: bool = True,
) -> SuiteResult:
    """Run the studies ``names`` (or ``["all"]``) into ``out_dir``.

    All their jobs go into one run (shared optimisations run once) on ``scheduler`` (None:
    serially here; ``"local:N"``; a Dask scheduler's address; see
    :func:`agents.runner.run_jobs`); ``workers=N > 1`` is short for
    ``scheduler="local:N"``. Finished jobs from an earlier, killed or partial run with the same
    configuration are reused. The report covers every paper study whose records are all
    present, so running ``speed`` and then ``power`` into one directory gives one report with
    both.
    """
    start = time.perf_counter()
    out = Path(out_dir)
    scheduler = executor_spec(scheduler, workers)
    studies = [STUDIES[n] for n in expand(names)]
    jobs = [job for study in studies for job in study.jobs(plan)]
    summary = run_jobs(jobs, out, scheduler=scheduler, progress=progress)
    outputs = [study.analyse(plan, load_records(out, study.jobs(plan)), out) for study in studies]

    done = {o.name: o for o in outputs}
    for name, study in PAPER_STUDIES.items():
        if name not in done and have_records(out, study.jobs(plan)):
            done[name] = study.analyse(plan, load_records(out, study.jobs(plan)), out)
    report_path = None
    if any(name in PAPER_STUDIES for name in done):
        wall = time.perf_counter() - start
        report_path = report.write_report(
            out / "report.md",
            plan,
            [done[n] for n in PAPER_STUDIES if n in done],
            list(PAPER_STUDIES),
        )
        write_json_atomic(
            out / "manifest.json",
            {
                "preset": plan.preset.name,
                "methods": list(plan.methods),
                "studies": [n for n in PAPER_STUDIES if n in done],
                "jobs": sorted({j.key for n in done for j in STUDIES[n].jobs(plan)}),
                "last_run": {
                    "studies": [s.NAME for s in studies],
                    **summary.to_dict(),
                    "wall_time_s": round(wall, 1),  # the whole call's, analysis included
                },
            },
        )
    return SuiteResult(outputs, summary, report_path, time.perf_counter() - start)
