"""Global-best particle swarm optimisation over the normalised box [-1, 1]^d.

Velocity and position update (per particle i and dimension j, r1, r2 ~ U(0, 1) fresh each time)::

    v <- w v + c1 r1 (pbest - x) + c2 r2 (gbest - x),   |v_j| <= velocity_clamp * 2
    x <- x + v,                                          then clip or reflect into the box

Parameter sets: ``"constriction"``, Clerc & Kennedy's (2002) coefficients in inertia-weight form
(phi = c1 + c2 = 4.1, chi = 2 / |2 - phi - sqrt(phi^2 - 4 phi)| = 0.72984: w = 0.7298, c1 = c2 =
chi * 2.05 = 1.49618; Eberhart & Shi 2000), or ``"linear-decreasing"``, w from 0.9 to 0.4 over
the run with c1 = c2 = 2.0 (Shi & Eberhart 1998, 1999).

References
----------
J. Kennedy, R. Eberhart, "Particle swarm optimization", Proc. ICNN 1995, pp. 1942-1948.
Y. Shi, R. Eberhart, "A modified particle swarm optimizer", Proc. IEEE ICEC 1998, pp. 69-73.
Y. Shi, R. Eberhart, "Empirical study of particle swarm optimization", Proc. CEC 1999,
pp. 1945-1950.
R. Eberhart, Y. Shi, "Comparing inertia weights and constriction factors in particle swarm
optimization", Proc. CEC 2000, pp. 84-88.
M. Clerc, J. Kennedy, "The particle swarm - explosion, stability, and convergence in a
multidimensional complex space", IEEE Trans. Evol. Comput. 6(1), 2002, pp. 58-73.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal, get_args

import numpy as np

from agents.methods import register_optimiser
from agents.optimiser import (
    MAX_BATCH,
    AskTellOptimiser,
    FloatArray,
    OptimiserConfig,
    SeedLike,
    integer_setting,
    real_setting,
)
from tandem_env.envs.base import ACTION_HIGH, ACTION_LOW

Inertia = Literal["constriction", "linear-decreasing"]
Boundary = Literal["clip", "reflect"]

# Clerc & Kennedy (2002), inertia-weight form (see module docstring for the derivation).
CONSTRICTION_W = 0.7298
CONSTRICTION_C = 1.49618
# Shi & Eberhart (1998, 1999) linearly decreasing inertia weight.
LINEAR_W_START = 0.9
LINEAR_W_END = 0.4
LINEAR_C = 2.0

_CITATIONS: dict[str, str] = {
    "constriction": (
        "global-best PSO (Kennedy & Eberhart 1995) with Clerc & Kennedy (2002) constriction "
        "coefficients in inertia-weight form (chi = 0.72984 for phi = 4.1; IEEE Trans. Evol. "
        "Comput. 6(1):58-73)"
    ),
    "linear-decreasing": (
        "global-best PSO (Kennedy & Eberhart 1995) with linearly decreasing inertia weight "
        "(Shi & Eberhart 1998, Proc. IEEE ICEC pp. 69-73; 0.9 -> 0.4 schedule of Shi & "
        "Eberhart 1999, Proc. CEC pp. 1945-1950)"
    ),
}


@dataclass(frozen=True, kw_only=True)
class PSOConfig(OptimiserConfig):
    """Configuration of :class:`PSO`."""

    algorithm = "pso"

    swarm_size: int = integer_setting(2, MAX_BATCH, default=40)
    """Number of particles (>= 2)."""
    inertia: Inertia = "constriction"
    """Parameter set; see the module docstring."""
    cognitive: float | None = real_setting(0.0, math.inf, low_inclusive=True, default=None)
    """Override of c1 (>= 0); None uses the value of the chosen parameter set."""
    social: float | None = real_setting(0.0, math.inf, low_inclusive=True, default=None)
    """Override of c2 (>= 0); None uses the value of the chosen parameter set."""
    velocity_clamp: float = real_setting(0.0, 1.0, low_inclusive=False, default=0.5)
    """Maximum |v| per dimension as a fraction of the box width 2, in (0, 1]."""
    boundary: Boundary = "clip"
    """``"clip"``: a particle leaving the box stops on the wall, that velocity component
    zeroed; ``"reflect"``: it is mirrored back inside, that velocity component reversed."""

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.inertia not in get_args(Inertia):
            raise ValueError(f"inertia must be one of {get_args(Inertia)}, got {self.inertia!r}")
        if self.boundary not in get_args(Boundary):
            raise ValueError(
                f"boundary must be one of {get_args(Boundary)} (wrap-around is not supported), "
                f"got {self.boundary!r}"
            )

    @property
    def c1(self) -> float:
        """Cognitive acceleration coefficient in use."""
        return self.cognitive if self.cognitive is not None else self._default_c

    @property
    def c2(self) -> float:
        """Social acceleration coefficient in use."""
        return self.social if self.social is not None else self._default_c

    @property
    def _default_c(self) -> float:
        return CONSTRICTION_C if self.inertia == "constriction" else LINEAR_C

    @property
    def citation(self) -> str:
        """The variant, its source and the constants actually used."""
        weight = f"w = {LINEAR_W_START} -> {LINEAR_W_END} linearly"
        weight = f"w = {CONSTRICTION_W}" if self.inertia == "constriction" else weight
        overridden = [name for name in ("cognitive", "social") if getattr(self, name) is not None]
        note = f" ({' and '.join(overridden)} overridden)" if overridden else ""
        return f"{_CITATIONS[self.inertia]}: {weight}, c1 = {self.c1}, c2 = {self.c2}{note}"

    def inertia_schedule(self, iterations: int) -> FloatArray:
        """Inertia weight of each of the ``iterations - 1`` velocity updates of a run (the first
        iteration evaluates the initial swarm)."""
        n_updates = max(iterations - 1, 0)
        if self.inertia == "constriction":
            return np.full(n_updates, CONSTRICTION_W)
        return np.linspace(LINEAR_W_START, LINEAR_W_END, n_updates)

    def in_use(self) -> dict[str, Any]:
        """The record's constants in use: the inertia weight(s) and the coefficients c1, c2."""
        linear = [LINEAR_W_START, LINEAR_W_END]
        weight = CONSTRICTION_W if self.inertia == "constriction" else linear
        return {"inertia_weight": weight, "cognitive": self.c1, "social": self.c2}


