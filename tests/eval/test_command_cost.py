"""What a study command costs, said on its first line, and the record cache across output
folders: ``study readings`` after ``study all`` into another ``--out`` reuses the stored jobs
(the tiny preset, two readings: seconds, not the quick preset's minutes)."""

from __future__ import annotations

from pathlib import Path

import pytest

from agents.runner import look_ahead
from agents.store import RecordStore
from eval.__main__ import main
from eval.studies.base import StudyPlan
from eval.studies.paper_reading import DEFAULT
from eval.studies.presets import STUDY_PRESETS, TINY
from eval.studies.readings import ReadingsPlan, reading_by_name, reading_jobs
from tests.runner_calls import count_harness_calls


def test_readings_after_all_reuses_the_stored_jobs_and_its_first_line_gives_the_cost(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setitem(STUDY_PRESETS, TINY.name, TINY)
    calls = count_harness_calls(monkeypatch)
    plan = StudyPlan(TINY)
    suite = {job.key for job in reading_jobs(plan, DEFAULT)}
    assert main(["study", "all", "--preset", "tiny", "--out", str(tmp_path / "all")]) == 0
    first = capsys.readouterr().err.splitlines()[0]
    assert first.startswith("study all (speed, power, kinematics, wing-shape): preset tiny")
    assert (
        f"{len(suite)} optimisations over seeds [0, 1], budgets 16 model evaluations each "
        f"({16 * len(suite):,} in all); 0 stored in {tmp_path / 'all'}, 0 in the record cache, "
        f"{len(suite)} to run ({16 * len(suite):,} evaluations); time left: estimating"
    ) in first
    assert {job.key for job in calls} == suite

    # The readings study into another folder: its plan finds the default's records (the
    # suite's own jobs) in the cache, so the continued jobs' keys are known before any work.
    readings = (DEFAULT, reading_by_name("convected"))
    store = RecordStore(tmp_path / "readings")
    phases = look_ahead(ReadingsPlan(plan, store, readings), store)
    assert [p.name for p in phases] == ["default", "check", "singles"]
    assert {j.key for j in phases[0].jobs} == suite
    assert not any(p.provisional for p in phases)
    planned = {job.key: job for p in phases for job in p.jobs}
    calls.clear()
    argv = ["study", "readings", "--preset", "tiny", "--reading", "convected"]
    assert main([*argv, "--out", str(tmp_path / "readings")]) == 0
    err = capsys.readouterr().err
    line = err.splitlines()[0]
    to_run = [job for key, job in planned.items() if key not in suite]
    assert line.startswith("readings study (the default in full; 1 single reading continuing")
    assert (
        f"3 phases (default, check, singles): {len(planned)} optimisations over seeds [0, 1]"
    ) in line
    assert (
        f"0 stored in {tmp_path / 'readings'}, {len(suite)} in the record cache, "
        f"{len(to_run)} to run ({sum(j.budget for j in to_run):,} evaluations); then the "
        "combinations the singles' results point to (counted once known); time left: "
        "estimating"
    ) in line
    # nothing of the default reading ran: every job of it came from the cache
    assert not suite & {job.key for job in calls}
    assert f"default: {len(suite)} optimisations: 0 run, {len(suite)} reused from the cache" in err
    # each later phase says the whole command again, with the time left as measured
    assert "phase 2/3 (check) of the readings study: " in err
    assert "phase 3/3 (singles) of the readings study: " in err
    assert "evaluations/s measured so far" in err

    # --quiet says no cost line, and --no-cache runs the study's jobs again.
    calls.clear()
    assert main(["study", "speed", "--preset", "tiny", "--out", str(tmp_path / "again"),
                 "--quiet", "--no-cache"]) == 0  # fmt: skip
    err = capsys.readouterr().err
    assert "time left" not in err and "optimisations:" in err  # the summary line alone
    assert len(calls) == len(TINY.speeds) * len(TINY.seeds)

    # --rerun (every command that runs jobs): the stored jobs run again, their records replaced.
    calls.clear()
    argv = ["study", "speed", "--preset", "tiny", "--out", str(tmp_path / "again"), "--quiet"]
    assert main([*argv, "--rerun"]) == 0
    assert len(calls) == len(TINY.speeds) * len(TINY.seeds)
    assert f"--rerun: {len(calls)} record(s) in {tmp_path / 'again'} replaced" in (
        capsys.readouterr().err
    )
    for command in ("reference", "speed-change"):
        assert "--rerun" in _help(command)


def _help(command: str) -> str:
    import contextlib
    import io

    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.suppress(SystemExit):
        main([command, "--help"])
    return out.getvalue()
