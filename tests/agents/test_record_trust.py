"""What a store may serve: a reused record is checked against the physics (agents.verify), the
record cache's folder and files must be the user's own and writable by no one else (as ssh
checks its keys), only regular files are read (a named pipe never blocks), ``--rerun``
computes again, and a ``policy:`` job's key holds its trained run's identity.

tests/conftest.py points the cache at a fresh folder of each test (``record_cache``).
"""

from __future__ import annotations

import json
import os
import sys
import threading
import warnings
from pathlib import Path

import gymnasium as gym
import pytest

from agents.jobs import Job
from agents.records import Record, RecordError, RecordWarning
from agents.runner import run_jobs
from agents.store import CACHE_ENV, RecordStore, read_record, read_record_files
from agents.verify import refuted
from eval.__main__ import main

sys.path.insert(0, str(Path(__file__).parent))
from analytic_envs import register_analytic

from tests.runner_calls import count_harness_calls

SMALL = {"env_kwargs": {"n_blade": 6, "n_time": 32}, "method_config": {"swarm_size": 8}}


def _job(seed: int = 0, speed: float = 2.0) -> Job:
    return Job("pso", "level", speed, 16, seed, **SMALL)


def _forge(path: Path, **results: object) -> None:
    """Edit a record file's results and make its checksum again over the edit."""
    record = read_record(path)
    forged = Record(record.job, record.key, {**record.results, **results})
    path.write_text(json.dumps(forged.to_dict()))


@pytest.mark.parametrize("where", ["cache", "out"])
def test_a_forged_record_with_a_good_checksum_is_refused_and_recomputed(
    tmp_path: Path, record_cache: Path, monkeypatch: pytest.MonkeyPatch, where: str
) -> None:
    """The probe's case: a record whose results were edited (efficiency 0.99, feasible, its
    power over the cap) and its checksum made again, served as reused."""
    job = _job()
    run_jobs([job], tmp_path / "a", progress=False)
    good = read_record(tmp_path / "a" / "records" / f"{job.key}.json")
    target = record_cache if where == "cache" else tmp_path / "a"
    entry = RecordStore(target).path(job.key)
    metrics = {**good.metrics, "efficiency": 0.99, "feasible": True, "power_per_mass": 95.0}
    _forge(entry, objective=0.99, feasible=True, metrics=metrics)
    read_record(entry)  # the checksum alone does not tell
    calls = count_harness_calls(monkeypatch)
    out = tmp_path / ("b" if where == "cache" else "a")
    with pytest.warns(RecordWarning, match=rf"{entry}: its results are not what its stroke give"):
        summary = run_jobs([job], out, progress=False)
    assert (summary.ran, summary.cached, calls) == (1, 0, [job])  # never served
    served = summary.records[job.key]
    assert (served.objective, served.feasible, served.metrics) == (
        good.objective,
        good.feasible,
        good.metrics,
    )
    assert read_record(entry).checksum == served.checksum  # the forged file is replaced


def test_records_reused_at_once_are_checked_in_one_model_step(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A warm store's records, at several conditions and seeds, are re-evaluated together (one
    vector env, one step) and pass without a word."""
    jobs = [_job(seed, speed) for seed in (0, 1) for speed in (1.0, 2.0)]
    run_jobs(jobs, tmp_path / "a", progress=False)
    made: list[int] = []
    original = gym.make_vec

    def counting(*args: object, **kwargs: object) -> gym.vector.VectorEnv:
        made.append(int(kwargs["num_envs"]))  # type: ignore[arg-type]
        return original(*args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(gym, "make_vec", counting)
    calls = count_harness_calls(monkeypatch)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RecordWarning)
        summary = run_jobs(jobs, tmp_path / "a", progress=False)
    assert (summary.reused, calls, made) == (4, [], [4])
    # The check itself, on a record whose stroke was edited (its results kept): refuted, naming
    # what differs.
    key = jobs[0].key
    stroke = list(summary.records[key].normalised_stroke)
    stroke[0] = stroke[0] + 0.01 if stroke[0] < 0.99 else stroke[0] - 0.01
    edited = Record(jobs[0], key, {**summary.records[key].results, "normalised_stroke": stroke})
    why = refuted({key: edited}, {key: jobs[0]})
    assert list(why) == [key] and "re-evaluated" in why[key]
    # A stroke that cannot be stepped (outside the action box) is refuted alone, not its batch.
    outside = Record(jobs[0], key, {**edited.results, "normalised_stroke": [5.0] * len(stroke)})
    why = refuted({**summary.records, key: outside}, {j.key: j for j in jobs})
    assert list(why) == [key] and "cannot be re-evaluated" in why[key]


def test_a_plugin_tasks_records_are_checked_as_the_harness_made_them(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A task whose vector env takes one condition for all sub-envs (tests/agents/analytic_envs)
    has its records re-evaluated one by one in its single env, as the harness made them."""
    register_analytic()
    job = Job("random", "sphere", 0.3, 8, 0, method_config={"batch_size": 4})
    run_jobs([job], tmp_path / "a", progress=False)
    calls = count_harness_calls(monkeypatch)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RecordWarning)
        assert run_jobs([job], tmp_path / "a", progress=False).reused == 1 and calls == []
    entry = RecordStore(tmp_path / "a").path(job.key)
    _forge(entry, objective=0.0, reward=0.0)  # the sphere's maximum, claimed
    with pytest.warns(RecordWarning, match=rf"{entry}: its results are not what its stroke"):
        assert run_jobs([job], tmp_path / "a", progress=False).ran == 1 and calls == [job]


