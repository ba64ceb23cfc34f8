"""What every study shares: the plan (preset + methods), job construction, output writing and
the analysis (:class:`Analysis`).

A study module defines ``NAME``, ``TITLE``, ``jobs(plan) -> list[Job]`` and
``analyse(plan, records, out_dir) -> StudyOutput`` (the paper's studies: an :class:`Analysis`
of their figures and claims); jobs two studies share run once."""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from agents.jobs import Job
from agents.methods import preset_batch_setting
from agents.polish_config import split_settings
from agents.records import Record
from agents.store import RECORDS_DIR
from agents.tasks import get_task
from eval import figures
from eval.figures import FORMATS, figure_path
from eval.studies.claims import Claim, ClaimSpec, judged, study_claims
from eval.studies.paper_reading import DEFAULT, Reading
from eval.studies.presets import WARM_SHARE, Preset, distinct, fail, is_name, warm_start
from eval.studies.tables import Rows, Sweep, series_conditions, spread_summary_rows, tidy_rows
from tandem_env import PARAMETER_NAMES, ModelOptions
from tandem_env.envs.config import EXECUTION_KWARGS, MODEL_OPTION_KWARGS
from tandem_env.envs.reference import ConfigReference
from tandem_env.envs.registration import config_class
from tandem_env.io.files import write_csv_atomic, write_json_atomic
from tandem_env.physics import BACKENDS
from tandem_env.physics.backends import check_backend
from tandem_env.physics.insect import DRAGONFLY, Dragonfly

#: A study's index of the records it analysed, ``DIR/<study>/records.json`` (:func:`write_tables`).
INDEX_FILE = "records.json"
#: The target of the searches against the reference table: the seeds' median within this [%].
GAP_TARGET = 1.0
#: A stroke the table holds replays to its objective within this (relative): a best seed lower
#: by more is below the table (tests/envs/test_reference.py).
REPLAY_RTOL = 1e-6


