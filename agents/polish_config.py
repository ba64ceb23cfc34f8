"""The local polish's settings (:class:`PolishConfig`, validated where they enter) and
:func:`split_settings`, which takes them out of a method's settings."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from tandem_env.physics.checks import count, finite_real, is_real

#: Local optimisers the polish offers ("none": no polish).
POLISH_METHODS: tuple[str, ...] = ("none", "slsqp", "trust-constr")
#: The polish each search method gets when none is given (others: none).
POLISH_DEFAULTS: Mapping[str, str] = {"cmaes": "slsqp", "pso": "slsqp"}
#: Method settings (``method_config`` keys, ``--method-config``) that configure the polish.
POLISH_SETTINGS: Mapping[str, str] = {
    "polish": "method",
    "polish_share": "share",
    "polish_step": "step",
    "polish_tolerance": "tolerance",
    "polish_iterations": "max_iterations",
    "polish_optimality": "optimality",
    "polish_finish": "finish",
    "starts": "starts",
    "initial": "initial",
    "initial_share": "initial_share",
}
#: Most independent searches one run may split its budget into (``starts``).
MAX_STARTS = 64
#: Allowed ``initial_share``: the initial strokes' fraction of a run's budget, low and high.
INITIAL_SHARE_RANGE = (0.05, 0.95)


@dataclass(frozen=True)
class PolishConfig:
    """Settings of the local polish (validated here, where they enter)."""

    method: str = "slsqp"
    """The scipy optimiser (``minimize(method=...)``, :data:`POLISH_METHODS`); ``"none"``
    turns the polish off."""
    share: float = 0.4
    """Fraction of the run's budget kept for the polish, in [0.01, 0.9], the search getting the
    rest; chosen by measurement (docs/harness.md, "Local polish")."""
    step: float = 1e-5
    """Central-difference step in normalised units, in [1e-8, 1e-2] (gradients agree to ~1e-7
    relative between 1e-4 and 1e-5)."""
    tolerance: float = 1e-14
    """Stopping tolerance (SLSQP ``ftol``, absolute; trust-constr ``gtol``/``xtol``), in
    [1e-14, 1e-2]: at 1e-10 SLSQP ended level-flight polishes at KKT residuals of 1.2-2.7e-4;
    at 1e-14 they run on to the KKT stop (``optimality``; docs/harness.md, "Certified")."""
    max_iterations: int = 200
    """Optimiser iterations at most, 1 to 10 000."""
    optimality: float = 1e-5
    """Stop at the first feasible iterate whose KKT residual (:func:`agents.polish.kkt_residual`)
    is at most this [-] (the certificate then says converged), in [0, 1e-2]; 0: the optimiser's
    own test (``tolerance``), which can stall long after. 1e-5 certified one more of eight seeds
    than 0 at the same budget and optima (docs/harness.md, "Local polish")."""
    finish: float = 0.1
    """Fraction of a polish's allowance kept back, in [0, 0.5], where it climbs by central
    differences and the problem differentiates: where the run's reported stroke is not
    certified, :func:`agents.harness.finish` polishes it on with autograd gradients on
    what the run left (central differences misread the gradient where the model's second
    derivative jumps within a step); 0: no finish (docs/harness.md, "Certified")."""
    margin: float = 1e-9
    """Every constraint is held at margin >= ``margin`` [-] (0 to 1e-4), plus one float32 step
    of every coordinate, so the optimum cast to the action type passes the exact test."""
    active: float = 1e-6
    """Distance to its limit [-] within which a constraint or bound counts as active in the
    certificate, 0 to 1e-2."""
    starts: int = 1
    """Independent searches (own seeds, equal parts of the budget, each polished) the run reports
    the best of, 1 to :data:`MAX_STARTS` (docs/harness.md, "Starts and initial strokes")."""
    initial: tuple[tuple[float, ...], ...] = ()
    """Normalised strokes polished directly, each on an equal part of the budget: warm starts
    (feasible or not), e.g. a neighbouring model reading's optimum."""
    initial_share: float | None = None
    """The initial strokes' fraction of the budget together (split evenly), in [0.05, 0.95],
    the searches sharing the rest; None: every part an equal share."""

    def __post_init__(self) -> None:
        if self.method not in POLISH_METHODS:
            raise ValueError(
                f"polish = {self.method!r}; allowed: {', '.join(map(repr, POLISH_METHODS))}"
            )
        for name, low, high in (
            ("share", 0.01, 0.9),
            ("step", 1e-8, 1e-2),
            ("tolerance", 1e-14, 1e-2),
            ("optimality", 0.0, 1e-2),
            ("finish", 0.0, 0.5),
            ("margin", 0.0, 1e-4),
            ("active", 0.0, 1e-2),
        ):
            value = finite_real(getattr(self, name), f"polish {name}", low, high)
            object.__setattr__(self, name, value)
        iterations = count(self.max_iterations, "polish max_iterations", high=10_000)
        object.__setattr__(self, "max_iterations", iterations)
        object.__setattr__(self, "starts", count(self.starts, "starts", high=MAX_STARTS))
        object.__setattr__(self, "initial", _strokes(self.initial))
        if self.initial_share is not None:
            share = finite_real(self.initial_share, "initial_share", *INITIAL_SHARE_RANGE)
            if not self.initial:
                raise ValueError("initial_share without initial strokes; allowed: with initial")
            object.__setattr__(self, "initial_share", share)
        if self.initial and not self.enabled:
            raise ValueError(
                "initial strokes are polished, but polish = 'none'; allowed: "
                "initial with polish 'slsqp' or 'trust-constr'"
            )

    @property
    def enabled(self) -> bool:
        return self.method != "none"

    def reserve(self, budget: int, gradient_cost: int) -> int:
        """Evaluations of ``budget`` kept for the polish: ``share`` of it, or 0 when it is off
        or that is below two gradients (it could not take one step and check it)."""
        reserve = round(self.share * budget) if self.enabled else 0
        return reserve if reserve >= 2 * gradient_cost else 0

    def to_dict(self) -> dict[str, Any]:
        return {**asdict(self), "initial": [list(stroke) for stroke in self.initial]}


