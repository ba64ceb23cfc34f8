"""Stable-Baselines3 models as harness methods: a trained policy, and training within a budget.

Two kinds of method, registered with the harness when this module is imported (it is the
provider :mod:`agents.methods` imports on first use, so ``agents`` imports SB3 only when asked):

``policy:RUN_DIR``
    A policy trained by ``python -m train``. Asked deterministically for its stroke at the
    condition (one forward pass), which the harness evaluates once: **1 evaluation**, any
    larger budget is left unused. ``model=best`` (default: ``best_model.zip``, the best
    deterministic evaluation during training) or ``model=final`` (``<env>.zip``). ``RUN_DIR``
    without its run number (``logs/ppo/TandemWing-LevelFlight-v0``) is the latest run there.
``ppo`` / ``sac``
    Trained from scratch at the harness's condition with the zoo hyperparameters of
    ``train/hyperparams/<algo>.yml``. The budget counts env steps (one env step = one stroke =
    one model evaluation): training gets ``budget - 1`` of them, rounded down to whole learn
    iterations, and the last evaluation is the final deterministic policy's stroke. The
    result is the **best stroke seen** among everything training evaluated and that final
    deterministic stroke: feasible strokes first, then the highest reward (the harness's rule
    for PSO and random search too, so records compare like for like). The final policy's own metrics are in the record's method
    config under ``final_policy``.

Functions for use outside the harness: :func:`policy_stroke` (a run's deterministic stroke at
a condition) and :func:`train_and_propose` (train within a budget, return the chosen stroke).
"""

from __future__ import annotations

import math
import sys
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import TYPE_CHECKING, Any, Literal, get_args

import numpy as np
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.vec_env import VecEnv
from tqdm.auto import tqdm

from agents.methods import Method, SearchContext, SearchOutcome
from agents.selection import is_better
from tandem_env.envs.registration import check_env_id, condition_keywords, config_class
from tandem_env.envs.sb3 import make_sb3_vec_env
from tandem_env.io.files import to_jsonable
from tandem_env.physics.checks import is_integer
from train.checkpoint import load_policy_model
from train.config import ALGOS, check_algo, plain, resolve_hyperparams
from train.layout import RunLayout, env_name, read_normalizer, read_run_yaml, resolve_run_dir
from train.run import learn_in_memory
from train.vec import ConditionGrid, StrokeRecorder, option_key

if TYPE_CHECKING:
    from agents.tasks import TaskSpec

__all__ = [
    "CITATIONS",
    "PolicyMethod",
    "TrainedPolicy",
    "TrainingMethod",
    "TrainingMismatchWarning",
    "WhichModel",
    "policy_factory",
    "policy_stroke",
    "train_and_propose",
    "training_factory",
]

WhichModel = Literal["best", "final"]
WHICH_MODELS: tuple[str, ...] = get_args(WhichModel)

CITATIONS: dict[str, str] = {
    "ppo": (
        "PPO (Schulman et al. 2017, arXiv:1707.06347), Stable-Baselines3 implementation "
        "(Raffin et al. 2021, JMLR 22(268))"
    ),
    "sac": (
        "SAC (Haarnoja et al. 2018, ICML / arXiv:1812.05905), Stable-Baselines3 implementation "
        "(Raffin et al. 2021, JMLR 22(268))"
    ),
}

# Settings of the training methods that are not hyperparameter overrides.
# The budget notices this process has printed (PolicySearch._announce_budget).
_ANNOUNCED: set[tuple[Any, ...]] = set()
_TRAINING_SETTINGS = ("n_envs", "conf_file", "torch_threads", "log_dir")


class TrainingMismatchWarning(RuntimeWarning):
    """A policy is asked at a condition, or with env options, it was not trained with."""


