"""The branches of an amortised policy: which training optima belong together, the conditions
each branch learns over, its regression targets and where one branch hands over to the next
(steps (a), (b) and (d) of :mod:`train.amortised`; the rule and why: docs/training.md,
"Amortised policy", steps 2, 3 and 5).
"""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np

from train.amortised_policy import (
    HARMONICS,
    PHASE_MASK,
    AmortisedPolicy,
    Targets,
    regression_outputs,
    wrap_normalised,
)

#: Strokes interpolated between two neighbouring optima of a branch for its regression [-].
INTERPOLATED = 3
#: Conditions per gap between two branches on which their hand-over is chosen [-].
SWITCH_SAMPLES = 17


def between(first: np.ndarray, second: np.ndarray, fraction: Any = 0.5) -> np.ndarray:
    """The normalised strokes ``fraction`` of the way from ``first`` to ``second`` (B, 28):
    each phase the short way round the circle, the N coordinates the first's."""
    step = np.where(PHASE_MASK, wrap_normalised(second - first), second - first)
    middle = np.where(PHASE_MASK, wrap_normalised(first + fraction * step), first + fraction * step)
    middle[..., list(HARMONICS)] = first[..., list(HARMONICS)]
    return np.clip(middle, -1.0, 1.0)


def branch_segments(problem: Any, targets: Targets, tolerance: float) -> list[tuple[int, int]]:
    """The training conditions split into branches ``[(first, stop), ...]`` (index ranges) by
    the rule of docs/training.md (``tolerance``: ``branch_tolerance``, the midway stroke by
    :func:`between`); no held-out optimum is read."""
    k = targets.conditions.size
    if k == 1:
        return [(0, 1)]
    first, second = targets.strokes[:-1], targets.strokes[1:]
    found = problem.evaluate(
        between(first, second), 0.5 * (targets.conditions[:-1] + targets.conditions[1:])
    )
    expected = 0.5 * (targets.objectives[:-1] + targets.objectives[1:])
    joined = (
        np.all(first[:, list(HARMONICS)] == second[:, list(HARMONICS)], axis=1)
        & (found.objective >= expected - tolerance * np.abs(expected))
        & (np.min(found.margins, axis=1) >= -tolerance)
    )
    cuts = [0, *(int(i) + 1 for i in np.flatnonzero(~joined)), k]
    return list(itertools.pairwise(cuts))


def branch_domains(
    conditions: np.ndarray, segments: list[tuple[int, int]], reach: float
) -> np.ndarray:
    """(n_branches, 2) the conditions each branch learns over [the condition's unit]
    (docs/training.md, step 2; ``reach``: ``branch_reach``)."""
    last = conditions.size - 1
    return np.array(
        [
            (
                conditions[a] - reach * (conditions[a] - conditions[max(a - 1, 0)]),
                conditions[b - 1] + reach * (conditions[min(b, last)] - conditions[b - 1]),
            )
            for a, b in segments
        ],
        dtype=np.float64,
    ).reshape(-1, 2)


def regression_points(
    targets: Targets, segments: list[tuple[int, int]], domains: np.ndarray, centres: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """What each branch's regression fits (conditions (n,), branches (n,), atanh of the tanh
    outputs (n, 26)): its optima; the :data:`INTERPOLATED` strokes between each two
    neighbouring ones (within a basin they fly nearly as well); and its end optima at its
    domain's ends (a constant continuation, so a branch of one training condition starts flat
    over its domain)."""
    conditions = targets.conditions
    goal = np.arctanh(regression_outputs(targets.strokes, centres))
    owner = [np.full(b - a, i) for i, (a, b) in enumerate(segments)]
    at, of, goals = [conditions], owner, [goal]
    fractions = np.arange(1, INTERPOLATED + 1) / (INTERPOLATED + 1)
    for i, ((a, b), (low, high)) in enumerate(zip(segments, domains, strict=True)):
        for j in range(a, b - 1):
            pair = targets.strokes[j : j + 2]
            strokes = between(pair[:1], pair[1:], fractions[:, None])  # (fractions, 28)
            at.append(conditions[j] + fractions * (conditions[j + 1] - conditions[j]))
            of.append(np.full(fractions.size, i))
            goals.append(np.arctanh(regression_outputs(strokes, centres)))
        for end, index in ((low, a), (high, b - 1)):
            if end != conditions[index]:
                at.append(np.array([end]))
                of.append(np.array([i]))
                goals.append(goal[index : index + 1])
    return np.concatenate(at), np.concatenate(of), np.concatenate(goals)


def hand_overs(policy: AmortisedPolicy, problem: Any, penalty_weight: float) -> np.ndarray:
    """Where each branch hands over to the next: where their domains overlap (inside the gap
    between their training conditions), at the cut that maximises the summed penalised
    objective (objective − w·Σ max(0, −margin), the env's reward) of the two branches'
    strokes on :data:`SWITCH_SAMPLES` conditions there."""
    switches = []
    for branch in range(policy.n_branches - 1):
        grid = np.linspace(policy.domains[branch + 1, 0], policy.domains[branch, 1], SWITCH_SAMPLES)
        both = np.concatenate([grid, grid])
        found = problem.evaluate(
            policy.strokes_of(both, np.repeat([branch, branch + 1], grid.size)), both
        )
        value = found.objective - penalty_weight * np.sum(np.maximum(0.0, -found.margins), axis=1)
        own, next_ = value[: grid.size], value[grid.size :]
        cut = 1 + int(np.argmax([own[:k].sum() + next_[k:].sum() for k in range(1, grid.size)]))
        switches.append(0.5 * (grid[cut - 1] + grid[cut]))
    return np.asarray(switches, dtype=np.float64)
