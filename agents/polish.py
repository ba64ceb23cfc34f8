"""Local polish: SLSQP (or trust-constr) from a search's best feasible stroke, over the
continuous stroke parameters (each wing's harmonic N held fixed), the box [-1, 1] as bounds
and the task's constraints (the signed margins of ``Constraint.margin``) as constraints.

The driver (:func:`polish`, its :class:`Certificate`, the KKT check); the problem, its
gradients and the settings (:mod:`agents.polish_config`) are imported from here too. The budget
counts model evaluations (a central-difference gradient at most 2k + 1, an autograd gradient
one; docs/harness.md, "Local polish"), never exceeded. The result is the best feasible point
found if it beats the start, cast to float32 (:func:`float32_margin` keeps it feasible);
otherwise the start, the certificate saying why.

::

    problem = task_problem(task, condition, env_kwargs)
    result = polish(problem, start, budget=4000, config=PolishConfig())
    result.stroke, result.certificate.to_dict()
"""

from __future__ import annotations

import contextlib
import math
import warnings
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, replace
from typing import Any

import numpy as np
from scipy.optimize import BFGS, Bounds, NonlinearConstraint, OptimizeResult, minimize, nnls

# The polish's settings and problem: its users import them from here (re-exported).
from agents.polish_config import (  # noqa: F401
    MAX_STARTS,
    POLISH_DEFAULTS,
    POLISH_METHODS,
    AutogradGradient,
    BatchEvaluation,
    CentralDifferences,
    Gradient,
    GradientFunction,
    PolishConfig,
    Problem,
    finishable,
    split_settings,
    task_problem,
)
from tandem_env.envs.base import ACTION_DTYPE, as_action_type
from tandem_env.physics.checks import is_integer


def kkt_residual(
    objective_gradient: np.ndarray,
    margins: np.ndarray,
    jacobian: np.ndarray,
    x_free: np.ndarray,
    active: float,
) -> tuple[float, np.ndarray, np.ndarray]:
    """First-order optimality of a maximum of f subject to c >= 0 and -1 <= x <= 1.

    ∇f + Σ λ_i ∇c_i = 0, λ_i >= 0 over the active constraints (c_i <= ``active``) and bounds, solved
    by non-negative least squares. Returns (residual ||∇f + Σ λ_i ∇c_i|| / ||∇f|| [-], active
    constraint mask, active bound mask): the residual is near 0 at a KKT point, of order 1 where f
    can still rise feasibly, 0 where ∇f = 0, inf at an infeasible point (some c_i < -active).
    """
    g = np.asarray(objective_gradient, dtype=np.float64)
    norm = float(np.linalg.norm(g))
    on_constraint, infeasible = margins <= active, bool(np.any(margins < -active))
    if infeasible or norm == 0.0:
        return (math.inf if infeasible else 0.0), on_constraint, np.zeros(g.size, dtype=bool)
    upper = x_free >= 1.0 - active
    lower = x_free <= -1.0 + active
    eye = np.eye(g.size)
    # the active bounds as constraints: c = 1 - x_j >= 0 (upper), c = x_j + 1 >= 0 (lower)
    a = np.concatenate([jacobian[on_constraint].T, -eye[:, upper], eye[:, lower]], axis=1)
    if a.shape[1] == 0:
        return 1.0, on_constraint, upper | lower
    # min ||A λ - (-∇f)||, λ >= 0; scaled by ||∇f|| so the residual is relative.
    _, rnorm = nnls(a / norm, -g / norm)
    return float(rnorm), on_constraint, upper | lower


@dataclass(frozen=True)
class Certificate:
    """What a record says about the local optimality of its stroke (JSON: :meth:`to_dict`)."""

    method: str
    """The polish's optimiser, ``"none"`` when it did not run."""
    status: str
    """``"improved"``, ``"no gain"``, ``"failed: ..."`` (both: the start kept), ``"off"`` or
    ``"not applicable"``."""
    gain: float | None = None
    """(after − before) / |before| [-] (0: the start kept; None: the start's objective is 0)."""
    objective_before: float | None = None
    objective_after: float | None = None
    evaluations: int = 0
    """Model evaluations the polish used (counted in the run's budget)."""
    allowance: int = 0
    """Model evaluations it was allowed (the run's budget less what the search used)."""
    iterations: int = 0
    converged: bool | None = None
    """The optimiser's own convergence test passed (scipy ``success``)."""
    message: str = ""
    """The optimiser's message."""
    kkt_residual: float | None = None
    """First-order optimality residual at the reported stroke (:func:`kkt_residual`) [-]."""
    active_constraints: tuple[str, ...] = ()
    """Constraints (and bounds, as ``bound:<parameter>``) active at the reported stroke."""
    gradient: str = ""
    """``GradientFunction.name`` of the gradient used (``"central differences"`` or
    ``"autograd"``); empty when the polish did not run."""

    def to_dict(self) -> dict[str, Any]:
        out = asdict(self)
        out["active_constraints"] = list(self.active_constraints)
        # JSON has no inf/nan: an undefined residual is null.
        if out["kkt_residual"] is not None and not math.isfinite(out["kkt_residual"]):
            out["kkt_residual"] = None
        return out

    @classmethod
    def off(cls) -> Certificate:
        return cls(method="none", status="off")


