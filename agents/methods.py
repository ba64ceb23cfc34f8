"""Search methods the harness can run, and the registry that names them.

A method has a ``name`` and ``search(context) -> SearchOutcome``: an optimiser calls
``context.evaluate(actions)`` once per batch; a learner builds its own envs from the context. A
method's module registers it when imported (:func:`register_optimiser`, :func:`register_method`),
found by its name in a ``tandem_env.optimisers`` entry point (this project's in its pyproject.toml,
``train``'s included; a plug-in's in its own; docs/harness.md, "Methods: protocol and registry").
"""

from __future__ import annotations

import contextlib
import importlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, fields
from importlib.metadata import entry_points
from typing import Any, Protocol, runtime_checkable

import numpy as np

from agents.evaluator import EvaluatedBatch, VectorEnvEvaluator
from agents.optimiser import OptimiserConfig
from agents.tasks import Condition, TaskSpec


@dataclass(frozen=True, eq=False)
class SearchContext:
    """What a method is given for one seed."""

    task: TaskSpec
    condition: Condition
    """The fixed condition of every episode (e.g. speed = 1.5 m/s)."""
    env_id: str
    env_kwargs: Mapping[str, Any]
    """Constructor keywords that make the env of this run (they include the condition)."""
    budget: int
    """Maximum number of model evaluations (= env steps = strokes evaluated)."""
    seed: int
    """The run's seed; equal seeds must give identical runs."""
    dim: int
    """Dimension of the action box [-1, 1]^dim."""
    evaluator: VectorEnvEvaluator
    """The batched fitness; use :meth:`evaluate`."""
    _reporter: Callable[[int, int, float], None] | None = field(default=None, repr=False)

    def evaluate(self, actions: np.ndarray) -> np.ndarray:
        """Rewards (n,) of actions (n, dim) in [-1, 1], in one vector-env step (n budget units)."""
        return self.evaluator(actions)

    def evaluate_batch(self, actions: np.ndarray) -> EvaluatedBatch:
        """As :meth:`evaluate`, also returning the raw objective and feasibility."""
        return self.evaluator.evaluate_batch(actions)

    @property
    def remaining(self) -> int:
        """Budget not yet spent through :meth:`evaluate`."""
        return self.budget - self.evaluator.evaluations

    def report(self, iteration: int, evaluations: int, best_reward: float) -> None:
        """Progress of a method that runs its own envs (e.g. RL training)."""
        if self._reporter is not None:
            self._reporter(iteration, evaluations, best_reward)


@dataclass(frozen=True, eq=False)
class SearchOutcome:
    """What a method found."""

    best_action: np.ndarray
    """The normalised stroke (dim,) to record (it is re-evaluated by the harness)."""
    best_reward: float
    """Its reward as the method saw it [reward units]."""
    evaluations: int
    """Model evaluations (env steps) used, <= the budget."""
    history: tuple[tuple[int, float], ...]
    """(evaluations, best reward so far) pairs, evaluations increasing."""
    config: dict[str, Any]
    """The method's configuration as used (JSON-ready), including a ``citation``."""

    def __post_init__(self) -> None:
        if (action := np.array(self.best_action, dtype=np.float64)).ndim != 1:
            raise ValueError(f"best_action must be 1-D; got shape {action.shape}")
        action.setflags(write=False)
        object.__setattr__(self, "best_action", action)
        object.__setattr__(self, "history", tuple((int(e), float(b)) for e, b in self.history))


@runtime_checkable
class Method(Protocol):
    """A search method the harness can run (see the module docstring)."""

    @property
    def name(self) -> str:
        """The method spec it was made from, e.g. ``"pso"`` or ``"policy:runs/ppo"``."""
        ...

    def search(self, context: SearchContext) -> SearchOutcome:
        """Search within ``context.budget`` evaluations; deterministic for ``context.seed``."""
        ...


MethodFactory = Callable[[str | None, Mapping[str, Any]], Method]
"""``factory(argument, config) -> Method``; should validate ``config`` and raise ValueError."""