# --- a trained run ---------------------------------------------------------------------------
@dataclass(frozen=True)
class RunFiles:
    """What a run folder of ``python -m train`` holds for loading its policy: its settings read
    and checked (the model itself is checked by loading it, :meth:`TrainedPolicy.load`)."""

    run_dir: Path
    algo: str
    env_id: str
    entry: Mapping[str, Any]
    """The run's hyperparameters (``config.yml``)."""
    env_kwargs: dict[str, Any]
    model_path: Path
    normalizer_path: Path | None

    @classmethod
    def read(cls, run_dir: str | Path, which: WhichModel = "best") -> RunFiles:
        """The files of ``run_dir`` (or of the latest run it names); ValueError naming the
        folder or file and what is wrong: a missing file, an args.yml naming an algo or env
        other than its own (its folder is named after the env), hyperparameters that do not
        resolve (:func:`~train.config.resolve_hyperparams`: n_envs, the network's size)."""
        if which not in WHICH_MODELS:
            raise ValueError(f"model = {which!r}; allowed: {', '.join(WHICH_MODELS)}")
        run_dir = resolve_run_dir(run_dir)
        args_files = sorted(run_dir.glob("*/args.yml")) if run_dir.is_dir() else []
        if len(args_files) != 1:
            raise ValueError(
                f"{run_dir} is not a training run folder (expected one <env>/args.yml, found "
                f"{len(args_files)}); allowed: a folder written by python -m train, e.g. "
                "logs/sac/TandemWing-LevelFlight-v0_1, or logs/sac/TandemWing-LevelFlight-v0 "
                "for the latest run there"
            )
        args = read_run_yaml(args_files[0])
        try:
            algo = check_algo(str(args.get("algo")))
        except ValueError as error:
            raise ValueError(f"{args_files[0]}: {error}") from None
        env_id = args.get("env")
        if not isinstance(env_id, str) or env_name(env_id) != args_files[0].parent.name:
            raise ValueError(
                f"{args_files[0]}: env = {env_id!r}, but the file sits in the settings folder "
                f"of {args_files[0].parent.name}; allowed: the env the run was trained on"
            )
        check_env_id(env_id, f"{args_files[0]}: env")
        layout = RunLayout(run_dir, env_id)
        entry = read_run_yaml(layout.config_file) if layout.config_file.is_file() else {}
        env_kwargs = {**(entry.get("env_kwargs") or {}), **(args.get("env_kwargs") or {})}
        path = layout.best_model if which == "best" else layout.final_model
        normalizer: Path | None = None
        if entry.get("normalize"):
            normalizer = layout.vecnormalize
            best_stats = run_dir / "best_model_vecnormalize.pkl"
            if which == "best" and best_stats.is_file():
                normalizer = best_stats
        if which == "best" and not path.is_file():
            path = layout.final_model
        if not path.is_file():
            raise ValueError(f"{run_dir}: no model file {path.name} (did the run finish?)")
        if not layout.config_file.is_file():
            raise ValueError(
                f"{run_dir}: no {layout.config_file.relative_to(run_dir)}; the policy is rebuilt "
                "from the run's hyperparameters (its model file is not unpickled), so the run "
                "folder needs them. Allowed: a folder written by python -m train"
            )
        try:
            resolve_hyperparams(entry, n_timesteps=1)
        except ValueError as error:
            raise ValueError(f"{layout.config_file}: {error}") from None
        return cls(run_dir, algo, env_id, entry, env_kwargs, path, normalizer)

    def check_env(self, env_id: str) -> None:
        """ValueError unless the run was trained on ``env_id``."""
        if self.env_id != env_id:
            raise ValueError(
                f"{self.run_dir} was trained on {self.env_id}; this task's env is {env_id}; "
                "allowed: a run of the same env"
            )


