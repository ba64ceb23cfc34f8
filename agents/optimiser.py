"""Shared ask/tell machinery of the black-box maximisers over the box [-1, 1]^d: the budget,
best-so-far bookkeeping and history, and their settings' checks, derived from the fields."""

from __future__ import annotations

import functools
from abc import ABC, abstractmethod
from dataclasses import MISSING, dataclass, field, fields
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agents.selection import BestStroke
from tandem_env.io.files import to_jsonable
from tandem_env.physics.checks import count, finite_real
from tandem_env.physics.model import MAX_BATCH_STROKES

FloatArray = NDArray[np.float64]
SeedLike = int | np.random.SeedSequence | None


#: The most points of one ask/tell round [-]: one batched model evaluation.
MAX_BATCH = MAX_BATCH_STROKES


def integer_setting(minimum: int, maximum: int | None = None, *, default: Any = MISSING) -> Any:
    """A config field of an integer ``>= minimum`` (``<= maximum``), checked by
    :func:`check_settings`; a None ``default`` also allows None."""
    check = functools.partial(count, low=minimum, high=maximum)
    return field(default=default, metadata={"check": check})


def real_setting(low: float, high: float, *, low_inclusive: bool, default: Any = MISSING) -> Any:
    """A config field of a finite number in the interval, checked by :func:`check_settings`;
    a None ``default`` also allows None."""
    check = functools.partial(finite_real, low=low, high=high, above=not low_inclusive)
    return field(default=default, metadata={"check": check})


def check_settings(config: Any, prefix: str = "") -> None:
    """Check every field of ``config`` declared by :func:`integer_setting` or
    :func:`real_setting` (ValueError naming it, after ``prefix``), stored as a plain int / float."""
    for spec in fields(config):
        value = getattr(config, spec.name)
        if "check" in spec.metadata and not (value is None and spec.default is None):
            checked = spec.metadata["check"](value, prefix + spec.name)
            object.__setattr__(config, spec.name, checked)


class Tally:
    """Points evaluated, rounds, and the best value so far with its point (the rule of
    :mod:`agents.selection` without constraints): the base of an optimiser and the evaluator."""

    def __init__(self) -> None:
        self.evaluations = 0
        """Points (strokes, actions) evaluated so far."""
        self.iterations = 0
        """Rounds (ask/tell rounds, batches) so far."""
        self.history: list[tuple[int, float]] = []
        """(evaluations, best value so far) after every round."""
        self._top = BestStroke()
        self._top_point: FloatArray | None = None

    @property
    def best_value(self) -> float:
        """Best value so far (-inf before any above -inf)."""
        return self._top.reward

    @property
    def best_point(self) -> FloatArray | None:
        """The point of the best value (a copy), or None before any value above -inf."""
        return None if self._top_point is None else self._top_point.copy()

    def add(self, points: FloatArray, values: ArrayLike) -> None:
        """Count a round of points (n, dim) with their values (n,) and keep the best."""
        values = np.asarray(values, dtype=np.float64)
        if (i := self._top.offer(np.zeros(values.shape, dtype=bool), values)) is not None:
            self._top_point = np.array(points[i], dtype=np.float64)
        self.evaluations += values.shape[0]
        self.iterations += 1
        self.history.append((self.evaluations, self.best_value))


