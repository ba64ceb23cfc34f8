"""``python -m train.envelope`` on a policy trained at one speed: one note, no warnings."""

from __future__ import annotations

import csv
import warnings
from pathlib import Path

import pytest

from tandem_env.envs.registration import LEVEL_FLIGHT_ID
from train.config import TrainConfig
from train.envelope import main
from train.run import train


def test_conditions_outside_training_are_said_once(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    result = train(
        TrainConfig(
            algo="ppo",
            env_id=LEVEL_FLIGHT_ID,
            n_timesteps=64,
            n_envs=16,
            env_kwargs={"speed": 1.5},
            hyperparams={"n_steps": 4, "batch_size": 64},
            log_folder=tmp_path / "logs",
            eval_freq=0,
            save_freq=0,
            progress_bar=False,
            tensorboard=False,
            verbose=0,
        )
    )
    out = tmp_path / "envelope"
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # it used to print one RuntimeWarning per condition
        assert (
            main(["--run", str(result.run_dir), "--out", str(out), "--conditions", "1", "1.5", "2"])
            == 0
        )
    printed = capsys.readouterr()
    assert "Warning" not in printed.err and "Warning" not in printed.out
    lines = printed.out.splitlines()
    assert sum("(outside training)" in line for line in lines) == 2
    [note] = [line for line in lines if line.startswith("note:")]
    assert "trained at speed = 1.5 m/s; 2 of 3 conditions lie outside that" in note
    with (out / "envelope.csv").open() as stream:
        table = list(csv.DictReader(stream))
    assert [row["trained_at"] for row in table] == ["False", "True", "False"]