@dataclass(frozen=True, eq=False)
class TrainedPolicy:
    """A model saved by ``python -m train``, with what it needs to observe a condition."""

    files: RunFiles
    """The run folder's files the model was loaded from."""
    model: BaseAlgorithm
    which: WhichModel

    @classmethod
    def load(cls, run_dir: str | Path, which: WhichModel = "best") -> TrainedPolicy:
        """Load ``best_model.zip`` (``which="best"``, falling back to the final model when the
        run had no evaluations) or the final ``<env>.zip`` of a run folder."""
        return cls.from_files(RunFiles.read(run_dir, which), which)

    @classmethod
    def from_files(cls, files: RunFiles, which: WhichModel = "best") -> TrainedPolicy:
        """The policy of checked ``files``: its model loaded without unpickling anything
        (:func:`~train.checkpoint.load_policy_model`), its normalisation statistics read with
        their classes only; ValueError naming the file at fault."""
        model = load_policy_model(
            files.algo, files.model_path, files.entry, files.env_id, files.env_kwargs
        )
        if files.normalizer_path is not None:
            read_normalizer(files.normalizer_path)
        return cls(files=files, model=model, which=which)

    @property
    def run_dir(self) -> Path:
        return self.files.run_dir

    @property
    def algo(self) -> str:
        return self.files.algo

    @property
    def env_id(self) -> str:
        return self.files.env_id

    @property
    def env_kwargs(self) -> Mapping[str, Any]:
        """The env options it was trained with (``args.yml`` and the yml entry's
        ``env_kwargs``)."""
        return MappingProxyType(self.files.env_kwargs)

    @property
    def model_path(self) -> Path:
        return self.files.model_path

    @property
    def normalizer_path(self) -> Path | None:
        """VecNormalize statistics applied to observations, if the run normalised them."""
        return self.files.normalizer_path

    def _observing_env(self, conditions: Sequence[float]) -> VecEnv:
        # The training env's own observation path: reset at each condition through the env's
        # reset option, so the normalisation over the envelope is the one the policy learned.
        base = make_sb3_vec_env(self.env_id, n_envs=len(conditions), seed=0, **self.env_kwargs)
        venv: VecEnv = ConditionGrid(base, option_key(base), conditions)
        if self.normalizer_path is not None:
            normalizer = read_normalizer(self.normalizer_path)
            normalizer.set_venv(venv)
            venv = normalizer
            venv.training = False
            venv.norm_reward = False
        return venv

    def strokes(self, conditions: Sequence[float]) -> np.ndarray:
        """The deterministic normalised strokes (n, 28) in [-1, 1] at ``conditions``."""
        values = [float(c) for c in conditions]
        if not values:
            raise ValueError("conditions is empty; allowed: one or more conditions")
        venv = self._observing_env(values)
        try:
            observations = venv.reset()
        finally:
            venv.close()
        actions, _ = self.model.predict(observations, deterministic=True)
        # SAC's rescaling can land a float32 ulp outside the box; the env refuses that.
        return np.clip(np.asarray(actions, dtype=np.float64), -1.0, 1.0)

    @property
    def training_conditions(self) -> tuple[float, float] | float | None:
        """The condition range it was trained on, or the fixed condition (None if unknown)."""
        declared = getattr(config_class(self.env_id), "CONDITION", None)
        if declared is None:
            return None
        if self.env_kwargs.get(declared.range_keyword) is not None:
            low, high = self.env_kwargs[declared.range_keyword]
            return float(low), float(high)
        if self.env_kwargs.get(declared.keyword) is not None:
            return float(self.env_kwargs[declared.keyword])
        return None

    def trained_at(self, value: float) -> bool:
        """Whether ``value`` is a condition the policy saw in training (inside its sampled
        range, or its fixed condition); True when the training condition is unknown."""
        seen = self.training_conditions
        if isinstance(seen, tuple):
            return seen[0] - 1e-9 <= value <= seen[1] + 1e-9
        return seen is None or math.isclose(seen, value)

    @property
    def num_timesteps(self) -> int:
        return int(self.model.num_timesteps)


def policy_stroke(run_dir: str | Path, condition: float, which: WhichModel = "best") -> np.ndarray:
    """The trained run's deterministic normalised stroke (28,) at ``condition``."""
    return TrainedPolicy.load(run_dir, which).strokes([condition])[0]


# --- harness methods ---------------------------------------------------------------------------
@dataclass(frozen=True)
class PolicyMethod:
    """``policy:RUN_DIR``: ask a trained policy for its stroke (1 evaluation)."""

    run_dir: Path
    which: WhichModel = "best"

    @property
    def name(self) -> str:
        return f"policy:{self.run_dir}"

    def check(self, budget: int, dim: int, task: TaskSpec) -> None:
        """The harness's check before any work: the run folder holds a policy of this task's
        env, and its files load (the same load as :meth:`search`'s, so that a damaged or
        tampered folder is refused here, not as a failed job)."""
        files = RunFiles.read(self.run_dir, self.which)
        files.check_env(task.env_id)
        TrainedPolicy.from_files(files, self.which)

    def search(self, context: SearchContext) -> SearchOutcome:
        policy = TrainedPolicy.load(self.run_dir, self.which)
        policy.files.check_env(context.env_id)
        _warn_on_differences(policy, context)
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


