"""Training learns, a saved model acts the same after loading, and a killed run resumes."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
import zipfile
from pathlib import Path

import numpy as np
import pytest
from stable_baselines3 import PPO, SAC

import tandem_env  # noqa: F401 - registers the ids
from tandem_env.envs.registration import LEVEL_FLIGHT_ID
from tandem_env.envs.sb3 import make_sb3_vec_env
from train.config import TrainConfig, load_entry
from train.run import budget_hyperparams, learn_in_memory, train
from train.run_folder import Checkpoint, RunLayout
from train.trained_policy import TrainedPolicy

SPEED = 1.5
REPO = Path(__file__).resolve().parents[2]

# Every hyperparameter the learning check depends on, pinned here so that retuning the yml
# files cannot silently change what this test measures.
PPO_SHORT = {
    "n_steps": 4,
    "batch_size": 256,
    "n_epochs": 10,
    "learning_rate": 1e-3,
    "gamma": 0.0,
    "gae_lambda": 1.0,
    "clip_range": 0.2,
    "ent_coef": 0.0,
    "policy_kwargs": "dict(net_arch=dict(pi=[64, 64], vf=[64, 64]), log_std_init=-1.0)",
}
SHORT_STEPS = 8192
SHORT_ENVS = 64

# Measured (docs/training.md, "Learning check"): random strokes at V = 1.5 m/s score a mean
# reward of -34.8 (std 16.3, 95th percentile -11.1, 4096 strokes); the untrained deterministic
# policy (actions ~0, the box centre) scores -53 to -55; after SHORT_STEPS steps of PPO_SHORT the
# deterministic policy scored -0.11, -0.33, -0.91, -1.07, -1.60 for seeds 0-4 (7 s each).
TRAINED_AT_LEAST = -5.0
MARGIN_OVER_RANDOM = 25.0


def _reward(action: np.ndarray) -> float:
    env = make_sb3_vec_env(LEVEL_FLIGHT_ID, n_envs=1, seed=0, speed=SPEED)
    env.reset()
    _, _, _, info = env.step(np.asarray(action, dtype=np.float32).reshape(1, -1))
    env.close()
    return float(info[0]["objective"] - info[0]["penalty"])


def test_short_ppo_run_beats_random_strokes() -> None:
    env = make_sb3_vec_env(LEVEL_FLIGHT_ID, n_envs=2048, seed=0, speed=SPEED)
    env.reset()
    rng = np.random.default_rng(0)
    _, random_rewards, _, _ = env.step(rng.uniform(-1, 1, (2048, 28)).astype(np.float32))
    env.close()
    random_mean = float(np.mean(random_rewards))

    hp = budget_hyperparams(
        "ppo", load_entry("ppo", LEVEL_FLIGHT_ID), PPO_SHORT, SHORT_ENVS, SHORT_STEPS
    )
    model, recorder = learn_in_memory(hp, LEVEL_FLIGHT_ID, {"speed": SPEED}, seed=0)
    assert recorder.evaluations == SHORT_STEPS
    observation = model.get_env().reset()[:1]
    action, _ = model.predict(observation, deterministic=True)
    trained = _reward(action[0])
    assert trained > TRAINED_AT_LEAST, (trained, random_mean)
    assert trained - random_mean > MARGIN_OVER_RANDOM, (trained, random_mean)


@pytest.mark.parametrize("algo", ["ppo", "sac"])
def test_save_load_gives_the_same_actions(algo: str, tmp_path: Path) -> None:
    overrides = {"n_steps": 4, "batch_size": 64} if algo == "ppo" else {"learning_starts": 64}
    hp = budget_hyperparams(algo, load_entry(algo, LEVEL_FLIGHT_ID), overrides, 16, 512)
    model, _ = learn_in_memory(hp, LEVEL_FLIGHT_ID, {"speed_range": (0.25, 2.0)}, seed=1)
    observations = np.linspace(-1, 1, 9, dtype=np.float32)[:, None]
    before, _ = model.predict(observations, deterministic=True)
    model.save(tmp_path / "model.zip")
    loaded = (PPO if algo == "ppo" else SAC).load(tmp_path / "model.zip", device="cpu")
    after, _ = loaded.predict(observations, deterministic=True)
    np.testing.assert_array_equal(before, after)


def test_run_folder_policy_matches_its_model(tmp_path: Path) -> None:
    config = TrainConfig(
        algo="ppo",
        env_id=LEVEL_FLIGHT_ID,
        n_timesteps=512,
        n_envs=16,
        seed=2,
        env_kwargs={"speed_range": (0.25, 2.0)},
        hyperparams={"n_steps": 4, "batch_size": 64},
        log_folder=tmp_path,
        eval_freq=256,
        save_freq=256,
        progress_bar=False,
        tensorboard=False,
        verbose=0,
    )
    result = train(config)
    assert result.run_dir is not None
    policy = TrainedPolicy.load(result.run_dir, "final")
    speeds = [0.25, 1.0, 2.0]
    observations = (2 * (np.array(speeds) - 0.25) / 1.75 - 1).astype(np.float32)[:, None]
    expected, _ = PPO.load(RunLayout(result.run_dir, LEVEL_FLIGHT_ID).final_model).predict(
        observations, deterministic=True
    )
    np.testing.assert_allclose(policy.strokes(speeds), np.clip(expected, -1, 1), rtol=0, atol=1e-7)


def test_killed_run_resumes_from_its_last_checkpoint(tmp_path: Path) -> None:
    command = [
        sys.executable,
        "-m",
        "train",
        "--algo",
        "sac",
        "--env",
        LEVEL_FLIGHT_ID,
        "-n",
        "1000000",
        "--n-envs",
        "16",
        "--seed",
        "3",
        "--save-freq",
        "256",
        "--eval-freq",
        "128",
        "--hyperparams",
        "learning_starts=64",
        "gradient_steps=1",
        "-f",
        str(tmp_path),
        "--no-progress",
        "--verbose",
        "0",
    ]
    layout = RunLayout(tmp_path / "sac" / "TandemWing-LevelFlight-v0_1", LEVEL_FLIGHT_ID)
    process = subprocess.Popen(
        command, cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, start_new_session=True
    )
    try:
        deadline = time.monotonic() + 90
        # Two complete checkpoints: the first is surely complete when the second starts.
        while time.monotonic() < deadline and len(layout.checkpoints()) < 2:
            assert process.poll() is None, process.stderr.read().decode() if process.stderr else ""
            time.sleep(0.2)
    finally:
        os.killpg(process.pid, signal.SIGKILL)
        process.wait()
    assert len(layout.checkpoints()) >= 2, "no checkpoint before the deadline"
    assert not layout.final_model.exists()

    config = TrainConfig(
        algo="sac",
        env_id=LEVEL_FLIGHT_ID,
        n_timesteps=None,
        log_folder=tmp_path,
        resume=True,
        progress_bar=False,
        verbose=0,
    )
    complete = [c for c in layout.checkpoints() if _complete(c)]
    last = complete[-1].step
    target = last + 256  # two evaluations (eval_freq 128) after the resume
    result = train(TrainConfig(**{**_fields(config), "n_timesteps": target}))
    assert result.resumed_from == last
    assert result.num_timesteps == target  # the step count continued, not restarted
    # The replay buffer continued too: it holds every transition since step 0.
    with np.load(layout.checkpoint(target).replay_buffer, allow_pickle=False) as buffer:
        assert not buffer["full"] and buffer["pos"] * 16 == target
        assert buffer["actions"].shape == (target // 16, 16, 28)
    with np.load(layout.evaluations) as evaluations:
        steps = evaluations["timesteps"]
    assert steps[0] <= last < steps[-1] and np.all(np.diff(steps) > 0)
    assert len(layout.monitor_files()) == 2  # one per training segment


def _complete(checkpoint: Checkpoint) -> bool:
    """Whether the checkpoint's model and replay buffer are whole zips (every CRC right)."""
    if not checkpoint.replay_buffer.is_file():
        return False
    with (
        zipfile.ZipFile(checkpoint.model) as model,
        zipfile.ZipFile(checkpoint.replay_buffer) as rb,
    ):
        return model.testzip() is None and rb.testzip() is None


