"""One keyed, atomic record store for `optimize` and the studies, written by the runner alone; the
serial runner's resume, failures and progress; records that are not valid (corrupt, edited,
of an earlier format) are recomputed, never mixed in."""

from __future__ import annotations

import errno
import hashlib
import json
import math
import os
import re
import stat
import warnings
from pathlib import Path

import pytest

from agents import harness, runner
from agents.harness import PreparedJob
from agents.jobs import OLD_SCHEMAS, SCHEMA, Job
from agents.records import Record, RecordError, RecordWarning
from agents.runner import JobsFailed, run_jobs
from agents.store import RecordStore, read_record, read_record_files
from eval.__main__ import main
from eval.studies.base import StudyPlan
from eval.studies.presets import STUDY_PRESETS, TINY
from tests.runner_calls import count_harness_calls

SMALL = {"env_kwargs": {"n_blade": 6, "n_time": 32}, "method_config": {"swarm_size": 8}}


def _job(budget: int = 16, seed: int = 0, **changes) -> Job:
    fields = {
        "method": "pso",
        "task": "level",
        "condition": 2.0,
        "budget": budget,
        "seed": seed,
        **SMALL,
        **changes,
    }
    return Job(**fields)


def test_job_key_is_the_configuration() -> None:
    job = _job()
    same = Job("pso", "level", 2, 16, 0, env_kwargs=[("n_time", 32), ("n_blade", 6)],
               method_config={"swarm_size": 8})  # fmt: skip
    assert same == job and same.key == job.key  # order and int/float do not matter
    others = [_job(budget=32), _job(seed=1), _job(preset="tiny"), _job(method="random"),
              _job(env_kwargs={**SMALL["env_kwargs"], "thrust_split": "body"})]  # fmt: skip
    assert len({j.key for j in [job, *others]}) == 1 + len(others)
    assert Job(**job.to_dict()) == job  # what a record stores is enough to rebuild the job
    assert Job.from_dict(job.to_dict()) == job


def _run_prepared(out: Path, budget: int) -> Record:
    # What `eval optimize` does: prepare (validate once), run through the runner, read back.
    (prepared,) = harness.prepare("pso", "level", 2.0, budget, [0], **SMALL)
    run_jobs([prepared], out, progress=False)
    record = RecordStore(out).load(prepared.job)
    assert record is not None
    return record


def test_prepared_and_plain_jobs_share_one_store(tmp_path: Path, monkeypatch) -> None:
    first = _run_prepared(tmp_path, 16)
    calls = count_harness_calls(monkeypatch)
    assert first.key == _job().key and first.job == _job()
    assert (tmp_path / "records" / f"{first.key}.json").is_file()
    # The runner finds the prepared job's record by its configuration and does not run it again.
    summary = run_jobs([_job()], tmp_path, progress=False)
    assert (summary.ran, summary.reused, calls) == (0, 1, [])
    # Another budget is another record, beside the first (the old file names lost one).
    second = _run_prepared(tmp_path, 24)
    assert second.key != first.key
    assert sorted(r.budget for r in read_record_files([tmp_path])) == [16, 24]
    RecordStore(tmp_path).write_summary()
    rows = (tmp_path / "summary.csv").read_text().splitlines()
    assert len(rows) == 3 and rows[0].endswith(",key")


def test_corrupt_record_is_reported_and_recomputed(tmp_path: Path, monkeypatch) -> None:
    # The store's own check (cache=False: the record cache would restore the record instead,
    # tests/agents/test_record_cache.py).
    job = _job()
    run_jobs([job], tmp_path, progress=False)
    path = RecordStore(tmp_path).path(job.key)
    good = read_record(path)
    path.write_text('{"schema": "tandem_env.harness-rec')  # a half-written file, by hand
    calls = count_harness_calls(monkeypatch)
    with pytest.warns(RecordWarning, match=f"{path}: corrupt record .* runs again"):
        summary = run_jobs([job], tmp_path, progress=False, cache=False)
    assert summary.ran == 1 and calls == [job]
    again = read_record(path)
    assert again.normalised_stroke == good.normalised_stroke


