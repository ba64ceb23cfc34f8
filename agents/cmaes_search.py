"""CMA-ES with IPOP / BIPOP restarts over the normalised box [-1, 1]^d.

The evolution strategy itself is the ``cmaes`` package's CMA-ES with margin (``cmaes.CMAwM``,
Hamano et al. 2022), which is the standard CMA-ES (Hansen 2016) on the continuous coordinates
and keeps a discrete coordinate from fixing on one value for good. This module adds what the
package leaves to its caller: the box, the discrete coordinates, one batched population per
ask, the restart schedule and the stagnation rule that triggers it.

**Box and bounds.** Every coordinate lives in [-1, 1], with the package's bounds support: a
candidate whose continuous coordinates leave the box is drawn again, up to ``resampling``
times (default 100, the package's), and the last draw is clipped onto the walls if none fell
inside. The point evaluated is the point the distribution learns from. Resampling matters on
level flight: with clipping alone (``resampling=0``) many candidates sit on the walls, and
the median η over four tuning seeds at 30 000 evaluations was 0.33-0.41 (several settings)
where resampling reached 0.44-0.46 (docs/harness.md).

**Discrete coordinates.** ``discrete = ((index, levels), ...)``: coordinate ``index`` takes
``levels`` values, level i being the centre of the i-th of ``levels`` equal bins of [-1, 1]
(``-1 + (2 i + 1) / levels``). This is the convention of ``tandem_env``'s stroke map for the
harmonic N (N = 1 where a < 0, N = 2 otherwise; ``physical_to_normalised`` maps N = 1 to -0.5
and N = 2 to +0.5): CMAwM's lattice for that coordinate is exactly {-0.5, +0.5}, so every
evaluated stroke has an integer N and nothing is rounded behind the optimiser's back.

**One population = one batch.** A population is sampled in one vectorised draw from the
package's own state (mean, step size, eigendecomposition, random stream) and is one ask/tell
round of :class:`~agents.optimiser.AskTellOptimiser`, so one batched model call. The draw is
exactly the package's ``ask()`` called λ times (the same normal deviates of the same random
stream, the same resampling), done with array operations; deviates drawn ahead are kept for
the next population rather than drawn again. A test checks that the two agree population
after population, and that the package internals the draw reads are still there.

**Restarts** (``restarts``), triggered by stagnation (below), each from a new uniform random
mean:

``"none"``
    one run; stagnation is ignored and the run goes on until the budget is spent.
``"ipop"``
    Auger & Hansen (2005): every restart doubles the population, ``sigma0`` unchanged.
``"bipop"``
    Hansen (2009): two interlaced regimes. A *large* restart doubles the population of the
    previous large one (``λ_def · 2^k`` after k large restarts) with ``sigma0``; a *small*
    restart draws ``λ = ⌊λ_def · (2^k)^(U²)⌋`` and ``σ = sigma0 · 10^(−2 U')`` (U, U' uniform
    on [0, 1)). The regime that has used fewer evaluations so far runs next; the first run
    (``λ_def``, ``sigma0``) counts as small, so the first restart is large (as in pycma's
    ``fmin`` and the ``cmaes`` package's BIPOP example).

**Stagnation** (the restart trigger), checked every ``CHECK_EVERY`` (10) generations: the package's own
termination tests (``should_stop()``: flat fitness history, collapsed or diverging step size,
no-effect axis, ill-conditioned covariance; its tolerances are tight, 1e-12, and rarely fire
first), or Hansen's (2009) stagnation test: over the last L generations, L = max(``patience``,
20 % of the run's generations) (``patience`` defaults to ``120 + ⌈30 d / λ⌉``, Hansen's), the
median of the newest 30 % of the generations' best fitness, and that of their median fitness,
are both no better than the oldest 30 %'s by more than ``tolerance · |oldest|``. It looks at
each generation, not at the best so far: a lucky early sample can hold the best for long while
the distribution is still improving, and a run whose step size has blown up (seen on level
flight, where the penalised ridge makes the step-size control overshoot) keeps its old best but
stops producing good generations.

**Budget.** The restart rules depend only on what has been evaluated, never on the budget, and
the random stream does not depend on it either: a run with budget B is exactly the first B
evaluations of any longer run with the same seed (the convergence study relies on this). When
the budget ends inside a population, the first ``n`` of that (fully drawn) population are
evaluated and the distribution is not updated: the run ends there. A budget smaller than the
first population is an error.

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
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, replace
from functools import cache
from importlib.metadata import version
from typing import Any, Literal, get_args

import cmaes._cmawm
import numpy as np
import scipy.special
from cmaes import CMAwM

from agents.optimiser import (
    LOWER,
    UPPER,
    AskTellOptimiser,
    Budget,
    FloatArray,
    OptimisationResult,
    SeedLike,
    Sense,
    check_int,
    check_real,
    store_plain,
)

__all__ = ["CMAES", "CMAESConfig", "Restarts", "default_popsize", "discrete_levels"]

Restarts = Literal["none", "ipop", "bipop"]

#: Population growth per large restart (IPOP and BIPOP's large regime; Auger & Hansen 2005).
POPSIZE_FACTOR = 2
#: Smallest population accepted: CMA-ES recombines the best half, which needs a few points.
MIN_POPSIZE = 4
#: Largest initial step size [box units]: the box is 2 wide.
MAX_SIGMA0 = 2.0
#: Generations between two stagnation checks.
CHECK_EVERY = 10


def default_popsize(dim: int) -> int:
    """Twice Hansen's default population, 2 (4 + ⌊3 ln d⌋) (26 at d = 28).

    Measured on the two flight tasks (docs/harness.md): the larger population gave a better and
    tighter F̄_v at 60 W/kg and a similar η at 1.5 m/s, and it halves the optimiser's share of
    the run time (its cost is mostly per generation).
    """
    return 2 * (4 + math.floor(3.0 * math.log(dim)))


def discrete_levels(levels: int) -> FloatArray:
    """The normalised values of a discrete coordinate with ``levels`` values: the bin centres."""
    return -1.0 + (2.0 * np.arange(levels) + 1.0) / levels


@dataclass(frozen=True)
class CMAESConfig:
    """Configuration of :class:`CMAES` (the defaults are chosen by measurement: docs/harness.md).

    Parameters
    ----------
    popsize : int or None
        Population of the first run (>= 4); None uses :func:`default_popsize` of the dimension.
    sigma0 : float
        Initial step size [box units; the box is 2 wide], in (0, 2].
    restarts : {"none", "ipop", "bipop"}
        Restart schedule; see the module docstring.
    patience : int or None
        Shortest stagnation history [generations] (>= 1); None uses ``120 + ⌈30 d / λ⌉`` of
        each run (Hansen 2009).
    resampling : int
        Draws of a candidate that leaves the box before it is clipped (>= 0; the package's
        ``n_max_resampling``).
    tolerance : float
        Relative rise of the generations' median best (and median) fitness over the history
        that counts as progress (>= 0).
    discrete : tuple of (int, int)
        ``(index, levels)`` of each discrete coordinate: distinct indices >= 0, levels >= 2.
    iterations : int or None
        Maximum number of populations evaluated (ask/tell rounds).
    max_evaluations : int or None
        Maximum number of points evaluated; the last population is truncated to fit.
    """

    popsize: int | None = None
    sigma0: float = 0.5
    restarts: Restarts = "bipop"
    patience: int | None = None
    tolerance: float = 1e-4
    resampling: int = 100
    discrete: tuple[tuple[int, int], ...] = ()
    iterations: int | None = None
    max_evaluations: int | None = None

    def __post_init__(self) -> None:
        if self.popsize is not None:
            check_int("popsize", self.popsize, minimum=MIN_POPSIZE)
        check_real("sigma0", self.sigma0, low=0.0, high=MAX_SIGMA0, low_inclusive=False)
        if self.restarts not in get_args(Restarts):
            raise ValueError(f"restarts must be one of {get_args(Restarts)}, got {self.restarts!r}")
        if self.patience is not None:
            check_int("patience", self.patience, minimum=1)
        check_real("tolerance", self.tolerance, low=0.0, high=math.inf, low_inclusive=True)
        check_int("resampling", self.resampling, minimum=0)
        object.__setattr__(self, "discrete", _check_discrete(self.discrete))
        Budget(self.iterations, self.max_evaluations)  # validates the budget fields
        store_plain(
            self,
            ints=("popsize", "patience", "resampling", "iterations", "max_evaluations"),
            floats=("sigma0", "tolerance"),
        )

    @property
    def budget(self) -> Budget:
        """The evaluation budget."""
        return Budget(self.iterations, self.max_evaluations)

    @property
    def citation(self) -> str:
        """The variant and its sources."""
        schedule = {
            "none": "no restarts",
            "ipop": "IPOP restarts (Auger & Hansen 2005, Proc. IEEE CEC pp. 1769-1776)",
            "bipop": "BIPOP restarts (Hansen 2009, Proc. GECCO companion pp. 2389-2396)",
        }[self.restarts]
        return (
            "CMA-ES (Hansen 2016, arXiv:1604.00772) with margin for discrete coordinates "
            "(Hamano et al. 2022, Proc. GECCO pp. 639-647), cmaes package "
            f"{_cmaes_version()} (Nomura & Shibata 2024, arXiv:2402.01373); {schedule}"
        )

    def describe(self) -> str:
        """One-line human-readable summary, including the citation."""
        popsize = "default" if self.popsize is None else str(self.popsize)
        return (
            f"CMA-ES, population {popsize}, sigma0 {self.sigma0}, restarts {self.restarts}, "
            f"{self.budget.describe()}; {self.citation}"
        )

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready record of every setting, the fixed constants and the citation."""
        return {
            "algorithm": "cmaes",
            "popsize": self.popsize,
            "popsize_rule": "2 (4 + floor(3 ln d))" if self.popsize is None else "given",
            "sigma0": self.sigma0,
            "restarts": self.restarts,
            "popsize_factor": POPSIZE_FACTOR,
            "patience": self.patience,
            "patience_rule": "120 + ceil(30 d / popsize)" if self.patience is None else "given",
            "tolerance": self.tolerance,
            "discrete": [list(pair) for pair in self.discrete],
            "resampling": self.resampling,
            "bounds": "redraw up to `resampling` times, then clip onto [-1, 1] (cmaes)",
            "iterations": self.iterations,
            "max_evaluations": self.max_evaluations,
            "package": f"cmaes {_cmaes_version()}",
            "citation": self.citation,
        }

    def build(self, dim: int, seed: SeedLike = None) -> CMAES:
        """A fresh :class:`CMAES` for this configuration."""
        return CMAES(dim, self, seed)