def _fields(config: TrainConfig) -> dict:
    from dataclasses import fields

    return {f.name: getattr(config, f.name) for f in fields(config)}


def test_ctrl_c_saves_a_checkpoint_says_one_line_and_the_run_resumes(tmp_path: Path) -> None:
    """Ctrl-C (SIGINT to the process group, as a terminal sends it) stops at the next step,
    saves a checkpoint at the last whole iteration and exits with 130: no traceback, no tqdm
    error at exit, and a resume continues from that checkpoint."""
    command = [sys.executable, "-m", "train", "--algo", "sac", "--env", LEVEL_FLIGHT_ID,
               "-n", "1000000", "--n-envs", "16", "--seed", "3", "--save-freq", "256",
               "--eval-freq", "0", "--hyperparams", "learning_starts=64", "gradient_steps=1",
               "-f", str(tmp_path), "--verbose", "0"]  # fmt: skip  # the progress bar is on
    layout = RunLayout(tmp_path / "sac" / "TandemWing-LevelFlight-v0_1", LEVEL_FLIGHT_ID)
    process = subprocess.Popen(
        command,
        cwd=REPO,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),  # as a terminal's
    )
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and not layout.checkpoints():
            assert process.poll() is None, process.communicate()
            time.sleep(0.2)
        assert layout.checkpoints(), "no checkpoint before the deadline"
        os.killpg(process.pid, signal.SIGINT)
        out, err = process.communicate(timeout=120)
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()
    assert process.returncode == 130, (out, err)
    assert "Traceback" not in err and "meta_path" not in err, err
    said = [line for line in err.splitlines() if "interrupted" in line]
    assert len(said) == 1 and f"--run-dir {layout.run_dir}" in said[0], err
    last = layout.checkpoints()[-1]
    assert _complete(last)
    assert str(last.model) in said[0] and last.step % 16 == 0
    assert not layout.final_model.exists()
    # The buffer holds exactly the transitions up to the checkpoint's step.
    with np.load(last.replay_buffer, allow_pickle=False) as buffer:
        assert buffer["pos"] * 16 == last.step

    config = TrainConfig(
        algo="sac",
        env_id=LEVEL_FLIGHT_ID,
        n_timesteps=last.step + 32,
        log_folder=tmp_path,
        run_dir=layout.run_dir,
        progress_bar=False,
        verbose=0,
    )
    result = train(config)
    assert result.resumed_from == last.step and result.num_timesteps == last.step + 32