def test_record_of_another_configuration_is_not_replaced_silently(tmp_path: Path) -> None:
    a, b = _job(seed=0), _job(seed=1)
    run_jobs([a], tmp_path, progress=False)
    store = RecordStore(tmp_path)
    store.path(b.key).write_bytes(store.path(a.key).read_bytes())  # a's record under b's key
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        run_jobs([b], tmp_path, progress=False)
    messages = [str(w.message) for w in caught if issubclass(w.category, RecordWarning)]
    # found on loading, and said there: the store's one writer never reads a file back
    assert any("not pso level V=2 seed 1" in m for m in messages)
    assert any("replaces the file" in m and "seed 0" in m for m in messages)
    assert store.load(b).seed == 1 and store.load(a).seed == 0


def test_out_that_is_a_file_is_rejected(tmp_path: Path, capsys) -> None:
    target = tmp_path / "results.json"
    target.write_text("{}")
    for command in (
        ["optimize", "--task", "level", "--speed", "2", "--method", "pso", "--budget", "8",
         "--seeds", "0", "--out", str(target)],
        ["study", "speed", "--out", str(target)],
    ):  # fmt: skip
        with pytest.raises(SystemExit) as info:
            main(command)
        assert info.value.code == 2
        assert f"{target} is a file; allowed: a directory" in capsys.readouterr().err
    assert target.read_text() == "{}"
    with pytest.raises(ValueError, match="is a file"):
        run_jobs([_job(budget=8)], target, progress=False)


def test_optimize_resumes_and_adds_seeds(tmp_path: Path, monkeypatch, capsys) -> None:
    calls = count_harness_calls(monkeypatch)
    argv = ["optimize", "--task", "level", "--speed", "2", "--method", "pso", "--budget", "16",
            "--swarm-size", "8", "--out", str(tmp_path), "--env-kwargs", "n_blade=6", "n_time=32",
            "--quiet", "--seeds"]  # fmt: skip
    assert main([*argv, "0", "1"]) == 0
    assert [j.seed for j in calls] == [0, 1]
    assert main([*argv, "0", "1", "2"]) == 0  # a killed run, or more seeds: only the new one
    assert [j.seed for j in calls] == [0, 1, 2]
    out = capsys.readouterr()
    assert "3 seeds: 1 run, 2 reused" in out.err
    assert out.out.count("pso seed 2:") == 1 and out.out.count("pso seed 0:") == 2


def test_failing_job_is_reported_by_key_and_the_others_finish(
    tmp_path: Path, monkeypatch, capsys
) -> None:
    jobs = StudyPlan(TINY).jobs("level", TINY.speeds)
    victim = jobs[1]
    original = runner._harness_run

    def sometimes_failing(prepared: PreparedJob) -> Record:
        if prepared.job == victim:
            raise RuntimeError("induction diverged (test)")
        return original(prepared)

    monkeypatch.setattr(runner, "_harness_run", sometimes_failing)
    with pytest.raises(JobsFailed) as info:
        run_jobs(jobs, tmp_path, progress=False)
    assert [f.key for f in info.value.summary.failures] == [victim.key]
    assert "RuntimeError: induction diverged (test)" in str(info.value)
    assert "Traceback (most recent call last)" in str(info.value)
    stored = {p.stem for p in (tmp_path / "records").glob("*.json")}
    assert stored == {j.key for j in jobs} - {victim.key}
    # The command line says the same and exits with status 1.
    monkeypatch.setitem(STUDY_PRESETS, TINY.name, TINY)
    code = main(["study", "speed", "--preset", "tiny", "--out", str(tmp_path), "--quiet"])
    assert code == 1
    err = capsys.readouterr().err
    assert f"key {victim.key}" in err and "induction diverged" in err
    assert not (tmp_path / "report.md").exists()


def test_one_progress_bar_over_the_jobs(tmp_path: Path, capsys) -> None:
    run_jobs([_job(seed=0), _job(seed=1)], tmp_path, progress=True)
    err = capsys.readouterr().err
    assert "2 optimisations" in err and "2/2 jobs" in err and "32.0/32.0" in err