@dataclass(frozen=True)
class PolishResult:
    stroke: np.ndarray
    """The reported stroke (dim,): the polished one, or the start when the polish did not gain."""
    objective: float
    certificate: Certificate
    feasible: bool = True
    """The reported stroke is feasible (False only for an infeasible start that was kept)."""

    @property
    def improved(self) -> bool:
        return self.certificate.status == "improved"


class _OutOfBudget(Exception):
    pass


class _Optimal(Exception):
    """Raised at an iterate that passes the KKT test, with its objective and full stroke."""


@dataclass(eq=False)
class _Run:
    """The bookkeeping of one polish: budget, cache by point, best feasible point seen."""

    problem: Problem
    start: np.ndarray
    allowance: int
    gradient_function: GradientFunction
    config: PolishConfig
    used: int = 0
    values: dict[bytes, tuple[float, np.ndarray, bool]] = field(default_factory=dict)
    gradients: dict[bytes, Gradient] = field(default_factory=dict)
    best: tuple[float, np.ndarray] | None = None
    margin: np.ndarray | float = 0.0
    """(m,) the margin held inside each constraint (:func:`float32_margin`)."""
    active: float = field(init=False)
    """How near its held margin a constraint counts as active [-]: ``config.active`` plus
    the largest float32 step of :func:`float32_margin` (the reported stroke is cast to
    float32, which moves each margin by up to half its step)."""

    def __post_init__(self) -> None:
        self.free = np.asarray(self.problem.free)
        self.active = self.config.active

    def full(self, z: np.ndarray) -> np.ndarray:
        x = self.start.copy()
        x[self.free] = np.clip(z, -1.0, 1.0)
        return x

    def _spend(self, n: int) -> None:
        if self.used + n > self.allowance:
            raise _OutOfBudget
        self.used += n

    def _offer(self, objective: float, feasible: bool, x: np.ndarray) -> None:
        better = self.best is None or objective > self.best[0]
        if feasible and math.isfinite(objective) and better:
            self.best = (objective, x.copy())

    def value(self, z: np.ndarray) -> tuple[float, np.ndarray, bool]:
        x = self.full(z)
        if (key := x.tobytes()) not in self.values:
            self._spend(1)
            batch = self.problem.evaluate(x[None, :])
            found = (float(batch.objective[0]), batch.margins[0].copy(), bool(batch.feasible[0]))
            self.values[key] = found
            self._offer(found[0], found[2], x)
        return self.values[key]

    def gradient(self, z: np.ndarray) -> Gradient:
        x = self.full(z)
        if (key := x.tobytes()) not in self.gradients:
            self._spend(self.gradient_function.cost)
            grad = self.gradient_function(x)
            self.used -= self.gradient_function.cost - grad.evaluations
            self.gradients[key] = grad
            if isinstance(self.gradient_function, AutogradGradient):
                # autograd differentiates the torch model, which need not be the problem's
                # own evaluation (numba; equal to the last bits at most): the values the polish
                # compares and reports are the problem's own
                self.value(z)
                return grad
            self.values[key] = (grad.objective, grad.margins, grad.feasible)
            # Only the point itself is a candidate, not its perturbed neighbours: one of those
            # can beat it by rounding while h off an active constraint, where the KKT check
            # would no longer see that constraint as active.
            self._offer(grad.objective, grad.feasible, x)
        return self.gradients[key]