@dataclass(frozen=True)
class AskTellMethod:
    """An ask/tell optimiser run on the vector-env fitness; its config is built once at
    construction (budget 1) so bad settings fail early."""

    name: str
    config_class: Callable[..., OptimiserConfig]
    settings: Mapping[str, Any]
    from_task: Mapping[str, Callable[[TaskSpec], Any]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.config_class(**self.settings, max_evaluations=1)

    def config(self, budget: int, task: TaskSpec | None = None) -> OptimiserConfig:
        """The optimiser configuration for ``budget`` evaluations (on ``task``, if given)."""
        extra = {} if task is None else {key: get(task) for key, get in self.from_task.items()}
        return self.config_class(**self.settings, **extra, max_evaluations=budget)

    def check(self, budget: int, dim: int, task: TaskSpec) -> None:
        """Raise ValueError if the optimiser cannot run this budget on this box (e.g. a budget
        smaller than one CMA-ES population); the harness calls it before any evaluation."""
        self.config(budget, task).build(dim, 0)

    def search(self, context: SearchContext) -> SearchOutcome:
        optimiser = self.config(context.budget, context.task).build(context.dim, context.seed)
        while not optimiser.done:
            X = optimiser.ask()
            optimiser.tell(X, context.evaluate(X))
        if (best := optimiser.best_position) is None:
            raise RuntimeError(f"{self.name}: every evaluation returned NaN or -inf")
        found = (best, optimiser.best_fitness, optimiser.evaluations, tuple(optimiser.history))
        return SearchOutcome(*found, config=optimiser.record())


#: The setting a study's preset swarm size goes to, per ask/tell method (None: the method
#: keeps its own default batch), filled by :func:`register_optimiser`.
_PRESET_BATCH: dict[str, str | None] = {}


def register_optimiser(
    name: str,
    config_class: type,
    *,
    batch: str,
    from_task: Mapping[str, Callable[[TaskSpec], Any]] | None = None,
    preset_batch: bool = True,
    replace: bool = False,
) -> None:
    """Register an ask/tell optimiser as method ``name``: its settings are ``config_class``'s
    fields but ``max_evaluations`` (the harness's budget) and those ``from_task`` fills;
    ``batch`` names the points per round (alias ``swarm_size``, the CLI's ``--swarm-size``),
    which a study's preset sets unless ``preset_batch=False``."""
    filled = dict(from_task or {})
    allowed = tuple(
        f.name for f in fields(config_class) if f.name != "max_evaluations" and f.name not in filled
    )
    if batch not in allowed:
        raise ValueError(f"batch {batch!r} is not a setting of {config_class.__name__}: {allowed}")

    def factory(argument: str | None, config: Mapping[str, Any]) -> Method:
        if argument is not None:
            raise ValueError(f"method {name!r} takes no ':' argument; got {name}:{argument}")
        settings = dict(config)
        if budget := sorted({"iterations", "max_evaluations"} & set(settings)):
            raise ValueError(
                f"method {name!r}: {budget} cannot be set here; the harness budget (model "
                "evaluations) is the only budget"
            )
        if batch != "swarm_size" and "swarm_size" in settings:
            alias = settings.pop("swarm_size")
            if settings.setdefault(batch, alias) != alias:
                raise ValueError(f"method {name!r}: give {batch} or its alias swarm_size, not both")
        if unknown := sorted(set(settings) - set(allowed)):
            raise ValueError(
                f"method {name!r}: unknown setting(s) {unknown}; allowed: {', '.join(allowed)}"
                + ("" if batch == "swarm_size" else f", swarm_size (alias of {batch})")
            )
        return AskTellMethod(name, config_class, settings, filled)

    register_method(name, factory, replace=replace)
    _PRESET_BATCH[name] = batch if preset_batch else None


def preset_batch_setting(method: str) -> str | None:
    """The setting of ``method`` (a spec) that a study's preset swarm size sets, or None."""
    if (name := method.partition(":")[0]) not in _REGISTRY and name in providers():
        with contextlib.suppress(NotImplementedError):  # a provider that is not there: none
            _factory(name)  # registers it (and its batch setting)
    return _PRESET_BATCH.get(name)


_REGISTRY: dict[str, MethodFactory] = {}


def register_method(name: str, factory: MethodFactory, *, replace: bool = False) -> None:
    """Register ``factory`` under ``name`` (a method spec is ``name`` or ``name:argument``)."""
    if not isinstance(name, str) or not name or ":" in name or name != name.strip():
        raise ValueError(f"method name {name!r}; allowed: a non-empty name without ':' or spaces")
    if not callable(factory):
        raise ValueError(f"factory for {name!r} is not callable: {factory!r}")
    if name in _REGISTRY and not replace and _REGISTRY[name] is not factory:
        raise ValueError(f"method {name!r} is already registered; pass replace=True to replace it")
    _REGISTRY[name] = factory


#: The entry-point group that names every method: name -> the module that registers it when
#: imported, e.g. ``hill-climb = "my_opt"`` under ``[project.entry-points."tandem_env.optimisers"]``
#: (this project's own: its pyproject.toml).
OPTIMISER_ENTRY_POINTS = "tandem_env.optimisers"


def providers() -> dict[str, str]:
    """Method name -> the module that registers it on first use: the installed
    ``tandem_env.optimisers`` entry points (read now)."""
    return {p.name: p.module for p in entry_points(group=OPTIMISER_ENTRY_POINTS)}


def available_methods() -> tuple[str, ...]:
    """Registered method names plus those a provider module would register on first use."""
    return tuple(sorted({*providers(), *_REGISTRY}))


def _factory(name: str) -> MethodFactory:
    if name in _REGISTRY:
        return _REGISTRY[name]
    if name not in (known := providers()):
        installed = "" if known else " (no entry points installed: pip install -e . here)"
        raise ValueError(
            f"unknown method {name!r}; allowed: {', '.join(available_methods())} "
            f"('policy' as policy:RUN_DIR){installed}"
        )
    module = known[name]
    try:
        importlib.import_module(module)
    except ModuleNotFoundError as error:
        # only a missing provider is "not implemented"; one whose own imports fail is a real
        # error and propagates
        if module != error.name and not module.startswith(f"{error.name}."):
            raise
        raise NotImplementedError(
            f"method {name!r} is provided by module {module}, which is not available: {error}"
        ) from error
    if name not in _REGISTRY:
        raise NotImplementedError(
            f"method {name!r} is provided by module {module}, but importing it did not "
            f"register {name!r} (it should call agents.methods.register_optimiser or "
            "register_method)"
        )
    return _REGISTRY[name]


def get_method(spec: str | Method, config: Mapping[str, Any] | None = None) -> Method:
    """The method for a spec such as ``"pso"`` or ``"policy:runs/ppo"``: ValueError for an
    unknown name or bad settings, NotImplementedError for a provider that is not there."""
    if not isinstance(spec, str):
        if isinstance(spec, Method):
            if config:
                raise ValueError("method_config is only used with a method name, not an object")
            return spec
        raise ValueError(f"method = {spec!r}; allowed: a method name or a Method object")
    name, sep, argument = spec.partition(":")
    if sep and not argument:
        raise ValueError(f"method {spec!r}: empty argument after ':'")
    return _factory(name)(argument if sep else None, dict(config or {}))
