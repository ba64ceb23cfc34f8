"""A policy trained by ``python -m train``, loaded from its run folder and asked for strokes:
:class:`TrainedPolicy` (ppo, sac), and :func:`load_policy` of either kind of run folder.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType
from typing import Any, Literal, get_args

import numpy as np
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.vec_env import VecEnv

from tandem_env.envs.registration import check_env_id, config_class
from tandem_env.envs.sb3 import make_sb3_vec_env
from train.amortised_policy import load_policy as load_amortised
from train.config import AMORTISED, check_algo, resolve_hyperparams
from train.run import ConditionGrid
from train.run_folder import RunPolicy, read_run_folder
from train.saved import load_on_copy, read_normalizer, read_run_yaml

WhichModel = Literal["best", "final"]
WHICH_MODELS: tuple[str, ...] = get_args(WhichModel)
#: What ``python -m train`` writes, and so what a policy is loaded from.
RUN_FOLDER = (
    "a folder written by python -m train, e.g. logs/sac/TandemWing-LevelFlight-v0_1, or "
    "logs/sac/TandemWing-LevelFlight-v0 for the latest run there"
)


class TrainingMismatchWarning(RuntimeWarning):
    """A policy is asked at a condition, or with env options, it was not trained with."""


# --- a trained run ---------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class TrainedPolicy(RunPolicy):
    """A model saved by ``python -m train``, with what it needs to observe a condition: the
    run folder's settings read and checked, the model loaded without unpickling anything."""

    run_dir: Path
    algo: str
    env_id: str
    env_kwargs: Mapping[str, Any]
    """The env options it was trained with (``args.yml`` and the yml entry's ``env_kwargs``)."""
    model_path: Path
    normalizer_path: Path | None
    """VecNormalize statistics applied to observations, if the run normalised them."""
    model: BaseAlgorithm

    @classmethod
    def load(cls, run_dir: str | Path, which: WhichModel = "best") -> TrainedPolicy:
        """Load ``best_model.zip`` (``which="best"``; the final model if there is none) or the
        final ``<env>.zip`` of ``run_dir`` (or of the latest run it names); ValueError naming
        the folder or file and what is wrong."""
        if which not in WHICH_MODELS:
            raise ValueError(f"model = {which!r}; allowed: {', '.join(WHICH_MODELS)}")
        layout, args = read_run_folder(run_dir, RUN_FOLDER)
        run_dir = layout.run_dir
        env_id = layout.env_id
        try:
            algo = check_algo(str(args.get("algo")))
        except ValueError as error:
            raise ValueError(f"{layout.args_file}: {error}") from None
        check_env_id(env_id, f"{layout.args_file}: env")
        entry = read_run_yaml(layout.config_file) if layout.config_file.is_file() else {}
        env_kwargs = {**(entry.get("env_kwargs") or {}), **(args.get("env_kwargs") or {})}
        best = which == "best" and layout.best_model.is_file()
        path = layout.best_model if best else layout.final_model
        normalizer: Path | None = None
        if entry.get("normalize"):
            best_statistics = which == "best" and layout.best_vecnormalize.is_file()
            normalizer = layout.best_vecnormalize if best_statistics else layout.vecnormalize
        if not path.is_file():
            raise ValueError(f"{run_dir}: no model file {path.name} (did the run finish?)")
        if not layout.config_file.is_file():
            raise ValueError(
                f"{run_dir}: no {layout.config_file.relative_to(run_dir)}; the policy is rebuilt "
                "from the run's hyperparameters (its model file is not unpickled), so the run "
                "folder needs them. Allowed: a folder written by python -m train"
            )
        try:
            hp = resolve_hyperparams(entry, algo=algo, n_timesteps=1)
        except ValueError as error:
            raise ValueError(f"{layout.config_file}: {error}") from None
        model = load_on_copy(algo, path, hp, env_id, env_kwargs)
        if normalizer is not None:
            read_normalizer(normalizer)
        return cls(run_dir, algo, env_id, MappingProxyType(env_kwargs), path, normalizer, model)

    def strokes(self, conditions: Sequence[float]) -> np.ndarray:
        """The deterministic normalised strokes (n, 28) in [-1, 1] at ``conditions``."""
        values = [float(c) for c in conditions]
        if not values:
            raise ValueError("conditions is empty; allowed: one or more conditions")
        # the training env's own observation path: reset at each condition through the env's
        # reset option, so the normalisation over the envelope is the one the policy learned
        venv: VecEnv = ConditionGrid(
            make_sb3_vec_env(self.env_id, n_envs=len(values), seed=0, **self.env_kwargs), values
        )
        if self.normalizer_path is not None:
            venv = read_normalizer(self.normalizer_path, venv, training=False, norm_reward=False)
        try:
            observations = venv.reset()
        finally:
            venv.close()
        actions, _ = self.model.predict(observations, deterministic=True)
        # SAC's rescaling can land a float32 ulp outside the box; the env refuses that.
        return np.clip(np.asarray(actions, dtype=np.float64), -1.0, 1.0)

    @property
    def training_conditions(self) -> tuple[float, float] | float | None:
        """From the env options it was trained with (:class:`~train.run_folder.RunPolicy`)."""
        declared = getattr(config_class(self.env_id), "CONDITION", None)
        ranged = None if declared is None else self.env_kwargs.get(declared.range_keyword)
        fixed = None if declared is None else self.env_kwargs.get(declared.keyword)
        if ranged is not None:
            low, high = ranged
            return float(low), float(high)
        return None if fixed is None else float(fixed)

    @property
    def num_timesteps(self) -> int:
        return int(self.model.num_timesteps)


def load_policy(run_dir: str | Path, which: WhichModel = "best") -> Any:
    """The policy of a run folder of ``python -m train`` (or of the latest run it names): a
    :class:`TrainedPolicy` for ppo and sac, a :class:`train.amortised_policy.AmortisedPolicy` for an
    amortised run (one weights file: ``which`` best and final are the same)."""
    if which not in WHICH_MODELS:
        raise ValueError(f"model = {which!r}; allowed: {', '.join(WHICH_MODELS)}")
    layout, args = read_run_folder(run_dir, RUN_FOLDER)
    if args.get("algo") == AMORTISED or layout.policy_file.is_file():
        return load_amortised(layout.run_dir)
    return TrainedPolicy.load(layout.run_dir, which)
