"""Resuming under hostile conditions: unsafe or garbage YAML, damaged checkpoints, a read-only
folder, two commands on one run. Each ends in one clear message (exit status 2 from the parser,
no traceback) or in a documented fallback, and leaves the run's files as they were."""

from __future__ import annotations

import base64
import json
import os
import pickle
import shutil
import subprocess
import sys
import warnings
import zipfile
from collections import OrderedDict
from pathlib import Path

import numpy as np
import pytest
import yaml

from tandem_env.envs.registration import LEVEL_FLIGHT_ID
from tandem_env.io.files import FolderInUse
from tandem_env.io.progress_bar import ProgressBar, warnings_as_lines
from train.__main__ import main
from train.run_folder import LOCK_FILE, RunLayout, resolve_run_dir, run_lock
from train.saved import parse_run_yaml, read_run_yaml

REPO = Path(__file__).resolve().parents[2]
NAME = "TandemWing-LevelFlight-v0"
# One PPO iteration is n_steps 4 x n_envs 16 = 64 env steps; checkpoints at 64 and 128.
COMMON = ["--algo", "ppo", "--env", LEVEL_FLIGHT_ID, "--no-progress", "--no-tensorboard"]
COMMON += ["--eval-freq", "0", "--save-freq", "64", "--verbose", "1"]
FIRST = [*COMMON, "-n", "128", "--n-envs", "16", "--hyperparams", "n_steps=4", "batch_size=64"]


@pytest.fixture(scope="module")
def finished_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A run of 128 env steps at V = 1.5 m/s with checkpoints at 64 and 128."""
    logs = tmp_path_factory.mktemp("logs")
    assert main([*FIRST, "-f", str(logs), "--env-kwargs", "speed=1.5"]) == 0
    run_dir = logs / "ppo" / f"{NAME}_1"
    assert [c.step for c in RunLayout(run_dir, LEVEL_FLIGHT_ID).checkpoints()] == [64, 128]
    return run_dir


def _copy(run_dir: Path, tmp_path: Path) -> RunLayout:
    target = tmp_path / "ppo" / run_dir.name
    shutil.copytree(run_dir, target)
    return RunLayout(target, LEVEL_FLIGHT_ID)


def _files(folder: Path) -> dict[Path, bytes]:
    return {p: p.read_bytes() for p in folder.rglob("*") if p.is_file() and p.name != LOCK_FILE}


def _refused(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    with pytest.raises(SystemExit) as exit_:
        main(argv)
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return err


# --- YAML ----------------------------------------------------------------------------------------
def test_the_zoo_tags_are_read_as_plain_values(tmp_path: Path) -> None:
    text = yaml.dump(OrderedDict([("algo", "sac"), ("train_freq", (1, "step")), ("n", None)]))
    assert "!!python/object/apply:collections.OrderedDict" in text and "!!python/tuple" in text
    data = parse_run_yaml(text, tmp_path / "args.yml")
    assert data == {"algo": "sac", "train_freq": (1, "step"), "n": None}
    assert type(data) is dict and type(data["train_freq"]) is tuple


@pytest.mark.parametrize(
    "text",
    [
        "algo: !!python/object/apply:os.system ['touch {marker}']\n",
        "!!python/object/apply:os.system ['touch {marker}']\n",
        "a: !!python/name:os.system\n",
        "a: !!python/object/new:subprocess.Popen [['touch', '{marker}']]\n",
        # The admitted tag in another form than the zoo's is refused too.
        "!!python/object/apply:collections.OrderedDict {{args: [[[a, 1]]]}}\n",
    ],
)
def test_a_python_tag_is_refused_and_nothing_runs(tmp_path: Path, text: str) -> None:
    marker = tmp_path / "marker"
    path = tmp_path / "args.yml"
    path.write_text(text.format(marker=marker))
    with pytest.raises(ValueError, match="refused: it holds the YAML tag") as error:
        read_run_yaml(path)
    assert str(path) in str(error.value)
    assert not marker.exists()


def test_resume_of_a_run_with_an_unsafe_args_file_is_refused(
    finished_run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    layout = _copy(finished_run, tmp_path)
    marker = tmp_path / "executed"
    layout.args_file.write_text(
        layout.args_file.read_text()
        + f"extra: !!python/object/apply:os.system ['touch {marker}']\n"
    )
    files = _files(layout.run_dir)
    err = _refused([*COMMON, "--resume", "-f", str(tmp_path), "-n", "192"], capsys)
    assert f"{layout.args_file}: refused: it holds the YAML tag" in err
    assert "python/object/apply:os.system" in err
    assert not marker.exists()
    assert _files(layout.run_dir) == files


@pytest.mark.parametrize(
    ("text", "what"),
    [
        ("n_envs: [16\npolicy: {{\n", "is not readable YAML"),
        ("- just\n- a list\n", "holds a YAML list, not a mapping of settings"),
        (b"\xff\xfe\x00garbage", "is not UTF-8 text"),
    ],
)
def test_a_garbage_config_file_is_named(
    finished_run: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    text: str | bytes,
    what: str,
) -> None:
    layout = _copy(finished_run, tmp_path)
    if isinstance(text, bytes):
        layout.config_file.write_bytes(text)
    else:
        layout.config_file.write_text(text)
    files = _files(layout.run_dir)
    err = _refused([*COMMON, "--run-dir", str(layout.run_dir), "-n", "192"], capsys)
    assert f"{layout.config_file} {what}" in err
    assert _files(layout.run_dir) == files


def test_a_missing_config_file_is_refused_not_replaced_by_the_yml(
    finished_run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Without config.yml the resume took the yml's current hyperparameters, unsaid: a run of
    two settings under one name."""
    layout = _copy(finished_run, tmp_path)
    layout.config_file.unlink()
    files = _files(layout.run_dir)
    err = _refused([*COMMON, "--run-dir", str(layout.run_dir), "-n", "192"], capsys)
    assert f"{layout.config_file} is missing: the hyperparameters the run started with" in err
    assert _files(layout.run_dir) == files


