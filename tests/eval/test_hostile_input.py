"""Hostile input on the evaluation side: every class gets a clear error (exit 2 on the command
line, no traceback) or a documented behaviour, before any computation where it can be known.

Classes: scheduler values and ports that are not Dask schedulers (loopback servers only, each
bounded in time); output folders that are files or cannot be written; measured-kinematics files
that are not UTF-8, repeat a key or a column, are too long, jump, or give radians as degrees;
bad options of ``speed-change`` and ``study``; records ``show`` cannot draw (a stroke or env
keywords the model refuses) and ``crosscheck --out ''``; the rough edges (progress before the
first report, the readings rule's words, the budget notice once per setting).
"""

from __future__ import annotations

import json
import os
import re
import socket
import subprocess
import sys
import threading
import time
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import pytest

from agents import dask_cluster
from agents.dask_cluster import SchedulerUnreachable, dask_client, parse_scheduler
from eval.__main__ import main
from eval.measured import SpecError, load_case
from eval.studies.presets import STUDY_PRESETS, TINY
from tandem_env.io.files import output_directory
from tandem_env.io.progress_bar import COMPILING, STARTING, ProgressBar
from tandem_env.physics.measured import MAX_SAMPLES, MeasuredWing

ROOT = Path(__file__).resolve().parents[2]
HOVER = (ROOT / "examples" / "hover.yaml").read_text(encoding="utf-8")
CLOSE = b"close"  # what the loopback server below does instead of a greeting
OPTIMIZE = ["optimize", "--task", "level", "--speed", "1", "--method", "pso", "--budget", "8"]


