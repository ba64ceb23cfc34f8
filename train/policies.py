"""Stable-Baselines3 models as harness methods (docs/training.md, "Through the harness"),
registered when imported (:mod:`agents.methods` imports it on first use): ``policy:RUN_DIR``, a
trained policy asked once for its deterministic stroke, and ``ppo`` / ``sac``, trained at the
harness's condition within its budget of env steps.
"""

from __future__ import annotations

import functools
import hashlib
import sys
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np
from tqdm.auto import tqdm

from agents.methods import Method, SearchContext, SearchOutcome, register_method
from agents.selection import is_better
from agents.tasks import TaskSpec
from tandem_env.envs.registration import condition_keywords
from tandem_env.io.files import to_jsonable
from tandem_env.physics.checks import count
from train.amortised_policy import CITATION as AMORTISED_CITATION
from train.config import (
    ALGOS,
    Hyperparams,
    TrainConfig,
    check_algo,
    load_entry,
    plain,
    step_granularity,
)
from train.run import StrokeRecorder, TrainResult, budget_hyperparams, learn_in_memory, train
from train.run_folder import resolve_run_dir
from train.trained_policy import WHICH_MODELS, TrainingMismatchWarning, WhichModel, load_policy

_SB3 = "Stable-Baselines3 implementation (Raffin et al. 2021, JMLR 22(268))"
CITATIONS: dict[str, str] = {
    "ppo": f"PPO (Schulman et al. 2017, arXiv:1707.06347), {_SB3}",
    "sac": f"SAC (Haarnoja et al. 2018, ICML / arXiv:1812.05905), {_SB3}",
    "amortised": AMORTISED_CITATION,
}

# The budget notices this process has printed (TrainingMethod.search).
_ANNOUNCED: set[tuple[Any, ...]] = set()
# The suffixes of the files a run's policy is read from (train.run_folder.RunLayout, and an
# amortised run's weights and policy.json): what PolicyMethod.identity hashes.
_POLICY_SUFFIXES = (".zip", ".pkl", ".pt", ".json", ".yml")


@functools.lru_cache(maxsize=256)
def _file_digest(path: Path, size: int, modified: int) -> str:
    """SHA-256 of a file's bytes, read once per process while its ``size`` and ``modified``
    time (``st_mtime_ns``) stay."""
    with path.open("rb") as handle:
        return hashlib.file_digest(handle, "sha256").hexdigest()


# --- harness methods ---------------------------------------------------------------------------
@dataclass(frozen=True)
class PolicyMethod:
    """``policy:RUN_DIR``: ask a trained policy for its stroke (1 evaluation)."""

    run_dir: Path
    which: WhichModel = "best"

    @property
    def name(self) -> str:
        return f"policy:{self.run_dir}"

    def identity(self) -> str:
        """Part of its jobs' keys: a digest of the run folder's name and of the files a policy
        is read from, so a run trained again in place is another job."""
        run_dir = resolve_run_dir(self.run_dir)
        digest = hashlib.sha256(run_dir.name.encode())
        for path in sorted(run_dir.glob("*")) + sorted(run_dir.glob("*/*")):
            if path.suffix in _POLICY_SUFFIXES and path.is_file():
                status = path.stat()
                found = _file_digest(path.resolve(), status.st_size, status.st_mtime_ns)
                digest.update(f"{path.relative_to(run_dir)}:{found}".encode())
        return digest.hexdigest()[:20]

    def check(self, budget: int, dim: int, task: TaskSpec) -> None:
        """The harness's check before any work: the run's policy loads, for this task's env."""
        load_policy(self.run_dir, self.which).check_env(task.env_id)

    def search(self, context: SearchContext) -> SearchOutcome:
        policy = load_policy(self.run_dir, self.which)
        policy.check_env(context.env_id)
        # the condition's keywords may differ between training and evaluation
        condition = condition_keywords()
        trained = {k: v for k, v in policy.env_kwargs.items() if k not in condition}
        asked = {k: v for k, v in context.env_kwargs.items() if k not in condition}
        if plain(trained) != plain(asked):
            message = f"was trained with env options {trained}, evaluated with {asked}"
            warnings.warn(f"{policy.run_dir} {message}", TrainingMismatchWarning, stacklevel=2)
        if not policy.trained_at(context.condition.value):
            message = (
                f"was trained at {policy.training_conditions}, asked at "
                f"{context.condition.describe()}"
            )
            warnings.warn(f"{policy.run_dir} {message}", TrainingMismatchWarning, stacklevel=2)
        action = policy.strokes([context.condition.value])[0]
        reward = float(context.evaluate(action[None, :])[0])
        return SearchOutcome(
            best_action=action,
            best_reward=reward,
            evaluations=1,
            history=((1, reward),),
            config={
                "method": "policy",
                "run_dir": str(self.run_dir),
                "model": self.which,
                "model_file": policy.model_path.name,
                "algo": policy.algo,
                "training_timesteps": policy.num_timesteps,
                "training_env_kwargs": dict(policy.env_kwargs),
                "deterministic": True,
                "citation": CITATIONS[policy.algo],
            },
        )


