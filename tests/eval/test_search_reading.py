"""A reading's search override (eval/studies/paper_reading.py ``Search``): it reaches every job
(method, budget, settings), leaves the default reading's jobs as they were, is refused with a
message naming the value and what is allowed, and combines like any other change."""

from __future__ import annotations

from dataclasses import replace

import pytest

from agents.harness import prepare_job
from agents.jobs import Job
from eval.studies import PAPER_STUDIES, readings
from eval.studies.base import StudyPlan
from eval.studies.paper_reading import (
    DEFAULT,
    PAPER_SEARCH,
    PAPER_SEARCHES,
    Reading,
    Search,
    combine,
)
from eval.studies.presets import PAPER, TINY
from eval.studies.readings import run as readings_run


def _suite(plan: StudyPlan) -> list[Job]:
    return [job for study in PAPER_STUDIES.values() for job in study.jobs(plan)]


def test_default_reading_builds_the_preset_jobs_field_by_field() -> None:
    # Built here by hand from the preset, not by the code under test (a cold start: the warm
    # start's settings, tests/eval/test_warm_start.py).
    plan = StudyPlan(replace(PAPER, warm_start="none"))
    jobs = plan.jobs("level", [1.5], seeds=[3])
    assert jobs == [
        Job(
            method="cmaes",
            task="level",
            condition=1.5,
            budget=16_000,
            seed=3,
            env_kwargs={"planform": "tear-drop"},
            method_config=(),
            preset="paper",
        )
    ]
    tiny = StudyPlan(TINY).jobs("accelerate", [90.0], objective="horizontal", seeds=[0])
    assert tiny == [
        Job(
            method="pso",
            task="accelerate",
            condition=90.0,
            budget=16,
            seed=0,
            env_kwargs={
                "n_blade": 6,
                "n_time": 32,
                "objective": "horizontal",
                "planform": "tear-drop",
            },
            method_config={"swarm_size": 8},
            preset="tiny",
        )
    ]


def test_a_reading_without_search_keeps_every_key_of_the_default() -> None:
    plan = StudyPlan(TINY)
    restated = Reading("restated", "defaults spelt out", {"power": "absolute"}, search=None)
    assert [j.key for j in _suite(StudyPlan(TINY, reading=restated))] == [
        j.key for j in _suite(plan)
    ]


def test_the_search_reaches_every_job() -> None:
    plan = StudyPlan(PAPER, methods=("cmaes", "random"), reading=PAPER_SEARCH)
    assert plan.methods == ("pso",)  # the analyses select records by plan.methods
    jobs = _suite(plan)
    assert jobs and all(j.method == "pso" for j in jobs)
    assert {j.budget for j in jobs} == {40 * 50}
    assert {j.method_config for j in jobs} == {(("polish", "none"), ("swarm_size", 40))}
    # the model is the default's: same env keywords, job for job
    default = _suite(StudyPlan(PAPER))
    assert [j.env_kwargs for j in jobs] == [j.env_kwargs for j in default]
    assert not {j.key for j in jobs} & {j.key for j in default}
    # a study's explicit budget still wins (e.g. a convergence run)
    assert plan.jobs("level", [1.5], budget=123)[0].budget == 123


def test_per_task_budgets_and_the_preset_swarm() -> None:
    search = Search("pso", budgets={"level": 900}, settings={"inertia": "linear-decreasing"})
    plan = StudyPlan(TINY, reading=Reading("s", "a test search", search=search))
    level = plan.jobs("level", [2.0])[0]
    acc = plan.jobs("accelerate", [90.0], objective="vertical")[0]
    assert (level.budget, acc.budget) == (900, TINY.accelerate_budget)
    assert dict(level.method_config) == {"inertia": "linear-decreasing", "swarm_size": 8}
    cmaes = Search("cmaes", swarm_size=12, iterations=5)
    job = StudyPlan(PAPER, reading=Reading("c", "a test search", search=cmaes)).jobs(
        "level", [1.5]
    )[0]
    assert (job.method, job.budget, dict(job.method_config)) == ("cmaes", 60, {"swarm_size": 12})