def polish(
    problem: Problem,
    start: np.ndarray,
    budget: int,
    config: PolishConfig,
    gradient: GradientFunction | None = None,
    *,
    infeasible_start: bool = False,
    keep_certified: bool = False,
) -> PolishResult:
    """Polish ``start`` (dim,) on ``problem`` with at most ``budget`` model evaluations.

    An infeasible start is kept (``"failed: the start is infeasible"``) unless ``infeasible_start``:
    then the optimiser starts there all the same (SLSQP moves onto the constraints) and any feasible
    point found is a gain (certificate ``gain`` None). ``keep_certified``: an iterate that passed
    the KKT stop is reported even up to 1e-6 relative below the start (a polished stroke its check
    could not certify). ``gradient`` defaults to :class:`CentralDifferences` with ``config.step``;
    one gradient's ``cost`` is counted per call and kept back for the certificate's check at the
    reported stroke, so the total never exceeds ``budget``. Without a feasible stroke better than
    the start, the start is returned (``"no gain"`` or ``"failed: ..."``)."""
    x0 = np.asarray(start, dtype=np.float64)
    if not config.enabled:
        return PolishResult(x0, math.nan, Certificate.off())
    if x0.shape != (problem.dim,) or not np.all(np.abs(x0) <= 1.0):
        raise ValueError(f"start has shape {x0.shape} or leaves [-1, 1]; allowed: ({problem.dim},)")
    if not is_integer(budget) or budget < 0:
        raise ValueError(f"polish budget = {budget!r}; allowed: an integer >= 0")
    # The coordinates the polish does not move (the discrete ones) are held as the action type
    # carries them from the start: the stroke it evaluates last is then the one it reports
    # (a start that is no float32 action, e.g. a policy's, would otherwise differ there).
    x0 = np.where(np.isin(np.arange(problem.dim), problem.free), x0, as_action_type(x0))
    grad_fn = gradient if gradient is not None else CentralDifferences(problem, config.step)
    template = Certificate(method=config.method, status="", gradient=grad_fn.name)
    if budget < 2 * grad_fn.cost:
        status = f"failed: allowance {budget} < two gradients ({2 * grad_fn.cost})"
        return PolishResult(x0, math.nan, replace(template, status=status, allowance=int(budget)))
    # kept back for the certificate's check at the reported stroke: one gradient (autograd's
    # with the problem's own value there, below)
    check = grad_fn.cost + isinstance(grad_fn, AutogradGradient)
    run = _Run(problem, x0, int(budget) - check, grad_fn, config)
    if finishable(problem, grad_fn.name, config):  # kept for agents.harness.finish
        run.allowance -= round(config.finish * run.allowance)
    z0 = x0[run.free]
    first = run.gradient(z0)
    before = first.objective
    run.margin = margin = float32_margin(first.jacobian, config.margin)
    run.active = config.active + float(np.max(margin - config.margin, initial=0.0))
    if not first.feasible and not infeasible_start:
        # the search's stroke is where the polish starts; one that fails the task's test has
        # no feasible neighbourhood guaranteed: keep it and say so.
        failed = replace(template, status="failed: the start is infeasible")
        return _keep(run, x0, before, failed, False)

    optimal, failure, ended = _climb(run, z0, margin)
    template = replace(template, **ended)
    # a start already polished (:func:`agents.harness.finish`'s) gives way to the iterate
    # that passed the KKT stop beside it, within the 1e-6 of the stop's rule, to certify it
    settled = keep_certified and optimal and run.best is not None
    settled = settled and not np.array_equal(run.best[1], x0)
    if run.best is None or (first.feasible and run.best[0] <= before and not settled):
        status = "no gain" if not failure.startswith("failed") else failure
        if not first.feasible and not failure.startswith("failed"):
            status = "failed: no feasible point from the infeasible start"
        return _keep(run, x0, before, replace(template, status=status), first.feasible)
    after, x_best = run.best
    # reported as the action type carries it (the margin keeps it feasible there): the
    # certificate's check evaluates the rounded stroke, whose objective is reported
    x_best = as_action_type(x_best)
    gain = (after - before) / abs(before) if before != 0.0 and first.feasible else None
    result = _finish(run, x_best, before, after, gain, replace(template, status="improved"))
    if not result.feasible:  # the margin is a first-order bound: say so if it ever falls short
        status = "failed: the optimum is infeasible as a float32 action"
        gain = 0.0 if first.feasible else None
        certificate = replace(result.certificate, status=status, gain=gain, objective_after=before)
        return PolishResult(x0, before, certificate, feasible=first.feasible)
    return result