def _strokes(value: Any) -> tuple[tuple[float, ...], ...]:
    """``initial`` as a tuple of strokes of finite values in [-1, 1] (equal lengths)."""
    allowed = "a list of strokes, each a list of numbers in [-1, 1] of the action box's size"
    if isinstance(value, str | bytes) or not isinstance(value, list | tuple):
        raise ValueError(f"initial = {value!r}; allowed: {allowed}")
    strokes = []
    for stroke in value:
        if isinstance(stroke, str | bytes) or not isinstance(stroke, list | tuple | np.ndarray):
            raise ValueError(f"initial stroke {stroke!r}; allowed: {allowed}")
        for v in stroke:
            if not (is_real(v) and math.isfinite(v) and -1.0 <= v <= 1.0):
                raise ValueError(f"initial stroke value {v!r}; allowed: {allowed}")
        strokes.append(tuple(float(v) for v in stroke))
    if len({len(s) for s in strokes}) > 1:
        raise ValueError(
            f"initial strokes of lengths {sorted({len(s) for s in strokes})}; allowed: {allowed}"
        )
    return tuple(strokes)


def split_settings(
    method: str, method_config: Mapping[str, Any]
) -> tuple[PolishConfig, dict[str, Any]]:
    """The polish settings among a method's settings (the default polish is the method's,
    :data:`POLISH_DEFAULTS`), and the rest; ValueError naming a bad one."""
    name = method.partition(":")[0]
    own = {k: v for k, v in method_config.items() if k not in POLISH_SETTINGS}
    given = {POLISH_SETTINGS[k]: v for k, v in method_config.items() if k in POLISH_SETTINGS}
    given.setdefault("method", POLISH_DEFAULTS.get(name, "none"))
    return PolishConfig(**given), own