@dataclass(frozen=True)
class StudyPlan:
    """A preset and the methods to run at every condition (the preset's method by default),
    under a reading of the paper (the documented defaults by default)."""

    preset: Preset
    methods: tuple[str, ...] | None = None
    """The methods run at every condition; under a reading with a search, its method alone."""
    reading: Reading = DEFAULT
    """The model options, F̄_h's objective and search of every job
    (:mod:`eval.studies.paper_reading`); the default adds nothing to the jobs."""
    figure_format: str = FORMATS[0]
    """The figures' file format (:data:`eval.figures.FORMATS`)."""
    execution: tuple[tuple[str, Any], ...] = ()
    """Env keywords that choose only how the model is computed (``backend``, ``device``); one
    given as None is not set (``--backend`` / ``--device`` left out)."""
    insect: Dragonfly = DRAGONFLY
    """The insect every job flies (``--insect``; the paper's specimen adds no env keyword)."""

    def __post_init__(self) -> None:
        if not isinstance(self.preset, Preset):
            fail("preset", self.preset, "a Preset", "StudyPlan")
        if self.methods is None:
            object.__setattr__(self, "methods", (self.preset.method,))
        if not distinct(self.methods, is_name):
            specs = "distinct method specs such as ('pso',), ('pso', 'random') or ('pso', 'policy:runs/ppo')"
            fail("methods", self.methods, specs, "StudyPlan")
        if self.figure_format not in FORMATS:
            fail("figure_format", self.figure_format, ", ".join(FORMATS), "StudyPlan")
        if not isinstance(self.insect, Dragonfly):
            fail("insect", self.insect, "a tandem_env.Dragonfly", "StudyPlan")
        if not isinstance(self.reading, Reading):
            fail("reading", self.reading, "a Reading", "StudyPlan")
        if self.reading.search is not None:
            # the analyses select records by plan.methods, so the search's method goes there
            object.__setattr__(self, "methods", (self.reading.search.method,))
        execution = {k: v for k, v in dict(self.execution).items() if v is not None}
        if not set(execution) <= set(EXECUTION_KWARGS):
            allowed = f"keywords among {', '.join(EXECUTION_KWARGS)}"
            fail("execution", self.execution, allowed, "StudyPlan")
        if execution:  # the backend's rule: a device only with torch, one that is there
            backend, device = check_backend(
                execution.get("backend", BACKENDS[0]), execution.get("device")
            )
            execution = {"backend": backend} | ({} if device is None else {"device": device})
        object.__setattr__(self, "execution", tuple(sorted(execution.items())))
        clash = sorted({k for k, _ in self.preset.env_kwargs} & set(self.reading.env_kwargs()))
        if clash:
            raise ValueError(
                f"StudyPlan.reading {self.reading.name!r} sets {clash}, which preset "
                f"{self.preset.name!r} sets too; allowed: a reading of other options"
            )

    @property
    def model_options(self) -> ModelOptions:
        """The model options of every job: the preset's and the reading's env keywords."""
        kwargs = {**dict(self.preset.env_kwargs), **self.reading.env_kwargs()}
        options = {MODEL_OPTION_KWARGS[k]: v for k, v in kwargs.items() if k in MODEL_OPTION_KWARGS}
        return ModelOptions(**options)

    def figure(self, folder: Path, stem: str) -> Path:
        """The path of the figure ``stem`` in ``folder``, in the plan's format."""
        return figure_path(folder, stem, self.figure_format)

    def sweep_figures(
        self, folder: Path, xlabel: str, specs: Sequence[tuple[str, str, str, list[figures.Panel]]]
    ) -> Drawn:
        """(caption, path) of each sweep figure ``(caption, stem, title, panels)`` of ``specs``
        over the condition axis ``xlabel``, drawn into ``folder`` in the plan's format."""
        return [
            (caption, figures.sweep_figure(panels, xlabel, title, self.figure(folder, stem)))
            for caption, stem, title, panels in specs
        ]

    def series(self, points: Callable[[str], Sweep], **style: Any) -> list[figures.Series]:
        """One figure series per method of ``points(method)``, named by the method."""
        label = figures.method_label
        return [figures.Series(label(m), points(m), method=m, **style) for m in self.methods]

    def method_config(self, method: str) -> tuple[tuple[str, Any], ...]:
        """The settings of ``method`` in every job: the reading's search's, else the preset's
        swarm size as its batch."""
        search = self.reading.search
        if search is not None and method == search.method:
            return search.method_config(self.preset.swarm_size)
        key = preset_batch_setting(method)
        return ((key, self.preset.swarm_size),) if key else ()

    def budget(self, task: str) -> int:
        """Model evaluations per optimisation of ``task``: the reading's search's, else the preset's."""
        search = self.reading.search
        given = None if search is None else search.budget(task)
        return self.preset.budget(task) if given is None else given

    def env_kwargs(
        self, task: str, objective: str | None = None, planform: str = "tear-drop"
    ) -> dict[str, Any]:
        """The env keywords of the plan's jobs of one series (the condition aside); ``objective``
        is the env's (after the reading's), for a task that takes one."""
        kwargs = {**dict(self.preset.env_kwargs), **self.reading.env_kwargs()}
        kwargs.update(self.execution)
        if self.insect != DRAGONFLY:
            kwargs["insect"] = self.insect  # the job keeps what differs from the specimen
        kwargs["planform"] = planform
        if get_task(task).declared_objectives.keyword is not None and objective is not None:
            kwargs["objective"] = objective
        return kwargs

    def warm_start(
        self, method: str, task: str, condition: float, kwargs: Mapping[str, Any]
    ) -> tuple[dict[str, Any], str]:
        """The method settings of the preset's warm start of one job (none: ``{}``) and how it
        starts, in words: from the table, or cold and why (:func:`~eval.studies.presets.warm_start`)."""
        if self.preset.warm_start == "none":
            return {}, "cold (warm start none)"
        if self.reading.search is not None:  # it is how the reading finds its optima
            return {}, f"cold: the reading's own search ({self.reading.search.describe()})"
        if not split_settings(method, dict(self.method_config(method)))[0].enabled:
            return {}, f"cold: {method} has no polish to warm-start"
        try:
            settings = warm_start(task, condition, kwargs)
        except ValueError as error:
            return {}, f"cold: {error}"
        return settings, f"table ({len(settings['initial'])} strokes)"

    def jobs(
        self,
        task: str,
        conditions: Sequence[float],
        *,
        objective: str | None = None,
        planform: str = "tear-drop",
        budget: int | None = None,
        seeds: Sequence[int] | None = None,
        warm: bool = True,
    ) -> list[Job]:
        """Every method × condition × seed of one series under the plan's reading (the plan's
        :meth:`budget` and the preset's seeds unless given); ``warm``: with the preset's
        :meth:`warm_start`."""
        given = None if objective is None else self.reading.objective(objective)
        kwargs = self.env_kwargs(task, given, planform)
        budget = self.budget(task) if budget is None else budget
        env = tuple(kwargs.items())
        seeds = self.preset.seeds if seeds is None else seeds
        jobs = []
        for method, c in itertools.product(self.methods, map(float, conditions)):
            warmed = self.warm_start(method, task, c, kwargs)[0] if warm else {}
            config = {**dict(self.method_config(method)), **warmed}
            jobs += [Job(method, task, c, budget, s, env, config, self.preset.name) for s in seeds]
        return jobs

    def table_lines(self, rows: Sequence[Mapping[str, Any]]) -> list[str]:
        """The report's check against the reference table (Markdown): per series and condition,
        how the searches started, the table's optimum and the seeds' median and best objective
        with their gap below it [%]; the conditions within :data:`GAP_TARGET` and any best seed
        below the table (beyond the replay's :data:`REPLAY_RTOL`)."""
        lines = [
            f"Warm start `{self.preset.warm_start}` ({WARM_SHARE:g} of each budget for the "
            "table's strokes, counted in it; docs/reference.md, Warm starts).",
            "",
            "| method | series | condition | start | table | median (gap %) | best (gap %) |",
            "|---|---|---|---|---|---|---|",
        ]
        median_gaps, below = [], []
        for key, found in series_conditions({r["key"]: r for r in rows}.values()):
            method, task, objective, planform, c = key
            kwargs = self.env_kwargs(task, objective, planform)
            how = self.warm_start(method, task, c, kwargs)[1]
            series = ConfigReference(config_class(get_task(task).env_id).from_kwargs(**kwargs))
            on_grid = series.series is not None and c in series.series.conditions
            table = float(series.series.at(c)) if on_grid else math.nan  # type: ignore[union-attr]
            values = [float(r["objective_value"]) for r in found if r["feasible"]]
            median, best = (float(np.median(values)), max(values)) if values else (math.nan,) * 2
            gaps = [100 * (1 - v / table) for v in (median, best)]  # NaN: no table, no seed
            if not math.isnan(table):
                median_gaps.append(100.0 if math.isnan(median) else gaps[0])  # none flies
                if not best >= table * (1 - REPLAY_RTOL):
                    below.append(f"{task} {objective} {planform} at {c:g} ({gaps[1]:+.3f} %)")
            lines.append(
                f"| {method} | {task} {objective} {planform} | {c:g} | {how} | {table:.5g} | "
                f"{median:.5g} ({gaps[0]:+.2f}) | {best:.5g} ({gaps[1]:+.2f}) |"
            )
        within = sum(g <= GAP_TARGET for g in median_gaps)
        worst = f"largest {max(median_gaps):.2f} %" if median_gaps else "none"
        return [
            *lines,
            "",
            f"The seeds' median within {GAP_TARGET:g} % of the table at {within} of the "
            f"{len(median_gaps)} conditions it has ({worst}); the best seed below the table at: "
            f"{', '.join(below) or 'none'}.",
        ]