def test_a_cache_folder_others_can_write_is_not_used(
    tmp_path: Path, record_cache: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    job = _job()
    run_jobs([job], tmp_path / "a", progress=False)  # into the cache
    calls = count_harness_calls(monkeypatch)
    record_cache.chmod(0o777)  # e.g. TANDEM_CACHE_DIR on a shared folder
    with pytest.warns(
        RecordWarning, match=rf"record cache is not used: {record_cache} is writable"
    ):
        summary = run_jobs([job], tmp_path / "b", progress=False)
    assert (summary.ran, summary.cached, calls) == (1, 0, [job])
    record_cache.chmod(0o755)
    (record_cache / "records").chmod(0o775)  # its records folder too (group-writable)
    with pytest.warns(RecordWarning, match="writable by others"):
        assert run_jobs([job], tmp_path / "c", progress=False).cached == 0


def test_a_cache_entry_others_can_write_is_not_trusted(
    tmp_path: Path, record_cache: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    job = _job()
    run_jobs([job], tmp_path / "a", progress=False)
    entry = RecordStore(record_cache).path(job.key)
    entry.chmod(0o666)
    calls = count_harness_calls(monkeypatch)
    with pytest.warns(RecordWarning, match=rf"{entry} is writable by others.*not trusted"):
        assert run_jobs([job], tmp_path / "b", progress=False).cached == 0
    assert calls == [job] and entry.stat().st_mode & 0o022 == 0  # replaced by one of our own
    # --out is the user's own choice of folder: its files are not judged by their owner
    (tmp_path / "b" / "records" / f"{job.key}.json").chmod(0o666)
    assert run_jobs([job], tmp_path / "b", progress=False).reused == 1


def test_the_cache_it_writes_is_the_users_alone_whatever_the_umask(tmp_path: Path) -> None:
    """A group-writable umask (002, common with a group per user) would make every folder and
    entry the cache writes one it refuses to read."""
    cache = tmp_path / "fresh" / "cache"
    previous = os.umask(0o002)
    try:
        assert run_jobs([_job()], tmp_path / "a", progress=False, cache=cache).ran == 1
    finally:
        os.umask(previous)
    entry = RecordStore(cache).path(_job().key)
    for path in (cache, entry.parent, entry):
        assert path.stat().st_mode & 0o022 == 0, path
    with warnings.catch_warnings():
        warnings.simplefilter("error", RecordWarning)
        assert run_jobs([_job()], tmp_path / "b", progress=False, cache=cache).cached == 1


@pytest.mark.skipif(os.geteuid() != 0, reason="giving a file to another user needs root")
def test_a_cache_folder_or_entry_of_another_user_is_not_trusted(
    tmp_path: Path, record_cache: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    job = _job()
    run_jobs([job], tmp_path / "a", progress=False)
    entry = RecordStore(record_cache).path(job.key)
    os.chown(entry, 12345, -1)
    calls = count_harness_calls(monkeypatch)
    with pytest.warns(RecordWarning, match=rf"{entry} is owned by uid 12345, not by you"):
        assert run_jobs([job], tmp_path / "b", progress=False).cached == 0
    assert calls == [job] and entry.stat().st_uid == os.geteuid()  # replaced by one of ours
    os.chown(record_cache, 12345, -1)
    with pytest.warns(RecordWarning, match=rf"{record_cache} is owned by uid 12345"):
        assert run_jobs([job], tmp_path / "c", progress=False).cached == 0


def _finishes(work, limit: float = 300.0) -> object:
    """``work()``'s result; fails (instead of hanging the suite) if it blocks."""
    result: list[object] = []

    def call() -> None:
        try:
            result.append(work())
        except Exception as error:  # raised in the test's thread below
            result.append(error)

    thread = threading.Thread(target=call, daemon=True)
    thread.start()
    thread.join(limit)
    assert result, "blocked reading a named pipe"
    if isinstance(result[0], Exception):
        raise result[0]
    return result[0]


@pytest.mark.parametrize("where", ["cache", "out"])
def test_a_named_pipe_in_place_of_a_record_never_blocks(
    tmp_path: Path, record_cache: Path, monkeypatch: pytest.MonkeyPatch, where: str
) -> None:
    job = _job()
    store = RecordStore(record_cache if where == "cache" else tmp_path / "b")
    store.path(job.key).parent.mkdir(parents=True)
    os.mkfifo(store.path(job.key))
    calls = count_harness_calls(monkeypatch)
    with pytest.warns(RecordWarning, match=rf"{store.path(job.key)} is not a regular file"):
        _finishes(lambda: run_jobs([job], tmp_path / "b", progress=False))
    assert calls == [job] and store.path(job.key).is_file()  # replaced by the record
    pipe = tmp_path / "c" / "records" / f"{job.key}.json"
    pipe.parent.mkdir(parents=True)
    os.mkfifo(pipe)
    with pytest.raises(RecordError, match="not a regular file"):
        _finishes(lambda: read_record_files([tmp_path / "c"]))


def test_a_cache_folder_that_is_a_file_is_said_in_one_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    afile = tmp_path / "cache-file"
    afile.write_text("")
    monkeypatch.setenv(CACHE_ENV, str(afile))
    argv = ["optimize", "--task", "level", "--speed", "2", "--method", "pso", "--budget", "16",
            "--swarm-size", "8", "--env-kwargs", "n_blade=6", "n_time=32", "--quiet",
            "--seeds", "0", "--out", str(tmp_path / "out")]  # fmt: skip
    assert main(argv) == 0  # computed, without the cache
    err = capsys.readouterr().err
    assert f"RecordWarning: the record cache is not used: {afile} is not a folder" in err
    assert "Traceback" not in err and afile.read_text() == ""


def test_rerun_computes_again_and_says_so(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    calls = count_harness_calls(monkeypatch)
    out = tmp_path / "out"
    argv = ["optimize", "--task", "level", "--speed", "2", "--method", "pso", "--budget", "16",
            "--swarm-size", "8", "--env-kwargs", "n_blade=6", "n_time=32", "--quiet",
            "--seeds", "0", "--out", str(out)]  # fmt: skip
    assert main(argv) == 0 and len(calls) == 1
    capsys.readouterr()
    assert main([*argv, "--no-cache"]) == 0 and len(calls) == 1  # --out holds it: reused
    assert f"0 run, 1 reused from {out} (--rerun runs them again)" in capsys.readouterr().err
    before = read_record_files([out])[0]
    assert main([*argv, "--rerun"]) == 0 and len(calls) == 2
    assert f"1 run again (--rerun: 1 record(s) in {out} replaced)" in capsys.readouterr().err
    after = read_record_files([out])
    assert len(after) == 1 and after[0].key == before.key  # replaced, not added
    assert after[0].normalised_stroke == before.normalised_stroke  # the same search again


def test_a_policy_jobs_key_holds_its_runs_identity(tmp_path: Path) -> None:
    """A newer training run (logs/ppo/<env> names the latest), or a model trained again in
    place, is another job; a job of a method that reads no files keeps its key."""
    base = tmp_path / "logs" / "ppo" / "TandemWing-LevelFlight-v0"
    first = Path(f"{base}_1")
    first.mkdir(parents=True)
    (first / "best_model.zip").write_bytes(b"model one")
    spec = f"policy:{base}"
    old = Job(spec, "level", 1.0, 5, 0)
    assert old.method_identity and old.key != Job(spec, "level", 1.0, 5, 0, method_identity="").key
    (first / "best_model.zip").write_bytes(b"model two")  # trained again in place
    again = Job(spec, "level", 1.0, 5, 0)
    assert again.key != old.key
    Path(f"{base}_2").mkdir()
    (Path(f"{base}_2") / "best_model.zip").write_bytes(b"model two")  # a newer run
    newer = Job(spec, "level", 1.0, 5, 0)
    assert newer.key not in (old.key, again.key)
    # The identity travels with the job's record; another seed of the job keeps it.
    assert Job.from_dict(newer.to_dict()) == newer
    # Every other job's dict, and so its key, is what it was before the identity: the keys of
    # the records already stored stay theirs.
    assert _job().method_identity == "" and "method_identity" not in _job().to_dict()


def test_a_record_scored_against_another_reference_table_is_served(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A record's ``score`` reads its objective against the reference table of its run; a
    regenerated table moves it, and the record is still this stroke's (agents.verify
    .TABLE_RELATIVE): served without running again. Its objective is still checked."""
    job = _job()
    run_jobs([job], tmp_path, progress=False)
    entry = RecordStore(tmp_path).path(job.key)
    good = read_record(entry)
    _forge(entry, metrics={**good.metrics, "score": 12.5})  # another table's reading
    calls = count_harness_calls(monkeypatch)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RecordWarning)
        summary = run_jobs([job], tmp_path, progress=False)
    assert (summary.ran, summary.reused, calls) == (0, 1, [])
    assert summary.records[job.key].metrics["score"] == 12.5  # the record keeps its run's
    _forge(entry, objective=good.objective * 1.01)
    assert job.key in refuted({job.key: read_record(entry)}, {job.key: job})