def _climb(run: _Run, z0: np.ndarray, margin: np.ndarray) -> tuple[bool, str, dict[str, Any]]:
    """The local optimiser from z0 (free coordinates) on ``run``'s allowance and gradient function,
    each constraint held ``margin`` inside; the best feasible point seen is ``run.best``. How it
    ended: whether it stopped at an iterate that passed the KKT test (``config.optimality``), its
    failure (``"allowance used up"``, ``"failed: ..."`` or empty), and the certificate's
    ``iterations``, ``converged`` (the optimiser's own test, scipy ``success``; None where it did
    not end) and ``message``."""
    config = run.config

    def fun(z: np.ndarray) -> float:
        return -run.value(z)[0]

    def jac(z: np.ndarray) -> np.ndarray:
        # The optimiser asks for the gradient at each of its iterates: stop at the first that
        # passes the KKT test (its own test watches the objective's change, which can stall
        # long before it passes near active constraints, at 53 strokes a step).
        grad = run.gradient(z)
        if config.optimality > 0.0 and grad.feasible and _kkt(run, z, grad)[0] <= config.optimality:
            raise _Optimal(grad.objective, run.full(z))
        return -grad.objective_gradient

    def cons(z: np.ndarray) -> np.ndarray:
        return run.value(z)[1] - margin

    def cons_jac(z: np.ndarray) -> np.ndarray:
        return run.gradient(z).jacobian

    bounds = Bounds(-np.ones(z0.size), np.ones(z0.size))
    counter: list[None] = []  # an entry per optimiser iteration (its callback)
    outcome: OptimizeResult | None = None
    failure, optimal = "", False
    with warnings.catch_warnings():
        # trust-constr warns when it skips a BFGS update (delta_grad == 0) and SLSQP about
        # values outside the bounds it clips; the outcome is in the certificate either way
        warnings.simplefilter("ignore")
        try:
            # each optimiser's own form of the constraints and of the stopping tolerance
            if config.method == "slsqp":
                constraint: Any = {"type": "ineq", "fun": cons, "jac": cons_jac}
                own = {"method": "SLSQP", "options": {"ftol": config.tolerance}}
            else:
                constraint = NonlinearConstraint(cons, 0.0, np.inf, jac=cons_jac, hess=BFGS())
                tolerances = {"gtol": config.tolerance, "xtol": config.tolerance}
                own = {"method": "trust-constr", "hess": BFGS(), "options": tolerances}
            own["options"]["maxiter"] = config.max_iterations
            own |= {"jac": jac, "bounds": bounds, "constraints": [constraint]}
            outcome = minimize(fun, z0, callback=lambda *_: counter.append(None), **own)
        except _OutOfBudget:
            failure = "allowance used up"
        except _Optimal as stop:
            optimal = True
            # report the certified iterate unless a point of the line searches beat it by
            # more than 1e-6 (below the digits any table shows; the certificate then checks
            # that point instead)
            best = run.best[0] if run.best is not None else -math.inf
            if stop.args[0] >= best - 1e-6 * abs(best):
                run.best = stop.args
        except (ValueError, FloatingPointError, np.linalg.LinAlgError) as error:
            failure = f"failed: {type(error).__name__}: {error}"
    converged, message, iterations = None, failure, len(counter)
    if outcome is not None:
        # the optimiser's last point, for the certificate (it is feasible only if it says so)
        with contextlib.suppress(_OutOfBudget):
            run.value(np.asarray(outcome.x))
        converged, message = bool(outcome.success), str(outcome.message)
        iterations = int(outcome.get("nit", len(counter)))
    if optimal:
        converged, message = True, f"KKT residual <= {config.optimality:g} at a feasible iterate"
    return optimal, failure, {"iterations": iterations, "converged": converged, "message": message}


def float32_margin(jacobian: np.ndarray, margin: float) -> np.ndarray:
    """(m,) the margin held inside each constraint [-]: ``margin`` + Σ_j |∂g_i/∂x_j|·eps from
    the start's Jacobian (m, k), eps = ``np.finfo(float32).eps`` (one float32 step of every free
    coordinate, twice the largest rounding of a value in [-1, 1]); a stroke that far inside stays
    feasible cast to float32, to first order with a factor of 2 to spare; its cost in objective
    is the constraint's multiplier times it."""
    step = float(np.finfo(ACTION_DTYPE).eps)
    return margin + step * np.abs(np.asarray(jacobian, dtype=np.float64)).sum(axis=1)


def _kkt(run: _Run, z: np.ndarray, grad: Gradient) -> tuple[float, np.ndarray, np.ndarray]:
    """:func:`kkt_residual` at the iterate z (free coordinates) with ``run``'s margins."""
    margins = grad.margins - run.margin
    return kkt_residual(grad.objective_gradient, margins, grad.jacobian, z, run.active)