def _check_discrete(discrete: object) -> tuple[tuple[int, int], ...]:
    allowed = "a tuple of distinct (index >= 0, levels >= 2) pairs"
    try:
        pairs = tuple(tuple(pair) for pair in discrete)  # type: ignore[union-attr]
    except TypeError:
        raise ValueError(f"discrete must be {allowed}, got {discrete!r}") from None
    for pair in pairs:
        if len(pair) != 2:
            raise ValueError(f"discrete must be {allowed}, got the entry {pair!r}")
        check_int("discrete index", pair[0], minimum=0)
        check_int("discrete levels", pair[1], minimum=2)
    indices = [int(i) for i, _ in pairs]
    if len(set(indices)) != len(indices):
        raise ValueError(f"discrete must be {allowed}; index repeated in {discrete!r}")
    return tuple((int(i), int(k)) for i, k in pairs)


@cache
def _cmaes_version() -> str:
    return version("cmaes")


@cache
def _blas_libraries() -> tuple[Any, ...]:
    """The loaded BLAS libraries' thread controllers (threadpoolctl), looked up once."""
    from threadpoolctl import ThreadpoolController

    return tuple(ThreadpoolController().select(user_api="blas").lib_controllers)


def _norm_cdf(x: Any, loc: Any = 0.0, scale: Any = 1.0) -> FloatArray:
    """``scipy.stats.norm.cdf`` for scale > 0: the same ``ndtr`` of the same standardised x."""
    return scipy.special.ndtr((np.asarray(x, dtype=float) - loc) / scale)


