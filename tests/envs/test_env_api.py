"""The single envs: spaces, conditions, episode structure, infos, options, seeding, pickling."""

from __future__ import annotations

import pickle
import warnings
from dataclasses import fields

import cloudpickle
import gymnasium as gym
import numpy as np
import pytest

import tandem_env as te
from tandem_env.envs import (
    AccelerateConfig,
    AccelerateEnv,
    LevelFlightConfig,
    LevelFlightEnv,
    PenaltyConfig,
    register_envs,
)

LEVEL = "TandemWing/LevelFlight-v0"
ACCELERATE_ID = "TandemWing/Accelerate-v0"


def test_ids_resolve_with_module_prefix() -> None:
    env = gym.make(f"tandem_env:{LEVEL}")
    assert isinstance(env.unwrapped, LevelFlightEnv)
    assert isinstance(gym.make(ACCELERATE_ID).unwrapped, AccelerateEnv)
    assert gym.spec(LEVEL).vector_entry_point == "tandem_env.envs.level_flight:LevelFlightVectorEnv"


def test_registration_is_idempotent() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # re-registering an id would warn
        register_envs()
    assert gym.spec(LEVEL).max_episode_steps is None  # no TimeLimit: episodes terminate


@pytest.mark.parametrize("env_id", [LEVEL, ACCELERATE_ID])
def test_spaces(env_id: str) -> None:
    env = gym.make(env_id)
    assert env.action_space == gym.spaces.Box(-1.0, 1.0, (28,), np.float32)
    assert env.observation_space == gym.spaces.Box(-1.0, 1.0, (1,), np.float32)


def test_fixed_speed_observation_and_episode_end() -> None:
    env = gym.make(LEVEL, speed=1.5)
    obs, info = env.reset(seed=3)
    expected = np.float32(2.0 * (1.5 - 0.25) / (2.0 - 0.25) - 1.0)
    assert obs.dtype == np.float32 and obs.shape == (1,) and obs[0] == expected
    assert info == {"speed": 1.5, "available_power": 90.0}
    obs2, reward, terminated, truncated, info = env.step(env.action_space.sample())
    assert terminated is True and truncated is False
    assert isinstance(reward, float)
    np.testing.assert_array_equal(obs2, obs)
    assert info["speed"] == 1.5 and info["available_power"] == 90.0


def test_speed_range_is_sampled_from_the_seeded_generator() -> None:
    env = gym.make(LEVEL, speed_range=(0.5, 1.75))
    speeds = []
    obs, info = env.reset(seed=11)
    speeds.append(info["speed"])
    for _ in range(50):
        obs, info = env.reset()
        assert 0.5 <= info["speed"] <= 1.75
        np.testing.assert_array_equal(obs, env.unwrapped.core.observe(np.array([info["speed"]]))[0])
        speeds.append(info["speed"])
    assert len(set(speeds)) == len(speeds)
    # The same seed gives the same sequence; the draw is one uniform per reset.
    rng = np.random.default_rng(11)
    assert speeds[:3] == [rng.uniform(0.5, 1.75) for _ in range(3)]


def test_accelerate_condition_is_the_available_power() -> None:
    env = gym.make(ACCELERATE_ID, available_power_range=(50.0, 90.0), speed=0.5)
    obs, info = env.reset(seed=0)
    assert 50.0 <= info["available_power"] <= 90.0 and info["speed"] == 0.5
    assert obs[0] == np.float32(2.0 * (info["available_power"] - 50.0) / 40.0 - 1.0)
    _, _, _, _, step_info = env.step(env.action_space.sample())
    assert step_info["available_power"] == info["available_power"] and step_info["speed"] == 0.5


def test_reset_options_set_the_condition_for_one_episode() -> None:
    env = gym.make(LEVEL, speed_range=(0.25, 2.0))
    _, info = env.reset(seed=0, options={"speed": 0.75})
    assert info["speed"] == 0.75
    _, info = gym.make(ACCELERATE_ID).reset(options={"available_power": 55})
    assert info["available_power"] == 55.0
    with pytest.raises(ValueError, match="allowed: 'speed'"):
        env.reset(options={"available_power": 60.0})
    with pytest.raises(ValueError, match="reset option 'power' was renamed; use 'available_power'"):
        gym.make(ACCELERATE_ID).reset(options={"power": 60.0})
    with pytest.raises(ValueError, match=r"envelope 0\.25 to 2"):
        env.reset(options={"speed": 3.0})


