"""The reproduction studies on a tiny preset: outputs, resume, configuration changes, report numbers."""

from __future__ import annotations

import csv
import json
import math
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from agents.harness import run
from eval.studies import STUDIES, claims, convergence
from eval.studies.base import StudyPlan
from eval.studies.presets import STUDY_PRESETS, TINY, ConvergenceSpec, Preset
from eval.studies.suite import run_studies
from eval.studies.tables import Spread
from tandem_env import PARAMETER_NAMES
from tests.runner_calls import count_harness_calls

# A slightly larger budget than TINY's so that some optimisations are feasible and the report
# has numbers to check (still well under a second per study).
SMALL = replace(TINY, level_budget=48, accelerate_budget=48)


@pytest.fixture(scope="module")
def study_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("study")
    run_studies(["all", "convergence"], StudyPlan(SMALL), out, workers=1, progress=False)
    return out


def _raw_records(study_dir: Path) -> list[dict]:
    """The record files as plain JSON, each flattened to one level: its job's fields and its
    results side by side (independently of agents.records)."""
    out = []
    for path in (study_dir / "records").glob("*.json"):
        data = json.loads(path.read_text())
        out.append({**data["job"], **data["results"], "job": data["job"], "key": data["key"]})
    return out


def _read_csv(path: Path) -> list[dict[str, str]]:
    with open(path, newline="", encoding="utf-8") as handle:
        return list(csv.DictReader(handle))


def _report_rows(path: Path) -> dict[str, dict[str, str]]:
    """The paper-vs-ours table of report.md, by claim id."""
    lines = path.read_text(encoding="utf-8").splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("| id | figure |"))
    header = [h.strip() for h in lines[start].strip("|").split("|")]
    rows = {}
    for line in lines[start + 2 :]:
        if not line.startswith("|"):
            break
        cells = [c.strip() for c in re.split(r"(?<!\\)\|", line.strip().strip("|"))]
        rows[cells[0]] = dict(zip(header, cells, strict=True))
    return rows


def test_every_study_writes_records_csv_figures_and_report(study_dir: Path) -> None:
    for name in STUDIES:
        folder = study_dir / name
        index = json.loads((folder / "records.json").read_text())
        assert index, name
        for entry in index:
            assert (folder / entry["file"]).resolve().is_file()
        rows = _read_csv(folder / f"{name}.csv")
        assert len(rows) == len(index)
        assert set(PARAMETER_NAMES) | {"at_bounds"} <= set(rows[0])  # the strokes themselves
        summary = _read_csv(folder / f"{name}_summary.csv")
        assert "pinned" in summary[0] and {r["quantity"] for r in summary} >= set(PARAMETER_NAMES)
        pngs = sorted(folder.glob("*.png"))
        assert pngs and all(p.stat().st_size > 5_000 for p in pngs), name
    report = (study_dir / "report.md").read_text()
    assert "## Parameters pinned at Table 4 bounds" in report
    table = _report_rows(study_dir / "report.md")
    for cid in ("S1", "S7", "S8", "P1a", "P1b", "P3", "P6b", "K1", "K2", "K3", "K4", "W1", "W4"):
        assert cid in table, cid
    # the default's mean slipstream does not depend on the fore/hind phase: no verdict on it
    blind = "not identifiable (the model does not depend on the fore/hind phase)"
    for cid in ("K1", "K2", "K3"):
        assert table[cid]["verdict: median"] == table[cid]["verdict: best seed"] == blind
    assert not table["K4"]["verdict: median"].startswith("not identifiable")
    assert "not identifiable (K1, K2, K3)" in report
    # The claims as data beside the report: the same rows, their numbers and verdict words.
    data = json.loads((study_dir / "claims.json").read_text(encoding="utf-8"))["claims"]
    assert [c["id"] for c in data] == list(table)
    for c in data:
        assert {k: v.replace("|", "\\|") for k, v in c["cells"].items()} == table[c["id"]]
        assert c["cells"]["verdict: median"].startswith(c["verdict"])
        assert c["cells"]["verdict: best seed"].startswith(c["best_verdict"])
        assert c["median"] is None or f"{c['median']:.3g}" in c["cells"]["ours: median [IQR]"]
    # Every figure is linked from the report with a path relative to it.
    for png in study_dir.glob("*/fig*.png"):
        assert f"]({png.relative_to(study_dir).as_posix()})" in report


