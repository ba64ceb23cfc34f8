"""The one rule that picks "the best stroke", wherever one is chosen (the harness, training,
a resumed run; docs/harness.md, "Which stroke"):

1. A feasible stroke beats every infeasible one, whatever their rewards.
2. Between strokes of equal feasibility the higher reward wins.
3. Ties go to the earlier stroke: the lower index in a batch, the incumbent against a newcomer.

A NaN or -inf reward ranks as an infeasible stroke with reward -inf and never improves on
"nothing yet" (:data:`NOTHING`); +inf is a number.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike


@dataclass(frozen=True)
class Rank:
    """What the rule compares for one stroke."""

    feasible: bool
    """All constraints met (False for a stroke whose reward is NaN or -inf)."""
    reward: float
    """The reward [reward units]; -inf for a NaN reward."""

    def beats(self, other: Rank) -> bool:
        """Strictly better than ``other`` by the rule (ties keep ``other``, the earlier one)."""
        return (self.feasible, self.reward) > (other.feasible, other.reward)


NOTHING = Rank(feasible=False, reward=-np.inf)
"""The rank before any stroke: only a stroke with a real reward (> -inf) beats it."""


def rank(feasible: bool | np.bool_, reward: float) -> Rank:
    """The rule's view of one stroke (NaN -> -inf, and such a stroke counts as infeasible)."""
    value = -np.inf if np.isnan(float(reward)) else float(reward)
    return Rank(feasible=bool(feasible) and value > -np.inf, reward=value)


def is_better(
    feasible: bool | np.bool_, reward: float, best_feasible: bool | np.bool_, best_reward: float
) -> bool:
    """Whether a stroke (``feasible``, ``reward``) strictly beats the incumbent
    (``best_feasible``, ``best_reward``) by the rule; False on a tie."""
    return rank(feasible, reward).beats(rank(best_feasible, best_reward))


def best_index(feasible: ArrayLike, reward: ArrayLike) -> int:
    """Index of the best of n >= 1 strokes (``feasible`` (n,), ``reward`` (n,)) by the rule,
    vectorised; 0 when none has a real reward."""
    flags = np.asarray(feasible, dtype=bool)
    values = np.asarray(reward, dtype=np.float64)
    if values.ndim != 1 or values.shape != flags.shape or values.size == 0:
        raise ValueError(
            f"feasible {flags.shape} and reward {values.shape}; allowed: two arrays of the "
            "same shape (n,) with n >= 1"
        )
    clean = np.where(np.isnan(values), -np.inf, values)
    usable = flags & (clean > -np.inf)
    # np.argmax returns the first of equal maxima: the usable ones' if any
    return int(np.argmax(np.where(usable, clean, -np.inf) if usable.any() else clean))


class BestStroke:
    """The best stroke's rank over batches: :meth:`offer` each batch; the caller keeps what it
    wants of the stroke when it wins."""

    def __init__(self) -> None:
        self.rank = NOTHING

    @property
    def found(self) -> bool:
        """Whether any stroke with a real reward was offered."""
        return self.rank is not NOTHING

    @property
    def feasible(self) -> bool:
        return self.rank.feasible

    @property
    def reward(self) -> float:
        """The best stroke's reward [reward units] (-inf before any)."""
        return self.rank.reward

    def offer(self, feasible: ArrayLike, reward: ArrayLike) -> int | None:
        """Offer a batch (n,) of strokes; the index of its best one if that beats the best so
        far (which it then becomes), else None."""
        flags, values = np.asarray(feasible, dtype=bool), np.asarray(reward, dtype=np.float64)
        i = best_index(flags, values)
        if not (candidate := rank(flags[i], values[i])).beats(self.rank):
            return None
        self.rank = candidate
        return i
