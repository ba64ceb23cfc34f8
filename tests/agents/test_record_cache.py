"""The record cache: a store shared by every output folder (agents.store.cache_directory), read
after ``--out`` and written with every record computed, through the store's own checks and
atomic writes; ``cache=False`` / ``--no-cache`` turns it off.

tests/conftest.py points the cache at a fresh folder of each test (``record_cache``).
"""

from __future__ import annotations

import json
import threading
from pathlib import Path

import pytest

from agents.jobs import Job
from agents.progress import CommandProgress, Phase
from agents.record_cache import cacheable
from agents.records import RecordWarning
from agents.runner import run_jobs
from agents.store import CACHE_ENV, RecordStore, cache_directory, read_record
from eval.__main__ import main
from tests.runner_calls import count_harness_calls

SMALL = {"env_kwargs": {"n_blade": 6, "n_time": 32}, "method_config": {"swarm_size": 8}}


def _job(seed: int = 0) -> Job:
    return Job("pso", "level", 2.0, 16, seed, **SMALL)


def _files(out: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted((out / "records").glob("*.json"))}


def test_the_cache_folder_rule(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setenv(CACHE_ENV, str(tmp_path / "mine"))
    assert cache_directory() == tmp_path / "mine"
    monkeypatch.delenv(CACHE_ENV)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache_directory() == tmp_path / "xdg" / "tandem_env"
    monkeypatch.setenv("XDG_CACHE_HOME", "relative/cache")  # not absolute: ignored (XDG spec)
    assert cache_directory() == Path.home() / ".cache" / "tandem_env"
    monkeypatch.delenv("XDG_CACHE_HOME")
    assert cache_directory() == Path.home() / ".cache" / "tandem_env"


def test_a_second_output_folder_copies_from_the_cache_and_computes_nothing(
    tmp_path: Path, record_cache: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    calls = count_harness_calls(monkeypatch)
    jobs = [_job(0), _job(1)]
    first = run_jobs(jobs, tmp_path / "a", progress=False)
    assert (first.ran, first.cached, len(calls)) == (2, 0, 2)
    # every record computed is in the cache too, byte for byte
    assert _files(record_cache) == _files(tmp_path / "a") and len(_files(record_cache)) == 2
    second = run_jobs(jobs, tmp_path / "b", progress=False)
    assert (second.ran, second.reused, second.cached, len(calls)) == (0, 2, 2, 2)
    assert _files(tmp_path / "b") == _files(tmp_path / "a")  # identical records
    assert second.records == first.records
    assert second.describe(tmp_path / "b") == "0 run, 2 reused from the cache"
    # A third run into b finds them in b itself.
    third = run_jobs(jobs, tmp_path / "b", progress=False)
    assert (third.reused, third.cached) == (2, 0)
    assert third.describe(tmp_path / "b") == f"0 run, 2 reused from {tmp_path / 'b'}"


def test_no_cache_neither_reads_nor_writes_it(
    tmp_path: Path, record_cache: Path, monkeypatch: pytest.MonkeyPatch, capsys
) -> None:
    calls = count_harness_calls(monkeypatch)
    run_jobs([_job()], tmp_path / "a", progress=False, cache=False)
    assert not (record_cache / "records").exists()  # not written
    run_jobs([_job()], tmp_path / "b", progress=False)  # computed: the cache was empty
    assert len(calls) == 2 and len(_files(record_cache)) == 1
    run_jobs([_job()], tmp_path / "c", progress=False, cache=None)  # not read
    assert len(calls) == 3
    # The command line: --no-cache computes again where the cache holds the record.
    argv = ["optimize", "--task", "level", "--speed", "2", "--method", "pso", "--budget", "16",
            "--swarm-size", "8", "--env-kwargs", "n_blade=6", "n_time=32", "--quiet",
            "--seeds", "0", "--out"]  # fmt: skip
    assert main([*argv, str(tmp_path / "d"), "--no-cache"]) == 0
    assert len(calls) == 4 and "1 seed: 1 run" in capsys.readouterr().err
    assert main([*argv, str(tmp_path / "e")]) == 0
    assert len(calls) == 4 and "1 seed: 0 run, 1 reused from the cache" in capsys.readouterr().err


def test_a_store_made_without_the_cache_feeds_it(
    tmp_path: Path, record_cache: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    calls = count_harness_calls(monkeypatch)
    run_jobs([_job()], tmp_path / "a", progress=False, cache=False)
    run_jobs([_job()], tmp_path / "a", progress=False)  # reused from a, and added to the cache
    assert _files(record_cache) == _files(tmp_path / "a")
    assert run_jobs([_job()], tmp_path / "b", progress=False).cached == 1 and len(calls) == 1


@pytest.mark.parametrize("damage", ["truncated", "edited", "another job's"])
def test_a_damaged_cache_entry_is_ignored_with_a_warning_and_recomputed(
    tmp_path: Path, record_cache: Path, monkeypatch: pytest.MonkeyPatch, damage: str
) -> None:
    job, other = _job(0), _job(1)
    run_jobs([job, other], tmp_path / "a", progress=False)
    good = read_record(tmp_path / "a" / "records" / f"{job.key}.json")
    entry = RecordStore(record_cache).path(job.key)
    if damage == "truncated":
        entry.write_text(entry.read_text()[:100])
    elif damage == "edited":  # a "better" result, checksum left as it was
        data = json.loads(entry.read_text())
        data["results"]["objective"] = good.objective + 1.0
        entry.write_text(json.dumps(data))
    else:
        entry.write_bytes(RecordStore(record_cache).path(other.key).read_bytes())
    calls = count_harness_calls(monkeypatch)
    with pytest.warns(RecordWarning, match=str(entry)):
        summary = run_jobs([job], tmp_path / "b", progress=False)
    assert (summary.ran, summary.cached, calls) == (1, 0, [job])  # never trusted
    again = read_record(tmp_path / "b" / "records" / f"{job.key}.json")
    assert again.objective == good.objective and again.normalised_stroke == good.normalised_stroke
    assert read_record(entry).checksum == again.checksum  # the entry is replaced


def test_concurrent_writers_of_one_entry_never_leave_a_partial_file(
    tmp_path: Path, record_cache: Path
) -> None:
    """Writers of one key (two commands finishing the same job) race through the store's
    atomic replace: a reader sees the complete record at every moment, and no temporary file
    is left."""
    run_jobs([_job()], tmp_path / "a", progress=False)
    record = read_record(RecordStore(record_cache).path(_job().key))
    cache = RecordStore(record_cache)
    stop = threading.Event()
    seen: list[object] = []

    def write() -> None:
        for _ in range(40):
            cache.save(record)

    def read() -> None:
        while not stop.is_set():
            try:
                seen.append(read_record(cache.path(record.key)).checksum)
            except Exception as error:  # a partial file would fail to parse or to check
                seen.append(error)

    reader = threading.Thread(target=read)
    reader.start()
    writers = [threading.Thread(target=write) for _ in range(4)]
    for thread in writers:
        thread.start()
    for thread in writers:
        thread.join()
    stop.set()
    reader.join()
    assert seen and all(s == record.checksum for s in seen)
    assert [p.name for p in (record_cache / "records").iterdir()] == [f"{record.key}.json"]


def test_a_method_that_reads_a_path_is_never_cached() -> None:
    # policy:RUN_DIR's result depends on the files in RUN_DIR, which the key does not hash.
    assert not cacheable(Job("policy:runs/ppo", "level", 2.0, 16, 0))
    assert cacheable(_job())


def test_a_cache_that_cannot_be_used_is_said(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    afile = tmp_path / "cache-file"
    afile.write_text("")
    monkeypatch.setenv(CACHE_ENV, str(afile))
    # one warning, and the run goes on without the cache (tests/agents/test_record_trust.py)
    with pytest.warns(
        RecordWarning, match=r"record cache is not used: .*cache-file is not a folder"
    ):
        assert run_jobs([_job()], tmp_path / "a", progress=False).ran == 1
    assert afile.read_text() == ""


def test_the_command_progress_counts_the_whole_command(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys
) -> None:
    """The first line: every phase's jobs, what is stored and cached, the evaluations to run and
    "estimating"; a later phase's line: the time left at the rate measured so far."""
    run_jobs([_job(0)], tmp_path / "a", progress=False)  # into the cache
    run_jobs([_job(1)], tmp_path / "b", progress=False)  # stored in b
    first = [_job(0), _job(1)]
    stand_in = Job("pso", "level", 2.0, 4, 2, **SMALL)  # a later phase's job, its key not final
    command = CommandProgress("test command", tmp_path / "b", detail="two phases")
    phases = [Phase("one", tuple(first)), Phase("two", (stand_in, _job(3)),
              frozenset({stand_in.key}), later="more")]  # fmt: skip
    command.announce(phases)
    line = capsys.readouterr().err.splitlines()[0]
    assert line == (
        "test command: two phases; 2 phases (one, two): 4 optimisations over seeds [0, 1, 2, 3], "
        "budgets 4 / 16 model evaluations each (52 in all); 1 stored in "
        f"{tmp_path / 'b'}, 1 in the record cache, 2 to run (20 evaluations); then more; "
        "time left: estimating (from the speed of the first jobs to finish)"
    )
    command.start(phases, phases[:1])  # the first phase: the first line said it
    assert capsys.readouterr().err == ""
    run_jobs(first, tmp_path / "b", progress=False, command=command)
    command.ran(stand_in, 0.5)  # as run_jobs reports a job: 4 evaluations in 0.5 s
    command.start(phases, phases)
    line = capsys.readouterr().err.strip()
    assert line.startswith(
        "phase 2/2 (two) of the test command: 4 optimisations (52 evaluations), 3 done or "
        "stored, 1 to run (16 evaluations); then more; time left: about 2 s (at the 8 "
        "evaluations/s measured so far)"
    )
    quiet = CommandProgress("quiet", tmp_path / "b", enabled=False)
    quiet.announce([Phase("one", tuple(first))])
    assert capsys.readouterr().err == "" and quiet.lines[0].startswith("quiet: 2 optimisations")