@dataclass(frozen=True)
class TrainingMethod:
    """``ppo`` / ``sac``: train at the harness's condition within its budget of env steps."""

    algo: str
    overrides: Mapping[str, Any] = field(default_factory=dict)
    """Hyperparameters replacing the yml entry's (``--method-config key=value``)."""
    n_envs: int | None = None
    conf_file: str | None = None
    torch_threads: int = 1
    log_dir: str | None = None
    """If given, train as ``python -m train`` into ``log_dir/<algo>/<env>_<n>/`` (no evaluations
    or checkpoints, which the budget would not count), to plot and reuse as ``policy:RUN_DIR``."""

    def __post_init__(self) -> None:
        check_algo(self.algo)
        if "n_timesteps" in self.overrides:
            raise ValueError(
                f"method {self.algo!r}: n_timesteps cannot be set; the harness budget (env "
                "steps) is the only budget"
            )
        object.__setattr__(self, "overrides", MappingProxyType(dict(self.overrides)))
        method = f"method {self.algo!r}"
        if self.n_envs is not None:  # None: the yml's
            object.__setattr__(self, "n_envs", count(self.n_envs, f"{method}: n_envs"))
        object.__setattr__(
            self, "torch_threads", count(self.torch_threads, f"{method}: torch_threads")
        )
        for name in ("conf_file", "log_dir"):
            value = getattr(self, name)
            if value is not None and not isinstance(value, str | Path):
                raise ValueError(f"method {self.algo!r}: {name} = {value!r}; allowed: a path")

    @property
    def name(self) -> str:
        return self.algo

    def search(self, context: SearchContext) -> SearchOutcome:
        if context.budget < 2:
            raise ValueError(
                f"method {self.algo!r}: budget {context.budget}; allowed: >= 2 (training steps "
                "plus one evaluation of the final deterministic policy)"
            )
        hp = self._hyperparams(context.env_id, context.budget)
        steps = hp.n_timesteps
        unused = context.budget - (steps + 1)
        # when training cannot use the whole budget (SB3 learns in whole iterations), said on
        # stderr once per process and setting, not once per seed: the seeds of a run share it
        said = (self.algo, context.env_id, context.budget, self.n_envs, repr(self.overrides))
        if unused > 0 and said not in _ANNOUNCED:
            _ANNOUNCED.add(said)
            tqdm.write(
                f"{self.algo}: budget {context.budget} -> {steps} training steps (whole "
                f"{self.algo.upper()} iterations of {step_granularity(hp)} env steps, n_envs "
                f"{hp.n_envs}) + 1 final evaluation; {unused} evaluations stay unused (each seed "
                "alike)",
                file=sys.stderr,
            )
        if self.log_dir is None:
            training, final = self._learn(context, hp)
        else:
            training, final = self._learn_with_files(context, steps)
        evaluations = training.num_timesteps + 1
        best_feasible = bool((training.best_info or {}).get("feasible", False))
        # the selection rule (agents.selection); on a tie the stroke seen in training stays
        if training.best_action is None or is_better(
            final["feasible"], final["reward"], best_feasible, training.best_reward
        ):
            best_action, best_reward, chosen = final["action"], final["reward"], "final policy"
        else:
            best_action = np.asarray(training.best_action, dtype=np.float64)
            best_reward, chosen = training.best_reward, "seen during training"
        history = [*training.history, (evaluations, best_reward)]
        # Where the progress bar ends: every evaluation spent, training's and the final one's
        # (the harness's evaluator counted only the final one, and reported 1).
        context.report(len(history), evaluations, max(reward for _, reward in history))
        return SearchOutcome(
            best_action=best_action,
            best_reward=best_reward,
            evaluations=evaluations,
            history=tuple(history),
            config={
                "method": self.algo,
                "hyperparams": to_jsonable(dict(hp.saved), default=repr),
                "n_envs": hp.n_envs,
                "training_timesteps": training.num_timesteps,
                "budget_unused": unused,
                "result": "best stroke seen (training strokes and the final deterministic one)",
                "chosen": chosen,
                "final_policy": {**final, "action": final["action"].tolist()},
                "log_dir": self.log_dir,
                "run_dir": None if training.run_dir is None else str(training.run_dir),
                "citation": CITATIONS[self.algo],
            },
        )

    def check(self, budget: int, dim: int, task: TaskSpec) -> None:
        """The harness's check before any work: the hyperparameters resolve within ``budget``."""
        self._hyperparams(task.env_id, budget)

    def _hyperparams(self, env_id: str, budget: int) -> Hyperparams:
        """The hyperparameters of training within ``budget``: its env steps (``n_timesteps``)
        are ``budget - 1`` (the last evaluation is the final policy's) rounded down to whole
        iterations (:func:`~train.run.budget_hyperparams`)."""
        entry = load_entry(self.algo, env_id, self.conf_file)
        return budget_hyperparams(self.algo, entry, self.overrides, self.n_envs, budget - 1)

    def _learn(self, context: SearchContext, hp: Hyperparams) -> tuple[TrainResult, dict[str, Any]]:
        """Training without files (:func:`~train.run.learn_in_memory`, ``hp`` of
        :meth:`_hyperparams`), and its final deterministic stroke evaluated by the harness's
        evaluator, so the budget counts it."""

        def report(recorder: StrokeRecorder) -> None:
            context.report(recorder.steps, recorder.evaluations, recorder.max_reward)

        model, recorder = learn_in_memory(
            hp,
            context.env_id,
            context.env_kwargs,
            context.seed,
            on_step=report,
            threads=self.torch_threads,
        )
        env = model.get_env()
        assert env is not None
        action, _ = model.predict(env.reset()[:1], deterministic=True)
        env.close()
        final_action = np.clip(np.asarray(action[0], dtype=np.float64), -1.0, 1.0)
        final = context.evaluate_batch(final_action[None, :])
        best = (recorder.best_reward, recorder.best_action, recorder.best_info)
        history = tuple(recorder.history)
        training = TrainResult(recorder.evaluations, *best, history=history)
        found = (final.rewards[0], final.objective[0], final.feasible[0])
        return training, _final(*found, final_action)

    def _learn_with_files(
        self, context: SearchContext, steps: int
    ) -> tuple[TrainResult, dict[str, Any]]:
        """Training through ``python -m train``'s code into ``log_dir`` (:func:`~train.run.train`),
        and the final deterministic stroke it evaluated at the (fixed) condition."""
        result = train(
            TrainConfig(
                algo=self.algo,  # type: ignore[arg-type]
                env_id=context.env_id,
                n_timesteps=steps,
                seed=context.seed,
                n_envs=self.n_envs,
                env_kwargs=dict(context.env_kwargs),
                hyperparams=dict(self.overrides),
                hyperparams_file=self.conf_file,
                log_folder=Path(self.log_dir),  # type: ignore[arg-type]
                eval_freq=0,
                save_freq=0,
                progress_bar=False,
                verbose=0,
                torch_threads=self.torch_threads,
            )
        )
        context.report(len(result.history), result.num_timesteps, result.best_reward)
        [row] = result.final_evaluation
        # float64 as the harness re-evaluates it (the adapter's reward is float32)
        found = (row["objective"] - row["penalty"], row["objective"], row["feasible"])
        return result, _final(*found, np.asarray(row["action"], dtype=np.float64))


