"""CMA-ES with IPOP / BIPOP restarts over the normalised box [-1, 1]^d, on the ``cmaes`` package.

The package's CMA-ES with margin (``cmaes.CMAwM``) plus what it leaves to its caller
(docs/harness.md, "CMA-ES"): discrete coordinates on the bin centres, restarts from a uniform
random mean, Hansen's (2009) stagnation test, and a budget that truncates (a run of budget B
is the first B evaluations of any longer run).

References
----------
N. Hansen, "The CMA evolution strategy: a tutorial", arXiv:1604.00772, 2016.
A. Auger, N. Hansen, "A restart CMA evolution strategy with increasing population size",
Proc. IEEE CEC 2005, pp. 1769-1776.
N. Hansen, "Benchmarking a BI-population CMA-ES on the BBOB-2009 function testbed", Proc.
GECCO 2009 (companion), pp. 2389-2396.
R. Hamano, S. Saito, M. Nomura, S. Shirakawa, "CMA-ES with margin: lower-bounding marginal
probability for mixed-integer black-box optimization", Proc. GECCO 2022, pp. 639-647.
M. Nomura, M. Shibata, "cmaes: a simple yet practical Python library for CMA-ES",
arXiv:2402.01373, 2024.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace
from importlib.metadata import version
from typing import Any, Literal, get_args

import numpy as np
from cmaes import CMAwM

from agents.methods import register_optimiser
from agents.optimiser import (
    AskTellOptimiser,
    FloatArray,
    OptimiserConfig,
    SeedLike,
    integer_setting,
    real_setting,
)
from tandem_env.envs.base import ACTION_HIGH, ACTION_LOW
from tandem_env.physics.checks import count

Restarts = Literal["none", "ipop", "bipop"]

#: Population growth per large restart (Auger & Hansen 2005).
POPSIZE_FACTOR = 2
#: Smallest population: CMA-ES recombines the best half, which needs a few points.
MIN_POPSIZE = 4
#: Largest initial step size [box units]: the box is 2 wide.
MAX_SIGMA0 = 2.0
#: Generations between two stagnation checks: the tests watch slow quantities (a history of
#: >= 120 generations), and ``should_stop()`` costs about a generation's ``ask``.
CHECK_EVERY = 10
#: The default population as a multiple of Hansen's 4 + ⌊3 ln d⌋ (13 at d = 28).
POPSIZE_MULTIPLE = 4

_SCHEDULES = {
    "none": "no restarts",
    "ipop": "IPOP restarts (Auger & Hansen 2005, Proc. IEEE CEC pp. 1769-1776)",
    "bipop": "BIPOP restarts (Hansen 2009, Proc. GECCO companion pp. 2389-2396)",
}


def default_popsize(dim: int) -> int:
    """Four times Hansen's default population, 4 (4 + ⌊3 ln d⌋) (52 at d = 28): with the polish, the
    best of 8 seeds reproduces on disjoint seed sets (docs/harness.md, "Reproducibility check")."""
    return POPSIZE_MULTIPLE * (4 + math.floor(3.0 * math.log(dim)))


def discrete_levels(levels: int) -> FloatArray:
    """The normalised values of a discrete coordinate with ``levels`` values: the bin centres."""
    return -1.0 + (2.0 * np.arange(levels) + 1.0) / levels


@dataclass(frozen=True, kw_only=True)
class CMAESConfig(OptimiserConfig):
    """Configuration of :class:`CMAES` (defaults chosen by measurement: docs/harness.md)."""

    algorithm = "cmaes"

    popsize: int | None = integer_setting(MIN_POPSIZE, default=None)
    """Population of the first run (>= 4); None uses :func:`default_popsize` of the dimension."""
    sigma0: float = real_setting(0.0, MAX_SIGMA0, low_inclusive=False, default=0.5)
    """Initial step size [box units; the box is 2 wide], in (0, 2]."""
    restarts: Restarts = "bipop"
    """Restart schedule (module docstring)."""
    patience: int | None = integer_setting(1, default=None)
    """Shortest stagnation history [generations] (>= 1); None: ``120 + ⌈30 d / λ⌉`` per run."""
    tolerance: float = real_setting(0.0, math.inf, low_inclusive=True, default=1e-4)
    """Relative rise of the history's median (best) fitness that counts as progress (>= 0)."""
    resampling: int = integer_setting(0, default=100)
    """Draws of a candidate outside the box before it is clipped (``n_max_resampling``, >= 0)."""
    discrete: tuple[tuple[int, int], ...] = ()
    """``(index, levels)`` of each discrete coordinate: distinct indices >= 0, levels >= 2."""

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.restarts not in _SCHEDULES:
            raise ValueError(f"restarts must be one of {get_args(Restarts)}, got {self.restarts!r}")
        allowed = "a tuple of distinct (index >= 0, levels >= 2) pairs"
        try:
            pairs = tuple(tuple(pair) for pair in self.discrete)
        except TypeError:
            raise ValueError(f"discrete must be {allowed}, got {self.discrete!r}") from None
        if bad := [pair for pair in pairs if len(pair) != 2]:
            raise ValueError(f"discrete must be {allowed}, got the entry {bad[0]!r}")
        index, levels = "discrete index", "discrete levels"
        pairs = tuple((count(i, index, low=0), count(k, levels, low=2)) for i, k in pairs)
        if len({i for i, _ in pairs}) != len(pairs):
            raise ValueError(f"discrete must be {allowed}; index repeated in {self.discrete!r}")
        object.__setattr__(self, "discrete", pairs)

    @property
    def citation(self) -> str:
        """The variant and its sources."""
        return (
            "CMA-ES (Hansen 2016, arXiv:1604.00772) with margin for discrete coordinates "
            f"(Hamano et al. 2022, Proc. GECCO pp. 639-647), cmaes package {version('cmaes')} "
            f"(Nomura & Shibata 2024, arXiv:2402.01373); {_SCHEDULES[self.restarts]}"
        )

    def in_use(self) -> dict[str, Any]:
        """The record's rules in use: population and patience, the bounds, the package."""
        popsize = f"{POPSIZE_MULTIPLE} (4 + floor(3 ln d))" if self.popsize is None else "given"
        return {
            "popsize_rule": popsize,
            "patience_rule": "120 + ceil(30 d / popsize)" if self.patience is None else "given",
            "popsize_factor": POPSIZE_FACTOR,
            "bounds": "redraw up to `resampling` times, then clip onto [-1, 1] (cmaes)",
            "package": f"cmaes {version('cmaes')}",
        }


