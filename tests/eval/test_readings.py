"""The readings study: reading validation, job identity with the ``all`` suite, shared records,
the combination rule, the CSV and a tiny end-to-end run that a rerun does not recompute."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import pytest

from agents import runner
from eval.studies import PAPER_STUDIES, claims, readings
from eval.studies.base import StudyOutput, StudyPlan
from eval.studies.paper_reading import DEFAULT, Reading, combine
from eval.studies.presets import STUDY_PRESETS, TINY
from eval.studies.readings import ReadingResult, combinations, reading_jobs
from eval.studies.readings import plan as readings_plan
from eval.studies.readings import run as readings_run
from eval.studies.readings import timing as readings_time


def _keys(jobs: list[runner.Job]) -> set[str]:
    return {job.key for job in jobs}


# --- readings ----------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"options": {"bogus": 1}}, r"'x'.*options = 'bogus'; allowed: .*thrust_split"),
        ({"options": {"n_time": 64}}, r"options = 'n_time'; allowed: ModelOptions fields"),
        ({"options": {"thrust_split": "net"}}, r"'x'.*thrust_split.*'net'.*sign"),
        ({"options": {"interference": 3.0}}, r"'x'.*interference = 3.0; allowed: 0 to 2"),
        ({"rotational_coefficient": -1.0}, r"rotational_coefficient = -1.0; allowed"),
        ({"rotational_coefficient": "pi"}, r"rotational_coefficient = 'pi'; allowed"),
        ({"horizontal_objective": "vertical"}, r"horizontal_objective = 'vertical'; allowed: "),
        ({"description": " "}, r"description = ' '; allowed: a one-line description"),
    ],
)
def test_bad_reading_names_the_value_and_what_is_allowed(kwargs: dict, match: str) -> None:
    base = {"name": "x", "description": "a test reading"}
    with pytest.raises(ValueError, match=match):
        Reading(**{**base, **kwargs})


def test_unknown_single_reading_is_named() -> None:
    with pytest.raises(ValueError, match=r"unknown reading\(s\) 'nope'; allowed: default, body"):
        readings_plan.single_readings(["nope"])
    assert readings_plan.single_readings(["body"])[0] == DEFAULT


def test_every_single_reading_changes_one_decision_and_builds_envs() -> None:
    from tandem_env.envs import AccelerateConfig

    names = [r.name for r in readings.SINGLES]
    assert names[0] == "default" and len(set(names)) == len(names)
    assert DEFAULT.changes() == {} and DEFAULT.env_kwargs() == {}
    for reading in readings.SINGLES[1:]:
        assert len(reading.changes()) == 1, reading.name
        config = AccelerateConfig.from_kwargs(available_power=60.0, **reading.env_kwargs())
        for name, value in reading.options:
            assert getattr(config.options, name) == value
        if reading.rotational_coefficient is not None:
            assert config.insect.fore.rotational_coefficient == reading.rotational_coefficient
            assert config.insect.hind.rotational_coefficient == reading.rotational_coefficient


def test_the_convected_reading_is_the_one_single_reading_that_resolves_the_phase() -> None:
    """The readings study has the convected slipstream as a single reading, and only under it
    does the model depend on the fore/hind phase (so K1-K3 get verdicts)."""
    convected = readings.reading_by_name("convected")
    assert convected in readings.SINGLES
    assert convected.changes() == {"slipstream": "convected"}
    assert convected.env_kwargs() == {"slipstream": "convected"}
    resolving = [
        r.name
        for r in readings.SINGLES
        if StudyPlan(TINY, reading=r).model_options.phase_resolved()
    ]
    assert resolving == ["convected"]
    # a combination with a reading that hides the slipstream is blind again
    blind = readings.reading_by_name("convected+Chf=0")
    assert not StudyPlan(TINY, reading=blind).model_options.phase_resolved()
    # the plan's options are the preset's env keywords with the reading's over them
    options = StudyPlan(TINY, reading=convected).model_options
    assert (options.slipstream, options.n_time, options.n_blade) == ("convected", 32, 6)


def test_default_reading_gives_the_all_suite_jobs_key_for_key() -> None:
    plan = StudyPlan(TINY)
    suite = [job for study in PAPER_STUDIES.values() for job in study.jobs(plan)]
    assert [j.key for j in reading_jobs(plan, DEFAULT)] == [j.key for j in suite]
    # ... and a reading that restates the defaults is the same configuration.
    restated = Reading("restated", "defaults spelt out", {"thrust_split": "sign", "spin": "pitch"})
    assert _keys(reading_jobs(plan, restated)) == _keys(suite)


def test_readings_share_records_where_the_configuration_is_the_same() -> None:
    plan = StudyPlan(TINY)
    default = _keys(reading_jobs(plan, DEFAULT))
    body = _keys(reading_jobs(plan, readings.SINGLES[1]))
    assert not default & body  # a model option changes every job
    # F̄_h's objective changes the horizontal accelerating jobs only.
    literal = Reading("literal", "test", horizontal_objective="horizontal_literal")
    jobs = reading_jobs(plan, literal)
    changed = {j.key for j in jobs if j.env("objective") == "horizontal_literal"}
    assert changed and not changed & default
    assert _keys(jobs) - changed <= default
    assert len(_keys(jobs) - changed) == len(default) - len(changed)
    both = combine([readings.SINGLES[1], literal])
    assert _keys(reading_jobs(plan, both)) - body == {
        j.key for j in reading_jobs(plan, both) if j.env("objective") == "horizontal_literal"
    }


# --- the combination rule ----------------------------------------------------------------------
def _result(reading: Reading, agree: int, total: int = 10) -> ReadingResult:
    found = [
        claims.Claim(f"C{i}", "s", "Fig. 1", "x", "x", "number", verdict=v)
        for i, v in enumerate(["agrees"] * agree + ["differs"] * (total - agree))
    ]
    return ReadingResult(reading, (StudyOutput("s", "S", [], [], found),))


def test_combinations_join_the_gainers_best_first_skipping_conflicts() -> None:
    a = Reading("a", "t", {"thrust_split": "body"})
    b = Reading("b", "t", {"spin": "total"})
    c = Reading("c", "t", {"power": "elastic"})
    c2 = Reading("c2", "t", {"thrust_split": "sign", "interference": 0.0})
    d = Reading("d", "t", rotational_coefficient=1.0)
    lose = Reading("lose", "t", {"interference": 2.0})
    singles = [_result(DEFAULT, 4), _result(a, 7), _result(b, 6), _result(c, 5)]
    singles += [_result(lose, 3), _result(d, 4), _result(c2, 5)]
    out, words = combinations(singles[0], singles)
    # Gainers a, b, c, c2: their best two, all four; then a with each other single (a+b and
    # a+c2 once only), c2 and lose conflict with each other but not with a.
    assert [r.name for r in out] == ["a+b", "a+b+c+c2", "a+c", "a+lose", "a+d", "a+c2"]
    assert out[0].changes() == {"thrust_split": "body", "spin": "total"}
    assert out[0].derived_from == ("a", "b")
    assert "lose (" not in words and "d (" not in words and "a (+3)" in words
    # A gainer that conflicts with a better one is left out of the set, and said so.
    x = Reading("x", "t", {"interference": 0.0, "thrust_split": "body"})
    x_conflict = Reading("x-conflict", "t", {"interference": 2.0})
    singles = [_result(DEFAULT, 4), _result(x, 7), _result(x_conflict, 6), _result(b, 5)]
    out, words = combinations(singles[0], singles)
    assert [r.name for r in out] == ["x+b"]
    assert "x-conflict (conflicts with x)" in words
    # One gainer: paired with every other single (a loser included); none: nothing.
    out, words = combinations(singles[0], [singles[0], singles[3], _result(lose, 2)])
    assert [r.name for r in out] == ["b+lose"]
    out, words = combinations(singles[0], [singles[0], _result(lose, 2)])
    assert out == [] and "no gainer" in words


def test_combine_refuses_conflicting_readings() -> None:
    assert combine([Reading("a", "t", {"spin": "total"}), Reading("b", "t", {"spin": "total"})])
    with pytest.raises(ValueError, match="conflict on interference"):
        combine(
            [Reading("a", "t", {"interference": 0.0}), Reading("b", "t", {"interference": 2.0})]
        )


def test_csv_has_one_row_per_reading_with_the_documented_columns() -> None:
    rows = readings_run.csv_rows([_result(DEFAULT, 4), _result(readings.SINGLES[1], 6)])
    assert [tuple(r) for r in rows] == [readings_plan.CSV_COLUMNS] * 2
    assert rows[1]["reading"] == "body" and rows[1]["thrust_split"] == "body"
    assert (rows[1]["agree"], rows[1]["differ"], rows[1]["undecided"]) == (6, 4, 0)
    assert rows[0]["rotational_coefficient"] == math.pi
    assert math.isnan(rows[0]["eta_max_pct"])  # no S7 claim in the synthetic results


# --- end to end --------------------------------------------------------------------------------
def test_tiny_run_writes_everything_and_a_rerun_computes_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture
) -> None:
    from eval.__main__ import main

    plan = StudyPlan(TINY)
    chosen = readings_plan.single_readings(["convected"])
    first = readings.run_readings(
        plan, tmp_path, readings=chosen, progress=False, continuation=None
    )
    assert first.runs[0].ran == len(_keys(reading_jobs(plan, DEFAULT))) * 2
    for name in ("readings.csv", "readings_matrix.png", "report.md", readings.MANIFEST):
        assert (tmp_path / name).is_file(), name
    for reading in chosen:
        assert (tmp_path / reading.name / "report.md").is_file()
        assert (tmp_path / reading.name / "records").resolve() == (tmp_path / "records").resolve()
    with open(tmp_path / "readings.csv", newline="", encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    assert [r["reading"] for r in rows] == ["default", "convected"]
    assert tuple(rows[0]) == readings_plan.CSV_COLUMNS
    n_claims = len(first.results[0].claims)
    counts = ("agree", "differ", "undecided", "not_identifiable", "no_data")
    assert all(sum(int(r[k]) for k in counts) == n_claims for r in rows)
    # the phase claims (K1-K3) get no verdict under the default's mean slipstream, and real
    # ones under the convected slipstream
    assert [int(r["not_identifiable"]) for r in rows] == [3, 0]
    moved = {c.id: c for c in first.results[1].claims}
    assert all(moved[cid].verdict != "not identifiable" for cid in ("K1", "K2", "K3"))
    report = (tmp_path / "report.md").read_text(encoding="utf-8")
    assert "## Which decision moves which claim" in report and "`convected`" in report
    assert "| not identifiable |" in report

    # The same study from the command line: every record is reused, the verdicts are the same.
    calls: list[runner.Job] = []
    monkeypatch.setattr(runner, "_harness_run", lambda job: calls.append(job))
    monkeypatch.setitem(STUDY_PRESETS, TINY.name, TINY)
    argv = ["study", "readings", "--preset", "tiny", "--out", str(tmp_path), "--quiet"]
    assert main([*argv, "--reading", "convected", "--continuation", "none"]) == 0
    out = capsys.readouterr().out
    assert calls == []
    for r in first.results:
        assert f"{r.reading.name}: {r.agree} agree, {r.differ} differ" in out

    # The cost estimate for another preset reads the measured records.
    readings_time.main(["--measured", str(tmp_path), "--preset", "quick"])
    out = capsys.readouterr().out
    assert "convected" in out and "h serial" in out


def test_cli_names_an_unknown_reading(capsys: pytest.CaptureFixture) -> None:
    from eval.__main__ import main

    with pytest.raises(SystemExit):
        main(["study", "readings", "--reading", "nope", "--quiet"])
    assert "unknown reading(s) 'nope'; allowed: default, body" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["study", "speed", "--reading", "body", "--reading", "elastic", "--quiet"])
    assert "study 'speed' runs under one --reading" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["study", "speed", "--reading", "body+nope", "--quiet"])
    assert "reading 'body+nope': unknown 'nope'; allowed: " in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["optimize", "--task", "level", "--speed", "1.5", "--method", "cmaes",
              "--budget", "100", "--seeds", "0", "--out", "x", "--reading", "nope"])  # fmt: skip
    assert "reading 'nope': unknown 'nope'" in capsys.readouterr().err


def test_named_readings_are_the_singles_and_their_combinations() -> None:
    assert readings.reading_by_name("body") is readings_plan.single_readings(["body"])[1]
    both = readings.reading_by_name("hover-none+Fh-literal")
    assert both.changes() == {"hover_inflow": "none", "horizontal_objective": "horizontal_literal"}
    assert both.derived_from == ("hover-none", "Fh-literal")
    for alias, name in readings.ALIASES.items():
        assert readings.reading_by_name(alias) == readings.reading_by_name(name)
    with pytest.raises(ValueError, match="distinct singles other than the default"):
        readings.reading_by_name("body+body")


def test_optimize_and_study_run_under_a_named_reading(tmp_path: Path, capsys) -> None:
    from eval.__main__ import main

    argv = ["optimize", "--task", "accelerate", "--power", "60", "--objective", "horizontal",
            "--method", "random", "--budget", "20", "--seeds", "0", "--quiet"]  # fmt: skip
    assert main([*argv, "--out", str(tmp_path / "o"), "--reading", "hover-none+Fh-literal"]) == 0
    (record,) = runner.RecordStore(tmp_path / "o").records()
    assert record.job.env("hover_inflow") == "none"
    assert record.job.env("objective") == "horizontal_literal"
    with pytest.raises(SystemExit):  # the reading and --env-kwargs may not both set an option
        main([*argv, "--out", str(tmp_path / "p"), "--reading", "hover-none",
              "--env-kwargs", "hover_inflow=momentum"])  # fmt: skip
    assert "--reading hover-none sets ['hover_inflow']" in capsys.readouterr().err


# --- continuation ------------------------------------------------------------------------------
def test_continued_jobs_start_from_the_default_optimum_of_the_same_job() -> None:
    plan = StudyPlan(TINY)
    reading = next(r for r in readings.SINGLES if r.name == "Fh-literal")
    continuation = readings.Continuation(share=0.5, initial_share=0.6, starts=2)
    default = readings_plan.study_jobs(plan, DEFAULT)
    optima = {
        DEFAULT.name: {
            name: [[0.01 * k] * 28 for k in range(len(group))] for name, group in default.items()
        }
    }
    continued = readings_plan.study_jobs(plan, reading, continuation, optima)
    full = readings_plan.study_jobs(plan, reading)
    assert readings_plan.study_jobs(plan, DEFAULT, continuation, optima) == default
    # a task named in ``full`` keeps its own jobs
    assert readings_plan.study_jobs(plan, reading, continuation, optima, ("accelerate",)) == full
    shared = changed = 0
    for name in default:
        triples = zip(default[name], continued[name], full[name], strict=True)
        for position, (d, c, f) in enumerate(triples):
            if f.key == d.key:  # Fh-literal changes only the horizontal jobs: shared
                assert c == d
                shared += 1
                continue
            changed += 1
            config = dict(c.method_config)
            assert config["initial"] == (tuple(optima[DEFAULT.name][name][position]),)
            assert config["starts"] == 2
            assert config["initial_share"] == 0.6
            assert c.budget == round(0.5 * f.budget) and c.seed == f.seed
            assert (c.task, c.condition, c.env_kwargs) == (f.task, f.condition, f.env_kwargs)
    assert shared and changed


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"share": 0.0}, r"share = 0.0; allowed: a number in \(0, 1\]"),
        ({"share": 1.5}, r"share = 1.5"),
        ({"starts": 0}, r"starts = 0; allowed: an integer in \[1, 8\]"),
        ({"initial_share": 1.0}, r"initial_share = 1.0; allowed: a number in \[0.05, 0.95\]"),
        ({"check_studies": ("nope",)}, r"check_studies = \('nope',\); allowed: names among speed"),
        ({"check_seeds": (-1,)}, r"check_seeds = \(-1,\); allowed: integers >= 0"),
    ],
)
def test_bad_continuation_is_refused(kwargs: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        readings.Continuation(**kwargs)


def test_tiny_run_with_continuation_checks_its_bias(
    tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    plan = StudyPlan(TINY)
    chosen = readings_plan.single_readings(["hover-none"])
    continuation = readings.Continuation(share=1.0)
    result = readings.run_readings(
        plan, tmp_path, readings=chosen, progress=False, continuation=continuation
    )
    assert result.phases[:3] == ("default", "check", "singles")
    n_default = len(_keys(reading_jobs(plan, DEFAULT)))
    assert result.runs[0].ran == n_default
    with open(tmp_path / readings_plan.CHECK_CSV, newline="", encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    optima = readings_plan.optima_of(
        tmp_path, {DEFAULT.name: readings_plan.study_jobs(plan, DEFAULT)}
    )
    checked = readings.check_jobs(plan, chosen[1], continuation, optima)
    # the check's pairs ran in the check phase, so the singles' phase reuses its checked jobs
    assert result.runs[1].ran == len({job for pair in checked for job in pair})
    assert result.runs[2].reused >= len(checked)
    assert len(rows) == len(checked) > 0 and tuple(rows[0]) == readings_run.CHECK_COLUMNS
    assert {r["reading"] for r in rows} == {"hover-none"}
    report = (tmp_path / "report.md").read_text(encoding="utf-8")
    assert "## Continuation and its bias" in report and "**all**" in report
    # a second invocation reuses every job, and the manifest keeps both invocations' work
    again = readings.run_readings(
        plan, tmp_path, readings=chosen, progress=False, continuation=continuation
    )
    assert sum(run.ran for run in again.runs) == 0
    manifest = json.loads((tmp_path / readings.MANIFEST).read_text(encoding="utf-8"))
    first, second = manifest["invocations"]
    assert [p["name"] for p in first["phases"]] == list(result.phases)
    assert [p["ran"] for p in first["phases"]] == [run.ran for run in result.runs]
    assert all(p["ran"] == 0 for p in second["phases"]) and second["cpus"] >= 1
    verdicts = {r["name"]: r["verdicts"] for r in manifest["readings"]}
    assert verdicts["hover-none"] == result.results[1].verdicts()
    # the cost estimate reads the continued jobs' records, which the run analysed
    readings_time.main(["--measured", str(tmp_path), "--preset", "quick"])
    out = capsys.readouterr().out
    assert "hover-none: measured" in out and "h serial" in out


def test_a_task_whose_check_falls_short_runs_in_full() -> None:
    rule = readings.Continuation(full_median=-0.02, full_lowest=-0.5)
    base = {"pairs": 4, "highest": 0.1, "within_0.5%": 2, "infeasible": 0}
    summary = [
        {**base, "reading": "all", "task": "all", "median": -0.9, "lowest": -1.0,
         "infeasible_continued": 3},
        {**base, "reading": "a", "task": "level", "median": -0.019, "lowest": -0.49,
         "infeasible_continued": 0},
        {**base, "reading": "a", "task": "accelerate", "median": -0.021, "lowest": -0.1,
         "infeasible_continued": 0},
        {**base, "reading": "b", "task": "level", "median": 0.0, "lowest": -0.51,
         "infeasible_continued": 0},
        {**base, "reading": "c", "task": "level", "median": 0.0, "lowest": 0.0,
         "infeasible_continued": 1},
    ]  # fmt: skip
    assert readings.full_tasks(summary, rule) == {
        "a": {"accelerate": "median -2.1 %"},
        "b": {"level": "lowest -51.0 %"},
        "c": {"level": "1 continued optimum infeasible"},
    }
    assert readings.full_tasks(summary, readings.Continuation(full_median=-1, full_lowest=-1)) == {
        "c": {"level": "1 continued optimum infeasible"}
    }
    with pytest.raises(ValueError, match=r"full_median = 0.5; allowed: a relative difference"):
        readings.Continuation(full_median=0.5)


def test_a_combination_continues_from_the_optima_of_its_parts() -> None:
    plan = StudyPlan(TINY)
    parts = [readings.reading_by_name(name) for name in ("hover-none", "Fh-literal")]
    combined = readings.reading_by_name("hover-none+Fh-literal")
    assert readings_plan.continued_from(combined) == ("hover-none", "Fh-literal")
    default = readings_plan.study_jobs(plan, DEFAULT)
    optima = {
        r.name: {
            name: [[0.01 * k + 0.001 * i] * 28 for k in range(len(group))]
            for name, group in default.items()
        }
        for i, r in enumerate([DEFAULT, *parts])
    }
    continuation = readings.Continuation()
    with pytest.raises(ValueError, match=r"continues from \['Fh-literal'\], not run yet"):
        readings_plan.study_jobs(plan, combined, continuation, {"hover-none": optima["hover-none"]})
    continued = readings_plan.study_jobs(plan, combined, continuation, optima)
    seen = 0
    for name, group in continued.items():
        for position, (job, d) in enumerate(zip(group, default[name], strict=True)):
            if job.key == d.key:
                continue
            seen += 1
            expected = tuple(tuple(optima[p.name][name][position]) for p in parts)
            assert dict(job.method_config)["initial"] == expected
    assert seen
    # a part's stroke that equals the other's is polished once
    same = {**optima, "Fh-literal": optima["hover-none"]}
    once = readings_plan.study_jobs(plan, combined, continuation, same)
    configs = [dict(j.method_config) for g in once.values() for j in g]
    assert all(len(c["initial"]) == 1 for c in configs if "initial" in c)