def _chi2_ppf(q: Any) -> FloatArray:
    """``scipy.stats.chi2(df=1).ppf`` for 0 < q < 1: the same ``2 gammaincinv(1/2, q)``."""
    return 2.0 * scipy.special.gammaincinv(0.5, np.asarray(q, dtype=float))


@contextmanager
def _fast_package_numerics() -> Iterator[None]:
    """Run the package's small numerics without its avoidable fixed costs.

    * The dense algebra (a d×d eigendecomposition per generation) on one BLAS thread: measured
      on the shared 2-core machine, ``numpy.linalg.eigh`` of a 28×28 matrix took 8-18 ms with
      OpenBLAS's default threads (they wait for busy cores) against 0.2-0.4 ms on one.
    * CMAwM's margin correction calls ``scipy.stats`` (``norm.cdf``, ``chi2.ppf``) five times
      a generation on two-element arrays; the frozen-distribution argument handling costs
      about 0.3 ms a call there, the special functions underneath a microsecond. The package
      binds them as module globals, which are swapped here for the special functions for the
      duration of the call (equal values; tests/agents/test_cmaes.py).
    """
    module = cmaes._cmawm
    saved = module.norm_cdf, module.chi2_ppf
    libraries = _blas_libraries()
    # Set directly, not with ``ThreadpoolController.limit``: that looks the libraries up again
    # on every call (20-90 µs against 5 µs, twice a generation).
    threads = [library.num_threads for library in libraries]
    module.norm_cdf, module.chi2_ppf = _norm_cdf, _chi2_ppf
    try:
        for library in libraries:
            library.set_num_threads(1)
        yield
    finally:
        module.norm_cdf, module.chi2_ppf = saved
        for library, count in zip(libraries, threads, strict=True):
            library.set_num_threads(count)