def _warn_on_differences(policy: TrainedPolicy, context: SearchContext) -> None:
    # The condition's keywords may differ between training and evaluation.
    condition = condition_keywords()
    trained = {k: v for k, v in policy.env_kwargs.items() if k not in condition}
    asked = {k: v for k, v in context.env_kwargs.items() if k not in condition}
    if plain(trained) != plain(asked):
        warnings.warn(
            f"{policy.run_dir} was trained with env options {trained}, evaluated with {asked}",
            TrainingMismatchWarning,
            stacklevel=3,
        )
    if not policy.trained_at(context.condition.value):
        warnings.warn(
            f"{policy.run_dir} was trained at {policy.training_conditions}, asked at "
            f"{context.condition.describe()}",
            TrainingMismatchWarning,
            stacklevel=3,
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
    """If given, train through ``python -m train``'s code into ``log_dir/<algo>/<env>_<n>/``
    (Monitor, TensorBoard, final model, result.json; no EvalCallback and no checkpoints, whose
    evaluations the budget would not count), so the run can be plotted and reused as
    ``policy:RUN_DIR``."""

    def __post_init__(self) -> None:
        check_algo(self.algo)
        if "n_timesteps" in self.overrides:
            raise ValueError(
                f"method {self.algo!r}: n_timesteps cannot be set; the harness budget (env "
                "steps) is the only budget"
            )
        object.__setattr__(self, "overrides", MappingProxyType(dict(self.overrides)))
        for name, low in (("n_envs", 1), ("torch_threads", 1)):
            value = getattr(self, name)
            if value is None and name == "n_envs":
                continue
            if not is_integer(value) or value < low:
                raise ValueError(
                    f"method {self.algo!r}: {name} = {value!r}; allowed: an integer >= {low}"
                )
            object.__setattr__(self, name, int(value))
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

        unused = self._announce_budget(context)
        if self.log_dir is None:
            training = self._learn(context)
        else:
            training = self._learn_with_files(context)
        evaluations = training.steps + 1
        final_reward = training.final_reward
        # the selection rule (agents.selection); on a tie the stroke seen in training stays
        if training.best_action is None or is_better(
            training.final_feasible, final_reward, training.best_feasible, training.best_reward
        ):
            best_action, best_reward = training.final_action, final_reward
            chosen = "final policy"
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
                "hyperparams": to_jsonable(dict(training.hyperparams), default=repr),
                "n_envs": training.n_envs,
                "training_timesteps": training.steps,
                "budget_unused": unused,
                "result": "best stroke seen (training strokes and the final deterministic one)",
                "chosen": chosen,
                "final_policy": {
                    "reward": final_reward,
                    "objective": training.final_objective,
                    "feasible": training.final_feasible,
                    "action": training.final_action.tolist(),
                },
                "log_dir": self.log_dir,
                "run_dir": training.run_dir,
                "citation": CITATIONS[self.algo],
            },
        )

    def check(self, budget: int, dim: int, task: TaskSpec) -> None:
        """The harness's check before any work: the yml entry and the overrides resolve, and
        the budget holds one whole iteration (:func:`~train.run.budget_steps` raises)."""
        from train.config import load_entry
        from train.run import budget_steps

        entry = load_entry(self.algo, task.env_id, self.conf_file)
        budget_steps(self.algo, entry, self.overrides, self.n_envs, budget - 1)

    def _announce_budget(self, context: SearchContext) -> int:
        """Say (stderr, one line) when training cannot use the whole budget; returns the
        evaluations left unused. SB3 learns in whole iterations, so the training steps are
        ``budget - 1`` rounded down to one (:func:`~train.run.budget_steps`)."""
        from train.config import load_entry, resolve_hyperparams
        from train.run import budget_steps, step_granularity

        entry = load_entry(self.algo, context.env_id, self.conf_file)
        steps = budget_steps(self.algo, entry, self.overrides, self.n_envs, context.budget - 1)
        unused = context.budget - (steps + 1)
        # Once per process and setting, not once per seed: the seeds of a run share it.
        said = (self.algo, context.env_id, context.budget, self.n_envs, repr(self.overrides))
        if unused > 0 and said not in _ANNOUNCED:
            _ANNOUNCED.add(said)
            hp = resolve_hyperparams(entry, self.overrides, n_envs=self.n_envs, n_timesteps=1)
            unit = step_granularity(self.algo, hp)
            tqdm.write(
                f"{self.algo}: budget {context.budget} -> {steps} training steps (whole "
                f"{self.algo.upper()} iterations of {unit} env steps, n_envs {hp.n_envs}) + 1 "
                f"final evaluation; {unused} evaluations stay unused (each seed alike)",
                file=sys.stderr,
            )
        return unused

    def _learn(self, context: SearchContext) -> _Training:
        def report(recorder: StrokeRecorder) -> None:
            context.report(recorder.steps, recorder.evaluations, recorder.max_reward)

        model, recorder, hp = learn_in_memory(
            self.algo,
            context.env_id,
            context.env_kwargs,
            context.budget - 1,
            context.seed,
            overrides=self.overrides,
            n_envs=self.n_envs,
            hyperparams_file=self.conf_file,
            on_step=report,
            threads=self.torch_threads,
        )
        env = model.get_env()
        assert env is not None
        observation = env.reset()[:1]
        action, _ = model.predict(observation, deterministic=True)
        env.close()
        final_action = np.clip(np.asarray(action[0], dtype=np.float64), -1.0, 1.0)
        # The final stroke goes through the harness's evaluator, so the budget counts it.
        final = context.evaluate_batch(final_action[None, :])
        return _Training(
            best_action=recorder.best_action,
            best_reward=recorder.best_reward,
            best_feasible=recorder.best_feasible,
            history=list(recorder.history),
            steps=recorder.evaluations,
            hyperparams=hp.saved,
            n_envs=hp.n_envs,
            final_action=final_action,
            final_reward=float(final.rewards[0]),
            final_objective=float(final.objective[0]),
            final_feasible=bool(final.feasible[0]),
        )

    def _learn_with_files(self, context: SearchContext) -> _Training:
        from train.config import TrainConfig, load_entry
        from train.run import budget_steps, train

        entry = load_entry(self.algo, context.env_id, self.conf_file)
        steps = budget_steps(self.algo, entry, self.overrides, self.n_envs, context.budget - 1)
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
        # train() evaluated the final deterministic stroke at the (fixed) condition once.
        [final] = result.final_evaluation
        saved = read_run_yaml(RunLayout(result.run_dir, context.env_id).config_file)  # type: ignore[arg-type]
        return _Training(
            best_action=result.best_action,
            best_reward=result.best_reward,
            best_feasible=bool((result.best_info or {}).get("feasible", False)),
            history=list(result.history),
            steps=result.num_timesteps,
            hyperparams=saved,
            n_envs=int(saved["n_envs"]),
            final_action=np.clip(np.asarray(final["action"], dtype=np.float64), -1.0, 1.0),
            # float64 as the harness re-evaluates it (the adapter's reward is float32)
            final_reward=float(final["objective"] - final["penalty"]),
            final_objective=float(final["objective"]),
            final_feasible=bool(final["feasible"]),
            run_dir=str(result.run_dir),
        )