class PSO(AskTellOptimiser, settings=PSOConfig):
    """Global-best particle swarm maximiser over [-1, 1]^dim: positions start uniform in the
    box, velocities in +-vmax; each iteration is vectorised over the swarm."""

    def __init__(self, dim: int, config: PSOConfig, seed: SeedLike = None) -> None:
        super().__init__(dim, config.swarm_size, config, seed)
        n, d = config.swarm_size, self.dim
        self._vmax = config.velocity_clamp * (ACTION_HIGH - ACTION_LOW)  # the box's width
        self._c1, self._c2 = config.c1, config.c2
        self._schedule = config.inertia_schedule(-(-config.max_evaluations // n))  # iterations
        self._schedule.setflags(write=False)
        self._x = self._rng.uniform(ACTION_LOW, ACTION_HIGH, (n, d))
        self._v = self._rng.uniform(-self._vmax, self._vmax, (n, d))
        self._pbest_x = self._x.copy()
        self._pbest_f = np.full(n, -np.inf)
        self._gbest = 0
        self._candidate_x, self._candidate_v = self._x, self._v

    @property
    def inertia_schedule(self) -> FloatArray:
        """Inertia weight of every velocity update this run will make (read-only)."""
        return self._schedule

    @property
    def velocities(self) -> FloatArray:
        """Current particle velocities, shape (swarm_size, dim) [box units per iteration]."""
        return self._v.copy()

    def _propose(self, n: int) -> FloatArray:
        if self.iterations == 0:
            self._candidate_x, self._candidate_v = self._x, self._v
            return self._x[:n]
        w = self._schedule[self.iterations - 1]
        # the whole swarm's draws even on a truncated last iteration: the stream stays
        # independent of the budget
        r1, r2 = self._rng.random((2, *self._x.shape))
        v = (
            w * self._v
            + self._c1 * r1 * (self._pbest_x - self._x)
            + self._c2 * r2 * (self._pbest_x[self._gbest] - self._x)
        )
        np.clip(v, -self._vmax, self._vmax, out=v)
        self._candidate_x, self._candidate_v = self._confine(self._x + v, v)
        return self._candidate_x[:n]

    def _confine(self, x: FloatArray, v: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Bring positions that left the box back inside, adjusting their velocities."""
        low, high = x < ACTION_LOW, x > ACTION_HIGH
        # landing exactly on a wall (e.g. -1 + vmax = 1 with the full-width clamp) is a hit
        # too: a particle there keeps no outward velocity
        hit = (x <= ACTION_LOW) | (x >= ACTION_HIGH)
        if self.config.boundary == "clip":
            v[hit] = 0.0
        else:
            # One mirror suffices: |v| <= box width, so x + v is at most one width outside.
            x = np.where(high, 2.0 * ACTION_HIGH - x, np.where(low, 2.0 * ACTION_LOW - x, x))
            v[hit] *= -1.0
        # For "reflect" this only guards against round-off at the walls.
        np.clip(x, ACTION_LOW, ACTION_HIGH, out=x)
        return x, v

    def _observe(self, X: FloatArray, fitness: FloatArray) -> None:
        n = fitness.shape[0]
        # Only evaluated particles move: on a truncated final batch the rest keep their state.
        self._x[:n] = self._candidate_x[:n]
        self._v[:n] = self._candidate_v[:n]
        improved = fitness > self._pbest_f[:n]
        self._pbest_x[:n][improved] = X[improved]
        self._pbest_f[:n][improved] = fitness[improved]
        self._gbest = int(np.argmax(self._pbest_f))


register_optimiser("pso", PSOConfig, batch="swarm_size")
