"""The native vector env equals SyncVectorEnv over n single envs, in one model call per step."""

from __future__ import annotations

import ast
import pickle
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.error import ResetNeeded
from gymnasium.vector import AutoresetMode, SyncVectorEnv

from tandem_env.envs import AccelerateVectorEnv, LevelFlightEnv, LevelFlightVectorEnv
from tandem_env.envs import base as task_module

LEVEL = "TandemWing/LevelFlight-v0"
ACCELERATE_ID = "TandemWing/Accelerate-v0"
CASES: list[tuple[str, dict[str, Any]]] = [
    (LEVEL, {"speed_range": (0.25, 2.0)}),
    (LEVEL, {"speed": 1.0, "thrust_split": "body"}),
    (ACCELERATE_ID, {"objective": "resultant", "available_power_range": (50.0, 90.0)}),
]


def make_pair(
    env_id: str, n: int, mode: AutoresetMode, **kwargs: Any
) -> tuple[gym.vector.VectorEnv, SyncVectorEnv]:
    native = gym.make_vec(
        env_id, num_envs=n, vectorization_mode="vector_entry_point", autoreset_mode=mode, **kwargs
    )
    sync = gym.make_vec(
        env_id,
        num_envs=n,
        vectorization_mode="sync",
        vector_kwargs={"autoreset_mode": mode},
        **kwargs,
    )
    return native, sync


def actions_for(n: int, step: int) -> np.ndarray:
    return np.random.default_rng(step).uniform(-1.0, 1.0, (n, 28)).astype(np.float32)


def test_make_vec_uses_the_native_env_by_default() -> None:
    envs = gym.make_vec(LEVEL, num_envs=3)
    assert isinstance(envs, LevelFlightVectorEnv)
    assert envs.metadata["autoreset_mode"] is AutoresetMode.NEXT_STEP
    assert envs.single_action_space == gym.spaces.Box(-1.0, 1.0, (28,), np.float32)
    assert envs.action_space.shape == (3, 28) and envs.observation_space.shape == (3, 1)
    assert isinstance(gym.make_vec(ACCELERATE_ID, num_envs=2), AccelerateVectorEnv)


@pytest.mark.parametrize(("env_id", "kwargs"), CASES)
def test_next_step_autoreset_matches_sync_vector_env(env_id: str, kwargs: dict, same) -> None:
    n = 5
    native, sync = make_pair(env_id, n, AutoresetMode.NEXT_STEP, **kwargs)
    same(native.reset(seed=123), sync.reset(seed=123))
    for step in range(6):
        actions = actions_for(n, step)
        if step % 2 == 1:
            # Every env terminated last step, so this step resets them: actions are ignored,
            # even invalid ones, exactly as SyncVectorEnv ignores them.
            actions[:, 0] = np.nan
        out_native, out_sync = native.step(actions), sync.step(actions)
        same(out_native, out_sync)
        assert out_native[2].all() == (step % 2 == 0)
    same(native.reset(), sync.reset())
    same(native.step(actions_for(n, 9)), sync.step(actions_for(n, 9)))


@pytest.mark.parametrize(("env_id", "kwargs"), CASES)
def test_same_step_autoreset_matches_sync_vector_env(env_id: str, kwargs: dict, same) -> None:
    n = 4
    native, sync = make_pair(env_id, n, AutoresetMode.SAME_STEP, **kwargs)
    assert native.metadata["autoreset_mode"] is AutoresetMode.SAME_STEP
    same(native.reset(seed=[3, 11, 5, 6]), sync.reset(seed=[3, 11, 5, 6]))
    for step in range(4):
        out_native, out_sync = native.step(actions_for(n, step)), sync.step(actions_for(n, step))
        same(out_native, out_sync)
        assert "final_info" in out_native[4] and out_native[2].all()


def test_partial_reset_mask_and_mixed_infos_match_sync_vector_env(same) -> None:
    n = 4
    native, sync = make_pair(LEVEL, n, AutoresetMode.NEXT_STEP, speed_range=(0.25, 2.0))
    same(native.reset(seed=0), sync.reset(seed=0))
    same(native.step(actions_for(n, 0)), sync.step(actions_for(n, 0)))
    mask = np.array([True, False, True, False])
    same(
        native.reset(options={"reset_mask": mask.copy()}),
        sync.reset(options={"reset_mask": mask.copy()}),
    )
    # Envs 0 and 2 step while 1 and 3 autoreset: one info dict mixing both, with masks.
    out = native.step(actions_for(n, 1))
    same(out, sync.step(actions_for(n, 1)))
    np.testing.assert_array_equal(out[4]["_efficiency"], mask)
    np.testing.assert_array_equal(out[4]["_speed"], np.ones(n, dtype=bool))
    same(native.step(actions_for(n, 2)), sync.step(actions_for(n, 2)))


def test_disabled_autoreset_matches_sync_vector_env(same) -> None:
    n = 3
    native, sync = make_pair(
        ACCELERATE_ID, n, AutoresetMode.DISABLED, available_power_range=(50.0, 90.0)
    )
    same(native.reset(seed=9), sync.reset(seed=9))
    same(native.step(actions_for(n, 0)), sync.step(actions_for(n, 0)))
    with pytest.raises(RuntimeError, match="reset_mask"):
        native.step(actions_for(n, 1))
    mask = np.ones(n, dtype=bool)
    same(
        native.reset(options={"reset_mask": mask}), sync.reset(options={"reset_mask": mask.copy()})
    )
    same(native.step(actions_for(n, 1)), sync.step(actions_for(n, 1)))


