"""``evaluate`` with a choice of implementation: the numba kernel or the torch port.

:func:`evaluate` is :func:`model.evaluate_numba` (the numba kernel) plus ``backend`` and ``device``;
``backend="torch"`` runs ``torch_model`` (imported only then) and returns the same numpy
``Result``. It lives here rather than in ``model``, which ``torch_model`` builds on, so that no
import leads back to where it started (tests/test_layering.py).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from . import model
from .insect import DRAGONFLY, Dragonfly
from .model import DEFAULT_OPTIONS, Result
from .options import ModelOptions
from .stroke import validate_physical

#: The implementations of :func:`evaluate`: the compiled numba kernel (default) and the torch
#: port (``torch_model``, on any torch device; docs/model.md §12.1).
BACKENDS: tuple[str, ...] = ("numba", "torch")


def evaluate(
    strokes: np.ndarray,
    speed: float | np.ndarray = 0.0,
    available_power: float | np.ndarray | None = None,
    *,
    flight_path_angle: float | np.ndarray = 0.0,
    insect: Dragonfly = DRAGONFLY,
    options: ModelOptions = DEFAULT_OPTIONS,
    backend: str = "numba",
    device: Any = None,
) -> Result:
    """Evaluate one wing-beat cycle of each stroke in a batch (:func:`model.evaluate_numba`'s
    arguments, units and ``Result``).

    ``backend``: ``"numba"`` (the compiled kernel) or ``"torch"`` (``torch_model``, float64,
    equal to the kernel to 1e-8); ``device``: the torch device (``"cpu"``, ``"cuda"``,
    ``"cuda:1"``; default the CPU), only with ``backend="torch"``. An unknown backend, a device
    with the numba backend, or a device that is not available raises ValueError naming it.
    A stroke outside the insect's ``stroke_bounds`` (Table 4's unless it sets its own) raises
    ValueError naming the parameter, its value and the bounds.
    """
    if isinstance(insect, Dragonfly):  # else the backend names the bad insect
        validate_physical(strokes, bounds=insect.stroke_bounds)
    kwargs = dict(flight_path_angle=flight_path_angle, insect=insect, options=options)
    if backend == "torch":
        from .torch_model import evaluate_numpy

        return evaluate_numpy(strokes, speed, available_power, device=device, **kwargs)
    check_backend(backend, device)
    return model.evaluate_numba(strokes, speed, available_power, **kwargs)


def check_backend(backend: Any, device: Any = None) -> tuple[str, str | None]:
    """``(backend, device)`` as :func:`evaluate` takes them, the device as its canonical name
    (``"cpu"``, ``"cuda:1"``) or None (the backend's default); ValueError naming the value and
    what is allowed for an unknown backend, a device with the numba backend, or a device that
    is not available (torch is imported only for ``backend="torch"``)."""
    if backend not in BACKENDS:
        raise ValueError(f"backend = {backend!r}; allowed: {', '.join(map(repr, BACKENDS))}")
    if backend == "torch":
        if device is None:
            return backend, None
        from .torch_model import resolve_device

        return backend, str(resolve_device(device))
    if device is not None:
        raise ValueError(
            f"device = {device!r} with backend 'numba'; allowed: None (the numba kernel runs on "
            "the CPU; give backend='torch' to choose a device)"
        )
    return backend, None