def test_report_numbers_are_the_records_numbers(study_dir: Path) -> None:
    # Independently of the study code: read the record files and recompute the statistics.
    records = _raw_records(study_dir)
    table = _report_rows(study_dir / "report.md")

    def values(task: str, objective: str, condition: float, metric: str) -> list[float]:
        return [
            r["metrics"][metric]
            for r in records
            if r["task"] == task
            and r["job"]["env_kwargs"].get("objective", "efficiency") == objective
            and r["job"]["env_kwargs"]["planform"] == "tear-drop"
            and r["job"]["budget"] == SMALL.budget(task)
            and r["job"]["condition"] == condition
            and r["feasible"]
            # the convergence study's other budget splits at the same condition
            and not any(k.startswith("polish") for k in r["job"]["method_config"])
        ]

    checked = 0
    for cid, objective, metric in (
        ("P1b", "vertical", "excess_vertical"),
        ("P2b", "horizontal", "excess_horizontal"),
    ):
        v = values("accelerate", objective, 90.0, metric)
        cell = table[cid]["ours: median [IQR]"]
        if not v:
            assert cell == "–"
            continue
        numbers = [float(x) for x in re.findall(r"-?\d+\.?\d*(?:e-?\d+)?", cell)]
        q25, med, q75 = np.percentile(v, [25, 50, 75])
        assert numbers[:3] == pytest.approx([med, q25, q75], rel=5e-3, abs=1e-3)
        checked += 1
    assert checked >= 1, "the tiny preset found no feasible accelerating stroke to check"

    # The tidy CSV is the records' numbers too.
    by_key = {r["key"]: r for r in records}
    for row in _read_csv(study_dir / "power" / "power.csv"):
        record = by_key[row["key"]]
        assert float(row["excess_vertical"]) == pytest.approx(record["metrics"]["excess_vertical"])
        assert float(row["objective_value"]) == pytest.approx(record["objective"])
        assert (row["feasible"] == "True") == record["feasible"]
        assert int(row["seed"]) == record["seed"]


def test_resume_skips_finished_jobs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    calls = count_harness_calls(monkeypatch)
    plan = StudyPlan(TINY)
    first = run_studies(["power"], plan, tmp_path, workers=1, progress=False)
    n = len(calls)
    assert n == first.run.total == first.run.ran > 0
    again = run_studies(["power"], plan, tmp_path, workers=1, progress=False)
    assert len(calls) == n and again.run.reused == again.run.total
    # A run killed part-way: one record missing -> exactly that job runs again.
    victim = next((tmp_path / "records").glob("*.json"))
    victim.unlink()  # (and not in the record cache, which would restore it)
    third = run_studies(["power"], plan, tmp_path, workers=1, progress=False, cache=False)
    assert len(calls) == n + 1 and third.run.ran == 1
    # Another study sharing jobs reuses them: kinematics' accelerating stroke at 90 W/kg.
    before = len(calls)
    run_studies(["kinematics"], plan, tmp_path, workers=1, progress=False)
    kin = {j.key for j in STUDIES["kinematics"].jobs(plan)}
    pow_ = {j.key for j in STUDIES["power"].jobs(plan)}
    assert len(calls) - before == len(kin - pow_)


