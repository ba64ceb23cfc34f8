"""The runner on Dask: a real scheduler and workers (the `dask` command), a worker killed mid-run,
a failing job, the scheduler argument, and `local:N`.

Every process listens on 127.0.0.1 only, every wait is bounded, and the processes are killed
at the end of the module whatever happened.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass, replace
from pathlib import Path

import pytest

from agents import dask_cluster
from agents.dask_cluster import parse_scheduler
from agents.jobs import Job
from agents.runner import JobsFailed, run_jobs
from eval.studies.base import StudyPlan
from eval.studies.presets import STUDY_PRESETS, TINY
from eval.studies.suite import run_studies

distributed = pytest.importorskip("distributed")

ROOT = Path(__file__).resolve().parents[2]
# Jobs of ~0.5 s (1 600 evaluations at the tiny resolution), so a worker can be killed while
# it holds one; 2 speeds x 3 seeds = 6 jobs.
PRESET = replace(TINY, level_budget=1600, seeds=(0, 1, 2))
STARTUP = 120.0  # [s] bound on a process becoming ready (imports on a loaded machine)
RUN = 300.0  # [s] bound on one study run


def _dask() -> str:
    found = shutil.which("dask", path=os.path.dirname(sys.executable)) or shutil.which("dask")
    if found is None:
        pytest.skip("the `dask` command is not installed")
    return found


@dataclass
class Cluster:
    address: str
    scheduler: subprocess.Popen
    workers: dict[str, subprocess.Popen]
    logs: Path

    def tails(self) -> str:
        return "\n".join(
            f"--- {p.name}\n{p.read_text(errors='replace')[-3000:]}"
            for p in self.logs.glob("*.log")
        )


def _start(args: list[str], log: Path) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    env.pop("NUMBA_NUM_THREADS", None)  # the jobs choose one numba thread themselves
    with open(log, "w") as stream:
        return subprocess.Popen(
            args,
            stdout=stream,
            stderr=subprocess.STDOUT,
            env=env,
            cwd=log.parent,
            start_new_session=True,  # so teardown can kill the whole group
        )


def _wait(condition, timeout: float, what: str, cluster: Cluster | None = None) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            raise TimeoutError(f"{what} within {timeout:g} s\n{cluster.tails() if cluster else ''}")
        time.sleep(0.05)


@pytest.fixture(scope="module")
def cluster(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Cluster]:
    """`dask scheduler` and two `dask worker` processes (one thread each, no nanny)."""
    dask = _dask()
    logs = tmp_path_factory.mktemp("dask")
    scheduler_file = logs / "scheduler.json"
    processes: list[subprocess.Popen] = []
    try:
        scheduler = _start(
            [dask, "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
             "--scheduler-file", str(scheduler_file), "--idle-timeout", "600"],
            logs / "scheduler.log",
        )  # fmt: skip
        processes.append(scheduler)
        box = Cluster("", scheduler, {}, logs)
        _wait(scheduler_file.exists, STARTUP, "no scheduler file", box)
        _wait(lambda: "address" in scheduler_file.read_text(), STARTUP, "empty file", box)
        box.address = json.loads(scheduler_file.read_text())["address"]
        assert box.address.startswith("tcp://127.0.0.1:")
        for name in ("w1", "w2"):
            worker = _start(
                [dask, "worker", box.address, "--nthreads", "1", "--nworkers", "1", "--no-nanny",
                 "--name", name, "--host", "127.0.0.1", "--no-dashboard",
                 "--local-directory", str(logs / name), "--death-timeout", "60"],
                logs / f"{name}.log",
            )  # fmt: skip
            processes.append(worker)
            box.workers[name] = worker
        with distributed.Client(box.address, timeout=STARTUP) as client:
            client.wait_for_workers(2, timeout=STARTUP)
        yield box
    finally:
        for process in processes:
            if process.poll() is None:
                os.killpg(process.pid, signal.SIGKILL)
            process.wait(timeout=30)


def _csv_without_timings(path: Path) -> list[list[str]]:
    rows = [line.split(",") for line in path.read_text().splitlines()]
    drop = rows[0].index("wall_time_s")
    return [[c for i, c in enumerate(row) if i != drop] for row in rows]


def test_killed_worker_gives_the_serial_report(
    cluster: Cluster, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    plan = StudyPlan(PRESET)
    run_studies(["speed"], plan, tmp_path / "serial", progress=False)
    capsys.readouterr()

    out = tmp_path / "dask"
    done: dict[str, object] = {}

    def client_run() -> None:
        try:
            # computed again on Dask, not copied from the record cache the serial run filled
            done["result"] = run_studies(
                ["speed"], plan, out, scheduler=cluster.address, cache=False
            )
        except BaseException as error:  # reported by the main thread
            done["error"] = error

    thread = threading.Thread(target=client_run, daemon=True)
    thread.start()
    with distributed.Client(cluster.address, timeout=STARTUP) as watcher:
        names = {a: w["name"] for a, w in watcher.scheduler_info()["workers"].items()}
        victim = next(a for a, n in names.items() if n == "w1")
        held: list[str] = []

        def victim_holds_a_job_after_some_finished() -> bool:
            held[:] = [str(k) for k in watcher.processing().get(victim, ())]
            finished = list((out / "records").glob("*.json")) if (out / "records").exists() else []
            return bool(held) and bool(finished) and thread.is_alive()

        _wait(victim_holds_a_job_after_some_finished, RUN, "w1 never held a job mid-run", cluster)
        os.kill(cluster.workers["w1"].pid, signal.SIGKILL)
        cluster.workers["w1"].wait(timeout=30)
    thread.join(RUN)
    assert not thread.is_alive(), f"the run did not finish\n{cluster.tails()}"
    assert "error" not in done, done.get("error")

    result = done["result"]
    assert result.run.ran == len(PRESET.speeds) * len(PRESET.seeds)
    assert result.run.executor == cluster.address
    # The jobs w1 held when it died were rerun (on w2) and stored.
    assert all(k.startswith("harness-") for k in held)
    for key in held:
        assert (out / "records" / f"{key.removeprefix('harness-')}.json").exists()
    # Byte-identical report, the same table (wall times aside).
    assert (out / "report.md").read_bytes() == (tmp_path / "serial" / "report.md").read_bytes()
    assert _csv_without_timings(out / "speed" / "speed.csv") == _csv_without_timings(
        tmp_path / "serial" / "speed" / "speed.csv"
    )
    # One progress bar, fed by the finished jobs.
    err = capsys.readouterr().err
    assert "6 optimisations" in err and "6/6 jobs" in err


def test_failing_job_is_reported_and_the_others_finish(cluster: Cluster, tmp_path: Path) -> None:
    good = StudyPlan(TINY).jobs("level", [2.0])
    bad = replace(good[0], method="no-such-method")
    with pytest.raises(JobsFailed) as info:
        run_jobs([bad, *good], tmp_path, scheduler=cluster.address, progress=False)
    (failure,) = info.value.summary.failures
    assert failure.key == bad.key and "no-such-method" in failure.error
    assert "Traceback" in failure.traceback and "agents/harness.py" in failure.traceback
    assert bad.key in str(info.value) and failure.traceback.rstrip() in str(info.value)
    assert sorted(p.stem for p in (tmp_path / "records").glob("*.json")) == sorted(
        j.key for j in good
    )


def test_unreachable_scheduler_fails_fast_naming_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from eval.__main__ import main

    monkeypatch.setitem(STUDY_PRESETS, TINY.name, TINY)
    argv = ["study", "speed", "--preset", "tiny", "--out", str(tmp_path), "--quiet"]
    start = time.monotonic()
    assert main([*argv, "--scheduler", "tcp://127.0.0.1:1"]) == 1
    seconds = time.monotonic() - start
    err = capsys.readouterr().err
    assert "no Dask scheduler answers at tcp://127.0.0.1:1" in err and "dask scheduler" in err
    assert seconds < dask_cluster.CONNECT_TIMEOUT  # refused at once, not retried until the timeout
    assert not (tmp_path / "records").exists()


@pytest.mark.parametrize("value", ["local:0", "local:x", "local:", "local:-2", "nowhere", ""])
def test_bad_scheduler_values_say_what_is_allowed(
    value: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from eval.__main__ import main

    with pytest.raises(ValueError, match="allowed: local:N"):
        parse_scheduler(value)
    for command in (
        ["study", "speed", "--out", str(tmp_path)],
        ["optimize", "--task", "level", "--speed", "1", "--method", "pso", "--budget", "8",
         "--seeds", "0", "--out", str(tmp_path)],
    ):  # fmt: skip
        with pytest.raises(SystemExit) as exit_info:
            main([*command, "--scheduler", value])
        assert exit_info.value.code == 2
        err = capsys.readouterr().err
        assert f"--scheduler {value!r}" in err and "allowed: local:N (N = 1 to" in err
    assert not any(tmp_path.iterdir())


def test_scheduler_values_are_normalised() -> None:
    assert parse_scheduler("local:4") == "local:4"
    assert parse_scheduler("tcp://10.0.0.5:8786") == "tcp://10.0.0.5:8786"
    assert parse_scheduler("node17:8786") == "tcp://node17:8786"
    assert parse_scheduler("tcp://[::1]:08786") == "tcp://[::1]:8786"
    assert dask_cluster.executor_spec(None, 3) == "local:3"
    assert dask_cluster.executor_spec(None, 1) is None
    with pytest.raises(ValueError, match="give one"):
        dask_cluster.executor_spec("local:2", 2)


def test_local_cluster_workers_use_one_numba_thread() -> None:
    with dask_cluster.dask_client("local:1", quiet=True) as client:
        (threads,) = client.run(lambda: os.environ.get("NUMBA_NUM_THREADS")).values()
        (nthreads,) = client.nthreads().values()
    assert threads == "1" and nthreads == 1


def test_jobs_are_picklable_with_their_key() -> None:
    import pickle

    (job,) = StudyPlan(TINY).jobs("level", [2.0], seeds=[0])
    again = pickle.loads(pickle.dumps(job))
    assert again == job and again.key == job.key and isinstance(again, Job)