@dataclass(frozen=True)
class RunInfo:
    """One CMA-ES run between restarts, as recorded."""

    regime: Literal["first", "small", "large"]
    popsize: int
    sigma0: float
    start: int
    """Evaluations done before the run [-]."""
    evaluations: int
    """Evaluations of the run [-]."""
    generations: int
    """Full populations told [-]."""
    best: float
    """Best fitness the run evaluated."""
    stop: str
    """Why it ended: ``"stagnation"``, ``"should_stop"`` or ``"budget"``."""

    def to_dict(self) -> dict[str, Any]:
        return {
            "regime": self.regime,
            "popsize": self.popsize,
            "sigma0": self.sigma0,
            "start": self.start,
            "evaluations": self.evaluations,
            "generations": self.generations,
            "best": self.best,
            "stop": self.stop,
        }


class CMAES(AskTellOptimiser):
    """CMA-ES maximiser with restarts and discrete coordinates, ask/tell over [-1, 1]^dim.

    Parameters
    ----------
    dim : int
        Dimension of the search box [-1, 1]^dim.
    config : CMAESConfig
        Settings and budget.
    seed : int, SeedSequence or None
        Seeds ``numpy.random.default_rng``, which draws every run's mean, the BIPOP choices
        and the seed of each run's ``cmaes`` generator; equal seeds give identical runs.
    """

    def __init__(self, dim: int, config: CMAESConfig, seed: SeedLike = None) -> None:
        if not isinstance(config, CMAESConfig):
            raise TypeError(f"config must be a CMAESConfig, got {type(config).__name__}")
        check_int("dim", dim, minimum=1)
        popsize = config.popsize if config.popsize is not None else default_popsize(dim)
        limit = config.budget.max_evaluations
        if limit is not None and limit < popsize:
            raise ValueError(
                f"budget of {limit} evaluations is smaller than one CMA-ES population "
                f"({popsize} points); allowed: a budget >= {popsize}, or a smaller popsize "
                f"(>= {MIN_POPSIZE})"
            )
        super().__init__(dim, popsize, config, seed)
        bad = [i for i, _ in config.discrete if i >= dim]
        if bad:
            raise ValueError(
                f"discrete index {bad[0]} is outside the box of dimension {dim}; allowed: "
                f"0 to {dim - 1}"
            )
        self._popsize0 = popsize
        self._bounds = np.tile([LOWER, UPPER], (dim, 1)).astype(float)
        self._steps = np.zeros(dim)
        for index, levels in config.discrete:
            values = discrete_levels(levels)
            self._bounds[index] = values[0], values[-1]
            self._steps[index] = values[1] - values[0]
        self._regime_evaluations = {"small": 0, "large": 0}
        self._large_restarts = 0
        self._runs: list[RunInfo] = []
        with _fast_package_numerics():
            self._start_run("first", popsize, config.sigma0, 0)
            self._es._cma._eigen_decomposition()

    # --- runs ----------------------------------------------------------------------------------
    def _start_run(
        self, regime: Literal["first", "small", "large"], popsize: int, sigma: float, start: int
    ) -> None:
        low, high = self._bounds[:, 0], self._bounds[:, 1]
        mean = self._rng.uniform(low, high)
        self._es = CMAwM(
            mean=mean,
            sigma=sigma,
            bounds=self._bounds,
            steps=self._steps,
            n_max_resampling=self._config.resampling,
            seed=int(self._rng.integers(2**32)),
            population_size=popsize,
        )
        # standard normal deviates drawn from the run's generator but not yet used (_draw)
        self._deviates = np.empty((0, self.dim))
        self._regime = regime
        self._run_sigma0 = float(sigma)
        self._run_start = start
        self._run_top = -math.inf  # the run's best fitness
        self._generation_best: list[float] = []  # best fitness of each generation told
        self._generation_median: list[float] = []  # ... and its median
        self._patience = (
            self._config.patience
            if self._config.patience is not None
            else 120 + math.ceil(30 * self.dim / popsize)
        )

    def _batch(self) -> int:
        return self._es.population_size

    def _run_info(self, stop: str, end: int) -> RunInfo:
        return RunInfo(
            regime=self._regime,
            popsize=self._es.population_size,
            sigma0=self._run_sigma0,
            start=self._run_start,
            evaluations=end - self._run_start,
            generations=self._es.generation,
            best=self._run_top,
            stop=stop,
        )

    def _restart(self, stop: str, end: int) -> None:
        """End the current run after ``end`` evaluations in all and start the next one."""
        finished = self._run_info(stop, end)
        self._runs.append(finished)
        regime = "large" if finished.regime == "large" else "small"
        self._regime_evaluations[regime] += finished.evaluations
        small, large = self._regime_evaluations["small"], self._regime_evaluations["large"]
        if self._config.restarts == "bipop" and small < large:
            multiplier = POPSIZE_FACTOR**self._large_restarts
            u, v = self._rng.random(2)
            popsize = max(MIN_POPSIZE, math.floor(self._popsize0 * multiplier ** (u**2)))
            sigma = self._config.sigma0 * 10.0 ** (-2.0 * v)
            self._start_run("small", popsize, sigma, end)
        else:
            self._large_restarts += 1
            popsize = self._popsize0 * POPSIZE_FACTOR**self._large_restarts
            self._start_run("large", popsize, self._config.sigma0, end)

    def _stagnated(self) -> str | None:
        """Why the current run should end now, or None."""
        if self._es.should_stop():
            return "should_stop"
        # Hansen's (2009) stagnation test: over the last L generations (L = max(patience,
        # 20 % of the run), at most 20 000), the median of the newest 30 % of the generations'
        # best and of their median fitness is no better than that of the oldest 30 %.
        # Per-generation values, not the best so far: a lucky early sample can hold the best
        # for long while the distribution still improves, and a run that has diverged (its
        # step size blown up) keeps its old best but stops producing good generations.
        length = min(max(self._patience, math.ceil(0.2 * len(self._generation_best))), 20_000)
        if len(self._generation_best) < length:
            return None
        part = max(1, math.ceil(0.3 * length))
        for history in (self._generation_best, self._generation_median):
            window = history[-length:]
            old, new = float(np.median(window[:part])), float(np.median(window[-part:]))
            if math.isfinite(old):
                better = new > old + self._config.tolerance * abs(old)
            else:
                better = new > old
            if better:
                return None
        return "stagnation"

    # --- ask / tell ----------------------------------------------------------------------------
    def _propose(self, n: int) -> FloatArray:
        # The whole population is drawn even when only n < popsize are evaluated, so the random
        # stream (and every earlier population) does not depend on the budget.
        es = self._es
        raw = self._draw(es.population_size)
        points = raw.copy()
        if es._n_zdim > 0:
            points[:, es._discrete_idx] = es._encode_discrete_params(raw[:, es._discrete_idx])
        self._raw = raw
        return points[:n]

    def _draw(self, count: int) -> FloatArray:
        """``count`` raw candidates exactly as ``count`` calls of the package's ``ask()`` draw them.

        ``ask()`` draws a candidate (``mean + σ B D z``, z a row of standard normal deviates from
        the package's generator) up to ``resampling`` times until its continuous coordinates are
        inside the box, else once more and clips it. Here the deviates are drawn in blocks and
        assigned to candidates in stream order; those a population does not use are kept (as z,
        before the transform) for the next population of the run, which takes them first. So
        every population is built from the very deviates the package's ``ask()`` would use, and
        no deviate is drawn twice or thrown away.
        """
        es = self._es
        cma = es._cma
        B, D = cma._eigen_decomposition()  # cached: computed at the end of the last tell
        transform = (B * D).T
        low, high = es._continuous_space[:, 0], es._continuous_space[:, 1]
        continuous = es._continuous_idx
        tries = self._config.resampling + 1  # rows a candidate may use, the clipped one last

        def candidates(z: FloatArray) -> tuple[FloatArray, np.ndarray]:
            rows = cma._mean + cma._sigma * (z @ transform)
            part = rows[:, continuous]
            return rows, np.all((part >= low) & (part <= high), axis=1)

        def more(
            z: FloatArray, rows: FloatArray, inside: np.ndarray
        ) -> tuple[FloatArray, FloatArray, np.ndarray]:
            """The rows in hand and the next block of the stream (growing geometrically)."""
            z_new = cma._rng.randn(max(count, tries, len(z)), self.dim)
            rows_new, inside_new = candidates(z_new)
            return (
                np.concatenate((z, z_new)),
                np.concatenate((rows, rows_new)),
                np.concatenate((inside, inside_new)),
            )

        z = self._deviates
        if len(z) < count:
            z = np.concatenate((z, cma._rng.randn(count - len(z), self.dim)))
        rows, inside = candidates(z)
        # The common case: no candidate runs out of draws (no run of tries - 1 rows outside the
        # box), so the candidates are simply the first `count` rows inside it.
        while True:
            hits = np.flatnonzero(inside)[:count]
            # a candidate whose tries - 1 rows all fall outside: before a hit, or after the last
            gap = len(hits) > 0 and (hits[0] >= tries - 1 or np.any(hits[1:] - hits[:-1] >= tries))
            tail = len(inside) - (hits[-1] + 1 if len(hits) else 0)
            if gap or (len(hits) < count and tail >= tries - 1):
                break  # some candidate is clipped: assign them one by one below
            if len(hits) == count:
                self._deviates = z[hits[-1] + 1 :]
                return rows[hits]
            z, rows, inside = more(z, rows, inside)
        chosen: list[int] = []  # row of each candidate
        clipped: list[int] = []  # candidates whose last row is clipped onto the box
        used = 0  # rows assigned so far
        while True:
            size = len(inside)
            # first row at or after each row that is inside the box (size if none)
            index = np.where(inside, np.arange(size), size)
            following = np.minimum.accumulate(index[::-1])[::-1].tolist()
            while len(chosen) < count:
                hit = following[used] if used < size else size
                last = used + tries - 1  # the row clipped when none before it is inside
                if hit < min(last, size):
                    chosen.append(hit)
                elif last < size:
                    clipped.append(len(chosen))
                    chosen.append(last)
                else:
                    break  # not enough rows in hand to decide this candidate
                used = chosen[-1] + 1
            if len(chosen) == count:
                break
            z, rows, inside = more(z, rows, inside)
        self._deviates = z[used:]
        raw = rows[chosen]
        if clipped:
            raw[np.ix_(clipped, continuous)] = np.clip(raw[np.ix_(clipped, continuous)], low, high)
        return raw

    def _observe(self, X: FloatArray, fitness: FloatArray) -> None:
        values = fitness.tolist()
        best = max(values)
        self._run_top = max(self._run_top, best)
        if len(values) < self._es.population_size:
            return  # a truncated last population: the budget ends here, nothing more to learn
        ranked = sorted(values)
        middle = len(ranked) // 2
        median = ranked[middle] if len(ranked) % 2 else (ranked[middle - 1] + ranked[middle]) / 2
        self._generation_best.append(best)
        self._generation_median.append(median)
        with _fast_package_numerics():
            # cmaes minimises: tell the negated fitness (NaN, mapped to -inf, becomes +inf).
            self._es.tell(list(zip(self._raw, (-fitness).tolist(), strict=True)))
            # The tests watch slow quantities (a history of >= 120 generations, the step size);
            # checking every CHECK_EVERY generations keeps their cost out of the run time.
            check = len(self._generation_best) % CHECK_EVERY == 0
            stop = self._stagnated() if check and self._config.restarts != "none" else None
            if stop is not None:
                # the base class counts this population after _observe returns
                self._restart(stop, self.evaluations + fitness.shape[0])
            self._es._cma._eigen_decomposition()  # the next population's basis, on one thread

    # --- record --------------------------------------------------------------------------------
    @property
    def runs(self) -> list[RunInfo]:
        """Every run so far, the current one last (its ``stop`` is ``"budget"``)."""
        return [*self._runs, self._run_info("budget", self.evaluations)]

    def result(self, sense: Sense = "maximise") -> OptimisationResult:
        """As the base class, with the runs (regime, population, σ0, evaluations) in config."""
        result = super().result(sense)
        config = {**result.config, "runs": [run.to_dict() for run in self.runs]}
        return replace(result, config=config)