def test_changed_configuration_is_not_mixed(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    calls = count_harness_calls(monkeypatch)
    run_studies(["speed"], StudyPlan(TINY), tmp_path, workers=1, progress=False)
    old = len(calls)
    changed = replace(TINY, level_budget=24)
    run_studies(["speed"], StudyPlan(changed), tmp_path, workers=1, progress=False)
    assert len(calls) == 2 * old  # nothing reused
    rows = _read_csv(tmp_path / "speed" / "speed.csv")
    assert len(rows) == len(TINY.speeds) * len(TINY.seeds)
    assert {r["budget"] for r in rows} == {"24"}
    # Model options are part of the configuration too.
    other = replace(TINY, env_kwargs=(("n_blade", 6), ("n_time", 40)))
    run_studies(["speed"], StudyPlan(other), tmp_path, workers=1, progress=False)
    assert len(calls) == 3 * old
    # The old records are still there, but only the current ones are read.
    assert len(list((tmp_path / "records").glob("*.json"))) == 3 * old


def test_pool_gives_the_serial_numbers(tmp_path: Path) -> None:
    plan = StudyPlan(TINY)
    run_studies(["speed"], plan, tmp_path / "serial", workers=1, progress=False)
    # computed again, not copied from the record cache
    run_studies(["speed"], plan, tmp_path / "pool", workers=2, progress=False, cache=False)
    serial = _read_csv(tmp_path / "serial" / "speed" / "speed.csv")
    pooled = _read_csv(tmp_path / "pool" / "speed" / "speed.csv")
    drop = {"wall_time_s"}
    assert [{k: v for k, v in r.items() if k not in drop} for r in serial] == [
        {k: v for k, v in r.items() if k not in drop} for r in pooled
    ]
    report = (tmp_path / "pool" / "report.md").read_text()
    assert report == (tmp_path / "serial" / "report.md").read_text()


def test_other_methods_run_beside_pso(tmp_path: Path) -> None:
    result = run_studies(
        ["speed"], StudyPlan(TINY, ("pso", "random")), tmp_path, workers=1, progress=False
    )
    rows = result.outputs[0].rows
    assert {r["method"] for r in rows} == {"pso", "random"}
    ids = {c.id for c in result.outputs[0].claims}
    assert {"S7", "S7/random"} <= ids


def test_cli_study(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture
) -> None:
    from eval.__main__ import main

    monkeypatch.setitem(STUDY_PRESETS, TINY.name, TINY)
    code = main(
        ["study", "power", "--preset", "tiny", "--out", str(tmp_path), "--workers", "1", "--quiet"]
    )
    assert code == 0
    assert "report:" in capsys.readouterr().out
    assert (tmp_path / "report.md").is_file()
    assert (tmp_path / "power" / "fig8_attainable.png").is_file()


def test_pso_budget_prefix_property() -> None:
    """A budget-B PSO run is the first B evaluations of a longer run (the convergence study's basis)."""
    kwargs = dict(env_kwargs=dict(TINY.env_kwargs), method_config={"swarm_size": 8}, progress=False)
    (short,) = run("pso", "level", 1.5, 24, [3], **kwargs)
    (long,) = run("pso", "level", 1.5, 48, [3], **kwargs)
    assert long.history[: len(short.history)] == short.history


def test_cmaes_budget_prefix_property() -> None:
    """The same for CMA-ES, its default restarts and a truncated last population included."""
    kwargs = dict(env_kwargs=dict(TINY.env_kwargs), progress=False)
    (long,) = run("cmaes", "level", 1.5, 180, [3], **kwargs)
    for budget in (52, 80, 131):  # one population (λ = 52), a truncated one, two and a part
        (short,) = run("cmaes", "level", 1.5, budget, [3], **kwargs)
        assert long.history[: len(short.history) - 1] == short.history[:-1]
        # the truncated last population is the first evaluations of the longer run's population
        e, best = short.history[-1]
        assert e == budget
        assert best <= next(b for f, b in long.history if f >= budget)


def test_convergence_study_compares_pso_and_cmaes(study_dir: Path) -> None:
    rows = _read_csv(study_dir / "convergence" / "convergence_checkpoints.csv")
    spec = SMALL.convergence
    assert {(r["method"], r["condition"].split(",")[0]) for r in rows} == {
        (m, t) for m in ("pso", "cmaes") for t in ("level", "accelerating")
    }
    records = _raw_records(study_dir)
    for row in rows:
        task = "level" if row["condition"].startswith("level") else "accelerate"
        budget = int(row["budget"])
        # independently of the study code: the best-so-far of each seed at the checkpoint
        values = [
            max(b for e, b in r["history"] if e <= budget)
            for r in records
            if r["job"]["budget"] == spec.budget
            and r["method"] == row["method"]
            and r["task"] == task
        ]
        assert len(values) == len(spec.seeds) == int(row["seeds"])
        median = float(np.median(values))
        assert float(row["median"]) == pytest.approx(median)
        assert float(row["min"]) == min(values) and float(row["max"]) == max(values)
        if median > 0:
            assert float(row["spread"]) == pytest.approx((max(values) - min(values)) / median)
    table = (study_dir / "convergence" / "convergence_checkpoints.md").read_text()
    assert table.count("\n") == len(rows) + 2 and "| cmaes |" in table


def test_studies_default_to_the_presets_method() -> None:
    assert StudyPlan(TINY).methods == (TINY.method,)
    assert {p.method for p in STUDY_PRESETS.values()} <= {"pso", "cmaes"}
    assert StudyPlan(TINY, ("pso",)).methods == ("pso",)
    with pytest.raises(ValueError, match="method"):
        replace(TINY, method="")


def test_presets_are_validated() -> None:
    with pytest.raises(ValueError, match="speeds"):
        replace(TINY, speeds=(3.0,))
    with pytest.raises(ValueError, match="powers"):
        replace(TINY, powers=(40.0, 90.0))
    with pytest.raises(ValueError, match="seeds"):
        replace(TINY, seeds=(0, 0))
    with pytest.raises(ValueError, match="level_budget"):
        replace(TINY, level_budget=4)
    with pytest.raises(ValueError, match="env_kwargs"):
        replace(TINY, env_kwargs=(("speed", 1.0),))
    with pytest.raises(ValueError, match="budget"):
        ConvergenceSpec(budget=1, seeds=(0,))
    with pytest.raises(ValueError, match="methods"):
        ConvergenceSpec(budget=100, seeds=(0,), methods=("pso", "pso"))
    with pytest.raises(ValueError, match="methods"):
        StudyPlan(TINY, ())
    assert all(isinstance(p, Preset) for p in STUDY_PRESETS.values())
    # The presets cover the kinematics conditions and the 2 m/s phase claim.
    for preset in STUDY_PRESETS.values():
        assert preset.kinematics_speed in preset.speeds and preset.phase_speed in preset.speeds
        assert preset.kinematics_power in preset.powers
        assert {50.0, 90.0} <= set(preset.powers)


def _spread(values: list[float]) -> Spread:
    q25, med, q75 = np.percentile(values, [25, 50, 75])
    return Spread(
        tuple(values),
        tuple(range(len(values))),
        med,
        q25,
        q75,
        max(values),
        0,
        len(values),
        len(values),
    )


def test_agreement_rules() -> None:
    def ok(row: dict, rule: claims.Rule, target: object) -> bool | None:
        return claims.judge(row["median"], rule, target)

    assert ok(claims.spread_stats(_spread([12.0, 13.0, 14.0])), "number", 12.7)
    assert not ok(claims.spread_stats(_spread([30.0, 31.0])), "number", 12.7)
    rising = {v: _spread([v, v + 0.1]) for v in (0.5, 1.0, 1.5, 2.0)}
    row = claims.trend_stats(rising, +1)
    assert row["median"] == pytest.approx(1.0) and ok(row, "trend", +1) and "1.00" in row["detail"]
    assert ok(row, "trend", -1) is False
    valley = {v: _spread([abs(v - 1.5) + 1]) for v in (0.5, 1.0, 1.5, 2.0)}
    assert ok(claims.location_stats(valley, "min"), "location", 1.5)
    assert claims.location_stats(valley, "max")["median"] == 0.5
    assert claims.judge(21.0, "range", (10.0, 20.0))
    assert not claims.judge(30.0, "range", (10.0, 20.0))
    assert math.isnan(claims.rho([1.0, 2.0], [1.0, 2.0]))


def test_phase_angle_and_compare_rules() -> None:
    assert claims.judge(14.9, "phase", True) and not claims.judge(15.0, "phase", True)
    assert claims.judge(15.0, "phase", False) and not claims.judge(3.0, "phase", False)
    assert claims.judge(44.0, "angle", 30.0) and not claims.judge(46.0, "angle", 30.0)
    assert claims.judge(-9.0, "number", -10.0) and not claims.judge(-7.0, "number", -10.0)
    assert claims.judge(math.nan, "phase", True) is None
    assert claims.judge(math.nan, "number", 1.0) is None
    assert claims.judge(0.0, "compare", (">", 0.0)) is False
    spec = claims.ClaimSpec(
        "S9", "Fig. 0", "x", "every speed", "compare", ("==", 1.0), lambda _, __: {"median": 0.5}
    )
    [row] = claims.judged([spec], "speed", None, "random", 1)
    assert (row.id, row.study, row.rule, row.verdict) == (
        "S9/random",
        "speed",
        "compare",
        "differs",
    )
    none = claims.ClaimSpec("S9", "Fig. 0", "x", "1.5 m/s", "location", 1.5, lambda _, __: {})
    [row] = claims.judged([none], "speed", None, "pso", 0)
    assert row.verdict == "no data" and math.isnan(row.median)
    # a claim whose data is not run is not made
    assert claims.judged([replace(none, measure=lambda _, __: None)], "speed", None, "pso", 0) == []


def test_figures_in_another_format_and_the_report_shows_them(tmp_path: Path) -> None:
    run_studies(["power"], StudyPlan(TINY, figure_format="pdf"), tmp_path, progress=False)
    figures = sorted(p.name for p in (tmp_path / "power").glob("fig*"))
    assert figures == ["fig7_excess_forces.pdf", "fig8_attainable.pdf"]
    report = (tmp_path / "report.md").read_text(encoding="utf-8")
    # Markdown viewers cannot show a PDF inline: the report links it instead.
    assert "](power/fig8_attainable.pdf)" in report and "![" not in report
    assert "undecided" in report and "flips in more than 20 %" in report


def test_the_study_command_refuses_an_unknown_format(capsys: pytest.CaptureFixture) -> None:
    from eval.__main__ import main

    with pytest.raises(SystemExit):
        main(["study", "power", "--format", "jpg"])
    assert "invalid choice: 'jpg'" in capsys.readouterr().err


def test_convergence_splits_report_what_the_records_report(study_dir: Path) -> None:
    """v3: each polish share at the preset's budgets, judged by the records' feasible objective."""
    rows = _read_csv(study_dir / "convergence" / "convergence_splits.csv")
    spec = SMALL.convergence
    assert {(float(r["polish_share"]), r["condition"].split(",")[0]) for r in rows} == {
        (s, t) for s in spec.polish_shares for t in ("level", "accelerating")
    }
    records = _raw_records(study_dir)
    for row in rows:
        task = "level" if row["condition"].startswith("level") else "accelerate"
        share = float(row["polish_share"])
        setting = dict(convergence.polish_share_settings(SMALL.method, share))
        chosen = sorted(
            (
                r
                for r in records
                if r["task"] == task
                and r["job"]["budget"] == SMALL.budget(task)
                and r["condition"] == (spec.speed if task == "level" else spec.power)
                and r["job"]["env_kwargs"].get("objective", "vertical") == "vertical"
                and r["job"]["env_kwargs"]["planform"] == "tear-drop"
                and {k: v for k, v in r["job"]["method_config"].items() if "polish" in k} == setting
            ),
            key=lambda r: r["seed"],
        )
        assert [r["seed"] for r in chosen] == list(spec.seeds)
        values = [r["objective"] if r["feasible"] else math.nan for r in chosen]
        assert int(row["feasible"]) == sum(r["feasible"] for r in chosen)
        half = len(values) // 2
        first = max((v for v in values[:half] if math.isfinite(v)), default=math.nan)
        second = max((v for v in values[half:] if math.isfinite(v)), default=math.nan)
        if all(math.isfinite(v) for v in (first, second)):
            assert float(row["best_first_half"]) == first
            assert float(row["best_second_half"]) == second
            assert float(row["halves_apart"]) == pytest.approx(
                abs(first - second) / max(first, second)
            )
    assert (study_dir / "convergence" / "convergence_splits.md").read_text().count("\n") == len(
        rows
    ) + 2


def test_cli_study_takes_speeds_powers_seeds_and_budget(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture
) -> None:
    """--speeds/--powers/--seeds/--budget replace the preset's values, checked by its checks
    (one usage error naming the option, before any file), and reach the records and report."""
    from eval.__main__ import main

    monkeypatch.setitem(STUDY_PRESETS, TINY.name, TINY)
    out = tmp_path / "s"
    for option, values, said in (
        ("--speeds", ["3"], "--speeds: Preset.speeds = (3.0,); allowed: a non-empty, increasing"),
        ("--speeds", ["2", "1"], "--speeds: Preset.speeds = (2.0, 1.0)"),
        ("--powers", ["40"], "--powers: Preset.powers = (40.0,)"),
        ("--seeds", ["0", "0"], "--seeds: ConvergenceSpec.seeds = (0, 0); allowed: distinct"),
        ("--budget", ["4"], "--budget: Preset.level_budget = 4; allowed: an integer >= swarm_size"),
    ):
        with pytest.raises(SystemExit) as stop:
            main(["study", "speed", "--preset", "tiny", "--out", str(out), option, *values])
        assert stop.value.code == 2 and said in capsys.readouterr().err
    assert not out.exists()

    argv = ["study", "speed", "--preset", "tiny", "--out", str(out), "--quiet"]
    assert main([*argv, "--speeds", "2", "--seeds", "1", "--budget", "24"]) == 0
    index = json.loads((out / "speed" / "records.json").read_text())
    jobs = [entry["job"] for entry in index]
    assert [(j["condition"], j["seed"], j["budget"], j["preset"]) for j in jobs] == [
        (2.0, 1, 24, "tiny")
    ]
    report = (out / "report.md").read_text()
    assert "changed on the command line: --speeds 2, --seeds 1, --budget 24" in report
    assert "seeds [1]; budgets 24 (level) and 24 (accelerating)" in report