def _keep(
    run: _Run, x0: np.ndarray, before: float, template: Certificate, feasible: bool
) -> PolishResult:
    """The start stays (no gain, a failure, an infeasible start), checked with the held margins
    if it lies inside them (a polished stroke, e.g. one :func:`agents.harness.finish`
    starts from), else (a search's stroke) with the plain margin and activity."""
    found = run.values.get(x0.tobytes())
    if found is None or np.any(found[1] - run.margin < -run.active):
        run.margin, run.active = run.config.margin, run.config.active
    gain = 0.0 if feasible else None
    return replace(_finish(run, x0, before, before, gain, template), feasible=feasible)


def _finish(
    run: _Run, x: np.ndarray, before: float, after: float, gain: float | None, template: Certificate
) -> PolishResult:
    """The reported stroke x and its certificate (``template`` completed), with the KKT check
    at x (the gradient kept back for it released from the allowance first)."""
    gradient = run.gradient_function
    run.allowance += gradient.cost + isinstance(gradient, AutogradGradient)
    # the KKT residual and active constraints at x (one more gradient unless cached)
    kkt, active = None, ()
    with contextlib.suppress(_OutOfBudget):
        grad = run.gradient(x[run.free])
        kkt, on_constraint, on_bound = _kkt(run, x[run.free], grad)
        names = [n for n, a in zip(grad.names, on_constraint, strict=True) if a]
        active = (*names, *(f"bound:{run.problem.parameter_names[j]}" for j in run.free[on_bound]))
    feasible = True
    found = run.values.get(x.tobytes())  # x as evaluated by the check
    if found is not None and template.status == "improved":
        after, feasible = found[0], found[2]
        if gain is not None:
            gain = (after - before) / abs(before)
    certificate = replace(
        template,
        gain=gain,
        objective_before=before,
        objective_after=after,
        evaluations=run.used,
        allowance=run.allowance,
        kkt_residual=kkt,
        active_constraints=active,
    )
    return PolishResult(x, after, certificate, feasible=feasible)


def describe(certificate: Mapping[str, Any] | Certificate) -> str:
    """One line for a console, e.g. ``polish slsqp improved +7.49 %, 49 it, 2661 ev,
    converged, KKT 7.9e-06, active: power_violation 8 bounds``."""
    c = certificate.to_dict() if isinstance(certificate, Certificate) else dict(certificate)
    if not c or c.get("method", "none") == "none":
        return f"polish {c.get('status', 'off')}"
    parts = [f"polish {c['method']} {c['status']}"]
    if c.get("gain") is not None:
        parts[0] += f" {100 * c['gain']:+.2f} %"
    if ", then " in c.get("gradient", ""):  # a climb by differences finished by autograd
        parts[0] += f" (finished by {c['gradient'].partition(', then ')[2]})"
    converged, kkt = "converged" if c.get("converged") else "not converged", c.get("kkt_residual")
    parts += [f"{c.get('iterations', 0)} it", f"{c.get('evaluations', 0)} ev", converged]
    parts.append("KKT n/a" if kkt is None else f"KKT {kkt:.1e}")
    active = list(c.get("active_constraints") or ())
    bounds = sum(name.startswith("bound:") for name in active)
    named = [name for name in active if not name.startswith("bound:")]
    if active:
        parts.append("active: " + " ".join([*named, f"{bounds} bounds" if bounds else ""]).strip())
    line = ", ".join(parts)
    if not certified(c):  # why, then what the number is
        why = f"KKT residual above {CERTIFIED_KKT:.0e}" if c.get("converged") else c.get("message")
        line += f"\n    ({why or 'not converged'}: {UNCERTIFIED})"
    return line


#: What a number whose polish did not certify it means (printed under it by :func:`describe`).
UNCERTIFIED = (
    "not a certified optimum: the value of a feasible stroke, a lower bound on the local "
    "optimum of its basin, which may lie higher"
)


def certified(certificate: Mapping[str, Any] | Certificate) -> bool:
    """The polish certified its stroke: converged, with a KKT residual of at most
    :data:`CERTIFIED_KKT` at the reported stroke (docs/harness.md, "Local polish")."""
    c = certificate.to_dict() if isinstance(certificate, Certificate) else dict(certificate)
    kkt = c.get("kkt_residual")
    return bool(c.get("converged")) and kkt is not None and kkt <= CERTIFIED_KKT


#: The largest KKT residual [-] of a certified stroke.
CERTIFIED_KKT = 1e-4