def _final(reward: Any, objective: Any, feasible: Any, action: np.ndarray) -> dict[str, Any]:
    """The final deterministic stroke's row of a search's config."""
    return {
        "reward": float(reward),
        "objective": float(objective),
        "feasible": bool(feasible),
        "action": np.clip(action, -1.0, 1.0),
    }


# --- factories for the registry ---------------------------------------------------------------
def policy_factory(argument: str | None, config: Mapping[str, Any]) -> Method:
    """``policy:RUN_DIR`` with setting ``model`` = best | final."""
    if not argument:
        raise ValueError("method 'policy' needs a run folder: policy:RUN_DIR")
    unknown = sorted(set(config) - {"model"})
    if unknown:
        raise ValueError(f"method 'policy': unknown setting(s) {unknown}; allowed: model")
    which = config.get("model", "best")
    if which not in WHICH_MODELS:
        raise ValueError(f"method 'policy': model = {which!r}; allowed: {', '.join(WHICH_MODELS)}")
    run_dir = resolve_run_dir(argument)  # logs/<algo>/<env> -> its latest run
    if not run_dir.is_dir():
        raise ValueError(
            f"method 'policy': {run_dir} is not a folder; allowed: a training run folder, or "
            "logs/<algo>/<env> for the latest run there"
        )
    return PolicyMethod(run_dir, which)


def training_factory(algo: str, argument: str | None, config: Mapping[str, Any]) -> Method:
    """``ppo`` or ``sac`` (``algo``, bound when registered): settings are hyperparameter
    overrides, plus ``n_envs``, ``conf_file`` (a zoo-format yml) and ``torch_threads``."""
    if argument is not None:
        raise ValueError(f"method {algo!r} takes no ':' argument; got {algo}:{argument}")
    settings = dict(config)
    # TrainingMethod's own settings (after algo and overrides); the rest override hyperparameters
    extra = {f.name: settings.pop(f.name) for f in fields(TrainingMethod)[2:] if f.name in settings}
    return TrainingMethod(algo, overrides=settings, **extra)


# Importing this module registers ppo, sac and policy with the harness (idempotently): their
# tandem_env.optimisers entry points name it.
for _algo in ALGOS:
    register_method(_algo, functools.partial(training_factory, _algo), replace=True)
register_method("policy", policy_factory, replace=True)
