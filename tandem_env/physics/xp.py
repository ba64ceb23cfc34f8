"""Array namespaces: the few operations in which numpy and torch differ, so that the model code
outside the compiled kernel (the free stream, the hover mask, the flight performance of
``model``) is written once for both backends (docs/model.md §10).

:data:`NUMPY` is numpy's; the torch backend builds its own :class:`ArrayNamespace` from torch in
``torch_model`` (this module imports no torch). Everything else the shared code needs works on
both array types as it is: arithmetic, comparisons, ``&``, indexing, ``.sum(1)``, ``.mean(1)``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np


@dataclass(frozen=True)
class ArrayNamespace:
    """The elementwise and reducing operations the shared model code calls by name."""

    name: str
    sin: Callable[[Any], Any]
    cos: Callable[[Any], Any]
    abs: Callable[[Any], Any]
    hypot: Callable[[Any, Any], Any]
    rad2deg: Callable[[Any], Any]
    where: Callable[[Any, Any, Any], Any]
    """where(condition, x, y): x where condition, else y (y may be a Python number)."""
    clip_min: Callable[[Any, float], Any]
    """clip_min(x, low) = max(x, low) elementwise."""
    all_along: Callable[[Any, int], Any]
    """all_along(x, axis): logical and along an axis."""
    max_along: Callable[[Any, int], Any]
    """max_along(x, axis): the largest value along an axis (values only)."""
    as_int64: Callable[[Any], Any]
    zeros_bool: Callable[[Any], Any]
    """zeros_bool(x): False everywhere, x's shape (and device)."""


NUMPY = ArrayNamespace(
    name="numpy",
    sin=np.sin,
    cos=np.cos,
    abs=np.abs,
    hypot=np.hypot,
    rad2deg=np.rad2deg,
    where=np.where,
    clip_min=np.maximum,
    all_along=lambda x, axis: np.all(x, axis=axis),
    max_along=lambda x, axis: np.max(x, axis=axis),
    as_int64=lambda x: x.astype(np.int64),
    zeros_bool=lambda x: np.zeros(x.shape, dtype=bool),
)
