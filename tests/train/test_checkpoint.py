"""A checkpoint loaded without unpickling is the checkpoint SB3's own ``load`` gives: the same
weights, optimiser states, counters and replay buffer, and training resumed from either goes on
identically."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
import torch

import tandem_env  # noqa: F401 - registers the ids
from tandem_env.envs.registration import LEVEL_FLIGHT_ID
from train.config import load_entry, resolve_hyperparams
from train.run import make_training_env, torch_threads
from train.run_folder import RunLayout
from train.saved import (
    ALGORITHMS,
    REPLAY_ARRAYS,
    build_model,
    load_model,
    load_replay_buffer,
    save_checkpoint,
)

OVERRIDES = {
    "ppo": {"n_steps": 4, "batch_size": 64},
    "sac": {"learning_starts": 32, "batch_size": 32, "gradient_steps": 2},
}
N_ENVS = 16
SEED = 4


def _venv(seed: int) -> Any:
    venv, _ = make_training_env(
        LEVEL_FLIGHT_ID, N_ENVS, seed, {"speed": 1.5}, monitor_file=None, normalize=None
    )
    return venv


def _assert_same(a: Any, b: Any, where: str = "") -> None:
    """Nested state dicts (tensors, numbers, lists, dicts) equal exactly."""
    if isinstance(a, torch.Tensor):
        assert isinstance(b, torch.Tensor) and torch.equal(a, b), where
    elif isinstance(a, dict):
        assert isinstance(b, dict) and sorted(a, key=str) == sorted(b, key=str), where
        for key in a:
            _assert_same(a[key], b[key], f"{where}.{key}")
    elif isinstance(a, list | tuple):
        assert len(a) == len(b), where
        for k, (x, y) in enumerate(zip(a, b, strict=True)):
            _assert_same(x, y, f"{where}[{k}]")
    else:
        assert a == b, (where, a, b)


@pytest.mark.parametrize("algo", ["ppo", "sac"])
def test_a_checkpoint_loads_as_sb3_loads_it_and_resumes_identically(
    algo: str, tmp_path: Path
) -> None:
    hp = resolve_hyperparams(
        load_entry(algo, LEVEL_FLIGHT_ID),
        OVERRIDES[algo],
        algo=algo,
        n_envs=N_ENVS,
        n_timesteps=128,
    )
    layout = RunLayout(tmp_path, LEVEL_FLIGHT_ID)
    with torch_threads(1):
        model = build_model(
            algo, hp, _venv(SEED), seed=SEED, tensorboard_log=None, verbose=0, device="cpu"
        )
        model.learn(64)
        checkpoint = save_checkpoint(model, layout)
        reference = tmp_path / "reference_buffer.pkl"
        if algo == "sac":
            model.save_replay_buffer(reference)  # SB3's pickle: written here, trusted here

        # SB3's own load (it unpickles: only for this comparison), then ours.
        theirs = ALGORITHMS[algo].load(checkpoint.model, env=_venv(SEED + 1), device="cpu")
        if algo == "sac":
            theirs.load_replay_buffer(reference)
        ours = load_model(
            algo, checkpoint.model, hp, _venv(SEED + 1), seed=SEED, **checkpoint.loads(algo)
        )

        assert ours.num_timesteps == theirs.num_timesteps == 64
        _assert_same(ours.get_parameters(), theirs.get_parameters())
        if algo == "sac":
            assert torch.equal(ours.log_ent_coef, theirs.log_ent_coef)
            for name in REPLAY_ARRAYS:
                np.testing.assert_array_equal(
                    getattr(ours.replay_buffer, name), getattr(theirs.replay_buffer, name)
                )
            assert (ours.replay_buffer.pos, ours.replay_buffer.full) == (64 // N_ENVS, False)
            assert theirs.replay_buffer.pos == ours.replay_buffer.pos

        # What python -m train does after loading, then one more segment of training.
        for resumed in (ours, theirs):
            resumed.set_random_seed(SEED + resumed.num_timesteps)
            resumed.learn(64, reset_num_timesteps=False)
    assert ours.num_timesteps == theirs.num_timesteps == 128
    _assert_same(ours.get_parameters(), theirs.get_parameters())


def test_a_replay_buffer_of_another_run_is_refused(tmp_path: Path) -> None:
    hp = resolve_hyperparams(
        load_entry("sac", LEVEL_FLIGHT_ID),
        OVERRIDES["sac"],
        algo="sac",
        n_envs=N_ENVS,
        n_timesteps=64,
    )
    with torch_threads(1):
        model = build_model(
            "sac", hp, _venv(0), seed=0, tensorboard_log=None, verbose=0, device="cpu"
        )
        model.learn(32)
        checkpoint = save_checkpoint(model, RunLayout(tmp_path, LEVEL_FLIGHT_ID))
        other = resolve_hyperparams(
            load_entry("sac", LEVEL_FLIGHT_ID),
            OVERRIDES["sac"],
            algo="sac",
            n_envs=8,
            n_timesteps=64,
        )
        venv, _ = make_training_env(
            LEVEL_FLIGHT_ID, 8, 0, {"speed": 1.5}, monitor_file=None, normalize=None
        )
        fresh = build_model(
            "sac", other, venv, seed=0, tensorboard_log=None, verbose=0, device="cpu"
        )
    with pytest.raises(ValueError, match="refused as the replay buffer of this run") as error:
        load_replay_buffer(fresh, checkpoint.replay_buffer)
    assert str(checkpoint.replay_buffer) in str(error.value)
    assert "this run's buffer takes float32[2, 8" in str(error.value)  # its n_envs, 8
    assert fresh.replay_buffer.pos == 0 and not fresh.replay_buffer.full
