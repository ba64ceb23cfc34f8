"""Array namespaces: the few operations in which numpy and torch differ, so that the model code
outside the compiled kernel (the angle histories of ``kinematics``, the free stream, the hover
mask and the flight performance of ``model``) is written once for both backends (docs/model.md
§10).

:data:`NUMPY` is numpy's; the torch backend builds its own :class:`ArrayNamespace` from torch in
``torch_model`` (this module imports no torch). Its functions carry numpy's names, so a
numba-compiled elementwise function, which calls ``np.<name>``, runs on either array type through
:func:`on_namespace`. Everything else the shared code needs works on both array types as it is:
arithmetic, comparisons, indexing, ``.sum(1)``, ``.mean(1)``.
"""

from __future__ import annotations

import types
from collections.abc import Callable
from dataclasses import dataclass
from functools import cache
from typing import Any

import numba
import numpy as np
from numba import njit

#: Batches smaller than this run stroke by stroke on the calling thread: a parallel launch costs
#: more than it saves.
SERIAL_BELOW = 4


class StrokeLoop:
    """A compiled loop over a batch's strokes (``prange``), compiled twice: in parallel, and
    on the calling thread (without the GIL) for batches of fewer than :data:`SERIAL_BELOW`
    strokes, where waking the threads costs more than the loop, and wherever numba has one
    thread (without ``parallel``, ``prange`` is ``range``: the same arithmetic, the same
    bits). Call ``loop(strokes, *args)``, ``strokes`` the batch's size; ``options`` are
    numba's (``error_model``, ``fastmath``)."""

    def __init__(self, function: Callable, **options: Any) -> None:
        self.parallel = njit(cache=True, parallel=True, **options)(function)
        # numba's cache names its files by the function's qualified name, not by its options:
        # the serial twin gets a name of its own so that neither loads the other's machine code
        twin = types.FunctionType(
            function.__code__, function.__globals__, function.__name__, function.__defaults__
        )
        twin.__qualname__ = f"{function.__qualname__}_serial"
        twin.__module__ = function.__module__
        # without the GIL: the vortex reading runs chunks of strokes side by side in threads
        self.serial = njit(cache=True, nogil=True, **options)(twin)
        self.__doc__ = function.__doc__

    def __call__(self, strokes: int, *args: Any) -> Any:
        # one thread gains nothing from the parallel launch, which costs ~0.07 ms a call
        parallel = strokes >= SERIAL_BELOW and numba.get_num_threads() > 1
        return (self.parallel if parallel else self.serial)(*args)


def on_one_thread(function: Callable[..., Any], *args: Any) -> Any:
    """``function(*args)`` with numba's thread count set to one on the calling thread (numba
    keeps it per thread), so that its :class:`StrokeLoop` calls run serial: for work that
    runs side by side in threads of its own."""
    numba.set_num_threads(1)
    return function(*args)


def stroke_loop(**options: Any) -> Callable[[Callable], StrokeLoop]:
    """Decorator: the function as a :class:`StrokeLoop` with numba's ``options``."""
    return lambda function: StrokeLoop(function, **options)


@dataclass(frozen=True)
class ArrayNamespace:
    """An array module (numpy or torch) and the few operations in which the two differ.

    Any other name is the module's own: ``sin``, ``cos``, ``arcsin``, ``tanh``, ``sqrt``,
    ``abs``, ``hypot``, ``rad2deg`` and ``where`` (``where(condition, x, y)``, y may be a
    Python number) mean the same in both.
    """

    module: Any
    maximum: Callable[[Any, float], Any]
    """maximum(x, low): max(x, low) elementwise, ``low`` a Python number (so ``minimum``)."""
    minimum: Callable[[Any, float], Any]
    all_along: Callable[[Any, int], Any]
    """all_along(x, axis): logical and along an axis (so ``max_along``: values only)."""
    max_along: Callable[[Any, int], Any]
    as_int64: Callable[[Any], Any]
    zeros_bool: Callable[[Any], Any]
    """zeros_bool(x): False everywhere, x's shape (and device)."""
    arange_like: Callable[[int, Any], Any]
    """arange_like(n, x): 0, 1, …, n − 1 in x's floating dtype (and on its device)."""
    constant_like: Callable[[np.ndarray, Any], Any]
    """constant_like(a, x): a numpy constant ``a`` to combine with x (numpy: ``a`` itself;
    torch: a tensor in x's dtype on x's device)."""

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__"):  # no module lookups while copying or unpickling
            raise AttributeError(name)
        return getattr(self.module, name)


NUMPY = ArrayNamespace(
    module=np,
    maximum=np.maximum,
    minimum=np.minimum,
    all_along=lambda x, axis: np.all(x, axis=axis),
    max_along=lambda x, axis: np.max(x, axis=axis),
    as_int64=lambda x: x.astype(np.int64),
    zeros_bool=lambda x: np.zeros(x.shape, dtype=bool),
    arange_like=lambda n, x: np.arange(n, dtype=x.dtype),
    constant_like=lambda a, x: a,
)


#: numba's error model for the formulas that branch through :func:`select`: IEEE division, without
#: the zero-divisor check of numba's default ("python") error model, a branch which keeps the
#: compiler from vectorising the loops that call them (3-4× slower). Their divisors are
#: selected nonzero where the result is read, so no result changes.
BRANCH_FREE = "numpy"


@njit(cache=True)
def select(condition, if_true, otherwise):
    """``if_true`` where ``condition``, else ``otherwise``: in compiled code a scalar choice (both
    already computed, so the compiler may vectorise the loop around it), on arrays ``xp.where``
    (:func:`on_namespace`). An elementwise formula branches through this, never through ``if``,
    so that it runs on both. ``otherwise`` may be a number, but not both: torch would make that
    a float32."""
    return if_true if condition else otherwise


@cache
def on_namespace(kernel: Callable, xp: ArrayNamespace) -> Callable:
    """The pure-Python body of a numba-compiled elementwise function (its ``py_func``) with the
    name ``np`` in it bound to ``xp``, :func:`select` to ``xp.where`` and every numba-compiled
    function it calls to that function on ``xp`` in turn: the same formulas, compiled for
    numba's scalars, run on broadcast numpy or torch arrays. The functions may call only
    ``np.<name>`` that ``xp`` has, and branch with ``if`` only on what is not an array."""
    body = getattr(kernel, "py_func", kernel)
    names = {"np": xp, "select": xp.where}
    for name in body.__code__.co_names:
        called = body.__globals__.get(name)
        if name not in names and hasattr(called, "py_func"):
            names[name] = on_namespace(called, xp)
    return types.FunctionType(
        body.__code__,
        {**body.__globals__, **names},
        body.__name__,
        body.__defaults__,
        body.__closure__,
    )
