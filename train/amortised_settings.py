"""How an amortised policy is trained (:class:`Settings`): ``python -m train --algo amortised``'s
``--hyperparams`` and its run folder's ``config.yml``; the one home of their limits, which
:mod:`train.amortised_policy` checks a run's network against (:mod:`train.amortised` trains).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, fields
from typing import Any

import numpy as np

from tandem_env.io.files import to_jsonable
from tandem_env.physics.checks import is_integer, is_real


def _allowed(low: float, high: float, *, above: bool = False) -> dict[str, Any]:
    """A setting's allowed values, checked by :class:`Settings`: ``low`` (excluded if
    ``above``) to ``high``; an ``int | None`` setting may also be None."""
    return {"range": (low, high), "above": above}


@dataclass(frozen=True)
class Settings:
    """How an amortised policy is trained (``--hyperparams key=value``; ``config.yml``)."""

    hidden: tuple[int, ...] = (64, 64)
    """Widths of the MLP's hidden layers (tanh) [-]."""
    regression_steps: int = field(default=5000, metadata=_allowed(0, 10**6))
    """Adam steps of the regression on the training optima (full batch) [-]."""
    regression_lr: float = field(default=3e-3, metadata=_allowed(0.0, 1.0, above=True))
    """Adam's learning rate in the regression [-]."""
    finetune_steps: int = field(default=600, metadata=_allowed(0, 10**6))
    """Adam steps of the fine-tuning by the objective's gradient (0: none) [-]."""
    finetune_lr: float = field(default=1e-3, metadata=_allowed(0.0, 1.0, above=True))
    """Adam's learning rate in the fine-tuning [-]."""
    batch: int = field(default=16, metadata=_allowed(1, 4096))
    """Conditions per branch and fine-tuning step (all in one batched model evaluation) [-]."""
    penalty_weight: float = field(default=10.0, metadata=_allowed(0.0, 1e6, above=True))
    """w of the fine-tuning's penalty [objective units per unit of margin] (the env's default
    ``penalty_weight``)."""
    safety_margin: float = field(default=1e-3, metadata=_allowed(0.0, 0.1))
    """δ: the fine-tuning penalises every constraint margin below it [-] (margins are
    fractions: the level flight's tolerance is 0.02)."""
    anchor: float = field(default=30.0, metadata=_allowed(0.0, 1e6))
    """Weight of the regression loss on the training targets during the fine-tuning [-]."""
    branch_reach: float = field(default=0.6, metadata=_allowed(0.5, 1.0, above=True))
    """How far each branch's domain reaches into the gap to a neighbouring branch's training
    condition, as a fraction of the gap [-] (above 0.5, so that both branches cover its
    middle, where they hand over)."""
    branch_tolerance: float = field(default=0.1, metadata=_allowed(0.0, 1.0))
    """Two neighbouring training optima share a branch when the stroke midway between them
    loses at most this fraction of their mean objective and violates no margin by more
    (:func:`~train.amortised_branches.branch_segments`) [-]."""
    features: int = field(default=0, metadata=_allowed(0, 1024))
    """Gaussian radial features of the observation before the MLP (0: the observation
    itself) [-] (:func:`~train.amortised_policy.radial_features`)."""
    finetune_n_time: int | None = field(default=None, metadata=_allowed(8, 4096))
    """Time samples of the fine-tuning's model (None: the env's, default 128) [-]."""
    finetune_n_blade: int | None = field(default=None, metadata=_allowed(2, 512))
    """Blade elements of the fine-tuning's model (None: the env's, default 24) [-]."""

    def __post_init__(self) -> None:
        hidden = self.hidden
        if isinstance(hidden, int | np.integer) and not isinstance(hidden, bool):
            hidden = (hidden,)
        if (
            not isinstance(hidden, list | tuple)
            or not hidden
            or not all(is_integer(h) and 1 <= h <= 4096 for h in hidden)
            or len(hidden) > 8
        ):
            raise ValueError(
                f"hidden = {self.hidden!r}; allowed: 1 to 8 layer widths, each an integer from "
                "1 to 4096, e.g. [64, 64]"
            )
        object.__setattr__(self, "hidden", tuple(int(h) for h in hidden))
        for spec in fields(self)[1:]:
            name, value, (low, high) = spec.name, getattr(self, spec.name), spec.metadata["range"]
            if spec.type == "float":
                ok = is_real(value) and math.isfinite(value) and low <= value <= high
                if not ok or (spec.metadata["above"] and value == low):
                    bound = f"above {low:g}" if spec.metadata["above"] else f"from {low:g}"
                    raise ValueError(f"{name} = {value!r}; allowed: a number {bound} to {high:g}")
                object.__setattr__(self, name, float(value))
            elif value is not None or spec.type == "int":
                if not is_integer(value) or not low <= value <= high:
                    allowed = (
                        f"an integer from {low} to {high:,}"
                        if spec.type == "int"
                        else f"None (the env's) or an integer from {low} to {high}"
                    )
                    raise ValueError(f"{name} = {value!r}; allowed: {allowed}")
                object.__setattr__(self, name, int(value))

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any]) -> Settings:
        """Settings from ``key=value`` overrides; ValueError naming an unknown key."""
        names = [f.name for f in fields(cls)]
        unknown = sorted(set(values) - set(names))
        if unknown:
            raise ValueError(f"unknown amortised setting(s) {unknown}; allowed: {', '.join(names)}")
        return cls(**dict(values))

    def to_dict(self) -> dict[str, Any]:
        return to_jsonable(asdict(self))
