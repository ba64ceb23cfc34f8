"""``python -m train`` continues only its own runs, and says what it does.

rl_zoo3 writes the same layout into the same folders (``logs/<algo>/<env>_<n>/``), so a
``--resume`` used to adopt a zoo run and overwrite its model, args and config. Training stops
at whole iterations, so the target is rounded up and said; a resume says from which
checkpoint; a resume with nothing left says so and changes nothing.
"""

from __future__ import annotations

from collections import OrderedDict
from pathlib import Path

import pytest
import yaml

from tandem_env.envs.registration import LEVEL_FLIGHT_ID
from train.__main__ import main
from train.run_folder import MADE_BY, RunLayout

NAME = "TandemWing-LevelFlight-v0"


def _zoo_run(folder: Path) -> dict[Path, bytes]:
    """A run folder as rl_zoo3.train writes it (args.yml is a python-tagged OrderedDict)."""
    params = folder / NAME
    params.mkdir(parents=True)
    args = OrderedDict(
        (key, value)
        for key, value in sorted(
            {
                "algo": "ppo",
                "env": LEVEL_FLIGHT_ID,
                "n_timesteps": -1,
                "seed": 0,
                "save_freq": 1000,
                "eval_freq": 25000,
                "trained_agent": "",
                "num_threads": -1,
                "env_kwargs": None,
                "hyperparams": None,
                "log_folder": "logs",
                "gym_packages": ["tandem_env"],
            }.items()
        )
    )
    (params / "args.yml").write_text(yaml.dump(args))
    (params / "config.yml").write_text(yaml.dump(OrderedDict([("n_envs", 8)])))
    for name in (f"{NAME}.zip", "rl_model_1000_steps.zip", "evaluations.npz"):
        (folder / name).write_bytes(b"zoo " + name.encode())
    return {path: path.read_bytes() for path in folder.rglob("*") if path.is_file()}


def _own_args(folder: Path, **extra) -> None:
    params = folder / NAME
    params.mkdir(parents=True)
    args = {"made_by": MADE_BY, "algo": "ppo", "env": LEVEL_FLIGHT_ID, "seed": 0, **extra}
    (params / "args.yml").write_text(yaml.safe_dump(args))


def _unchanged(files: dict[Path, bytes]) -> bool:
    return all(path.read_bytes() == data for path, data in files.items())


def test_resume_refuses_a_zoo_run_and_names_ours(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    algo_folder = tmp_path / "ppo"
    _own_args(algo_folder / f"{NAME}_1")
    files = _zoo_run(algo_folder / f"{NAME}_2")
    with pytest.raises(SystemExit) as exit_:
        main(["--algo", "ppo", "--env", LEVEL_FLIGHT_ID, "--resume", "-f", str(tmp_path)])
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert f"{NAME}_2 was not written by python -m train" in err
    assert "rl-baselines3-zoo" in err and "left untouched" in err
    assert f"--run-dir {algo_folder / f'{NAME}_1'}" in err
    assert _unchanged(files)


def test_run_dir_refuses_folders_it_did_not_write(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    zoo = tmp_path / "zoo"
    files = _zoo_run(zoo)
    other = tmp_path / "other"
    (other / "TandemWing-Accelerate-v0").mkdir(parents=True)
    (other / "TandemWing-Accelerate-v0" / "args.yml").write_text("made_by: x\n")
    stray = tmp_path / "stray"
    stray.mkdir()
    (stray / "notes.txt").write_text("mine")
    expected = {
        zoo: "was not written by python -m train (it looks like an rl-baselines3-zoo run",
        other: "holds a run of TandemWing-Accelerate-v0",
        stray: f"holds files but no {NAME}/args.yml",
    }
    for folder, message in expected.items():
        with pytest.raises(SystemExit):
            main(["--algo", "ppo", "--env", LEVEL_FLIGHT_ID, "--run-dir", str(folder)])
        err = capsys.readouterr().err
        assert message in err and "left untouched" in err, err
    assert _unchanged(files) and (stray / "notes.txt").read_text() == "mine"


def test_a_finished_run_without_checkpoints_is_not_overwritten(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    run_dir = tmp_path / "run"
    _own_args(run_dir, save_freq=0)
    (run_dir / f"{NAME}.zip").write_bytes(b"final model")
    with pytest.raises(SystemExit):
        main(["--algo", "ppo", "--env", LEVEL_FLIGHT_ID, "--run-dir", str(run_dir)])
    err = capsys.readouterr().err
    assert "holds a finished run" in err and "no checkpoint" in err
    assert (run_dir / f"{NAME}.zip").read_bytes() == b"final model"


def test_rounding_resume_and_a_complete_run_are_said(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    common = ["--algo", "ppo", "--env", LEVEL_FLIGHT_ID, "-f", str(tmp_path), "--no-progress"]
    common += ["--no-tensorboard", "--eval-freq", "0", "--save-freq", "64"]
    zoo = _zoo_run(tmp_path / "ppo" / f"{NAME}_1")  # a new run goes beside it, to _2
    first = [
        *common,
        "-n",
        "100",
        "--n-envs",
        "16",
        "--hyperparams",
        "n_steps=4",
        "batch_size=64",
    ]
    assert main(first) == 0
    out = capsys.readouterr().out
    # One PPO iteration is n_steps 4 x n_envs 16 = 64 env steps: 100 becomes 128, said once.
    assert (
        "n_timesteps 100 is not a whole number of PPO iterations (64 env steps = n_steps 4 x "
        "n_envs 16); training runs to 128"
    ) in out
    assert "128 steps in" in out
    run_dir = tmp_path / "ppo" / f"{NAME}_2"
    layout = RunLayout(run_dir, LEVEL_FLIGHT_ID)
    assert yaml.safe_load(layout.args_file.read_text())["made_by"] == MADE_BY
    assert _unchanged(zoo)

    assert main([*common, "--run-dir", str(run_dir), "-n", "192"]) == 0
    out = capsys.readouterr().out
    assert f"resuming {run_dir} from checkpoint rl_model_128_steps.zip (step 128 of 192)" in out
    assert "best stroke seen since step 128" in out and "-inf" not in out

    model = layout.final_model.read_bytes()
    segments = len(layout.monitor_files())
    assert main([*common, "--run-dir", str(run_dir)]) == 0  # the run's own target: 128
    out = capsys.readouterr().out
    assert f"{run_dir} is complete: its last checkpoint is at 192 env steps" in out
    assert "nothing was trained or changed" in out and "nan" not in out
    assert layout.final_model.read_bytes() == model and len(layout.monitor_files()) == segments