def test_info_has_the_stroke_every_metric_and_each_violation() -> None:
    # Each env reports its own task's constraints (its declaration's), not the other task's.
    accelerate = _step_once(ACCELERATE_ID)
    for name in ("vertical_deficit", "horizontal_deficit", "power_violation"):
        assert isinstance(accelerate[name], float)
    assert "lift_violation" not in accelerate
    env = gym.make(LEVEL)
    env.reset(seed=0)
    action = env.action_space.sample()
    _, reward, _, _, info = env.step(action)
    for name in te.METRIC_NAMES:
        assert isinstance(info[name], float)
    assert "vertical_deficit" not in info
    for name in (
        "lift_violation",
        "thrust_violation",
        "power_violation",
        "feasible",
        "objective",
        "constraint_violation",
        "penalty",
        "induction_converged",
    ):
        assert name in info
    assert isinstance(info["feasible"], bool)
    stroke = info["stroke"]
    assert list(stroke) == list(te.PARAMETER_NAMES)
    assert stroke == te.strokes_to_dicts(te.normalised_to_physical(action.astype(float))[None])[0]
    assert isinstance(stroke["hind_elevation_harmonic"], int)
    assert reward == info["objective"] - info["penalty"]


@pytest.mark.parametrize(
    ("env_id", "kwargs", "speed", "power", "insect", "options"),
    [
        (LEVEL, {}, 1.5, None, te.Dragonfly(), te.ModelOptions()),
        (
            LEVEL,
            {"speed": 0.5, "thrust_split": "body", "planform": "real"},
            0.5,
            None,
            te.Dragonfly().with_planform("real"),
            te.ModelOptions(thrust_split="body"),
        ),
        (
            LEVEL,
            {"induction": "isolated", "n_time": 32, "n_blade": 6, "power_convention": "elastic"},
            1.5,
            None,
            te.Dragonfly(),
            te.ModelOptions(induction="isolated", n_time=32, n_blade=6, power="elastic"),
        ),
        (
            ACCELERATE_ID,
            {"objective": "horizontal", "speed": 2.0, "thrust_split": "body"},
            2.0,
            90.0,
            te.Dragonfly(),
            te.ModelOptions(thrust_split="body"),
        ),
        (
            ACCELERATE_ID,
            {"available_power": 70.0, "speed": 1.0, "spin": "total"},
            1.0,
            70.0,
            te.Dragonfly(),
            te.ModelOptions(spin="total"),
        ),
    ],
)
def test_info_metrics_match_a_direct_evaluate_call(
    env_id, kwargs, speed, power, insect, options
) -> None:
    env = gym.make(env_id, **kwargs)
    assert env.unwrapped.config.options == options
    assert env.unwrapped.config.insect == insect
    env.reset(seed=5)
    actions = np.random.default_rng(5).uniform(-1.0, 1.0, (4, 28))
    direct = te.evaluate(
        te.normalised_to_physical(actions), speed, power, insect=insect, options=options
    )
    for i, action in enumerate(actions):
        env.reset()
        _, _, _, _, info = env.step(action)
        expected = direct.row(i)
        assert {k: info[k] for k in expected} == expected


def test_model_options_and_insect_objects_pass_through() -> None:
    insect = te.Dragonfly(body_mass=130e-6)
    options = te.ModelOptions(n_time=64)
    env = gym.make(LEVEL, insect=insect, options=options, constraint_tolerance=0.05)
    cfg = env.unwrapped.config
    assert cfg.insect is insect
    assert cfg.options == te.ModelOptions(n_time=64)
    assert cfg.constraint_tolerance == 0.05  # the task's, not the model's
    penalty = gym.make(LEVEL, penalty_weight=3.0, penalty_offset=1.0).unwrapped.config.penalty
    assert penalty == PenaltyConfig(weight=3.0, offset=1.0)
    assert gym.make(LEVEL, penalty={"weight": 2.0}).unwrapped.config.penalty.weight == 2.0