def test_older_records_are_recomputed_never_mixed_in(tmp_path: Path, monkeypatch) -> None:
    job = _job()
    run_jobs([job], tmp_path, progress=False)
    path = RecordStore(tmp_path).path(job.key)
    good = read_record(path)
    # The previous format held the configuration three times and no checksum.
    old = {"schema": OLD_SCHEMAS[-1], "key": job.key, "job": job.to_dict(), **good.results}
    old.update(method="pso", task="level", seed=0, budget=16, config={})
    path.write_text(json.dumps(old))
    with pytest.warns(RecordWarning, match="left out"):
        assert read_record_files([tmp_path]) == []
    with pytest.raises(RecordError, match=r"earlier format .* rerun the command"):
        read_record(path)
    calls = count_harness_calls(monkeypatch)
    with pytest.warns(RecordWarning, match=f"{path}: a record of the earlier format .* recomputed"):
        summary = run_jobs([job], tmp_path, progress=False, cache=False)
    assert summary.ran == 1 and calls == [job]
    assert read_record(path).schema == SCHEMA
    # Where it really lies, under the key the earlier format hashed: no job finds it, and the
    # runner says once that the store holds it.
    path.with_name("0123456789abcdef0123.json").write_text(json.dumps(old))
    path.unlink()
    with pytest.warns(RecordWarning, match=r"1 record file\(s\) of an earlier format .* not used"):
        run_jobs([job], tmp_path, progress=False, cache=False)