# --- checkpoints ---------------------------------------------------------------------------------
def test_a_truncated_checkpoint_falls_back_to_the_intact_earlier_one(
    finished_run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    layout = _copy(finished_run, tmp_path)
    newest = layout.checkpoint(128).model
    newest.write_bytes(newest.read_bytes()[: newest.stat().st_size // 2])
    assert main([*COMMON, "--run-dir", str(layout.run_dir), "-n", "192"]) == 0
    captured = capsys.readouterr()
    # One line on stderr (the command shows warnings as lines), naming the file and why.
    assert any(
        line.startswith("RuntimeWarning: skipping checkpoint rl_model_128_steps.zip")
        and "rl_model_128_steps.zip is damaged (not a complete model file" in line
        for line in captured.err.splitlines()
    ), captured.err
    out = captured.out
    assert "from checkpoint rl_model_64_steps.zip (step 64 of 192)" in out
    assert "192 steps in" in out


def test_a_damaged_only_checkpoint_is_said_without_a_traceback(
    finished_run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    layout = _copy(finished_run, tmp_path)
    for checkpoint in layout.checkpoints():
        checkpoint.model.write_bytes(b"PK\x03\x04 not a zip")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        err = _refused([*COMMON, "--resume", "-f", str(tmp_path), "-n", "192"], capsys)
    assert f"{layout.run_dir}: no checkpoint is intact (rl_model_64_steps.zip, rl_model_128" in err


# --- the folder ----------------------------------------------------------------------------------
@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders")
def test_a_read_only_run_folder_is_refused_before_training(
    finished_run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    layout = _copy(finished_run, tmp_path)
    (layout.run_dir / LOCK_FILE).unlink(missing_ok=True)
    layout.run_dir.chmod(0o555)
    try:
        err = _refused([*COMMON, "--run-dir", str(layout.run_dir), "-n", "192"], capsys)
    finally:
        layout.run_dir.chmod(0o755)
    assert f"{layout.run_dir} is not writable" in err


def test_an_os_error_during_the_run_is_one_line(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import train.run

    def full_disk(config: object) -> None:
        raise OSError(28, "No space left on device", str(tmp_path / "rl_model_64_steps.zip"))

    monkeypatch.setattr(train.run, "train", full_disk)
    assert main([*FIRST, "-f", str(tmp_path)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        f"python -m train: error: [Errno 28] No space left on device: "
        f"'{tmp_path / 'rl_model_64_steps.zip'}'"
    ]


def test_a_second_command_on_a_run_in_use_is_refused(
    finished_run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    layout = _copy(finished_run, tmp_path)
    files = _files(layout.run_dir)
    with run_lock(layout.run_dir):
        err = _refused([*COMMON, "--resume", "-f", str(tmp_path), "-n", "192"], capsys)
        assert f"{layout.run_dir} is in use: another python -m train (pid {os.getpid()})" in err
        with pytest.raises(FolderInUse):
            run_lock(layout.run_dir).acquire()
    assert _files(layout.run_dir) == files
    run_lock(layout.run_dir).acquire().release()  # released on exit of the block


def test_the_lock_of_a_killed_process_is_not_stale(tmp_path: Path) -> None:
    holder = subprocess.Popen(
        [
            sys.executable,
            "-c",
            "import sys, time; from train.run_folder import run_lock; "
            f"run_lock({str(tmp_path)!r}).acquire(); print('held', flush=True); time.sleep(60)",
        ],
        cwd=REPO,
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert holder.stdout is not None and holder.stdout.readline().strip() == "held"
        with pytest.raises(FolderInUse, match=f"pid {holder.pid}"):
            run_lock(tmp_path).acquire()
    finally:
        holder.kill()
        holder.wait()
    with run_lock(tmp_path):  # the kernel released the killed holder's lock
        assert (tmp_path / LOCK_FILE).read_text().strip() == str(os.getpid())


# --- the latest run, and warnings under a progress bar -------------------------------------------
def test_a_run_prefix_is_its_latest_run(tmp_path: Path) -> None:
    algo = tmp_path / "ppo"
    for n in (1, 2, 10):
        (algo / f"{NAME}_{n}").mkdir(parents=True)
    assert resolve_run_dir(algo / NAME) == algo / f"{NAME}_10"
    assert resolve_run_dir(algo / f"{NAME}_2") == algo / f"{NAME}_2"
    assert resolve_run_dir(algo / "Other-v0") == algo / "Other-v0"  # no run: as given


def test_readme_training_order_runs_on_a_fresh_folder(
    finished_run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The README's training block in order, small: train, resume the latest run with a larger
    target, ask the latest run's policy through the harness (the run number is not written)."""
    from eval.__main__ import main as eval_main

    layout = _copy(finished_run, tmp_path / "logs")
    assert main([*COMMON, "--resume", "-f", str(tmp_path / "logs"), "-n", "192"]) == 0
    assert "(step 128 of 192)" in capsys.readouterr().out
    spec = f"policy:{tmp_path / 'logs' / 'ppo' / NAME}"
    argv = ["optimize", "--task", "level", "--speed", "1.0", "--method", spec]
    argv += ["--budget", "1", "--seeds", "0", "--out", str(tmp_path / "results")]
    assert eval_main(argv) == 0
    captured = capsys.readouterr()
    lines = [line for line in captured.err.splitlines() if "TrainingMismatchWarning" in line]
    # One clean line: the category, the run resolved to its number, what differs.
    assert len(lines) == 1, captured.err
    assert lines[0].startswith(f"TrainingMismatchWarning: {layout.run_dir} was trained at")


def test_a_warning_is_one_line_above_a_bar(capsys: pytest.CaptureFixture[str]) -> None:
    with warnings_as_lines(), ProgressBar(10, "work") as bar:
        bar.move_to(3)
        warnings.warn("trained at\n  speed 1.5, asked at 1.0", RuntimeWarning, stacklevel=1)
        bar.move_to(10)
    err = capsys.readouterr().err
    assert "RuntimeWarning: trained at speed 1.5, asked at 1.0\n" in err
    assert "warnings.warn(" not in err


# --- pickled files of a run folder ---------------------------------------------------------------
class _Touch:
    """Unpickling this runs ``touch path`` (what a hostile file would do)."""

    def __init__(self, path: Path) -> None:
        self.path = path

    def __reduce__(self):
        return (os.system, (f"touch {self.path}",))


def test_a_policy_is_loaded_without_unpickling_its_model_file(
    finished_run: Path, tmp_path: Path
) -> None:
    from train.trained_policy import TrainedPolicy

    layout = _copy(finished_run, tmp_path)
    marker = tmp_path / "executed"
    original = layout.final_model.read_bytes()
    expected = TrainedPolicy.load(layout.run_dir, "final").strokes([1.5])
    # The same model file with a hostile cloudpickled entry in its JSON `data`, one that SB3's
    # `load` would unpickle (an entry SB3 does not write is refused: test_run_folder_payloads).
    hostile = tmp_path / "hostile.zip"
    with zipfile.ZipFile(layout.final_model) as source, zipfile.ZipFile(hostile, "w") as target:
        for item in source.infolist():
            content = source.read(item)
            if item.filename == "data":
                data = json.loads(content)
                data["policy_class"] = {
                    ":type:": "<class 'object'>",
                    ":serialized:": base64.b64encode(pickle.dumps(_Touch(marker))).decode(),
                }
                content = json.dumps(data).encode()
            target.writestr(item, content)
    shutil.move(hostile, layout.final_model)
    assert layout.final_model.read_bytes() != original
    policy = TrainedPolicy.load(layout.run_dir, "final")
    np.testing.assert_array_equal(policy.strokes([1.5]), expected)
    assert policy.num_timesteps == 128
    assert not marker.exists()


def test_normalisation_statistics_are_read_with_their_classes_only(tmp_path: Path) -> None:
    from stable_baselines3.common.vec_env import VecNormalize

    from tandem_env.envs.sb3 import make_sb3_vec_env
    from train.saved import read_normalizer

    venv = make_sb3_vec_env(LEVEL_FLIGHT_ID, n_envs=2, seed=0)
    saved = VecNormalize(venv, norm_obs=True, norm_reward=False)
    saved.reset()
    saved.save(str(tmp_path / "vecnormalize.pkl"))
    loaded = read_normalizer(tmp_path / "vecnormalize.pkl")
    np.testing.assert_array_equal(loaded.obs_rms.mean, saved.obs_rms.mean)
    loaded.set_venv(venv)

    marker = tmp_path / "executed"
    (tmp_path / "hostile.pkl").write_bytes(pickle.dumps(_Touch(marker)))
    with pytest.raises(
        ValueError, match=r"refused: not a VecNormalize file of SB3 .*posix\.system"
    ):
        read_normalizer(tmp_path / "hostile.pkl")
    assert not marker.exists()
