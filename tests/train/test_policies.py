"""SB3 models as harness methods: ``policy:RUN_DIR``, ``ppo`` / ``sac``, and the envelope CSV."""

from __future__ import annotations

import csv
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pytest

from agents.harness import run
from agents.records import Record
from tandem_env.envs.registration import LEVEL_FLIGHT_ID
from train.config import TrainConfig
from train.envelope import evaluate_envelope
from train.run import train
from train.trained_policy import TrainedPolicy, load_policy


@pytest.fixture(scope="module")
def envelope_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("logs")
    result = train(
        TrainConfig(
            algo="ppo",
            env_id=LEVEL_FLIGHT_ID,
            n_timesteps=512,
            n_envs=32,
            seed=0,
            env_kwargs={"speed_range": (0.25, 2.0)},
            hyperparams={"n_steps": 4, "batch_size": 64},
            log_folder=folder,
            eval_freq=256,
            save_freq=0,
            progress_bar=False,
            tensorboard=False,
            verbose=0,
        )
    )
    assert result.run_dir is not None
    return result.run_dir


def test_policy_method_records_its_stroke_with_one_evaluation(
    envelope_run: Path, tmp_path: Path
) -> None:
    [record] = run(
        f"policy:{envelope_run}",
        "level",
        1.0,
        budget=5,
        seeds=[0],
        progress=False,
    )
    assert record.evaluations == 1 and record.budget == 5
    expected = load_policy(envelope_run).strokes([1.0])[0]
    np.testing.assert_array_equal(record.normalised_stroke, expected)
    assert record.reward == record.search_reward  # re-evaluated exactly
    assert record.config["method"]["model"] == "best"
    assert record.metrics["speed"] == 1.0
    assert Record.from_dict(record.to_dict()) == record