@dataclass(frozen=True)
class _Training:
    """What one training pass hands back to :meth:`TrainingMethod.search`."""

    best_action: np.ndarray | None
    """Best stroke the training env evaluated, feasible ones first (None if none)."""
    best_reward: float
    best_feasible: bool
    history: list[tuple[int, float]]
    steps: int
    """Env steps trained (each one stroke evaluated)."""
    hyperparams: Mapping[str, Any]
    n_envs: int
    final_action: np.ndarray
    final_reward: float
    final_objective: float
    final_feasible: bool
    run_dir: str | None = None


def train_and_propose(
    algo: str,
    task: str,
    condition: float,
    budget: int,
    seed: int,
    **options: Any,
) -> np.ndarray:
    """Train ``algo`` within ``budget`` env steps at ``condition`` and return the chosen stroke
    (normalised, (28,)); the same as ``agents.harness.run(algo, ...)`` without the record."""
    from agents.harness import run

    record = run(algo, task, condition, budget, [seed], progress=False, **options)[0]
    return np.asarray(record.normalised_stroke, dtype=np.float64)


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


def training_factory(algo: str):
    """The factory of ``ppo`` or ``sac``: settings are hyperparameter overrides, plus
    ``n_envs``, ``conf_file`` (a zoo-format yml) and ``torch_threads``."""

    def factory(argument: str | None, config: Mapping[str, Any]) -> Method:
        if argument is not None:
            raise ValueError(f"method {algo!r} takes no ':' argument; got {algo}:{argument}")
        settings = dict(config)
        extra = {key: settings.pop(key) for key in _TRAINING_SETTINGS if key in settings}
        return TrainingMethod(algo, overrides=settings, **extra)

    return factory


def register() -> None:
    """Register ``ppo``, ``sac`` and ``policy`` with the harness (idempotent)."""
    from agents.methods import register_method

    for algo in ALGOS:
        register_method(algo, training_factory(algo), replace=True)
    register_method("policy", policy_factory, replace=True)


# Importing this module registers the methods: agents.methods.PROVIDERS names it.
register()
