"""``python -m eval reference``: the plan of the reference table, its selection rule and its
refusals (the full table is checked as data by tests/envs/test_reference.py)."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import pytest

from agents.jobs import Continuation
from agents.runner import look_ahead, run_jobs, run_plan
from eval.reference import (
    BUDGETS,
    CONTINUATION,
    SEEDS,
    ReferencePlan,
    best_objectives,
    build_table,
    candidates,
    continuation,
    gather,
    plan,
    provenance,
    reference_markdown,
    round_gains,
    write_reference_figure,
)
from tandem_env.envs import ACCELERATE_ID, LEVEL_FLIGHT_ID
from tandem_env.envs.reference import (
    REFERENCE_FORMAT,
    REFERENCE_GRID,
    ReferenceTable,
    default_fingerprint,
)

SMALL = {"n_time": 32, "n_blade": 8}


def _key(job):
    return (LEVEL_FLIGHT_ID, "efficiency", job.env("planform"), job.condition)


def test_the_plan_is_one_job_per_point_objective_planform_and_seed():
    jobs = plan()
    points = sum(len(objectives) * 2 * len(grid) for objectives, grid in REFERENCE_GRID.values())
    assert len(jobs) == points == 84
    for (env_id, objective, planform, condition), prepared in jobs.items():
        assert [p.job.seed for p in prepared] == list(SEEDS)
        first = prepared[0].job
        assert first.method == "cmaes" and first.budget == BUDGETS[env_id]
        assert first.condition == condition and first.env("planform") == planform
        assert first.preset == "reference"
        if env_id == ACCELERATE_ID:
            assert first.env("objective") == objective


def test_a_small_table_keeps_the_best_stroke_and_says_how_it_was_made(tmp_path):
    grid = {LEVEL_FLIGHT_ID: (("efficiency",), (1.0, 1.125, 1.25))}
    jobs = plan(seeds=(0, 1), budgets={LEVEL_FLIGHT_ID: 480}, grid=grid, env_kwargs=SMALL)
    flat = [p for prepared in jobs.values() for p in prepared]
    records = dict(run_jobs(flat, tmp_path, progress=False, cache=False).records)
    before = best_objectives(gather(jobs, [], records))
    continued = continuation(jobs, gather(jobs, [], records))
    for (*_, condition), job in continued.items():
        # warm starts: this point's best and its neighbours' (2 at the ends, 3 inside)
        initial = dict(job.method_config)["initial"]
        assert len(initial) <= (3 if condition == 1.125 else 2)
        own = max(
            (r for r in gather(jobs, [], records)[_key(job)] if r.feasible),
            key=lambda r: r.objective,
            default=None,
        )
        if own is not None:
            assert list(own.normalised_stroke) in [list(x) for x in initial]
        assert job.budget == 240 and job.condition == condition
    records |= run_jobs(list(continued.values()), tmp_path, progress=False, cache=False).records
    # The plan a rerun announces: the rounds the stored optima decide are the real jobs (the
    # second round's from the first round's records), stand-ins of the same budgets after them
    # (a rule that runs every round: the default's stop rule may end it after the first).
    every_round = Continuation(share=0.5, initial_share=0.75, starts=None, rounds=4)
    phases = look_ahead(ReferencePlan(jobs, every_round), tmp_path, cache=False)
    assert list(continued.values()) == list(phases[1].jobs)
    assert not phases[1].provisional and not phases[2].provisional
    assert len(phases) == 1 + every_round.rounds and phases[2].jobs != phases[1].jobs
    for phase in phases[3:]:
        assert phase.provisional == {job.key for job in phase.jobs}
        assert [job.budget for job in phase.jobs] == [job.budget for job in phases[1].jobs]
    # The stop rule: rounds until one raises no point by more than `until` % (the packaged
    # rule's 0.1 % is until=0.1); the first round's records are stored, so nothing runs, and the look-ahead
    # stops where the run does.
    rule = Continuation(share=0.5, initial_share=0.75, starts=None, rounds=3, until=1e9)
    stopping = ReferencePlan(jobs, rule)
    run = run_plan(stopping, tmp_path, cache=False, progress=False)
    assert list(run.runs) == ["search", "continuation 1"]
    assert sum(r.ran for r in run.runs.values()) == 0 and stopping.rounds == [continued]
    assert [p.name for p in look_ahead(stopping, tmp_path, cache=False)] == list(run.runs)
    # the table's rounds run until no point moves by more than 0.1 %
    assert CONTINUATION.stops(0.1) and not CONTINUATION.stops(0.2) and rule.stops(5.0)
    assert not every_round.stops(0.0)
    after = best_objectives(gather(jobs, [continued], records))
    gains = round_gains(before, after)
    assert 0 <= gains["points_raised"] <= len(jobs)
    every = [*(p.job for p in flat), *continued.values()]
    table = build_table(
        jobs,
        [continued],
        records,
        provenance(every, records, [{"round": 1, **gains}], seeds=(0, 1)),
    )
    assert table["provenance"]["seeds"] == [0, 1]
    assert table["provenance"]["optimisations"] == 18
    assert table["format"] == REFERENCE_FORMAT
    parsed = ReferenceTable.from_dict(json.loads(json.dumps(table)))
    assert len(parsed.series) == 2  # both planforms
    for series in parsed.series:
        # made with another resolution: not the defaults' fingerprint, so no env uses it
        assert series.fingerprint != default_fingerprint(LEVEL_FLIGHT_ID, series.planform)
        for point in series.points:
            seeds = [records[p.job.key] for p in jobs[LEVEL_FLIGHT_ID, "efficiency",
                                                      series.planform, point["condition"]]]  # fmt: skip
            seeds.append(records[continued[LEVEL_FLIGHT_ID, "efficiency", series.planform,
                                               point["condition"]].key])  # fmt: skip
            feasible = [r.objective for r in seeds if r.feasible]
            if feasible:
                assert point["feasible"] and point["objective"] == max(feasible)
            else:
                assert not point["feasible"] and math.isnan(point["objective"])
            assert len(point["seed_objectives"]) == 2
    # Another run's stroke competes for its point (the table absorbs any better
    # stroke a method finds), with its provenance; one not of a grid point is refused.
    from agents.harness import prepare

    other = prepare("cmaes", "level", 1.0, 480, [7], env_kwargs={"planform": "real", **SMALL})
    off = prepare("cmaes", "level", 1.0625, 480, [7], env_kwargs={"planform": "real", **SMALL})
    ran = run_jobs([*other, *off], tmp_path / "other", progress=False, cache=False).records
    extra = ran[other[0].job.key]
    key = (LEVEL_FLIGHT_ID, "efficiency", "real", 1.0)
    with pytest.raises(ValueError, match=f"candidate record {ran[off[0].job.key].key}"):
        candidates([ran[off[0].job.key]], jobs)
    if extra.feasible:
        assert candidates([extra], jobs) == {key: [extra]}
        absorbed = build_table(jobs, [continued], records, table["provenance"], {key: [extra]})
        point = next(
            p for s in absorbed["series"] if s["planform"] == "real"
            for p in s["points"] if p["condition"] == 1.0
        )  # fmt: skip
        found = [*point["seed_objectives"], *point["continued_objectives"], extra.objective]
        assert point["objective"] == max(v for v in found if v is not None)
        assert point["candidate_objectives"] == [extra.objective]
        if point["objective"] > max(v for v in found[:-1] if v is not None):
            assert point["source"].startswith("candidate: cmaes, seed 7")
    text = reference_markdown(table)
    assert "| V [m/s] | efficiency, tear-drop | seeds | efficiency, real | seeds |" in text
    write_reference_figure(table, tmp_path / "reference.png")
    assert (tmp_path / "reference.png").stat().st_size > 0


def test_the_command_refuses_a_table_path_it_cannot_write_before_any_work(tmp_path):
    for table, said in ((tmp_path, "is a folder"), (tmp_path / "no" / "t.json", "does not exist")):
        done = subprocess.run(
            [sys.executable, "-m", "eval", "reference", "--out", str(tmp_path / "o"),
             "--table", str(table), "--quiet"],
            capture_output=True, text=True, timeout=120,
        )  # fmt: skip
        assert done.returncode == 2, done.stderr
        assert said in done.stderr
        assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("env_id", [LEVEL_FLIGHT_ID, ACCELERATE_ID])
def test_every_grid_condition_is_inside_its_tasks_limits(env_id):
    from tandem_env.envs.registration import config_class

    low, high = config_class(env_id).CONDITION.limits
    assert all(low <= c <= high for c in REFERENCE_GRID[env_id][1])


def test_records_summaries_and_comparisons_carry_the_score(tmp_path):
    import numpy as np

    import tandem_env
    from agents.harness import prepare
    from eval.compare import comparison_markdown, table_rows
    from tandem_env.envs.reference import normalised_score

    default = prepare("random", "level", 1.3, 8, [0, 1], method_config={"batch_size": 4})
    coarse = prepare(
        "random", "level", 1.3, 8, [0], env_kwargs=SMALL, method_config={"batch_size": 4}
    )
    records = run_jobs([*default, *coarse], tmp_path, progress=False, cache=False).records
    for prepared in default:
        record = records[prepared.job.key]
        expected = normalised_score(
            tandem_env.reference(LEVEL_FLIGHT_ID, 1.3),
            record.objective,
            record.feasible,
            record.metrics["constraint_violation"],
        )
        assert record.score == float(expected)
        assert record.summary_row()["score"] == record.score
    assert math.isnan(records[coarse[0].job.key].score)  # another resolution: no reference
    rows = {r.settings: r for r in table_rows(list(records.values()))}
    scored = [r for r in rows.values() if not math.isnan(r.score_median)]
    assert len(scored) == 1 and scored[0].seeds == 2
    assert scored[0].score_median == float(np.median([records[p.job.key].score for p in default]))
    assert "median score |" in comparison_markdown(list(rows.values()))
