"""The env keywords ``backend`` and ``device``: the torch backend steps every env to the numba
kernel's rewards within 1e-8, the default is the numba kernel, bad values are refused once."""

from __future__ import annotations

import pickle
import subprocess
import sys
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

from tandem_env.envs import LevelFlightConfig
from tandem_env.envs.registration import ACCELERATE_ID, LEVEL_FLIGHT_ID, SPEED_CHANGE_ID

torch = pytest.importorskip("torch")

ENV_IDS = (LEVEL_FLIGHT_ID, ACCELERATE_ID, SPEED_CHANGE_ID)
#: The torch backend's agreement with the numba kernel (docs/model.md §12.1; issue's 1e-8).
RTOL, ATOL = 1e-8, 1e-8
NO_CUDA = "CUDA is not available here (torch.cuda.is_available() is False)"


def step_vector(n: int, seed: int, env_id: str = LEVEL_FLIGHT_ID, **kwargs: Any):
    """Reset and step n sub-envs of the native vector env once with seeded random actions."""
    envs = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point", **kwargs)
    envs.reset(seed=seed)
    actions = np.random.default_rng(seed).uniform(-1.0, 1.0, (n, 28)).astype(np.float32)
    _, reward, terminated, truncated, info = envs.step(actions)
    envs.close()
    return reward, terminated, truncated, info


def assert_same_step(torch_step: tuple, numba_step: tuple) -> None:
    """Rewards and every float info metric within 1e-8; flags and booleans exactly."""
    reward, terminated, truncated, info = torch_step
    reward0, terminated0, truncated0, info0 = numba_step
    np.testing.assert_allclose(reward, reward0, rtol=RTOL, atol=ATOL)
    np.testing.assert_array_equal(terminated, terminated0)
    np.testing.assert_array_equal(truncated, truncated0)
    assert info.keys() == info0.keys()
    for key, value in info0.items():
        if isinstance(value, np.ndarray) and value.dtype.kind == "f":
            np.testing.assert_allclose(info[key], value, rtol=RTOL, atol=ATOL, err_msg=key)
        elif isinstance(value, np.ndarray) and value.dtype.kind == "b":
            np.testing.assert_array_equal(info[key], value, err_msg=key)


def test_make_vec_torch_gives_the_numba_rewards() -> None:
    """The issue's check: 64 sub-envs of level flight, sampled speeds, one step on each backend."""
    kwargs = {"speed_envelope": (0.0, 2.0), "speed_range": (0.0, 2.0)}
    torch_step = step_vector(64, 7, backend="torch", **kwargs)
    numba_step = step_vector(64, 7, **kwargs)
    assert_same_step(torch_step, numba_step)
    assert np.ptp(numba_step[0]) > 0.0  # 64 different strokes, so the comparison is not of one


@pytest.mark.parametrize(
    ("env_id", "kwargs"),
    [
        (ACCELERATE_ID, {"objective": "resultant", "planform": "real"}),
        (SPEED_CHANGE_ID, {}),
    ],
)
def test_other_envs_step_on_torch(env_id: str, kwargs: dict[str, Any]) -> None:
    """Accelerating flight (real planform) and the multi-cycle env, 4 sub-envs each."""
    assert_same_step(
        step_vector(4, 3, env_id, backend="torch", **kwargs), step_vector(4, 3, env_id, **kwargs)
    )


def test_single_env_takes_the_keywords() -> None:
    env = gym.make(LEVEL_FLIGHT_ID, backend="torch", device="cpu", speed=1.0)
    config = env.unwrapped.config
    assert (config.backend, config.device) == ("torch", "cpu")
    env.reset(seed=0)
    action = np.random.default_rng(0).uniform(-1.0, 1.0, 28).astype(np.float32)
    _, reward, *_ = env.step(action)
    reference = gym.make(LEVEL_FLIGHT_ID, speed=1.0)
    reference.reset(seed=0)
    _, reward0, *_ = reference.step(action)
    np.testing.assert_allclose(reward, reward0, rtol=RTOL, atol=ATOL)


def test_default_is_the_numba_kernel_bit_for_bit() -> None:
    config = LevelFlightConfig()
    assert (config.backend, config.device) == ("numba", None)
    reward, _, _, info = step_vector(8, 1)
    reward1, _, _, info1 = step_vector(8, 1, backend="numba")
    np.testing.assert_array_equal(reward, reward1)
    np.testing.assert_array_equal(info["efficiency"], info1["efficiency"])


def test_config_is_frozen_canonical_and_picklable() -> None:
    config = LevelFlightConfig(backend="torch", device=torch.device("cpu"))
    assert config.device == "cpu"  # stored by its name, so the config pickles and prints plainly
    assert pickle.loads(pickle.dumps(config)) == config
    with pytest.raises(AttributeError):
        config.backend = "numba"  # type: ignore[misc]


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"backend": "jax"}, "backend = 'jax'; allowed: 'numba', 'torch'"),
        ({"backend": None}, "backend = None; allowed: 'numba', 'torch'"),
        ({"device": "cpu"}, "device = 'cpu' with backend 'numba'; allowed: None"),
        ({"backend": "torch", "device": "tpu"}, "device = 'tpu' is not a torch device"),
    ],
)
def test_bad_values_are_refused_naming_them(kwargs: dict[str, Any], message: str) -> None:
    for env_id in ENV_IDS:
        with pytest.raises(ValueError, match="allowed") as error:
            gym.make(env_id, **kwargs)
        assert message in str(error.value)
        with pytest.raises(ValueError) as error:
            gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point", **kwargs)
        assert message in str(error.value)


@pytest.mark.skipif(torch.cuda.is_available(), reason="CUDA is available here")
def test_cuda_without_cuda_is_refused() -> None:
    with pytest.raises(ValueError, match=r"device = 'cuda' but CUDA is not available"):
        gym.make(LEVEL_FLIGHT_ID, backend="torch", device="cuda")


@pytest.mark.skipif(not torch.cuda.is_available(), reason=NO_CUDA)
def test_make_vec_on_cuda_gives_the_numba_rewards() -> None:
    kwargs = {"speed_envelope": (0.0, 2.0), "speed_range": (0.0, 2.0)}
    cuda_step = step_vector(256, 11, backend="torch", device="cuda", **kwargs)
    assert_same_step(cuda_step, step_vector(256, 11, **kwargs))


def test_numba_env_does_not_import_torch() -> None:
    """Validating the keywords imports torch only for the torch backend."""
    code = (
        "import sys, gymnasium as gym, tandem_env\n"
        f"gym.make({LEVEL_FLIGHT_ID!r}, backend='numba')\n"
        "assert 'torch' not in sys.modules, 'torch was imported'\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)