def _exit_status(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    """The status and stderr of a command that must end in an argparse error (no traceback)."""
    with pytest.raises(SystemExit) as info:
        main(argv)
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return int(info.value.code or 0), err


# --- scheduler values ---------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("value", "match"),
    [
        ("tls://127.0.0.1:8786", r"the scheme 'tls://' is not supported; allowed: .*tcp://HOST"),
        ("foo://x:1", r"the scheme 'foo://' is not supported"),
        ("http://localhost:8787", r"the scheme 'http://' is not supported"),
        ("127.0.0.1:99999", r"port 99999 is outside 1 to 65535"),
        ("tcp://h:0", r"port 0 is outside 1 to 65535"),
        ("h:1234567", r"allowed: local:N"),
        ("local:100000", r"local:N needs a whole number N of worker processes from 1 to 1024"),
        ("local:0", r"from 1 to 1024"),
        ("local:-3", r"from 1 to 1024"),
        ("tcp://:8786", r"allowed: local:N"),
        # names the resolver refuses with a codec error or a NUL instead of "not found"
        ("a" * 64 + ":8786", r"'a{40}…' is not a host name .*labels of 1 to 63"),
        ("a." * 130 + "b:8786", r"is not a host name .*at most 253 in all"),
        ("\x00:8786", r"'\\x00' is not a host name"),
        ("-a:1", r"'-a' is not a host name"),
        ("a..b:1", r"'a..b' is not a host name"),
    ],
)
def test_bad_scheduler_values_name_the_allowed_range(value: str, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        parse_scheduler(value)


@pytest.mark.parametrize("value", ["localhost:8786", "tcp://my-host.example.org:1", "h_1:2",
                                   "10.0.0.1:8786", "[::1]:8786", "host.:8786"])  # fmt: skip
def test_host_names_and_addresses_are_accepted(value: str) -> None:
    assert parse_scheduler(value).startswith("tcp://")


@pytest.mark.parametrize("value", [None, 8786, b"local:2"])
def test_a_scheduler_that_is_not_text_is_refused(value: object) -> None:
    with pytest.raises(ValueError, match=r"scheduler = .*; allowed: a string, local:N"):
        parse_scheduler(value)  # type: ignore[arg-type]


@pytest.mark.parametrize("workers", [0, -1, 100000])
def test_workers_out_of_range_exit_2(
    workers: int, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["study", "speed", "--workers", str(workers), "--out", str(tmp_path)]
    status, err = _exit_status(argv, capsys)
    assert status == 2 and f"workers = {workers}; allowed: an integer from 1 to 1024" in err


def test_bad_scheduler_on_the_command_line_exits_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    for value in ("tls://a:1", "local:100000", "a:99999"):
        for command in (
            [*OPTIMIZE, "--seeds", "0", "--out", str(tmp_path)],
            ["study", "speed", "--out", str(tmp_path)],
        ):
            status, err = _exit_status([*command, "--scheduler", value], capsys)
            assert status == 2 and f"--scheduler {value!r}" in err and "allowed:" in err
    assert not any(tmp_path.iterdir())


@pytest.fixture
def server() -> Iterator[Callable[[bytes | None, bool], int]]:
    """Loopback servers: ``start(greeting, answer_http)`` -> port. Each accepts connections;
    it sends ``greeting`` at once (None: nothing), or, with ``answer_http``, answers a request
    with an HTTP 400 like a web server. Closed at the end of the test."""
    sockets: list[socket.socket] = []
    stop = threading.Event()

    def start(greeting: bytes | None, answer_http: bool = False) -> int:
        listener = socket.create_server(("127.0.0.1", 0))
        listener.settimeout(0.2)
        sockets.append(listener)

        def serve() -> None:
            while not stop.is_set():
                try:
                    conn, _ = listener.accept()
                except OSError:
                    continue
                sockets.append(conn)
                try:
                    if greeting == CLOSE:
                        conn.close()
                        continue
                    if greeting is not None:
                        conn.sendall(greeting)
                    if answer_http:
                        conn.settimeout(5.0)
                        if conn.recv(65536):
                            conn.sendall(b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n")
                except OSError:
                    pass

        threading.Thread(target=serve, daemon=True).start()
        return int(listener.getsockname()[1])

    yield start
    stop.set()
    for s in sockets:
        s.close()


@pytest.mark.parametrize(
    ("greeting", "http", "match"),
    [
        (None, False, r"accepts connections but sent no Dask handshake within 0.5 s"),
        (None, True, r"accepts connections but sent no Dask handshake within 0.5 s"),
        (b"SSH-2.0-OpenSSH_9.6\r\n", False, r"answers, but not with the Dask protocol"),
        (b"", False, r"accepts connections but sent no Dask handshake"),
        (b"\x01\x00", False, r"accepts connections but sent no Dask handshake"),  # 2 of 8 bytes
        (CLOSE, False, r"accepted the connection and closed it without a Dask handshake"),
    ],
)
def test_a_port_that_is_no_dask_scheduler_is_reported_within_the_timeout(
    server: Callable[[bytes | None, bool], int],
    monkeypatch: pytest.MonkeyPatch,
    greeting: bytes | None,
    http: bool,
    match: str,
) -> None:
    """A silent port (or an HTTP server, which waits for a request) used to hang the client
    for minutes, an HTTP or SSH answer made it allocate exabytes: now both are reported after
    at most the connect timeout."""
    import distributed  # noqa: F401 - imported before the clock starts: seconds on a busy machine

    monkeypatch.setattr(dask_cluster, "CONNECT_TIMEOUT", 0.5)
    port = server(greeting, http)
    start = time.monotonic()
    with pytest.raises(SchedulerUnreachable, match=match), dask_client(f"127.0.0.1:{port}"):
        pass
    assert time.monotonic() - start < 5.0


def test_a_silent_port_ends_optimize_with_status_1(
    server: Callable[[bytes | None, bool], int],
    monkeypatch: pytest.MonkeyPatch,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    monkeypatch.setattr(dask_cluster, "CONNECT_TIMEOUT", 0.5)
    port = server(None, False)
    argv = [*OPTIMIZE, "--seeds", "0", "--out", str(tmp_path), "--quiet"]
    assert main([*argv, "--scheduler", f"127.0.0.1:{port}"]) == 1
    err = capsys.readouterr().err
    assert "sent no Dask handshake" in err and "Traceback" not in err
    assert not (tmp_path / "records").exists()


# --- output folders -----------------------------------------------------------------------------
def _commands(out: Path) -> list[list[str]]:
    return [
        ["measured", str(ROOT / "examples" / "hover.yaml"), "--out", str(out)],
        [*OPTIMIZE, "--seeds", "0", "--out", str(out), "--quiet"],
        ["study", "speed", "--preset", "tiny", "--out", str(out), "--quiet"],
        ["speed-change", "--out", str(out), "--quiet"],
        ["compare", str(ROOT / "examples"), "--out", str(out)],
    ]


@pytest.mark.parametrize("where", ["file", "parent"])
def test_a_file_as_out_is_refused_before_any_work(
    where: str,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    monkeypatch.setitem(STUDY_PRESETS, TINY.name, TINY)
    blocker = tmp_path / "taken"
    blocker.write_text("not a folder")
    out = blocker if where == "file" else blocker / "sub"
    for argv in _commands(out):
        start = time.monotonic()
        status, err = _exit_status(argv, capsys)
        assert status == 2, argv
        assert f"{blocker} is a file; allowed: a directory" in err, argv
        assert time.monotonic() - start < 30.0  # refused, not computed (the study alone: minutes)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["taken"]


def _permissions_bind() -> bool:
    """Whether this user is kept out of a folder without write permission (root is not,
    unless it runs without CAP_DAC_OVERRIDE)."""
    import tempfile

    with tempfile.TemporaryDirectory() as scratch:
        os.chmod(scratch, 0o555)
        try:
            Path(scratch, "probe").write_text("")
        except OSError:
            return True
        finally:
            os.chmod(scratch, 0o755)
    return False


needs_permissions = pytest.mark.skipif(
    not _permissions_bind(),
    reason="this user writes into read-only folders (root); run as an ordinary user",
)


@needs_permissions
def test_a_read_only_out_is_refused_before_any_work(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setitem(STUDY_PRESETS, TINY.name, TINY)
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o555)
    try:
        for out in (locked, locked / "new"):
            for argv in _commands(out):
                status, err = _exit_status(argv, capsys)
                assert status == 2 and f"cannot write into {locked}" in err, argv
    finally:
        locked.chmod(0o755)
    assert not any(locked.iterdir())


@needs_permissions
def test_a_read_only_records_folder_in_a_writable_out_is_refused_before_any_work(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    records = tmp_path / "records"
    records.mkdir()
    records.chmod(0o555)
    try:
        argv = [*OPTIMIZE, "--seeds", "0", "--out", str(tmp_path), "--quiet"]
        status, err = _exit_status(argv, capsys)
        assert status == 2 and f"cannot write into {records}" in err
    finally:
        records.chmod(0o755)
    assert not any(records.iterdir())


@needs_permissions
def test_a_rerun_with_nothing_to_compute_works_in_a_read_only_folder(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = [*OPTIMIZE, "--swarm-size", "4", "--seeds", "0", "--out", str(tmp_path), "--quiet"]
    argv += ["--env-kwargs", "n_time=32"]
    assert main(argv) == 0
    capsys.readouterr()
    for path in (tmp_path, tmp_path / "records"):
        path.chmod(0o555)
    try:
        assert main(argv) == 0
    finally:
        for path in (tmp_path, tmp_path / "records"):
            path.chmod(0o755)
    captured = capsys.readouterr()
    assert "pso seed 0" in captured.out and "summary.csv is left as it is" in captured.err


@needs_permissions
def test_an_unreadable_kinematics_file_is_named(tmp_path: Path) -> None:
    path = _case(tmp_path, HOVER)
    path.chmod(0o000)
    try:
        with pytest.raises(SpecError, match=r"cannot be read \(Permission denied\)"):
            load_case(path)
    finally:
        path.chmod(0o644)


def test_output_directory_reports_what_it_finds(tmp_path: Path) -> None:
    assert output_directory(tmp_path / "a" / "b") is True
    assert not (tmp_path / "a").exists()  # checking creates nothing
    (tmp_path / "f").write_text("")
    with pytest.raises(ValueError, match=r"--figures '.*f/x': .*f is a file"):
        output_directory(tmp_path / "f" / "x", "--figures")
    assert list(tmp_path.iterdir()) == [tmp_path / "f"]  # no probe file left behind


def test_concurrent_measured_runs_into_one_folder_do_not_mix(tmp_path: Path) -> None:
    """Two processes writing one case into one folder: unique temporary names and an atomic
    rename, so both succeed and the record is one whole run's (they raced on a fixed name)."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    argv = [sys.executable, "-m", "eval", "measured", str(ROOT / "examples" / "hover.yaml")]
    runs = [
        subprocess.Popen([*argv, "--out", str(tmp_path)], cwd=ROOT, env=env, stderr=subprocess.PIPE)
        for _ in range(2)
    ]
    for run in runs:
        _, err = run.communicate(timeout=300)
        assert run.returncode == 0, err.decode()
    assert json.loads((tmp_path / "hover.json").read_text())["summary"]["total"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["hover.json", "hover.png"]


# --- measured-kinematics files ------------------------------------------------------------------
def _case(tmp_path: Path, text: str | bytes, name: str = "case.yaml") -> Path:
    path = tmp_path / name
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text, encoding="utf-8")
    return path


@pytest.mark.parametrize(
    ("data", "match"),
    [
        (HOVER.encode("utf-16"), r"holds UTF-16 text; allowed: UTF-8 text"),
        (b"\x00\x01\x02\xff binary", r"holds binary data; allowed: UTF-8 text"),
        (HOVER.encode("latin-1", "replace"), r"is not UTF-8 text \(byte \d+"),
    ],
)
def test_files_that_are_not_utf8_text_are_named(tmp_path: Path, data: bytes, match: str) -> None:
    with pytest.raises(SpecError, match=match):
        load_case(_case(tmp_path, data))


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("", r"is empty; allowed: a mapping with flight, kinematics"),
        ("# only a comment\n", r"is empty"),
        ("[" * 20000 + "]" * 20000, r"nests too deeply|is not valid YAML"),
        ("- 1\n- 2\n", r"= \[1, 2\]; allowed: a mapping of fields"),
    ],
)
def test_empty_or_odd_files_are_named(tmp_path: Path, text: str, match: str) -> None:
    with pytest.raises(SpecError, match=match):
        load_case(_case(tmp_path, text))


def test_a_utf8_bom_is_accepted(tmp_path: Path) -> None:
    case = load_case(_case(tmp_path, "\ufeff" + HOVER))
    assert case.fore.frequency == 39.0


def test_yaml_1_2_numbers_are_numbers(tmp_path: Path) -> None:
    text = HOVER.replace("frequency: 39.0 ", "frequency: 39e0 ", 1)
    text = text.replace("speed: 0.0 ", "speed: 1e-4 ").replace("[[5.0, 90.0]]", "[[5E+0, 90.0]]")
    case = load_case(_case(tmp_path, text))
    assert case.fore.frequency == 39.0 and case.speed == 1e-4
    assert np.ptp(case.fore.elevation) == pytest.approx(np.deg2rad(10.0))
    # text that only looks numeric stays text, and is refused as such
    with pytest.raises(SpecError, match=r"kinematics.fore.frequency = '39e'"):
        load_case(_case(tmp_path, HOVER.replace("frequency: 39.0 ", "frequency: 39e ", 1)))


def test_duplicate_keys_are_refused_naming_the_key(tmp_path: Path) -> None:
    text = HOVER.replace("  speed: 0.0 ", "  speed: 0.0\n  speed: 3.0 ")
    with pytest.raises(SpecError, match=r"duplicate key 'speed' on lines 8 and 9"):
        load_case(_case(tmp_path, text))
    nested = HOVER.replace("    frequency: 39.0 ", "    frequency: 39.0\n    frequency: 40 ", 1)
    with pytest.raises(SpecError, match=r"duplicate key 'frequency'"):
        load_case(_case(tmp_path, nested))


def test_the_loader_builds_no_python_objects(tmp_path: Path) -> None:
    text = "!!python/object/apply:os.system ['echo owned']\n"
    with pytest.raises(SpecError, match="is not valid YAML"):
        load_case(_case(tmp_path, text))


def _csv_case(tmp_path: Path, header: str, rows: list[str], n_samples: int | None = None) -> Path:
    (tmp_path / "fore.csv").write_text("\n".join([header, *rows]) + "\n", encoding="utf-8")
    fore = "  fore:\n    frequency: 39.0\n    stroke_plane_angle: 55.0\n    csv: fore.csv\n"
    text = re.sub(r"  fore:\n(    .*\n)+", fore, HOVER, count=1)
    if n_samples is not None:
        text = text.replace("degrees: true ", f"degrees: true\n  n_samples: {n_samples} ")
    return _case(tmp_path, text)


def _cycle(n: int, sweep: Callable[[np.ndarray], np.ndarray]) -> list[str]:
    i = np.arange(n + 1)
    phase = 2 * np.pi * i / n
    return [
        f"{float(k / n / 39.0)!r},{float(s)!r},0,{float(30 * np.cos(p))!r}"
        for k, s, p in zip(i, sweep(phase), phase, strict=True)
    ]


def test_a_repeated_csv_column_is_named(tmp_path: Path) -> None:
    path = _csv_case(tmp_path, "time,sweep,elevation,pitch,sweep", [r + ",0" for r in _cycle(
        64, lambda p: 40 * np.cos(p))])  # fmt: skip
    with pytest.raises(SpecError, match=r"column 'sweep' appears 2 times in the header"):
        load_case(path)


def test_sample_counts_are_bounded_before_any_table(tmp_path: Path) -> None:
    big = HOVER.replace("degrees: true ", "degrees: true\n  n_samples: 100000000 ")
    with pytest.raises(SpecError, match=rf"n_samples = 100000000; allowed: .*<= {MAX_SAMPLES:,}"):
        load_case(_case(tmp_path, big))
    n = 3 * MAX_SAMPLES
    path = _csv_case(tmp_path, "time,sweep,elevation,pitch", _cycle(n, lambda p: 40 * np.cos(p)))
    with pytest.raises(SpecError, match=rf"has {n + 1} samples; allowed: at most {MAX_SAMPLES}"):
        load_case(path)
    with pytest.raises(ValueError, match=rf"at most {MAX_SAMPLES} per cycle"):
        z = np.zeros(MAX_SAMPLES + 1)
        MeasuredWing(z, z, z, 40.0, 0.5)


def test_a_jump_in_a_series_is_warned_about(tmp_path: Path) -> None:
    """A square-wave sweep (a jump of 80° between two samples) gives P/m of ~10⁴ W/kg: the
    command says why, naming the series and the samples."""
    path = _csv_case(
        tmp_path,
        "time,sweep,elevation,pitch",
        _cycle(64, lambda p: np.where(p < np.pi, 40.0, -40.0)),
        n_samples=64,
    )
    with pytest.warns(UserWarning, match=r"MeasuredWing.sweep jumps by 80° from sample 31 to 32"):
        load_case(path)


def test_smooth_series_and_the_examples_raise_no_warning() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for name in ("hover", "forward_flight", "climb", "twisted_wing"):
            load_case(ROOT / "examples" / f"{name}.yaml")
        n = 8  # the fewest samples: a sinusoid's largest step is 0.19 of its variation
        phase = 2 * np.pi * np.arange(n) / n
        MeasuredWing(0.7 * np.cos(phase), 0 * phase, 0.5 * np.sin(phase), 40.0, 0.5)


def test_radians_declared_as_degrees_are_warned_about(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    text = HOVER.replace("37.0", "0.65").replace("-29.0", "-0.5").replace("7.4", "0.1")
    path = _case(tmp_path, text.replace("[[5.0", "[[0.09"))
    assert main(["measured", str(path), "--out", str(tmp_path / "out")]) == 0
    err = capsys.readouterr().err
    assert err.count("warning: ") == 2 and "these look like radians; pass degrees=False" in err
    assert "Traceback" not in err and "UserWarning" not in err  # one line each, no file:line


# --- command-line options -----------------------------------------------------------------------
@pytest.mark.parametrize(
    ("options", "match"),
    [
        (["--grid", "99"], r"--grid speed 99 m/s .*speed_envelope"),
        (["--grid", "nan"], r"--grid speed nan m/s"),
        (["--grid", "1", "1"], r"--grid 1 1: allowed: distinct speeds"),
        (["--grid", "x"], r"argument --grid: invalid float value: 'x'"),
        (["--optima-budget", "0"], r"budget = 0; allowed: an integer >= 1 and <= 100,000,000"),
        (["--optima-budget", str(2**63)], r"budget = 9223372036854775808; allowed: an integer"),
        (["--optima-budget", "-5"], r"budget = -5; allowed"),
        (["--optimiser", "nosuch"], r"unknown method 'nosuch'; allowed: cmaes, .*pso"),
        # found by the method's check when the optimum is prepared, not after training started
        (["--optimiser", "ppo", "--optima-budget", "8"], r"budget 7 is below one PPO iteration"),
        (["--episodes", str(2**63)], r"--episodes 9223372036854775808; allowed: 1 to 10,000"),
        (["--first-seed", "-1"], r"--first-seed -1; allowed: an integer >= 0"),
        (["--optimiser", "pso:x"], r"method 'pso' takes no ':' argument"),
        (["--scheduler", "tls://a:1"], r"the scheme 'tls://' is not supported"),
    ],
)
def test_bad_speed_change_options_exit_2_before_any_work(
    options: list[str], match: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "sc"
    status, err = _exit_status(["speed-change", *options, "--out", str(out), "--quiet"], capsys)
    assert status == 2 and re.search(match, err), err
    assert not out.exists()


def test_a_figure_that_cannot_be_written_is_refused_before_any_work(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "taken").write_text("")
    for figure, match in [
        (tmp_path / "taken" / "episode.png", f"--figure '{tmp_path / 'taken'}': .* is a file"),
        (tmp_path, "is a folder; allowed: a file name"),
        (tmp_path / "episode.txt", r"the format '.txt' is not one matplotlib writes; .*\.png"),
    ]:
        argv = ["speed-change", "--out", str(tmp_path / "sc"), "--quiet", "--figure", str(figure)]
        status, err = _exit_status(argv, capsys)
        assert status == 2 and re.search(match, err), err
    assert not (tmp_path / "sc").exists()


@pytest.mark.parametrize(
    ("method", "match"),
    [
        ("nosuch", r"unknown method 'nosuch'; allowed: cmaes, .*pso, random"),
        ("pso:x", r"method 'pso' takes no ':' argument"),
        ("policy:", r"empty argument after ':'"),
    ],
)
def test_a_bad_study_method_exits_2_before_any_job(
    method: str, match: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    status, err = _exit_status(
        ["study", "speed", "--method", method, "--out", str(tmp_path)], capsys
    )
    assert status == 2 and re.search(match, err), err
    assert not any(tmp_path.iterdir())


def test_a_folder_that_is_no_training_run_is_refused_before_any_job(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``policy:DIR`` of a folder without a run was found only when the job ran: a failed job,
    its traceback, exit 1. The method's check now reads the folder when the job is prepared."""
    (tmp_path / "notarun").mkdir()
    argv = [*OPTIMIZE, "--seeds", "0", "--out", str(tmp_path / "out"), "--quiet"]
    argv[argv.index("pso")] = f"policy:{tmp_path / 'notarun'}"
    status, err = _exit_status(argv, capsys)
    assert status == 2 and f"{tmp_path / 'notarun'} is not a training run folder" in err
    assert not (tmp_path / "out").exists()


# --- rough edges --------------------------------------------------------------------------------
def test_study_says_what_it_will_run(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """Before the first job: the studies, optimisations, seeds, budgets and the work left."""
    monkeypatch.setitem(STUDY_PRESETS, TINY.name, TINY)
    monkeypatch.setattr("eval.study.run_plan", lambda *a, **k: (_ for _ in ()).throw(
        KeyboardInterrupt))  # fmt: skip
    assert main(["study", "speed", "--preset", "tiny", "--out", str(tmp_path)]) == 130
    err = capsys.readouterr().err
    jobs = len(TINY.speeds) * len(TINY.seeds)
    assert (
        f"study speed (speed): preset tiny, method {TINY.method}; {jobs} optimisations over "
        f"seeds {list(TINY.seeds)}, budgets {TINY.level_budget:,} model evaluations each "
        f"({jobs * TINY.level_budget:,} in all); 0 stored in {tmp_path}, 0 in the record "
        f"cache, {jobs} to run ({jobs * TINY.level_budget:,} evaluations); time left: estimating"
    ) in err
    assert "interrupted" in err


def test_the_progress_bar_says_it_waits_instead_of_a_rate(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import tandem_env.io.progress_bar as progress

    monkeypatch.setattr(progress, "_reported", False)
    bar = ProgressBar(1000, "job")
    err = capsys.readouterr().err
    assert COMPILING in err and "eval/s" not in err and "<" not in err  # no rate, no ETA
    bar.move_to(40, "iter 1")
    bar.close()
    err = capsys.readouterr().err
    assert "eval/s" in err and "iter 1" in err
    with ProgressBar(1000, "next") as second:
        assert STARTING in capsys.readouterr().err  # the model is compiled by now
        second.waiting("waiting for the first job")
        assert "waiting for the first job" in capsys.readouterr().err


def test_the_readings_rule_never_says_no_gainer_when_there_is_one() -> None:
    from eval.studies import claims
    from eval.studies.base import StudyOutput
    from eval.studies.paper_reading import DEFAULT, Reading
    from eval.studies.readings import ReadingResult, combinations

    def result(reading: Reading, agree: int) -> ReadingResult:
        found = [
            claims.Claim(f"C{i}", "s", "Fig. 1", "x", "x", "number", verdict=v)
            for i, v in enumerate(["agrees"] * agree + ["differs"] * (10 - agree))
        ]
        return ReadingResult(reading, (StudyOutput("s", "S", [], [], found),))

    hover = Reading("hover-none", "t", {"interference": 0.0})
    out, words = combinations(result(DEFAULT, 4), [result(DEFAULT, 4), result(hover, 6)])
    assert out == [] and "hover-none (+2)" in words and "no gainer" not in words
    assert "hover-none is the only gainer" in words


def test_the_unused_budget_notice_is_said_once_per_setting(
    capsys: pytest.CaptureFixture[str],
) -> None:
    from agents.harness import run

    settings = {"n_envs": 16, "n_steps": 4, "batch_size": 64}
    records = run("ppo", "level", 1.5, budget=203, seeds=[0, 1], method_config=settings)
    assert [r.config["method"]["budget_unused"] for r in records] == [10, 10]
    assert capsys.readouterr().err.count("evaluations stay unused") == 1


def test_ctrl_c_on_a_local_dask_run_prints_one_line(tmp_path: Path) -> None:
    """Ctrl-C reaches the whole process group: the workers ignore it (they used to die at once
    and their nannies log tracebacks), this process closes the cluster and says one line."""
    import signal

    argv = [sys.executable, "-m", "eval", *OPTIMIZE[:-1], "200000", "--seeds", "0"]
    argv += ["--out", str(tmp_path), "--scheduler", "local:1", "--env-kwargs", "n_time=32"]
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    run = subprocess.Popen(
        argv,
        cwd=ROOT,
        env=env,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),  # as a terminal's
    )
    assert run.stderr is not None
    lines = []
    deadline = time.monotonic() + 180.0  # imports and the cluster's start on a loaded machine
    while time.monotonic() < deadline:
        line = run.stderr.readline()
        lines.append(line)
        if not line or line.startswith("Dask scheduler"):
            break
    assert lines[-1].startswith("Dask scheduler"), lines
    time.sleep(2.0)  # the job is running on the worker
    os.killpg(run.pid, signal.SIGINT)
    try:
        err = run.communicate(timeout=120)[1]
    finally:
        if run.poll() is None:
            os.killpg(run.pid, signal.SIGKILL)
    assert run.returncode == 130
    assert "Traceback" not in err and "ERROR" not in err, err
    assert err.count("interrupted; the finished records are stored") == 1


# --- readings and method flags -----------------------------------------------------------------
def test_aliases_combine_like_singles() -> None:
    from eval.studies.readings import reading_by_name

    assert reading_by_name("paper+body").name == "hover-none+Fh-literal+body"
    assert reading_by_name("paper").changes() == reading_by_name("hover-none+Fh-literal").changes()
    with pytest.raises(ValueError, match=r"unknown 'nosuch'; allowed: paper, default, body"):
        reading_by_name("paper+nosuch")
    with pytest.raises(ValueError, match=r"'paper\+Fh-literal' is 'hover-none\+Fh-literal\+Fh-lit"):
        reading_by_name("paper+Fh-literal")  # a single twice, said as what it stands for
    with pytest.raises(ValueError, match=r"reading '\+': no name"):
        reading_by_name("+")


def test_a_reading_that_changes_nothing_for_the_task_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "r"
    status, err = _exit_status(
        [*OPTIMIZE, "--seeds", "0", "--reading", "Fh-literal", "--out", str(out)], capsys
    )
    assert status == 2 and "--reading Fh-literal changes nothing here" in err
    accelerate = ["optimize", "--task", "accelerate", "--power", "60", "--method", "pso",
                  "--budget", "8", "--seeds", "0", "--objective", "vertical", "--reading", "Fh-literal",
                  "--out", str(out)]  # fmt: skip
    status, err = _exit_status(accelerate, capsys)
    assert status == 2 and "not vertical (--task accelerate --objective vertical)" in err
    assert not out.exists()


def test_a_reading_that_changes_part_of_what_it_says_warns(
    tmp_path: Path, monkeypatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from eval import optimize

    def stop(*args, **kwargs):  # everything was checked: stop before the run
        raise SystemExit(0)

    monkeypatch.setattr(optimize, "run_jobs", stop)
    with pytest.raises(SystemExit):
        main([*OPTIMIZE, "--seeds", "0", "--reading", "paper", "--out", str(tmp_path), "--quiet"])
    err = capsys.readouterr().err
    assert "UserWarning: --reading paper: its objective horizontal_literal" in err


@pytest.mark.parametrize(
    ("value", "match"),
    [
        ("abc", r"argument --continuation: 'abc' is not a number; allowed: a share"),
        ("1e-9", r"--continuation 1e-09: a continued cmaes job \(1 of its 8000 evaluations"),
        ("0.01", r"--continuation 0.01: .*smaller than one CMA-ES population"),
        ("2", r"continuation share = 2.0; allowed: a number in \(0, 1\]"),
    ],
)
def test_a_continuation_share_no_job_can_run_is_refused_up_front(
    value: str, match: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["study", "readings", "--preset", "quick", "--continuation", value,
            "--out", str(tmp_path / "r")]  # fmt: skip
    status, err = _exit_status(argv, capsys)
    assert status == 2 and re.search(match, err), err
    assert not (tmp_path / "r").exists()


@pytest.mark.parametrize("option", ["--method-config", "--env-kwargs"])
def test_an_option_without_a_value_is_refused(
    option: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    status, err = _exit_status(
        [*OPTIMIZE, "--seeds", "0", option, "popsize=", "--out", str(tmp_path)], capsys
    )
    assert status == 2 and f"{option} 'popsize=': no value after '='" in err


# --- measured kinematics ------------------------------------------------------------------------
def test_pitch_without_stations_or_columns_is_named() -> None:
    n = 16
    sweep = 0.5 * np.cos(2 * np.pi * np.arange(n) / n)
    with pytest.raises(ValueError, match=r"MeasuredWing.pitch has shape \(16, 0\), no columns"):
        MeasuredWing(sweep, 0 * sweep, np.zeros((n, 0)), 40.0, 0.5, pitch_stations=[])
    with pytest.raises(ValueError, match=r"no columns"):
        MeasuredWing.from_samples(np.arange(n) / (n * 40.0), sweep, 0 * sweep, np.zeros((n, 0)),
                                  30.0, frequency=40.0, pitch_stations=[])  # fmt: skip


def test_a_sweep_its_samples_do_not_resolve_is_warned_about(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A step smoothed over 3 samples jumps by no more than a quarter of its variation between
    two samples (no jump), yet its rate is set by the sampling: P/m of thousands of W/kg."""
    from tandem_env.physics.measured import UNRESOLVED_SHARE, unresolved_share

    def step(phase: np.ndarray) -> np.ndarray:
        square = np.where(np.cos(phase[:-1]) > 0, 40.0, -40.0)
        smooth = np.convolve(np.tile(square, 3), np.ones(3) / 3, "same")[64:128]
        return np.append(smooth, smooth[0])

    rows = _cycle(64, step)
    path = _csv_case(tmp_path, "time,sweep,elevation,pitch", rows, n_samples=64)
    assert main(["measured", str(path), "--out", str(tmp_path / "out")]) == 0
    err = capsys.readouterr().err
    assert re.search(
        r"MeasuredWing.sweep: \d+% of its mean-square rate lies in harmonics above", err
    )
    # the criterion: a resolved motion has almost none of its rate there
    phase = 2 * np.pi * np.arange(64) / 64
    triangle = np.arcsin(np.cos(phase))
    assert unresolved_share(np.cos(phase))[0] < 1e-20
    assert unresolved_share(triangle)[0] < 0.06 < UNRESOLVED_SHARE  # 0.05 above harmonic 10
    assert unresolved_share(np.sign(np.cos(phase)))[0] > 0.5


@pytest.mark.parametrize("time", [True, False], ids=["with time", "without time"])
def test_radians_in_a_csv_declared_as_degrees_are_warned_about(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], time: bool
) -> None:
    rows = [",".join([*r.split(",")[:2], "0", repr(0.5 * float(r.split(",")[3]) / 30)])
            for r in _cycle(64, lambda p: 0.6 * np.cos(p))]  # fmt: skip
    header = "time,sweep,elevation,pitch"
    if not time:  # one open cycle of samples, no time column
        rows, header = [r.split(",", 1)[1] for r in rows[:-1]], "sweep,elevation,pitch"
    path = _csv_case(tmp_path, header, rows, n_samples=64)
    assert main(["measured", str(path), "--out", str(tmp_path / "out")]) == 0
    err = capsys.readouterr().err
    assert "from_samples: with degrees=True the sweep and pitch never exceed" in err


# --- eval show and eval crosscheck ----------------------------------------------------------------
@pytest.fixture(scope="module")
def record_data(tmp_path_factory: pytest.TempPathFactory) -> dict:
    """A record of a tiny optimize run, as its file holds it."""
    out = tmp_path_factory.mktemp("results")
    assert main([*OPTIMIZE, "--seeds", "0", "--out", str(out), "--quiet"]) == 0
    [path] = (out / "records").iterdir()
    return json.loads(path.read_text(encoding="utf-8"))


def _stroke(name: str, value: object) -> Callable[[dict], None]:
    def change(data: dict) -> None:
        if value is None:
            del data["results"]["stroke"][name]
        else:
            data["results"]["stroke"][name] = value

    return change


def _env(**env_kwargs: object) -> Callable[[dict], None]:
    return lambda data: data["job"]["env_kwargs"].update(env_kwargs)


@pytest.mark.parametrize(
    ("change", "match"),
    [
        (_stroke("fore_frequency", 500.0), r"fore_frequency = 500 Hz is outside Table 4"),
        (_stroke("hind_pitch_phase", float("nan")), r"hind_pitch_phase = nan is not finite"),
        (_stroke("fore_frequency", None), r"its stroke has no parameter 'fore_frequency'"),
        (_env(n_time=10**8), r"n_time = 100000000; allowed: an integer 8 to"),
        (_env(wingspan=3), r"unknown argument\(s\) 'wingspan'"),
    ],
)
def test_show_refuses_a_record_the_model_refuses_in_one_line(
    record_data: dict,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    change: Callable[[dict], None],
    match: str,
) -> None:
    """A record whose checksum and key were made again over the edit (a store reads it) but
    whose stroke or env keywords the model refuses: one line naming the file, nothing written."""
    from agents.jobs import Job
    from agents.records import Record

    data = json.loads(json.dumps(record_data))
    change(data)
    job = Job.from_dict(data["job"])
    record = Record(job=job, key=job.key, results=data["results"], schema=data["schema"])
    path = tmp_path / "records" / f"{job.key}.json"
    path.parent.mkdir()
    path.write_text(json.dumps(record.to_dict()), encoding="utf-8")
    status, err = _exit_status(["show", str(path), "--frames", "8"], capsys)
    line = err.strip().splitlines()[-1]
    assert status == 2 and line.startswith(f"python -m eval show: error: record {path}: ")
    assert re.search(match, line)
    assert not (tmp_path / "show").exists()


def test_crosscheck_refuses_an_empty_out(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)  # Path('') is the current folder: nothing may land there
    status, err = _exit_status(["crosscheck", "--grid", "tiny", "--out", ""], capsys)
    assert status == 2 and "--out '': an empty path" in err
    assert not any(tmp_path.iterdir())
