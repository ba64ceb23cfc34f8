"""Analytic test objectives (28-D sphere, Rastrigin) as one-step Gymnasium envs with a native
batched vector env, so the harness runs them through exactly the path it uses for the flight
tasks (``gym.make_vec(..., vectorization_mode="vector_entry_point")``, reset with the condition
as option, one step per batch, rewards as fitness, a fresh single env for the re-evaluation).

The condition is ``shift``: the optimum is at x*_j = shift·(−1)^j, where the reward is 0.
Every action either env is stepped with is logged in :data:`ACTION_LOG`, and an action outside
[-1, 1] raises, so tests can check that the optimisers never leave the box.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.envs.registration import register, registry
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from agents.optimiser import AskTellOptimiser
from agents.tasks import TaskSpec, register_task
from tandem_env.envs import TaskCondition, TaskDeclaration, TaskObjectives

DIM = 28
FUNCTIONS = ("sphere", "rastrigin", "constrained")
"""``constrained`` is the sphere with the constraint x_0 <= 0, which its optimum violates; its
reward is not penalised, so the best reward is always infeasible."""
#: Every batch of actions stepped (single env: shape (1, 28)), for box checks.
ACTION_LOG: list[np.ndarray] = []


def optimum(shift: float) -> np.ndarray:
    return shift * (-1.0) ** np.arange(DIM)


def value(function: str, actions: np.ndarray, shift: float, scale: float) -> np.ndarray:
    """Rewards (B,) of actions (B, 28): maximum 0 at :func:`optimum`."""
    d = actions - optimum(shift)
    if function in ("sphere", "constrained"):
        return -np.sum(d**2, axis=1)
    z = scale * d
    return -(10.0 * DIM + np.sum(z**2 - 10.0 * np.cos(2.0 * np.pi * z), axis=1))


def feasible(function: str, actions: np.ndarray) -> np.ndarray:
    """Feasibility flags (B,) of actions (B, 28)."""
    if function == "constrained":
        return actions[:, 0] <= 0.0
    return np.ones(actions.shape[0], dtype=bool)


def _check(actions: np.ndarray) -> None:
    ACTION_LOG.append(actions.copy())
    if not np.all(np.isfinite(actions)) or np.any(np.abs(actions) > 1.0):
        raise ValueError("action outside the box [-1, 1]")


class AnalyticEnv(gym.Env):
    """One step: reward = f(action); info has objective, feasible and the condition."""

    metadata = {"render_modes": []}  # noqa: RUF012

    def __init__(self, function: str = "sphere", shift: float = 0.3, scale: float = 5.12) -> None:
        if function not in FUNCTIONS:
            raise ValueError(f"function = {function!r}; allowed: {FUNCTIONS}")
        if not -1.0 <= shift <= 1.0:
            raise ValueError(f"shift = {shift!r}; allowed: -1 to 1")
        self.function, self.shift, self.scale = function, float(shift), float(scale)
        self.action_space = spaces.Box(-1.0, 1.0, (DIM,), dtype=np.float32)
        self.observation_space = spaces.Box(-1.0, 1.0, (1,), dtype=np.float32)
        self._shift: float | None = None

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        self._shift = float((options or {}).get("shift", self.shift))
        return np.array([self._shift], dtype=np.float32), {"shift": self._shift}

    def step(self, action: np.ndarray):
        actions = np.asarray(action, dtype=np.float64)[None, :]
        _check(actions)
        reward = float(value(self.function, actions, self._shift, self.scale)[0])
        info = {
            "objective": reward,
            "feasible": bool(feasible(self.function, actions)[0]),
            "shift": self._shift,
            "distance": float(np.linalg.norm(actions[0] - optimum(self._shift))),
        }
        return np.array([self._shift], dtype=np.float32), reward, True, False, info


class AnalyticVectorEnv(VectorEnv):
    """n :class:`AnalyticEnv` evaluated in one vectorised call (autoreset Disabled only)."""

    metadata = {"autoreset_mode": AutoresetMode.DISABLED}  # noqa: RUF012

    def __init__(
        self,
        num_envs: int = 1,
        function: str = "sphere",
        shift: float = 0.3,
        scale: float = 5.12,
        autoreset_mode: str = "Disabled",
    ) -> None:
        if AutoresetMode(autoreset_mode) != AutoresetMode.DISABLED:
            raise ValueError("this test vector env supports autoreset_mode='Disabled' only")
        self.single = AnalyticEnv(function, shift, scale)
        self.num_envs = num_envs
        self.single_action_space = self.single.action_space
        self.single_observation_space = self.single.observation_space
        self.action_space = batch_space(self.single_action_space, num_envs)
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self._shift: float | None = None
        self.steps = 0

    def reset(self, *, seed: Any = None, options: dict[str, Any] | None = None):
        self._shift = float((options or {}).get("shift", self.single.shift))
        obs = np.full((self.num_envs, 1), self._shift, dtype=np.float32)
        return obs, {"shift": np.full(self.num_envs, self._shift)}

    def step(self, actions: np.ndarray):
        if self._shift is None:
            raise gym.error.ResetNeeded("reset first")
        actions = np.asarray(actions, dtype=np.float64)
        _check(actions)
        self.steps += 1
        rewards = value(self.single.function, actions, self._shift, self.single.scale)
        n = self.num_envs
        infos = {
            "objective": rewards.copy(),
            "feasible": feasible(self.single.function, actions),
            "shift": np.full(n, self._shift),
        }
        self._shift = None  # one-step episodes: the next step needs a reset, as with Disabled
        obs = np.zeros((n, 1), dtype=np.float32)
        return obs, rewards, np.ones(n, bool), np.zeros(n, bool), infos


#: The analytic tasks' condition: the shift of the optimum.
SHIFT = TaskCondition(
    keyword="shift",
    label="optimum shift",
    symbol="s",
    unit="-",
    limits=(-1.0, 1.0),
    default=0.0,
    envelope=(-1.0, 1.0),
    sweep=(0.0,),
)


def register_analytic() -> dict[str, TaskSpec]:
    """Register the gym ids and harness tasks of :data:`FUNCTIONS` (idempotent)."""
    specs = {}
    for function in FUNCTIONS:
        env_id = f"HarnessTest/{function.capitalize()}-v0"
        if env_id not in registry:
            register(
                id=env_id,
                entry_point=lambda function=function, **kw: AnalyticEnv(function, **kw),
                vector_entry_point=lambda function=function, **kw: AnalyticVectorEnv(
                    function=function, **kw
                ),
            )
        declaration = TaskDeclaration(
            name=function,
            summary=f"28-D {function}, maximum 0 at x*_j = shift·(-1)^j",
            condition=SHIFT,
            objectives=TaskObjectives(metrics={"value": "objective"}, default="value"),
            constraints=(),  # the analytic envs report their own "feasible"
        )
        spec = TaskSpec(name=function, env_id=env_id, declaration=declaration)
        register_task(spec)
        specs[function] = spec
    return specs


def drive(optimiser: AskTellOptimiser, objective: Any) -> list[np.ndarray]:
    """Run ``optimiser`` on the batched ``objective`` (maximised) to the end of its budget, one
    call per ask/tell round; returns every asked batch."""
    batches = []
    while not optimiser.done:
        X = optimiser.ask()
        batches.append(X)
        optimiser.tell(X, objective(X.copy()))
    return batches