def test_a_config_object_can_be_given_instead_of_kwargs() -> None:
    env = LevelFlightEnv(config=LevelFlightConfig(speed=1.0))
    assert env.config.speed == 1.0
    assert (
        AccelerateEnv(config=AccelerateConfig(objective="horizontal")).config.available_power
        == 90.0
    )
    for f in fields(LevelFlightConfig):
        assert f.name in LevelFlightConfig.allowed_kwargs()


@pytest.mark.parametrize("env_id", [LEVEL, ACCELERATE_ID])
def test_same_seed_same_everything(env_id: str, same) -> None:
    kwargs = (
        {"speed_range": (0.25, 2.0)} if env_id == LEVEL else {"available_power_range": (50.0, 90.0)}
    )
    envs = [gym.make(env_id, **kwargs) for _ in range(2)]
    outputs = []
    for env in envs:
        env.action_space.seed(7)
        out = [env.reset(seed=42)]
        for _ in range(3):
            out.append(env.step(env.action_space.sample()))
            out.append(env.reset())
        outputs.append(out)
    same(outputs[0], outputs[1])


@pytest.mark.parametrize("env_id", [LEVEL, ACCELERATE_ID])
def test_a_second_step_after_the_episode_ended_raises_as_in_speed_change(env_id: str) -> None:
    env = gym.make(env_id).unwrapped
    env.reset(seed=0)
    action = np.zeros(28)
    assert env.step(action)[2]  # terminated: a one-cycle episode
    with pytest.raises(gym.error.ResetNeeded, match="the episode has ended; call reset"):
        env.step(action)
    env.reset()
    assert env.step(action)[2]  # and a reset starts the next episode


def test_step_before_reset_raises() -> None:
    with pytest.raises(gym.error.ResetNeeded):
        LevelFlightEnv().step(np.zeros(28, dtype=np.float32))


@pytest.mark.parametrize(
    "dumps,loads", [(pickle.dumps, pickle.loads), (cloudpickle.dumps, pickle.loads)]
)
@pytest.mark.parametrize("wrapped", [False, True])
def test_pickle_round_trip_then_step(dumps, loads, wrapped: bool, same) -> None:
    env = gym.make(LEVEL, speed_range=(0.25, 2.0), planform="real")
    env = env if wrapped else env.unwrapped
    env.reset(seed=1)
    copy = loads(dumps(env))
    assert copy.unwrapped.config == env.unwrapped.config
    action = np.linspace(-1.0, 1.0, 28, dtype=np.float32)
    same(copy.step(action), env.step(action))
    same(copy.reset(), env.reset())  # the generator state travelled too


def _step_once(env_id: str) -> dict:
    env = gym.make(env_id)
    env.reset(seed=0)
    return env.step(np.zeros(28))[4]


def test_a_docstring_that_lists_the_model_options_lists_every_one() -> None:
    """Checked on each registered env class's docstring as Python holds it (written or
    generated), so a new ``ModelOptions`` field is caught: a docstring that names two or more
    model-option keywords (``n_time``) lists them, and then names every one of them with each of
    its choices (a new ``slipstream`` value too); one that mentions a single option
    (``thrust_split``) refers to another's list."""
    from typing import get_args, get_type_hints

    from gymnasium.envs.registration import load_env_creator

    from tandem_env.envs.config import MODEL_OPTION_KWARGS
    from tandem_env.envs.registration import ENTRIES
    from tandem_env.physics import ModelOptions

    hints = get_type_hints(ModelOptions)

    listing = 0
    for env_id in ENTRIES:
        spec = gym.spec(env_id)
        for entry_point in (spec.entry_point, spec.vector_entry_point):
            doc = load_env_creator(entry_point).__doc__ or ""
            named = {k for k in MODEL_OPTION_KWARGS if f"``{k}``" in doc}
            if len(named) > 1:
                listing += 1
                assert named == set(MODEL_OPTION_KWARGS), (
                    entry_point,
                    set(MODEL_OPTION_KWARGS) - named,
                )
                for keyword, name in MODEL_OPTION_KWARGS.items():
                    for choice in get_args(hints[name]):
                        assert f'"{choice}"' in doc, (entry_point, keyword, choice)
    assert listing >= 1  # LevelFlightEnv's
