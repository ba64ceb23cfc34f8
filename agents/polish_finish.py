"""The finish of a polish: a stroke whose climb by central differences ended short of the KKT
stop, polished on with autograd gradients (:func:`finish`; docs/harness.md, "Certified"), once
per run (:func:`agents.parts.finish_part`), on the ``polish_finish`` share of its allowance
each polish by differences kept back for it (:func:`agents.polish_gradients.finishable`)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from threadpoolctl import threadpool_limits

from agents.polish import (
    AutogradGradient,
    PolishConfig,
    PolishResult,
    Problem,
    certified,
    finishable,
    polish,
)

__all__ = ["finish"]


def finish(
    problem: Problem, result: PolishResult, budget: int, config: PolishConfig
) -> PolishResult:
    """``result``, a polish by central differences that ended short of the KKT stop (where the
    model's second derivative jumps within a step), polished on with autograd gradients (one
    evaluation each) on ``budget`` more evaluations; ``result`` itself where it is certified,
    infeasible, not :func:`finishable` or ``budget`` is below two gradients. The certificate
    covers both: evaluations, allowance and iterations summed, the stop and the KKT check the
    finish's, ``gradient`` ``"central differences, then autograd"``."""
    first = result.certificate
    if (
        certified(first)
        or not result.feasible
        or first.method == "none"
        or first.status.startswith("not applicable")
        or not finishable(problem, first.gradient, config)
        or budget < 2
    ):
        return result
    try:
        # one stroke is too small a tensor for threads to gain (and waiting threads cost):
        # torch's OpenMP pool on one thread, restored afterwards
        gradient = AutogradGradient(problem)
        with threadpool_limits(limits=1, user_api="openmp"):
            more = polish(problem, result.stroke, budget, config, gradient, keep_certified=True)
    except (ValueError, FloatingPointError, np.linalg.LinAlgError) as error:
        message = f"{first.message}; the finish failed: {type(error).__name__}: {error}"
        return replace(result, certificate=replace(first, message=message))
    last = more.certificate
    if last.status.startswith("failed"):
        message = f"{first.message}; the finish {last.status}"
        return replace(result, certificate=replace(first, message=message))
    before = first.objective_before
    improved = more.improved or result.improved
    gain = first.gain
    if more.improved and before is not None and first.gain is not None and before != 0.0:
        gain = (more.objective - before) / abs(before)
    certificate = replace(
        last,
        status="improved" if improved else first.status,
        gain=gain,
        objective_before=before,
        objective_after=more.objective if more.improved else first.objective_after,
        evaluations=first.evaluations + last.evaluations,
        allowance=first.allowance + last.allowance,
        iterations=first.iterations + last.iterations,
        gradient=f"{first.gradient}, then {last.gradient}",
    )
    stroke = more.stroke if more.improved else result.stroke
    objective = more.objective if more.improved else result.objective
    return PolishResult(stroke, objective, certificate, feasible=True)
