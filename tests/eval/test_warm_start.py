"""Warm starts from the reference table: the option, the jobs and records they make, the
report's check against the table."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest

from agents.harness import run_job
from eval.__main__ import main
from eval.studies import PAPER_STUDIES
from eval.studies.base import StudyPlan
from eval.studies.paper_reading import Reading, Search
from eval.studies.presets import PAPER, TINY, WARM_SHARE
from tandem_env.envs.reference import reference_series, table_strokes

LEVEL = "TandemWing/LevelFlight-v0"
#: The tiny preset on the default model (the table's problem) instead of its coarse one.
TABLE_TINY = replace(TINY, env_kwargs=())


def test_the_option_is_checked_where_it_enters(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(ValueError, match=r"warm_start = 'tabel'; allowed: 'none' or 'table'"):
        replace(TINY, warm_start="tabel")
    for argv, message in (
        (["--warm-start", "tabel"], "invalid choice: 'tabel' (choose from 'none', 'table')"),
        (["--speed", "1.3", "--warm-start", "table"], "condition 1.3 is not a feasible point"),
        (["--env-kwargs", "n_time=32", "--warm-start", "table"], "no TandemWing/LevelFlight-v0"),
        (
            ["--warm-start", "table", "--method-config", "initial_share=0.5"],
            "--warm-start table or --method-config initial",
        ),
    ):
        base = ["optimize", "--task", "level", "--method", "pso", "--budget", "40"]
        speed = [] if "--speed" in argv else ["--speed", "1.25"]
        with pytest.raises(SystemExit) as exit_info:
            main([*base, *speed, "--seeds", "0", "--out", "unused", *argv])
        assert exit_info.value.code == 2
        assert message in capsys.readouterr().err


def test_table_strokes_are_the_point_and_its_neighbours() -> None:
    series = reference_series(LEVEL)
    strokes = table_strokes(LEVEL, {}, 1.25)
    i = series.conditions.index(1.25)
    expected = [tuple(series.points[j]["normalised_stroke"]) for j in (i, i - 1, i + 1)]
    assert list(strokes) == list(dict.fromkeys(expected))
    first = table_strokes(LEVEL, {}, series.conditions[0])  # one neighbour only
    assert first[0] == tuple(series.points[0]["normalised_stroke"]) and len(first) <= 2
    real = table_strokes(LEVEL, {"planform": "real"}, 1.25)[0]
    assert real == tuple(reference_series(LEVEL, planform="real").points[i]["normalised_stroke"])
    assert real != strokes[0]  # the planform is part of the problem


def test_studies_warm_start_where_the_table_has_the_problem_and_say_where_not() -> None:
    for preset, matches in ((TABLE_TINY, True), (TINY, False)):
        plan = StudyPlan(preset)
        for job in {j.key: j for s in PAPER_STUDIES.values() for j in s.jobs(plan)}.values():
            settings = dict(job.method_config)
            kwargs = dict(job.env_kwargs)
            how = plan.warm_start(job.method, job.task, job.condition, kwargs)[1]
            if matches:
                env_id = f"TandemWing/{'LevelFlight' if job.task == 'level' else 'Accelerate'}-v0"
                strokes = table_strokes(env_id, kwargs, job.condition)
                assert settings["initial"] == strokes, job.label()
                assert settings["initial_share"] == WARM_SHARE
                assert how == f"table ({len(strokes)} strokes)"
            else:  # the coarse model is another problem: a cold start, and the reason
                assert "initial" not in settings
                assert how.startswith("cold: the reference table has no") and "fingerprint" in how
    # warm start none, and a reading's own search (how it finds its optima), start cold
    search = Reading("c", "a test search", search=Search("cmaes", swarm_size=12, iterations=5))
    for plan in (StudyPlan(replace(PAPER, warm_start="none")), StudyPlan(PAPER, reading=search)):
        assert all("initial" not in dict(j.method_config) for j in plan.jobs("level", [1.25]))
    assert "cold: the reading's own search" in plan.warm_start("cmaes", "level", 1.25, {})[1]


def test_a_warm_started_record_names_its_strokes_and_reaches_the_table() -> None:
    job = StudyPlan(TABLE_TINY).jobs("level", [1.25], budget=72, seeds=[0])[0]
    record = run_job(job)
    strokes = dict(job.method_config)["initial"]
    assert record.job.to_dict()["method_config"]["initial"] == [list(s) for s in strokes]
    kinds = [part["kind"] for part in record.results["starts"]]
    assert kinds == ["initial"] * len(strokes) + ["search"]
    assert sum(part["evaluations"] for part in record.results["starts"]) <= job.budget
    # the table's stroke replays through the env: the record is never below the table
    table = float(reference_series(LEVEL).at(1.25))
    assert record.feasible and record.objective >= table * (1 - 1e-6)


def test_the_report_checks_the_studies_against_the_table(tmp_path: Path) -> None:
    plan = StudyPlan(TABLE_TINY)
    table = float(reference_series(LEVEL).at(1.25))
    row = {"method": "pso", "task": "level", "objective": "efficiency", "planform": "tear-drop"}
    rows = [
        {
            **row,
            "condition": 1.25,
            "seed": s,
            "feasible": True,
            "key": f"k{s}",
            "objective_value": v,
        }
        for s, v in enumerate((table, 0.995 * table, 0.9 * table))
    ]
    low = 0.5 * float(reference_series(LEVEL).at(2.0))
    rows.append({**rows[0], "condition": 2.0, "key": "k3", "objective_value": low})
    lines = plan.table_lines(rows)
    text = "\n".join(lines)
    assert "| pso | level efficiency tear-drop | 1.25 | table (3 strokes) |" in text
    assert "(+0.50) |" in text  # the median seed 0.5 % below
    assert "within 1 % of the table at 1 of the 2 conditions" in text
    assert "below the table at: level efficiency tear-drop at 2" in text  # only there
    cold = StudyPlan(TINY).table_lines(rows[:1])
    assert "cold: the reference table has no" in "\n".join(cold)
    assert "at 0 of the 0 conditions it has (none)" in cold[-1]
