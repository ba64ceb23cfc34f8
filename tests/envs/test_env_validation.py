"""Bad actions and bad options fail loudly, with messages that say what is allowed."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import tandem_env as te
from tandem_env.envs import AccelerateConfig, LevelFlightConfig, PenaltyConfig

LEVEL = "TandemWing/LevelFlight-v0"
ACCELERATE_ID = "TandemWing/Accelerate-v0"


@pytest.fixture
def env() -> gym.Env:
    env = gym.make(LEVEL)
    env.reset(seed=0)
    return env


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
@pytest.mark.parametrize("clip", [False, True])
def test_non_finite_actions_raise(bad: float, clip: bool) -> None:
    env = gym.make(LEVEL, clip_actions=clip)
    env.reset()
    action = np.zeros(28, dtype=np.float32)
    action[5] = bad
    with pytest.raises(ValueError, match=r"fore_elevation_offset = .* is not finite"):
        env.step(action)


def test_out_of_range_actions_raise_unless_clipped() -> None:
    action = np.zeros(28)
    action[0], action[27] = 1.5, -3.0
    env = gym.make(LEVEL)
    env.reset()
    # Refused by default, and the message recommends the option to clients that do not clip.
    advice = r"outside the action space; allowed: \[-1, 1\]\. A client that does not clip .*clip_actions=True"
    with pytest.raises(ValueError, match=advice):
        env.step(action)
    vector = gym.make_vec(LEVEL, num_envs=2, vectorization_mode="vector_entry_point")
    vector.reset(seed=0)
    with pytest.raises(ValueError, match=advice):
        vector.step(np.stack([np.zeros(28), np.full(28, 1.2)]))
    clipping = gym.make(LEVEL, clip_actions=True)
    clipping.reset()
    _, _, _, _, info = clipping.step(action)
    clipped = np.clip(action, -1.0, 1.0)
    assert info["stroke"] == te.strokes_to_dicts(te.normalised_to_physical(clipped)[None])[0]
    assert (
        info["stroke"]["fore_frequency"] == 45.0
        and info["stroke"]["hind_stroke_plane_angle"] == 5.0
    )


@pytest.mark.parametrize("action", [np.zeros(27), np.zeros((1, 28)), "fast", [[0.0] * 28] * 2])
def test_wrong_action_shapes_raise(env: gym.Env, action) -> None:
    with pytest.raises(ValueError, match="28"):
        env.step(action)


def test_env_limits_are_the_models() -> None:
    # The widest envelopes an env accepts are the model's own limits, no narrower, no wider.
    LevelFlightConfig(speed_envelope=te.SPEED_LIMITS, speed=te.SPEED_LIMITS[1])
    for power in te.AVAILABLE_POWER_LIMITS:
        env = gym.make(
            ACCELERATE_ID,
            available_power_envelope=te.AVAILABLE_POWER_LIMITS,
            available_power=power,
            speed=te.SPEED_LIMITS[1],
        )
        env.reset(seed=0)
        env.step(np.zeros(28, dtype=np.float32))  # the model takes every condition the env does
    with pytest.raises(ValueError, match="high <= 20"):
        LevelFlightConfig(speed_envelope=(0.25, 20.5))
    with pytest.raises(ValueError, match="1 <= low < high <= 1000"):
        AccelerateConfig(available_power_envelope=(0.5, 90.0))
    with pytest.raises(ValueError, match="allowed: a finite number from 0 to 20 m/s"):
        AccelerateConfig(speed=20.5)


@pytest.mark.parametrize(
    ("env_id", "kwargs", "message"),
    [
        (LEVEL, {"planform": "square"}, "planform = 'square'; allowed: 'tear-drop', 'real'"),
        (LEVEL, {"speed": -1}, r"speed = -1 m/s; allowed: a finite number inside .*\(0.25, 2\)"),
        (LEVEL, {"speed": 3.0}, r"speed = 3.0 m/s; allowed: a finite number inside .*\(0.25, 2\)"),
        (LEVEL, {"speed": "fast"}, "speed = 'fast'"),
        (LEVEL, {"speed": 1.0, "speed_range": (0.5, 1.5)}, "not both"),
        (LEVEL, {"speed_range": (1.5, 0.5)}, "low < high"),
        (LEVEL, {"speed_range": (0.1, 1.0)}, "speed_envelope"),
        (LEVEL, {"speed_envelope": (0.0, 30.0)}, "high <= 20"),
        (LEVEL, {"objective": "vertical"}, "unknown argument.*'objective'; allowed: .*speed_range"),
        (
            LEVEL,
            {"induction": "magic"},
            "induction = 'magic'; allowed: 'coupled', 'isolated', 'none'",
        ),
        (LEVEL, {"thrust_split": "force"}, "thrust_split = 'force'; allowed: 'sign', 'body'"),
        (
            LEVEL,
            {"power_convention": "net"},
            r"power_convention \(ModelOptions.power\) = 'net'; allowed: 'absolute', 'elastic'",
        ),
        (LEVEL, {"n_time": 4}, "n_time = 4; allowed: an integer 8 to 8192"),
        (LEVEL, {"interference": "high"}, "interference = 'high'; allowed: a finite number"),
        (LEVEL, {"insect": "dragonfly"}, "allowed: a tandem_env.Dragonfly"),
        (LEVEL, {"options": {"n_time": 8}}, "allowed: a tandem_env.ModelOptions"),
        (
            LEVEL,
            {"penalty_weight": -1.0},
            r"penalty_weight \(PenaltyConfig.weight\) = -1.0; allowed: a finite number from 0",
        ),
        (LEVEL, {"penalty_offset": "x"}, r"penalty_offset \(PenaltyConfig.offset\) = 'x'"),
        (LEVEL, {"penalty_weight": 0.0}, r"penalty_weight \(PenaltyConfig.weight\) and .*> 0"),
        (LEVEL, {"penalty": {"scale": 2.0}}, "allowed: weight, offset"),
        (LEVEL, {"clip_actions": "yes"}, "clip_actions = 'yes'; allowed: True or False"),
        (
            ACCELERATE_ID,
            {"objective": "sideways"},
            "objective = 'sideways'; allowed: 'vertical', 'horizontal', 'resultant'",
        ),
        (ACCELERATE_ID, {"available_power": 95.0}, "available_power_envelope"),
        (
            ACCELERATE_ID,
            {"available_power": 0.0},
            r"allowed: a finite number inside .*\(50, 90\) W/kg",
        ),
        (ACCELERATE_ID, {"speed": -0.5}, "speed = -0.5 m/s"),
        (ACCELERATE_ID, {"speed_range": (0.5, 1.0)}, "unknown argument.*'speed_range'"),
    ],
)
def test_invalid_options_fail_at_make_time(env_id: str, kwargs: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        gym.make(env_id, **kwargs)


def test_unknown_render_mode_fails_at_make_time() -> None:
    # Gymnasium warns about the unknown mode before the env rejects it.
    with (
        pytest.warns(UserWarning, match="not in the possible render_modes"),
        pytest.raises(
            ValueError, match="render_mode = 'ansi'; allowed: None, 'human', 'rgb_array'"
        ),
    ):
        gym.make(LEVEL, render_mode="ansi")


def test_invalid_vector_options_fail_at_make_time() -> None:
    with pytest.raises(ValueError, match="objective = 'sideways'"):
        gym.make_vec(
            ACCELERATE_ID, num_envs=2, vectorization_mode="vector_entry_point", objective="sideways"
        )
    with pytest.raises(ValueError, match="num_envs = 0; allowed: an integer >= 1"):
        gym.make_vec(LEVEL, num_envs=0, vectorization_mode="vector_entry_point")
    with pytest.raises(ValueError, match="autoreset_mode = 'Sometimes'; allowed: 'NextStep'"):
        gym.make_vec(
            LEVEL, num_envs=2, vectorization_mode="vector_entry_point", autoreset_mode="Sometimes"
        )


def test_configs_are_frozen_and_normalised() -> None:
    cfg = LevelFlightConfig(speed_range=[0.5, 1])
    assert cfg.speed_range == (0.5, 1.0) and cfg.speed is None
    assert LevelFlightConfig().speed == 1.5
    assert AccelerateConfig().available_power == 90.0 and AccelerateConfig().speed == 0.0
    with pytest.raises(AttributeError):
        cfg.speed = 1.0  # type: ignore[misc]
    assert hash(cfg) == hash(LevelFlightConfig(speed_range=(0.5, 1.0)))
    assert PenaltyConfig() == PenaltyConfig(weight=10.0, offset=0.0)