def test_reset_options_apply_to_every_env(same) -> None:
    native, sync = make_pair(LEVEL, 3, AutoresetMode.NEXT_STEP, speed_range=(0.25, 2.0))
    out = native.reset(seed=1, options={"speed": 0.5})
    same(out, sync.reset(seed=1, options={"speed": 0.5}))
    np.testing.assert_array_equal(out[1]["speed"], [0.5, 0.5, 0.5])


def test_per_env_generators_match_sync_vector_env() -> None:
    native, sync = make_pair(LEVEL, 3, AutoresetMode.NEXT_STEP, speed_range=(0.25, 2.0))
    native.reset(seed=4)
    sync.reset(seed=4)
    assert native.np_random_seed == sync.np_random_seed == (4, 5, 6)
    states = [g.bit_generator.state for g in native.np_random]
    assert states == [g.bit_generator.state for g in sync.np_random]


def test_started_and_step_checked_are_the_sub_envs_own() -> None:
    """The public primitives the single env drives: ``started`` marks the sub-envs reset so
    far, ``step_checked`` steps only those and refuses the others as ``step`` does."""
    envs = LevelFlightVectorEnv(3, autoreset_mode=AutoresetMode.DISABLED, speed=1.0)
    np.testing.assert_array_equal(envs.started, [False, False, False])
    mask = np.array([True, False, True])
    envs.reset(seed=0, options={"reset_mask": mask})
    np.testing.assert_array_equal(envs.started, mask)
    envs.started[:] = True  # a copy: the env's own state is not handed out
    np.testing.assert_array_equal(envs.started, mask)
    actions = actions_for(2, 0).astype(np.float64)
    batch, observations = envs.step_checked(np.array([0, 2]), actions)
    assert len(batch) == 2 and observations.shape == (2, 1)
    with pytest.raises(ResetNeeded, match="reset"):
        envs.step_checked(np.array([1]), actions[:1])


def test_the_single_env_drives_only_public_members_of_its_vector_env() -> None:
    """No module of the envs (the single env above all) reaches into ``vector_env._...``."""
    env_dir = Path(task_module.__file__).parent
    reached = []
    for path in sorted(env_dir.glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if (
                isinstance(node, ast.Attribute)
                and node.attr.startswith("_")
                and isinstance(node.value, ast.Attribute)
                and node.value.attr == "vector_env"
            ):
                reached.append(f"{path.name}:{node.lineno} vector_env.{node.attr}")
    assert reached == []
    env = LevelFlightEnv(speed=1.0)
    assert isinstance(env.vector_env, LevelFlightVectorEnv) and not hasattr(env, "batch")


def test_stepping_n_envs_is_one_batched_model_call(monkeypatch: pytest.MonkeyPatch) -> None:
    calls: list[int] = []
    evaluate = task_module.evaluate

    def counting(strokes, *args, **kwargs):
        calls.append(len(strokes))
        return evaluate(strokes, *args, **kwargs)

    monkeypatch.setattr(task_module, "evaluate", counting)
    envs = gym.make_vec(LEVEL, num_envs=64, vectorization_mode="vector_entry_point")
    envs.reset(seed=0)
    envs.step(envs.action_space.sample())
    assert calls == [64]
    envs.step(envs.action_space.sample())  # the autoreset step evaluates nothing
    assert calls == [64]


def test_vector_env_pickles_and_renders(same) -> None:
    envs = gym.make_vec(
        LEVEL,
        num_envs=2,
        vectorization_mode="vector_entry_point",
        render_mode="rgb_array",
        speed_range=(0.25, 2.0),
    )
    before = envs.render()
    assert len(before) == 2 and all(f.dtype == np.uint8 and f.ndim == 3 for f in before)
    envs.reset(seed=2)
    copy = pickle.loads(pickle.dumps(envs))
    actions = actions_for(2, 0)
    same(copy.step(actions), envs.step(actions))
    frames = envs.render()
    assert len(frames) == 2 and frames[0].shape == before[0].shape
    envs.close()


def test_every_native_vector_env_names_gymnasiums_vector_env_among_its_direct_bases() -> None:
    """Libraries that tell a vector env by its class's direct bases (skrl's ``wrap_env`` reads
    ``type(env).__bases__``) recognise every registered vector env, made as Gymnasium makes it."""
    from tandem_env.envs.registration import ENTRIES

    for env_id in [i for i in ENTRIES if i.startswith("TandemWing/")]:  # this package's
        envs = gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point")
        assert gym.vector.VectorEnv in type(envs).__bases__, (env_id, type(envs).__bases__)
        assert isinstance(envs, gym.vector.VectorEnv) and envs.num_envs == 2
        assert envs.single_action_space == gym.spaces.Box(-1.0, 1.0, (28,), np.float32)
        assert envs.metadata["autoreset_mode"] is AutoresetMode.NEXT_STEP
        envs.close()
