"""SpeedChange's API: the vector env and SB3 adapter equal their single-env references, the reward
is the sum of its documented terms, episodes end as documented, and bad options fail clearly."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode
from stable_baselines3.common.vec_env import DummyVecEnv

import tandem_env as te
from tandem_env.envs import SPEED_CHANGE_ID, SpeedChangeConfig, SpeedChangeEnv, TandemVecEnv
from tandem_env.envs import base as task_module
from tandem_env.envs.sb3 import make_sb3_vec_env
from tandem_env.envs.speed_change import SpeedChangeVectorEnv
from tandem_env.physics.model import OPTIONAL_FIELDS

# Short episodes, so truncation and autoreset happen within a few steps; random strokes also
# leave the bands at different cycles, so sub-envs end at different steps.
SHORT = {"max_cycles": 4}


def make_pair(n: int, mode: AutoresetMode, **kwargs: Any) -> tuple[gym.vector.VectorEnv, Any]:
    native = gym.make_vec(
        SPEED_CHANGE_ID,
        num_envs=n,
        vectorization_mode="vector_entry_point",
        autoreset_mode=mode,
        **kwargs,
    )
    sync = gym.make_vec(
        SPEED_CHANGE_ID,
        num_envs=n,
        vectorization_mode="sync",
        vector_kwargs={"autoreset_mode": mode},
        **kwargs,
    )
    return native, sync


def random_actions(n: int, step: int, scale: float = 1.0) -> np.ndarray:
    rng = np.random.default_rng(step)
    return (scale * rng.uniform(-1.0, 1.0, (n, 28))).astype(np.float32)


def test_spaces_and_make_vec() -> None:
    envs = gym.make_vec(SPEED_CHANGE_ID, num_envs=3)
    assert isinstance(envs, SpeedChangeVectorEnv)
    assert envs.single_observation_space == gym.spaces.Box(-1.0, 1.0, (5,), np.float32)
    assert envs.observation_space.shape == (3, 5) and envs.action_space.shape == (3, 28)
    env = gym.make(SPEED_CHANGE_ID)
    assert env.observation_space.shape == (5,) and env.action_space.shape == (28,)
    assert env.unwrapped.config.thrust_split == "body"


@pytest.mark.parametrize("mode", [AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP])
def test_vector_env_matches_sync_vector_env(mode: AutoresetMode, same) -> None:
    n = 5
    native, sync = make_pair(n, mode, **SHORT)
    same(native.reset(seed=11), sync.reset(seed=11))
    ended = 0
    for step in range(10):
        actions = random_actions(n, step, scale=0.3)
        out_native, out_sync = native.step(actions), sync.step(actions)
        same(out_native, out_sync)
        ended += int((out_native[2] | out_native[3]).sum())
    assert ended >= n  # every sub-env ended at least one episode


def test_disabled_autoreset_and_reset_mask_match_sync_vector_env(same) -> None:
    n = 4
    native, sync = make_pair(n, AutoresetMode.DISABLED, **SHORT)
    same(native.reset(seed=3), sync.reset(seed=3))
    for step in range(8):
        actions = random_actions(n, step, scale=0.3)
        out_native, out_sync = native.step(actions), sync.step(actions)
        same(out_native, out_sync)
        done = out_native[2] | out_native[3]
        if done.any():
            options = {"reset_mask": done, "target_speed": 1.25}
            same(native.reset(options=options), sync.reset(options=options))
    with pytest.raises(RuntimeError, match="reset_mask"):
        native.step(random_actions(n, 0))  # after a step that ends every episode
        native.step(random_actions(n, 1))


def test_one_batched_model_call_per_step(monkeypatch: pytest.MonkeyPatch) -> None:
    calls: list[tuple[int, np.ndarray]] = []
    original = task_module.evaluate

    def counting(strokes, speed, *args, **kwargs):
        calls.append((len(strokes), kwargs["flight_path_angle"].copy()))
        return original(strokes, speed, *args, **kwargs)

    monkeypatch.setattr(task_module, "evaluate", counting)
    envs = gym.make_vec(SPEED_CHANGE_ID, num_envs=6)
    envs.reset(seed=0)
    envs.step(random_actions(6, 0, scale=0.3))
    envs.step(random_actions(6, 1, scale=0.3))
    assert [size for size, _ in calls] == [6, 6]
    # each sub-env at its own flight-path angle: after one cycle they climb or sink differently
    assert np.unique(calls[1][1]).size == 6


def test_sb3_adapter_matches_dummy_vec_env(same) -> None:
    n = 4
    ours = make_sb3_vec_env(SPEED_CHANGE_ID, n_envs=n, seed=5, **SHORT)
    theirs = DummyVecEnv([lambda: gym.make(SPEED_CHANGE_ID, **SHORT) for _ in range(n)])
    theirs.seed(5)
    assert isinstance(ours, TandemVecEnv)
    assert ours.observation_space == theirs.observation_space
    same(ours.reset(), theirs.reset())
    same(ours.reset_infos, theirs.reset_infos)
    dones = 0
    for step in range(9):
        actions = random_actions(n, step, scale=0.3)
        out_ours, out_theirs = ours.step(actions), theirs.step(actions)
        same(out_ours, out_theirs)
        same(ours.reset_infos, theirs.reset_infos)
        dones += int(out_ours[2].sum())
        if step == 0:
            assert not out_ours[2].all()  # episodes do not all end after one cycle
    assert dones >= n


def test_single_env_replays_from_its_seed_and_refuses_steps_after_the_end() -> None:
    env = SpeedChangeEnv(**SHORT)
    first = env.reset(seed=42)
    again = env.reset(seed=42)
    np.testing.assert_array_equal(first[0], again[0])
    assert first[1] == again[1]
    assert env.config.speed_envelope[0] <= first[1]["forward_speed"] <= env.config.speed_envelope[1]
    action = np.zeros(28)
    done = False
    while not done:
        _, _, terminated, truncated, _ = env.step(action)
        done = terminated or truncated
    with pytest.raises(gym.error.ResetNeeded):
        env.step(action)


def test_reward_is_the_sum_of_its_documented_terms() -> None:
    weights = {"progress": 0.7, "speed": 1.3, "altitude": 3.0, "energy": 20.0, "termination": 0.5}
    env = SpeedChangeEnv(start_speed=0.6, target_speed=1.4, reward=weights, max_cycles=6)
    env.reset(seed=0)
    before = env.flight
    action = random_actions(1, 9, scale=0.3)[0]
    _, reward, terminated, _, info = env.step(action)
    u, u0, target = info["forward_speed"], float(before.forward_speed[0]), 1.4
    dt = info["cycle_time"]
    assert info["reward_progress"] == pytest.approx(0.7 * (abs(u0 - target) - abs(u - target)))
    assert info["reward_speed"] == pytest.approx(-1.3 * abs(u - target) * dt)
    assert info["reward_altitude"] == pytest.approx(-3.0 * abs(info["altitude"]) * dt)
    assert info["reward_energy"] == pytest.approx(-20.0 * info["power"] * dt)
    expected_termination = -0.5 * (6 - 1) if terminated else 0.0
    assert info["reward_termination"] == pytest.approx(expected_termination)
    terms = sum(info[f"reward_{name}"] for name in weights)
    assert info["objective"] == pytest.approx(terms, rel=1e-12)
    assert reward == pytest.approx(info["objective"] - info["penalty"], rel=1e-12)
    # the power cap as in level flight: 10 · excess / cap per cycle
    excess = max(0.0, info["power_per_mass"] - 90.0) / 90.0
    assert info["penalty"] == pytest.approx(10.0 * excess)
    assert info["feasible"] == (excess == 0.0)


def test_weights_of_zero_switch_terms_off() -> None:
    off = dict.fromkeys(("progress", "speed", "altitude", "energy", "termination"), 0.0)
    env = SpeedChangeEnv(reward=off, penalty_weight=1e-9, **SHORT)
    env.reset(seed=1)
    _, reward, _, _, info = env.step(random_actions(1, 2, scale=0.3)[0])
    assert info["objective"] == 0.0 and reward == -info["penalty"]


def test_leaving_the_altitude_band_terminates_and_charges_the_cycles_not_flown() -> None:
    env = SpeedChangeEnv(start_speed=1.0, target_speed=1.0, altitude_band=1e-4, max_cycles=10)
    env.reset(seed=0)
    _, _, terminated, truncated, info = env.step(np.zeros(28))  # the box centre pushes down
    assert info["left_altitude_band"] and terminated and not truncated
    assert abs(info["altitude"]) > 1e-4
    assert info["reward_termination"] == pytest.approx(-0.2 * 9)


def test_truncation_after_max_cycles(level_feasible_action: np.ndarray) -> None:
    """A level-flight stroke at 1.5 m/s keeps the body in the bands; the episode truncates at
    exactly max_cycles cycles and the observation counts the cycles left down to -1."""
    env = SpeedChangeEnv(start_speed=1.5, target_speed=1.5, max_cycles=5, thrust_split="sign")
    obs, _ = env.reset(seed=0)
    assert obs[4] == 1.0
    for k in range(1, 6):
        obs, _, terminated, truncated, info = env.step(level_feasible_action)
        assert not terminated and truncated == (k == 5) and info["cycle"] == k
    assert obs[4] == -1.0 and info["time"] == pytest.approx(5 * info["cycle_time"], rel=0.2)


def test_default_termination_weight_exceeds_the_cost_of_any_cycle_in_the_bands() -> None:
    config = SpeedChangeConfig()
    assert config.max_cycle_cost() == pytest.approx(
        (2.75 * 1.0 + 0.5 * 2.0 + 90.0 * 121.9e-6 * 50.0) / 30.0
    )
    assert config.reward.termination > config.max_cycle_cost()


def test_observation_is_the_normalised_state() -> None:
    env = SpeedChangeEnv(max_cycles=8)
    obs, info = env.reset(options={"start_speed": 1.5, "target_speed": 0.25, "vertical_speed": 1})
    np.testing.assert_allclose(obs, [0.0, 0.5, 0.0, -1.0, 1.0], atol=1e-7)
    assert info["forward_speed"] == 1.5 and info["target_speed"] == 0.25


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"target_speed": 2.5}, r"target_speed = 2.5 m/s; allowed: .*inside .*speed_envelope"),
        (
            {"target_speed_range": (0.1, 1.0)},
            r"target_speed_range = \(0.1, 1.0\) m/s; allowed: .*inside",
        ),
        ({"start_speed": 0.1}, r"start_speed = 0.1 m/s; allowed: a finite number inside"),
        ({"start_speed": 1.0, "start_speed_range": (0.5, 1.0)}, r"not both"),
        ({"max_cycles": -5}, r"max_cycles = -5; allowed: an integer from 1 to 500000"),
        ({"max_cycles": 2.5}, r"max_cycles = 2.5; allowed: an integer from 1 to 500000"),
        ({"max_cycles": 2**63}, r"max_cycles = 9223372036854775808; allowed: an integer"),
        ({"target_speed_range": "0.5,1"}, r"target_speed_range = '0.5,1'; allowed: a pair"),
        ({"reward": {"speed": 1.0, "comfort": 2.0}}, r"unknown reward term\(s\) 'comfort'"),
        ({"reward": {"energy": -1.0}}, r"SpeedChangeReward.energy = -1.0"),
        ({"reward": 3.0}, r"reward = 3.0; allowed"),
        ({"altitude_band": 0.0}, r"altitude_band = 0.0 m"),
        ({"forward_speed_band": (-1.0, 3.0)}, r"forward_speed_band"),
        (
            {"forward_speed_band": (0.5, 3.0)},
            r"speed_envelope low = 0.25 m/s; .*forward_speed_band",
        ),
        ({"speed_envelope": (0.25, 30.0)}, r"speed_envelope"),
        ({"wind": 3.0}, r"unknown argument\(s\) 'wind'"),
    ],
)
def test_bad_options_raise_clear_errors(kwargs: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        gym.make(SPEED_CHANGE_ID, **kwargs)


@pytest.mark.parametrize(
    ("options", "match"),
    [
        ({"target_speed": 3.0}, r"target_speed = 3.0; allowed: a number in the speed envelope"),
        ({"speed": 1.0}, r"unknown reset option\(s\) \['speed'\]"),
        ({"vertical_speed": np.nan}, r"vertical_speed = nan"),
    ],
)
def test_bad_reset_options_raise(options: dict, match: str) -> None:
    env = SpeedChangeEnv()
    with pytest.raises(ValueError, match=match):
        env.reset(options=options)


def test_render_shows_the_state_and_the_last_stroke() -> None:
    env = SpeedChangeEnv(render_mode="rgb_array", **SHORT)
    env.reset(seed=0)
    before = env.render()
    env.step(random_actions(1, 0, scale=0.3)[0])
    after = env.render()
    assert before.shape == after.shape and before.dtype == np.uint8
    assert not np.array_equal(before, after)


def test_info_reports_the_issue_keys() -> None:
    env = SpeedChangeEnv(**SHORT)
    env.reset(seed=0)
    info = env.step(random_actions(1, 0, scale=0.3)[0])[4]
    for key in (
        "forward_speed",
        "vertical_speed",
        "altitude",
        "cycle_time",
        "force_horizontal",
        "force_vertical",
        "power",
        "power_per_mass",
        "efficiency",
        "energy",
        "stroke",
    ):
        assert key in info, key
    optional = {"options", "planform", *OPTIONAL_FIELDS}  # metadata; asked for only
    assert set(info) >= set(te.Result.__dataclass_fields__) - optional
