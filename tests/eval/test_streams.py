"""Streams and environment of the command lines (tandem_env.io.command, the one wrapper of every
entry point): a reader of stdout that goes away, a closed or failing stderr, an ASCII-only
encoding and numba settings that numba cannot use each get a quiet end or one clear line, and
a closed stderr never costs a record."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from tandem_env.io.command import EnvironmentSettingError, check_numba_environment
from tandem_env.io.progress_bar import QuietStream

ROOT = Path(__file__).resolve().parents[2]
ENTRY_POINTS = (
    ["eval", "optimize"],
    ["train"],
    ["train.envelope"],
    ["train.amortised_eval"],
    ["train.tune"],
)
OPTIMIZE = ["-m", "eval", "optimize", "--task", "level", "--speed", "1", "--method", "random",
            "--budget", "4", "--env-kwargs", "n_blade=6", "n_time=32", "--seeds", "0"]  # fmt: skip


def _run(
    args: list[str], env: dict[str, str] | None = None, **kwargs
) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, *args],
        cwd=ROOT,
        env={**os.environ, **(env or {})},
        timeout=600,
        check=False,
        **kwargs,
    )


@pytest.mark.parametrize(
    ("variable", "value", "allowed"),
    [
        ("NUMBA_NUM_THREADS", "0", "a whole number >= 1"),
        ("NUMBA_NUM_THREADS", "-2", "a whole number >= 1"),
        ("NUMBA_NUM_THREADS", "two", "a whole number >= 1"),
        ("NUMBA_THREADING_LAYER", "bogus", "default, safe, forksafe"),
    ],
)
def test_numba_settings_are_checked_before_numba_reads_them(
    variable: str, value: str, allowed: str
) -> None:
    with pytest.raises(EnvironmentSettingError, match=f"{variable}={value!r}; allowed: {allowed}"):
        check_numba_environment({variable: value})
    check_numba_environment({"NUMBA_NUM_THREADS": "2", "NUMBA_THREADING_LAYER": "workqueue"})
    check_numba_environment({})


@pytest.mark.parametrize("entry", ENTRY_POINTS, ids=lambda e: e[0])
@pytest.mark.parametrize(
    ("variable", "value"), [("NUMBA_NUM_THREADS", "0"), ("NUMBA_THREADING_LAYER", "bogus")]
)
def test_a_bad_numba_setting_is_one_line_and_status_2(entry, variable, value) -> None:
    done = _run(["-m", *entry, "--help"], {variable: value}, capture_output=True, text=True)
    assert done.returncode == 2
    assert done.stderr.strip().splitlines() == [
        f"python -m {entry[0]}: error: " + done.stderr.split(": error: ", 1)[1].strip()
    ]
    assert variable in done.stderr and "Traceback" not in done.stderr


@pytest.mark.parametrize("entry", ENTRY_POINTS, ids=lambda e: e[0])
def test_help_survives_an_ascii_only_encoding(entry) -> None:
    done = _run(
        ["-m", *entry, "--help"], {"PYTHONIOENCODING": "ascii"}, capture_output=True, text=True
    )
    assert done.returncode == 0 and "Traceback" not in done.stderr
    assert "usage:" in done.stdout


@pytest.mark.parametrize(
    "args",
    [
        ["-m", "eval", "optimize", "--help"],
        # more than a pipe's buffer, written while the command runs
        ["-c", "from tandem_env.io.command import run_command\n"
               "run_command(lambda: [print('x' * 99) for _ in range(10_000)])"],
    ],
    ids=["help", "long output"],
)  # fmt: skip
def test_a_reader_of_stdout_that_goes_away_ends_quietly(args: list[str]) -> None:
    read, write = os.pipe()
    os.close(read)  # `| head` that has already left
    try:
        done = _run(args, stdout=write, stderr=subprocess.PIPE)
    finally:
        os.close(write)
    assert done.returncode in (0, 1)
    assert done.stderr == b""  # no BrokenPipeError traceback, no "Exception ignored"


def test_a_failing_stderr_costs_no_record(tmp_path: Path) -> None:
    read, write = os.pipe()
    os.close(read)  # stderr's reader went away: every write there fails with EPIPE
    try:
        done = _run([*OPTIMIZE, "--out", str(tmp_path)], stderr=write, capture_output=False,
                    stdout=subprocess.PIPE)  # fmt: skip
    finally:
        os.close(write)
    assert done.returncode == 0
    assert len(list((tmp_path / "records").glob("*.json"))) == 1
    assert b"random seed 0" in done.stdout


def test_a_closed_stderr_costs_no_record(tmp_path: Path) -> None:
    command = " ".join([sys.executable, *OPTIMIZE, "--out", str(tmp_path), "2>&-"])
    done = subprocess.run(["bash", "-c", command], cwd=ROOT, timeout=600, check=False,
                          capture_output=False, stdout=subprocess.PIPE)  # fmt: skip
    assert done.returncode == 0
    assert len(list((tmp_path / "records").glob("*.json"))) == 1


def test_a_quiet_stream_drops_what_it_cannot_write() -> None:
    class Broken:
        def write(self, text: str) -> int:
            raise BrokenPipeError(32, "Broken pipe")

        def flush(self) -> None:
            raise BrokenPipeError(32, "Broken pipe")

    stream = QuietStream(Broken())  # type: ignore[arg-type]
    assert stream.write("progress") == len("progress")
    stream.flush()
    assert stream.write("more") == 4  # silenced for good, no exception


def test_a_machine_failure_left_over_by_a_command_is_one_line(tmp_path: Path) -> None:
    """An OSError no command caught (a disk that fills while a table is written) names the
    file and the reason, status 1, no traceback."""
    script = (
        "import errno, os, sys\n"
        "from tandem_env.io.command import run_command\n"
        "def main():\n"
        "    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), 'out/table.csv')\n"
        "sys.exit(run_command(main, 'python -m eval compare'))\n"
    )
    done = _run(["-c", script], capture_output=True, text=True)
    assert done.returncode == 1
    assert done.stderr.strip() == (
        "python -m eval compare: error: out/table.csv: No space left on device; files already "
        "written are kept whole: fix that and run the same command again"
    )