def test_a_job_is_validated_once_on_the_optimize_path(tmp_path: Path, monkeypatch) -> None:
    """`optimize` prepares its seeds' jobs; the runner and run_job do not validate them again."""
    checked: list[Job] = []
    original = harness.prepare_job

    def counting(job: Job, **kwargs: object) -> PreparedJob:
        checked.append(job)
        return original(job, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(harness, "prepare_job", counting)
    monkeypatch.setattr(runner, "prepare_job", counting)
    argv = ["optimize", "--task", "level", "--speed", "2", "--method", "pso", "--budget", "16",
            "--swarm-size", "8", "--out", str(tmp_path), "--env-kwargs", "n_blade=6", "n_time=32",
            "--quiet", "--seeds", "0", "1"]  # fmt: skip
    assert main(argv) == 0
    assert len(checked) == 1  # one configuration, two seeds: validated once
    # A study's plain jobs are validated by the runner, once each, before any runs.
    checked.clear()
    run_jobs([_job(seed=5), _job(seed=6)], tmp_path, progress=False)
    assert [j.seed for j in checked] == [5, 6]


def test_a_record_edited_by_hand_is_detected_and_recomputed(tmp_path: Path, monkeypatch) -> None:
    job = _job()
    run_jobs([job], tmp_path, progress=False)
    path = RecordStore(tmp_path).path(job.key)
    good = read_record(path)
    data = json.loads(path.read_text())
    assert data["checksum"] == good.checksum and len(data["checksum"]) == 64
    data["results"]["objective"] = good.objective + 0.1  # a "better" result, by hand
    path.write_text(json.dumps(data))
    with pytest.raises(RecordError, match=r"checksum .* edited by hand or damaged"):
        read_record(path)
    with pytest.warns(RecordWarning, match="checksum .* left out"):
        assert read_record_files([tmp_path]) == []  # compare does not report it
    calls = count_harness_calls(monkeypatch)
    with pytest.warns(RecordWarning, match=f"{path}: corrupt record .*checksum.* runs again"):
        summary = run_jobs([job], tmp_path, progress=False, cache=False)
    assert summary.ran == 1 and calls == [job]
    again = read_record(path)  # recomputed: the computed result, not the edited one
    assert again.objective == good.objective and again.normalised_stroke == good.normalised_stroke
    # Editing the job inside the file is caught the same way.
    data = json.loads(path.read_text())
    data["job"]["seed"] = 5
    path.write_text(json.dumps(data))
    with pytest.raises(RecordError, match="checksum"):
        read_record(path)


@pytest.mark.parametrize(
    ("data", "message"),
    [
        ("abc", r"record data is str 'abc'; allowed: a JSON object with schema"),
        ([1, 2], r"record data is list \[1, 2\]; allowed: a JSON object"),
        ({}, r"not a harness record \(schema None"),
        ({"schema": SCHEMA}, r"record fields \['schema'\]; allowed: exactly"),
        (
            {"schema": SCHEMA, "key": "k", "checksum": "c", "job": "x", "results": {}},
            "job = 'x'; allowed: a JSON object",
        ),
        (
            {
                "schema": SCHEMA,
                "key": "k",
                "checksum": "c",
                "job": {"method": "pso"},
                "results": {},
            },
            "malformed job",
        ),
        (
            {"schema": SCHEMA, "key": "k", "checksum": "c", "job": _job().to_dict(), "results": {}},
            "record results are missing",
        ),
    ],
)
def test_bad_record_data_gives_a_clear_error(data: object, message: str) -> None:
    with pytest.raises(RecordError, match=message):
        Record.from_dict(data)  # type: ignore[arg-type]


def test_truncated_or_binary_record_files_give_a_clear_error(tmp_path: Path) -> None:
    job = _job()
    run_jobs([job], tmp_path, progress=False)
    path = RecordStore(tmp_path).path(job.key)
    text = path.read_text()
    for name, content in (
        ("truncated", text[: len(text) // 2].encode()),
        ("binary", b"\xff\xfe\x00"),
    ):
        bad = tmp_path / f"{name}.json"
        bad.write_bytes(content)
        with pytest.raises(RecordError, match=f"{bad}: not a record file, cannot read JSON"):
            read_record(bad)


def test_a_record_file_nested_too_deeply_is_left_out_not_a_crash(tmp_path: Path) -> None:
    """``[[[...]]]`` 10⁵ deep made the JSON decoder raise RecursionError: the record reader crashed
    and RecordStore.records() with it, so one such file hid every good record beside it."""
    job = _job()
    run_jobs([job], tmp_path, progress=False)
    deep = tmp_path / "records" / "deep.json"
    deep.write_bytes(b"[" * 100_000 + b"]" * 100_000)
    with pytest.raises(RecordError, match=f"{deep}: not a record file, .*nested too deeply"):
        read_record(deep)
    with pytest.warns(RecordWarning, match="nested too deeply"):
        records = RecordStore(tmp_path).records()
    assert [r.key for r in records] == [job.key]
    with pytest.raises(RecordError, match=f"{deep}: not a record file, .*nested too deeply"):
        read_record_files([tmp_path])


# --- store contents against names ----------------------------------------------------------------
def _reseal(path: Path, edit) -> None:
    """Edit a record file and make its checksum again, as a careful hand would."""
    data = json.loads(path.read_text())
    edit(data)
    payload = {k: data[k] for k in ("schema", "key", "job", "results")}  # as docs/harness.md
    text = json.dumps(payload, sort_keys=True, separators=(",", ":"))
    data["checksum"] = hashlib.sha256(text.encode()).hexdigest()
    path.write_text(json.dumps(data))


def test_a_resealed_record_moved_to_another_key_is_not_counted(tmp_path: Path) -> None:
    a, b = _job(seed=0), _job(seed=1)
    run_jobs([a], tmp_path, progress=False)
    store = RecordStore(tmp_path)
    moved = store.path(b.key)
    moved.write_bytes(store.path(a.key).read_bytes())
    # the job says seed 1, the key is still seed 0's: the key is not the hash of the job
    _reseal(moved, lambda d: d["job"].update(seed=1))
    with pytest.raises(RecordError, match=r"key .* is not the hash of the job it holds"):
        read_record(moved)
    with pytest.warns(RecordWarning, match="not the hash of the job it holds.*left out"):
        assert [r.seed for r in read_record_files([tmp_path])] == [0]
    # the key says seed 1 too, the job still seed 0: same check, from the other side
    moved.write_bytes(store.path(a.key).read_bytes())
    _reseal(moved, lambda d: d.update(key=b.key))
    with pytest.warns(RecordWarning, match="not the hash of the job it holds.*left out"):
        assert [r.seed for r in read_record_files([tmp_path])] == [0]
    # a copy, unchanged, under another key's name: compare and the summary leave it out
    moved.write_bytes(store.path(a.key).read_bytes())
    with pytest.warns(RecordWarning, match=f"{moved}: holds the record of key {a.key}.*left out"):
        assert [r.seed for r in read_record_files([tmp_path])] == [0]
    with pytest.warns(RecordWarning, match="moved or copied by hand"):
        assert [r.seed for r in store.records()] == [0]


def test_a_resealed_record_with_a_nan_objective_is_recomputed(tmp_path: Path, monkeypatch) -> None:
    job = _job()
    run_jobs([job], tmp_path, progress=False)
    path = RecordStore(tmp_path).path(job.key)
    _reseal(path, lambda d: d["results"].update(objective=float("nan")))
    with pytest.raises(RecordError, match=r"objective = nan; allowed: a number \(not NaN"):
        read_record(path)
    calls = count_harness_calls(monkeypatch)
    with pytest.warns(RecordWarning, match="corrupt record .*objective = nan"):
        run_jobs([job], tmp_path, progress=False, cache=False)
    assert calls == [job] and math.isfinite(read_record(path).objective)


# --- file-system faults ----------------------------------------------------------------------------
OPTIMIZE = ["optimize", "--task", "level", "--speed", "2", "--method", "pso", "--budget", "16",
            "--swarm-size", "8", "--env-kwargs", "n_blade=6", "n_time=32", "--quiet", "--seeds",
            "0"]  # fmt: skip


def _refused(argv: list[str], capsys) -> str:
    with pytest.raises(SystemExit) as info:
        main(argv)
    err = capsys.readouterr().err
    assert info.value.code == 2 and "Traceback" not in err
    return err.strip().splitlines()[-1]


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda out: (out / "records").symlink_to(out / "gone"), r"records is a dangling symlink"),
        (lambda out: (out / "records").symlink_to(out / "records"), r"records is a symlink loop"),
        (lambda out: (out / "summary.csv").mkdir(), r"summary.csv is a directory"),
        (lambda out: (out / "records").write_text(""), r"records is a file"),
    ],
)
def test_every_path_the_store_writes_is_checked_up_front(
    tmp_path: Path, capsys, make, match: str
) -> None:
    out = tmp_path / "out"
    out.mkdir()
    make(out)
    assert re.search(match, _refused([*OPTIMIZE, "--out", str(out)], capsys))
    assert not list(out.glob("records/*.json"))  # before any work