@dataclass(frozen=True)
class StudyOutput:
    """What a study wrote and what it claims."""

    name: str
    title: str
    rows: Rows
    figures: Drawn
    """(caption, path) of each figure."""
    claims: list[Claim]
    files: list[Path] = field(default_factory=list)
    """CSV and JSON files written (records index, tidy CSV, summary CSV)."""


def write_tables(
    name: str, records: Records, out_dir: Path, quantities: Sequence[str]
) -> tuple[Rows, list[Path]]:
    """Write ``DIR/<name>/records.json`` (the index), ``<name>.csv`` (tidy rows) and
    ``<name>_summary.csv`` (the ``quantities`` and the 28 stroke parameters)."""
    rows = tidy_rows(records)
    entry = lambda j: {"key": j.key, "file": f"../{RECORDS_DIR}/{j.key}.json", "label": j.label()}  # noqa: E731
    index = [{**entry(job), "job": job.to_dict()} for job in sorted(records, key=Job.label)]
    paths = [out_dir / name / f for f in (INDEX_FILE, f"{name}.csv", f"{name}_summary.csv")]
    write_json_atomic(paths[0], index)
    write_csv_atomic(paths[1], rows)
    extra = [n for n in PARAMETER_NAMES if n not in quantities]
    write_csv_atomic(paths[2], spread_summary_rows(rows, [*quantities, *extra]))
    return rows, paths


#: A study's records by job.
Records = Mapping[Job, Record]
#: (caption, path) of each figure a study drew.
Drawn = list[tuple[str, Path]]
#: A study's figures from its plan, tidy rows, records and folder.
Figures = Callable[[StudyPlan, Rows, Records, Path], Drawn]


@dataclass(frozen=True)
class Analysis:
    """A paper study's ``analyse``: its tables (:func:`write_tables`), its ``figures`` and its
    ``claims``, each judged on ``view(plan, rows, method)`` of every method's rows."""

    name: str
    title: str
    quantities: tuple[str, ...]
    """The summary CSV's quantities (the 28 stroke parameters follow)."""
    figures: Figures
    claims: tuple[ClaimSpec, ...]
    view: Callable[[StudyPlan, Rows, str], Any]

    def __call__(self, plan: StudyPlan, records: Records, out_dir: Path) -> StudyOutput:
        rows, files = write_tables(self.name, records, out_dir, self.quantities)
        figures = self.figures(plan, rows, records, out_dir / self.name)
        return StudyOutput(self.name, self.title, rows, figures, self.judge(plan, rows), files)

    def judge(self, plan: StudyPlan, rows: Rows) -> list[Claim]:
        """Every method's claims, with their confidence and identifiability
        (:func:`eval.studies.claims.study_claims`)."""
        words = vars(plan.preset)
        judge = lambda r, m, i: judged(self.claims, self.name, self.view(plan, r, m), m, i, words)  # noqa: E731
        return study_claims(rows, plan.methods, judge, options=plan.model_options)