def test_search_jobs_are_accepted_by_the_harness() -> None:
    for reading in PAPER_SEARCHES:
        job = StudyPlan(TINY, reading=reading).jobs("level", [2.0], seeds=[0])[0]
        prepared = prepare_job(job)
        assert prepared.job.budget == reading.search.budget("level")


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        (
            {"method": "nope"},
            r"Search of method 'nope': unknown method 'nope'; allowed: cmaes, .*pso",
        ),
        ({"method": "policy:runs/x"}, r"Search.method = 'policy:runs/x'; allowed: a harness"),
        ({"method": "pso", "swarm_size": 1}, r"swarm_size = 1; allowed: None or an integer >= 2"),
        ({"method": "pso", "iterations": 0, "swarm_size": 4}, r"iterations = 0; allowed"),
        ({"method": "pso", "iterations": 5}, r"iterations = 5 without swarm_size; allowed: both"),
        (
            {"method": "pso", "swarm_size": 4, "iterations": 5, "budgets": {"level": 9}},
            r"budgets = \{'level': 9\} and iterations = 5; allowed: one of the two",
        ),
        ({"method": "pso", "budgets": {"hover": 9}}, r"budgets\['hover'\] = 9; allowed: tasks"),
        ({"method": "pso", "budgets": {"level": 0}}, r"budgets\['level'\] = 0; allowed: tasks"),
        (
            {"method": "pso", "settings": {"max_evaluations": 9}},
            r"settings sets \['max_evaluations'\]; allowed: the budget as iterations",
        ),
        (
            {"method": "pso", "swarm_size": 4, "settings": {"swarm_size": 8}},
            r"sets \['swarm_size'\] and swarm_size = 4; allowed: the batch size once",
        ),
        (
            {"method": "pso", "settings": {"velocity_clamp": 2.0}},
            r"Search of method 'pso': velocity_clamp",
        ),
        ({"method": "pso", "settings": {"polish": "newton"}}, r"polish = 'newton'; allowed:"),
        ({"method": "pso", "settings": {"bogus": 1}}, r"unknown setting\(s\) \['bogus'\]"),
        ({"method": "pso", "settings": 5}, r"Search.settings = 5; allowed: \(name, value\) pairs"),
    ],
)
def test_bad_search_names_the_value_and_what_is_allowed(kwargs: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        Search(**kwargs)


def test_bad_search_in_a_reading_names_the_reading() -> None:
    with pytest.raises(ValueError, match=r"Reading 'x': search = 'pso'; allowed: None, a Search"):
        Reading("x", "a test reading", search="pso")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"Reading 'x': .*swarm_size = 1; allowed"):
        Reading("x", "a test reading", search={"method": "pso", "swarm_size": 1})


def test_search_is_a_change_that_combines_round_trips_and_conflicts() -> None:
    hover = Reading("hover-none", "no hover inflow", {"hover_inflow": "none"})
    both = combine([hover, PAPER_SEARCH])
    assert both.search == PAPER_SEARCH.search and both.env_kwargs() == {"hover_inflow": "none"}
    assert PAPER_SEARCH.env_kwargs() == {} and DEFAULT.changes() == {}
    again = Reading.from_changes("again", "round trip", both.changes())
    assert again.changes() == both.changes() and again.search == both.search
    assert PAPER_SEARCH.conflicts(PAPER_SEARCHES[0]) == ["search"]
    assert "search=pso 40×50 (2000 evaluations), polish=none" in both.describe_changes()
    job = StudyPlan(TINY, reading=both).jobs("level", [2.0])[0]
    assert (job.method, dict(job.env_kwargs)["hover_inflow"]) == ("pso", "none")


def test_the_readings_study_runs_a_search_reading() -> None:
    plan = StudyPlan(TINY, methods=("random",))
    jobs = readings.reading_jobs(plan, PAPER_SEARCH)
    assert {j.method for j in jobs} == {"pso"} and {j.budget for j in jobs} == {2000}
    assert replace(plan, reading=PAPER_SEARCH).methods == ("pso",)


def test_a_search_readings_report_and_csv_row_name_its_search() -> None:
    from eval.studies.readings import ReadingResult
    from eval.studies.report import settings_lines

    small = PAPER_SEARCHES[0]  # PSO 20 × 50: not the paper preset's swarm or budgets
    plan = replace(StudyPlan(PAPER), reading=small)
    budgets = settings_lines(plan)[1]
    assert "budgets 1000 (level) and 1000 (accelerating)" in budgets
    assert budgets.endswith(f"search of the reading: {small.search.describe()}")
    assert "PSO swarm" not in budgets  # the preset's swarm, which the search replaces
    row, default = readings_run.csv_rows([ReadingResult(small, ()), ReadingResult(DEFAULT, ())])
    assert row["search"] == small.search.describe() and default["search"] == ""