def test_a_record_path_that_is_a_directory_is_refused_up_front(tmp_path: Path, capsys) -> None:
    (tmp_path / "records" / _job().key).with_suffix(".json").mkdir(parents=True)
    line = _refused([*OPTIMIZE, "--out", str(tmp_path)], capsys)
    assert f"{_job().key}.json is a directory" in line


@pytest.mark.parametrize("target", ["loop", "dangling", ""])
def test_out_that_is_a_bad_symlink_or_empty_is_refused(tmp_path: Path, capsys, target) -> None:
    out = tmp_path / "out"
    if target == "loop":
        out.symlink_to(out)
    elif target == "dangling":
        out.symlink_to(tmp_path / "nowhere")
    line = _refused([*OPTIMIZE, "--out", str(out) if target else ""], capsys)
    want = {"loop": "is a symlink loop", "dangling": "is a dangling symlink", "": "an empty path"}
    assert want[target] in line
    assert not (Path.cwd() / "summary.csv").exists() or target  # '' wrote nothing here


def test_a_full_disk_during_the_run_keeps_the_store_and_resumes(
    tmp_path: Path, monkeypatch, capsys
) -> None:
    from agents import store as store_module
    from tandem_env.io import files

    a, b = _job(seed=0), _job(seed=1)
    run_jobs([a], tmp_path, progress=False)
    before = {p.name: p.read_bytes() for p in (tmp_path / "records").iterdir()}

    def full(path, obj, **kwargs):  # the project's own writer, as on a full disk
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(store_module, "write_json_atomic", full)
    argv = [*OPTIMIZE[:-1], "0", "1", "--out", str(tmp_path)]
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert "No space left on device" in err and "run the same command again" in err
    after = {p.name: p.read_bytes() for p in (tmp_path / "records").iterdir()}
    assert after == before  # as it was: no partial file, no temporary left
    monkeypatch.setattr(store_module, "write_json_atomic", files.write_json_atomic)
    assert main(argv) == 0  # fixed: the same command resumes
    assert RecordStore(tmp_path).load(b) is not None


