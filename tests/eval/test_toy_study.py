"""docs/architecture.md, "Where to add a study": one module plus one registry line in
eval/studies/__init__.py, and ``python -m eval study <name>`` runs it. The toy study
(tests/eval/toy_study.py) is that module; the line is added here with ``monkeypatch``."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest
import toy_study  # tests/eval/toy_study.py (pytest puts the test folder on the path)

from eval.__main__ import main
from eval.studies import STUDIES
from eval.studies import speed as speed_study
from eval.studies.base import StudyPlan
from eval.studies.presets import STUDY_PRESETS, TINY


def test_a_study_in_one_file_runs_through_the_command_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setitem(STUDIES, toy_study.NAME, toy_study)  # the one registry line
    monkeypatch.setitem(STUDY_PRESETS, TINY.name, TINY)
    argv = ["study", "toy", "--preset", "tiny", "--out", str(tmp_path), "--quiet"]
    assert main(argv) == 0
    out = capsys.readouterr().out
    n_jobs = len(toy_study.SPEEDS) * len(TINY.seeds)
    plan = StudyPlan(TINY)
    assert f"toy: {n_jobs} records, 0 figures" in out

    with (tmp_path / "toy" / "toy.csv").open() as stream:
        rows = list(csv.DictReader(stream))
    assert len(rows) == n_jobs and {float(r["condition"]) for r in rows} == set(toy_study.SPEEDS)
    # The study's own table is computed from the records the runner stored.
    records = [json.loads(p.read_text()) for p in (tmp_path / "records").glob("*.json")]
    assert len(records) == n_jobs
    with (tmp_path / "toy" / "best.csv").open() as stream:
        best = {float(r["speed"]): float(r["best_objective"]) for r in csv.DictReader(stream)}
    for speed in toy_study.SPEEDS:
        values = [float(r["objective_value"]) for r in rows if float(r["condition"]) == speed]
        assert best[speed] == max(values)
    # The toy's jobs are the tiny preset's speed sweep, key for key: a job shared between
    # studies runs once, and the speed study, whose records are now all there, is reported.
    assert {j.key for j in toy_study.jobs(plan)} == {j.key for j in speed_study.jobs(plan)}
    assert (tmp_path / "speed" / "speed.csv").is_file() and (tmp_path / "report.md").is_file()


def test_an_unregistered_study_is_refused_by_name(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_:
        main(["study", "toy", "--quiet"])
    assert exit_.value.code == 2
    assert "invalid choice: 'toy'" in capsys.readouterr().err