@dataclass(frozen=True, kw_only=True)
class OptimiserConfig:
    """Base of an optimiser's frozen configuration: checks, record (:meth:`to_dict`) and
    :meth:`build` follow from its fields. A subclass names its ``algorithm`` and ``citation``;
    its optimiser names it (``class PSO(AskTellOptimiser, settings=PSOConfig)``)."""

    algorithm: ClassVar[str]
    """The record's name of the algorithm."""
    optimiser: ClassVar[type[AskTellOptimiser]]
    """The ask/tell class :meth:`build` makes (set by its ``settings=`` class keyword)."""

    max_evaluations: int = integer_setting(1)
    """Points evaluated (>= 1), the harness's budget; the last round is truncated to fit."""

    def __post_init__(self) -> None:
        check_settings(self)

    def in_use(self) -> dict[str, Any]:
        """What the record adds to (or puts in place of) the settings: the constants and rules
        in use (none here)."""
        return {}

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready record: the algorithm, every setting, :meth:`in_use` and the citation."""
        settings = {spec.name: getattr(self, spec.name) for spec in fields(self)}
        record = {"algorithm": self.algorithm, **settings, **self.in_use()}
        return to_jsonable({**record, "citation": self.citation})  # type: ignore[attr-defined]

    def build(self, dim: int, seed: SeedLike = None) -> AskTellOptimiser:
        """A fresh optimiser of ``dim`` dimensions for this configuration, seeded by ``seed``."""
        return self.optimiser(dim, self, seed)  # type: ignore[call-arg]


class AskTellOptimiser(Tally, ABC):
    """Base class for batched ask/tell maximisers over [-1, 1]^dim: subclasses implement
    :meth:`_propose` and :meth:`_observe`; ``config.max_evaluations`` bounds the run, ``seed``
    seeds ``numpy.random.default_rng`` (equal seeds, identical runs)."""

    _settings: ClassVar[type[OptimiserConfig]] = OptimiserConfig

    def __init_subclass__(cls, settings: type[OptimiserConfig] | None = None, **kw: Any) -> None:
        super().__init_subclass__(**kw)
        if settings is not None:
            settings.optimiser, cls._settings = cls, settings

    def __new__(cls, dim: int, config: OptimiserConfig, *args: Any, **kw: Any) -> AskTellOptimiser:
        # before the subclass's __init__ reads its settings from ``config``
        if not isinstance(config, cls._settings):
            name = cls._settings.__name__
            raise TypeError(f"config must be a {name}, got {type(config).__name__}")
        return super().__new__(cls)

    def __init__(self, dim: int, batch_size: int, config: OptimiserConfig, seed: SeedLike) -> None:
        super().__init__()
        self.dim = count(dim, "dim")
        """Dimension of the search box."""
        self.config = config
        """The configuration this optimiser was built from."""
        self._full_batch = int(batch_size)
        self._rng = np.random.default_rng(seed)
        self._pending: FloatArray | None = None

    def _batch(self) -> int:
        """Points in the next full round (constant here; CMA-ES changes it on a restart)."""
        return self._full_batch

    @abstractmethod
    def _propose(self, n: int) -> FloatArray:
        """Return the next ``n`` points, shape (n, dim), inside the box."""

    @abstractmethod
    def _observe(self, X: FloatArray, fitness: FloatArray) -> None:
        """Update internal state from a told batch; NaN has already been mapped to -inf."""

    def _next_size(self) -> int:
        """Points in the next round: a full one, or what is left of the budget (0 at the end)."""
        return max(0, min(self._batch(), self.config.max_evaluations - self.evaluations))

    def ask(self) -> FloatArray:
        """Next batch of points (n, dim) in [-1, 1]^dim, the last truncated to the budget."""
        if self._pending is not None:
            raise RuntimeError("ask() called again before tell(); tell the pending batch first")
        if (n := self._next_size()) == 0:
            done = f"budget exhausted after {self.evaluations} evaluations; check `done` first"
            raise RuntimeError(done)
        self._pending = self._propose(n)
        return self._pending.copy()

    def tell(self, X: ArrayLike, fitness: ArrayLike) -> None:
        """Report the fitness (n,) (NaN counts as -inf) of the last :meth:`ask`'s batch X."""
        if self._pending is None:
            raise RuntimeError("tell() called without a preceding ask()")
        X = np.asarray(X, dtype=float)
        # PSO state is keyed to the asked rows, so a reordered or edited batch would corrupt it.
        if X.shape != self._pending.shape or not np.array_equal(X, self._pending):
            raise ValueError(
                f"tell() must receive the batch returned by the last ask() unchanged "
                f"(shape {self._pending.shape}), got shape {X.shape} or modified values"
            )
        if (f := np.asarray(fitness, dtype=float)).shape != (X.shape[0],):
            raise ValueError(f"fitness must have shape ({X.shape[0]},), got {f.shape}")
        f = np.where(np.isnan(f), -np.inf, f)
        self._observe(self._pending, f)
        self.add(self._pending, f)
        self._pending = None

    best_position = Tally.best_point
    best_fitness = Tally.best_value

    @property
    def done(self) -> bool:
        """True once the budget is exhausted (a further :meth:`ask` would raise)."""
        return self._next_size() == 0

    def record(self) -> dict[str, Any]:
        """JSON-ready record of the run's configuration (CMA-ES adds its restarts)."""
        return self.config.to_dict()