def test_rewritten_files_get_a_readable_mode_under_the_umask(tmp_path: Path) -> None:
    from tandem_env.io.files import new_file_mode, write_json_atomic

    path = tmp_path / "r.json"
    previous = os.umask(0o077)
    try:
        assert new_file_mode() == 0o600
        write_json_atomic(path, {})
        assert stat.S_IMODE(path.stat().st_mode) == 0o600  # the umask, not a fixed 0644
        path.chmod(0o000)  # unreadable: a rewrite must not inherit that
        write_json_atomic(path, {})
        assert stat.S_IMODE(path.stat().st_mode) == 0o600
    finally:
        os.umask(previous)
    write_json_atomic(path, {})
    assert stat.S_IMODE(path.stat().st_mode) == 0o600  # a readable mode is kept


def test_the_runner_hands_back_each_record_read_at_most_once(tmp_path: Path, monkeypatch) -> None:
    """A job's record comes back from run_jobs as saved (a reused one as checked, once), and
    the store's summary reads only the files it was not handed; rerun replaces a record."""
    from agents import store as store_module

    reads: list[str] = []
    original_read = store_module.read_record

    def counting_read(path, **options):
        reads.append(Path(path).stem)
        return original_read(path, **options)

    monkeypatch.setattr(store_module, "read_record", counting_read)
    calls = count_harness_calls(monkeypatch)
    a, b = _job(seed=0), _job(seed=1)
    first = run_jobs([a], tmp_path, progress=False)
    assert reads == [] and calls == [a]  # run now: saved, handed back, not read back
    assert first.records[a.key] == RecordStore(tmp_path).load(a)
    reads.clear()
    second = run_jobs([a, b], tmp_path, progress=False)
    assert (second.reused, second.ran) == (1, 1) and calls == [a, b]
    assert reads == [a.key]  # the reused record, checked once; b's is not read back
    assert second.records[a.key] == first.records[a.key] and set(second.records) == {a.key, b.key}
    reads.clear()
    RecordStore(tmp_path).write_summary(second.records)
    assert reads == []  # every file of the store was handed over
    RecordStore(tmp_path).write_summary({a.key: second.records[a.key]})
    assert reads == [b.key]
    reads.clear()
    again = run_jobs([a], tmp_path, progress=False, rerun=True)
    assert (again.reused, again.ran) == (0, 1) and calls == [a, b, a] and reads == []
    assert RecordStore(tmp_path).load(a) == again.records[a.key]  # the file is the new record


def test_an_out_that_cannot_be_written_is_used_only_if_it_holds_every_seed(
    tmp_path: Path, monkeypatch, capsys
) -> None:
    # The runner decides, once it has read the stored records: a folder that cannot be written
    # (here: said so by the store's check, as a read-only folder is, whoever runs the test) is
    # refused if a seed has no record there, and used as it is if every seed has one.
    assert main([*OPTIMIZE, "--out", str(tmp_path)]) == 0
    summary = (tmp_path / "summary.csv").read_bytes()
    capsys.readouterr()

    def read_only(store, option="--out", *, write=True, jobs=()):
        if write:
            raise ValueError(f"{option} {store.directory}: cannot write into it")
        return False

    monkeypatch.setattr(RecordStore, "check", read_only)
    ran = []
    monkeypatch.setattr(runner, "_harness_run", lambda job: ran.append(job))
    assert main([*OPTIMIZE, "--out", str(tmp_path)]) == 0
    captured = capsys.readouterr()
    assert "pso seed 0" in captured.out and "summary.csv is left as it is" in captured.err
    assert (tmp_path / "summary.csv").read_bytes() == summary and ran == []
    line = _refused([*OPTIMIZE[:-1], "1", "--out", str(tmp_path)], capsys)
    assert f"--out {tmp_path}: cannot write into it" in line and ran == []
    assert sorted(p.name for p in (tmp_path / "records").iterdir()) == [_job().key + ".json"]