@dataclass
class RunInfo:
    """One CMA-ES run between restarts, as recorded."""

    regime: Literal["first", "small", "large"]
    popsize: int
    sigma0: float
    start: int  # evaluations before the run [-]
    evaluations: int = 0  # evaluations of the run [-]
    generations: int = 0  # full populations told [-]
    best: float = -math.inf  # best fitness the run evaluated
    stop: str = "budget"  # why it ended: "stagnation", "should_stop" or "budget"


class CMAES(AskTellOptimiser, settings=CMAESConfig):
    """CMA-ES maximiser with restarts and discrete coordinates, ask/tell over [-1, 1]^dim;
    ``seed`` draws every run's mean, the BIPOP choices and each ``CMAwM``'s seed."""

    def __init__(self, dim: int, config: CMAESConfig, seed: SeedLike = None) -> None:
        count(dim, "dim")
        if config.max_evaluations < (popsize := config.popsize or default_popsize(dim)):
            raise ValueError(
                f"budget of {config.max_evaluations} evaluations is smaller than one CMA-ES "
                f"population ({popsize} points); allowed: a budget >= {popsize}, or a smaller "
                f"popsize (>= {MIN_POPSIZE})"
            )
        if bad := [i for i, _ in config.discrete if i >= dim]:
            box = f"the box of dimension {dim}; allowed: 0 to {dim - 1}"
            raise ValueError(f"discrete index {bad[0]} is outside {box}")
        super().__init__(dim, popsize, config, seed)
        self._popsize0 = popsize
        self._bounds = np.tile([ACTION_LOW, ACTION_HIGH], (dim, 1)).astype(float)
        self._steps = np.zeros(dim)  # CMAwM: > 0 marks a discrete coordinate and its spacing
        for index, levels in config.discrete:
            values = discrete_levels(levels)
            self._bounds[index] = values[0], values[-1]
            self._steps[index] = values[1] - values[0]
        self._used = {"small": 0, "large": 0}  # evaluations per BIPOP regime
        self._large_restarts = 0
        self._runs: list[RunInfo] = []
        self._start_run("first", popsize, config.sigma0, 0)

    def _start_run(self, regime: str, popsize: int, sigma: float, start: int) -> None:
        self._es = CMAwM(
            mean=self._rng.uniform(self._bounds[:, 0], self._bounds[:, 1]),
            sigma=sigma,
            bounds=self._bounds,
            steps=self._steps,
            n_max_resampling=self.config.resampling,
            seed=int(self._rng.integers(2**32)),
            population_size=popsize,
        )
        self._run = RunInfo(regime, popsize, float(sigma), start)  # type: ignore[arg-type]
        self._best: list[float] = []  # best fitness of each generation told
        self._median: list[float] = []  # ... and its median
        self._patience = self.config.patience or 120 + math.ceil(30 * self.dim / popsize)

    def _batch(self) -> int:
        return self._es.population_size

    def _propose(self, n: int) -> FloatArray:
        # the whole population is drawn even when n < λ: the stream does not depend on the budget
        encoded, raw = zip(*(self._es.ask() for _ in range(self._es.population_size)), strict=True)
        self._raw = raw  # what the package learns from (discrete coordinates not encoded)
        return np.array(encoded[:n])

    def _observe(self, X: FloatArray, fitness: FloatArray) -> None:
        run = self._run
        run.evaluations += len(fitness)
        run.best = max(run.best, float(fitness.max()))
        if len(fitness) < self._es.population_size:
            return  # a truncated last population: the budget ends here
        self._best.append(float(fitness.max()))
        self._median.append(float(np.median(fitness)))
        # cmaes minimises: tell the negated fitness (NaN, mapped to -inf, becomes +inf).
        self._es.tell(list(zip(self._raw, (-fitness).tolist(), strict=True)))
        run.generations = self._es.generation
        check = self.config.restarts != "none" and len(self._best) % CHECK_EVERY == 0
        if check and (stop := self._stop()) is not None:
            self._restart(stop)

    def _stop(self) -> str | None:
        """Why the current run should end now, or None: the newest 30 % of the window no better
        than the oldest 30 % by ``tolerance · |oldest|`` in both histories' medians
        (docs/harness.md, "CMA-ES")."""
        if self._es.should_stop():
            return "should_stop"
        length = min(max(self._patience, math.ceil(0.2 * len(self._best))), 20_000)
        if len(self._best) < length:
            return None
        part = max(1, math.ceil(0.3 * length))
        for history in (self._best, self._median):
            window = history[-length:]
            old, new = float(np.median(window[:part])), float(np.median(window[-part:]))
            if new > (old + self.config.tolerance * abs(old) if math.isfinite(old) else old):
                return None
        return "stagnation"

    def _restart(self, stop: str) -> None:
        finished = self._run
        finished.stop = stop
        self._runs.append(finished)
        self._used["large" if finished.regime == "large" else "small"] += finished.evaluations
        end = finished.start + finished.evaluations
        if self.config.restarts == "bipop" and self._used["small"] < self._used["large"]:
            u, v = self._rng.random(2)
            multiplier = POPSIZE_FACTOR**self._large_restarts
            popsize = max(MIN_POPSIZE, math.floor(self._popsize0 * multiplier ** (u**2)))
            self._start_run("small", popsize, self.config.sigma0 * 10.0 ** (-2.0 * v), end)
        else:
            self._large_restarts += 1
            popsize = self._popsize0 * POPSIZE_FACTOR**self._large_restarts
            self._start_run("large", popsize, self.config.sigma0, end)

    @property
    def runs(self) -> list[RunInfo]:
        """Every run so far (copies), the current one last (its ``stop`` is ``"budget"``)."""
        return [replace(run) for run in (*self._runs, self._run)]

    def record(self) -> dict[str, Any]:
        """The configuration record with every run (regime, population, σ0, evaluations...)."""
        return {**super().record(), "runs": [asdict(run) for run in self.runs]}


register_optimiser(
    "cmaes",
    CMAESConfig,
    batch="popsize",
    from_task={"discrete": lambda task: task.discrete_actions},
    preset_batch=False,  # its default population, 26 at d = 28, is measured (docs/harness.md)
)