def test_a_newer_run_into_the_same_out_is_another_job(
    envelope_run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``policy:logs/ppo/<env>`` names the latest run: after a newer one, the same command into
    the same --out runs it, not the older run's record (the run's identity is in the key)."""
    from eval.__main__ import main

    logs = tmp_path / "logs" / "ppo"
    shutil.copytree(envelope_run, logs / f"{envelope_run.name.rsplit('_', 1)[0]}_1")
    spec = f"policy:{logs / envelope_run.name.rsplit('_', 1)[0]}"
    argv = ["optimize", "--task", "level", "--speed", "1", "--method", spec, "--budget", "1",
            "--seeds", "0", "--quiet", "--out", str(tmp_path / "out")]  # fmt: skip
    assert main(argv) == 0 and "1 seed: 1 run" in capsys.readouterr().err
    assert main(argv) == 0 and "0 run, 1 reused" in capsys.readouterr().err
    shutil.copytree(envelope_run, logs / f"{envelope_run.name.rsplit('_', 1)[0]}_2")  # newer
    assert main(argv) == 0 and "1 seed: 1 run" in capsys.readouterr().err


def test_policy_strokes_depend_on_the_condition(envelope_run: Path) -> None:
    policy = TrainedPolicy.load(envelope_run, "final")
    strokes = policy.strokes([0.25, 2.0])
    assert strokes.shape == (2, 28) and np.all(np.abs(strokes) <= 1.0)
    assert not np.array_equal(strokes[0], strokes[1])
    assert policy.training_conditions == (0.25, 2.0)


def test_policy_method_rejects_bad_runs(tmp_path: Path, envelope_run: Path) -> None:
    with pytest.raises(ValueError, match="not a folder"):
        run(f"policy:{tmp_path / 'missing'}", "level", 1.0, budget=1, seeds=[0], progress=False)
    with pytest.raises(ValueError, match="not a training run"):
        run(f"policy:{tmp_path}", "level", 1.0, budget=1, seeds=[0], progress=False)
    with pytest.raises(ValueError, match="trained on"):
        run(f"policy:{envelope_run}", "accelerate", 60.0, budget=1, seeds=[0], progress=False)
    with pytest.raises(ValueError, match="allowed: best, final"):
        run(
            f"policy:{envelope_run}",
            "level",
            1.0,
            budget=1,
            seeds=[0],
            method_config={"model": "newest"},
            progress=False,
        )


@pytest.mark.parametrize("algo", ["ppo", "sac"])
def test_training_methods_stay_within_budget(algo: str) -> None:
    settings = {
        "n_envs": 16,
        **({"n_steps": 4, "batch_size": 64} if algo == "ppo" else {"learning_starts": 64}),
    }
    [record] = run(
        algo, "level", 1.5, budget=300, seeds=[0], method_config=settings, progress=False
    )
    # Training gets budget - 1 = 299 steps, rounded down to whole iterations (PPO 64, SAC 16),
    # then one evaluation of the final deterministic policy.
    assert record.evaluations == (257 if algo == "ppo" else 289)
    assert record.reward == record.search_reward
    config = record.config["method"]
    assert config["training_timesteps"] == record.evaluations - 1
    assert record.reward >= config["final_policy"]["reward"]  # the best stroke seen wins
    assert record.history[-1][0] == record.evaluations


def test_training_methods_reject_a_budget_below_one_iteration() -> None:
    with pytest.raises(ValueError, match="below one PPO iteration"):
        run(
            "ppo", "level", 1.5, budget=100, seeds=[0], method_config={"n_envs": 64}, progress=False
        )
    with pytest.raises(ValueError, match="n_timesteps cannot be set"):
        run(
            "sac",
            "level",
            1.5,
            budget=100,
            seeds=[0],
            method_config={"n_timesteps": 5},
            progress=False,
        )


def test_envelope_csv(envelope_run: Path, tmp_path: Path) -> None:
    rows = evaluate_envelope(envelope_run, tmp_path, conditions=[0.5, 1.5])
    assert [row["condition_value"] for row in rows] == [0.5, 1.5]
    with (tmp_path / "envelope.csv").open() as stream:
        table = list(csv.DictReader(stream))
    assert [float(r["condition_value"]) for r in table] == [0.5, 1.5]
    assert {"efficiency", "feasible", "evaluations"} <= set(table[0])
    assert all(r["evaluations"] == "1" for r in table)
    assert len(list((tmp_path / "records").glob("*.json"))) == 2


def test_training_method_with_log_dir_writes_a_reusable_run(tmp_path: Path) -> None:
    settings = {"n_envs": 16, "n_steps": 4, "batch_size": 64, "log_dir": str(tmp_path)}
    [record] = run(
        "ppo", "level", 1.5, budget=300, seeds=[4], method_config=settings, progress=False
    )
    assert record.evaluations == 257
    assert record.reward == record.search_reward
    run_dir = Path(record.config["method"]["run_dir"])
    assert run_dir == tmp_path / "ppo" / "TandemWing-LevelFlight-v0_1"
    assert (run_dir / "TandemWing-LevelFlight-v0.zip").is_file()
    assert not list(run_dir.glob("rl_model_*"))  # no checkpoints: nothing outside the budget
    final = record.config["method"]["final_policy"]
    [again] = run(f"policy:{run_dir}", "level", 1.5, budget=1, seeds=[0], progress=False)
    assert again.reward == final["reward"]  # the saved final model plays the same stroke


def test_training_method_with_log_dir_takes_a_conf_file_entry_without_n_envs(
    tmp_path: Path,
) -> None:
    """A zoo entry may leave n_envs out (one env, as rl_zoo3 reads it); the run's record says
    the one env it trained with."""
    conf = tmp_path / "ppo.yml"
    conf.write_text(
        "TandemWing/LevelFlight-v0:\n  n_timesteps: 1000\n  policy: MlpPolicy\n"
        "  n_steps: 64\n  batch_size: 64\n  n_epochs: 1\n"
    )
    settings = {"conf_file": str(conf), "log_dir": str(tmp_path / "logs")}
    [record] = run(
        "ppo", "level", 1.5, budget=128, seeds=[4], method_config=settings, progress=False
    )
    assert record.config["method"]["n_envs"] == 1
    assert "n_envs" not in record.config["method"]["hyperparams"]


def test_training_leaves_nothing_in_the_temp_dir(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Without TensorBoard, SB3's default logger would make an empty SB3-<time> folder in the
    temp dir at every learn(): one per harness run, thousands over a sweep."""
    temp = tmp_path / "temp"
    temp.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(temp))
    monkeypatch.delenv("SB3_LOGDIR", raising=False)  # the suite's (tests/conftest.py)
    settings = {"n_envs": 16, "n_steps": 4, "batch_size": 64}
    run("ppo", "level", 1.5, budget=128, seeds=[0], method_config=settings, progress=False)
    assert list(temp.glob("SB3-*")) == []
