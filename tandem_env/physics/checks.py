"""Checks of numeric input shared by the model's entry points and the environments.

Python and NumPy convert too readily: ``np.asarray(["30"], dtype=float)`` is 30.0, ``True``
is 1.0 and a complex number loses its imaginary part with a warning. Every public entry point
takes its numbers through these checks instead, so a string, a boolean, a complex number or a
ragged list is refused with a message naming the argument, the value and what is allowed.
NumPy integers and floats are real numbers here, like Python's.
"""

from __future__ import annotations

import math
import numbers
from typing import Any

import numpy as np

__all__ = ["count", "finite_real", "flag", "is_integer", "is_real", "real_array", "shown"]


def is_real(value: Any) -> bool:
    """A real number (Python or NumPy int or float); not a bool, a string or a complex."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool | np.bool_)


def is_integer(value: Any) -> bool:
    """An integer (Python or NumPy); not a bool."""
    return isinstance(value, numbers.Integral) and not isinstance(value, bool | np.bool_)


def flag(value: Any, name: str) -> bool:
    """``value`` as a bool if it is True or False (Python or NumPy), else a ``ValueError``.

    Truthiness would take ``"no"`` or ``"false"`` (non-empty strings) for True, and 0 or 1 for
    a choice the caller may have meant otherwise: a switch is given as a boolean.
    """
    if isinstance(value, bool | np.bool_):
        return bool(value)
    what = "a string" if isinstance(value, str | bytes) else f"a {type(value).__name__}"
    raise ValueError(f"{name} = {short_repr(value)} is {what}; allowed: True or False")


def count(value: Any, name: str, low: int = 1, high: int | None = None, what: str = "") -> int:
    """``value`` as an int if it is an integer (Python or NumPy, not a bool) in [low, high],
    else a ``ValueError`` naming ``name``, the value and the range (``what``: its meaning)."""
    if not is_integer(value) or value < low or (high is not None and value > high):
        upper = f" and <= {high:,}" if high is not None else ""
        meaning = f" ({what})" if what else ""
        raise ValueError(
            f"{name} = {short_repr(value)}; allowed: an integer >= {low}{upper}{meaning}"
        )
    return int(value)


def shown(value: Any, *bounds: float) -> str:
    """``value`` as a message shows it next to the ``bounds`` it is compared with.

    Six significant digits (``%g``), or as many more as it takes to tell it from each bound it
    differs from: 45.00001 next to a limit of 45 reads ``45.00001``, not ``45``, so a message
    never shows a refused value equal to its limit. Up to the shortest form that round-trips
    (``repr``), which tells any two different floats apart.
    """
    if not is_real(value):
        return short_repr(value)
    number = float(value)
    others = [float(b) for b in bounds if float(b) != number]
    for digits in range(6, 17):
        text = f"{number:.{digits}g}"
        if all(text != f"{b:.{digits}g}" for b in others):
            return text
    return repr(number)


def _describe(value: Any) -> str:
    if isinstance(value, str | bytes | np.str_ | np.bytes_):
        return "a string"
    if isinstance(value, bool | np.bool_):
        return "a boolean"
    if isinstance(value, complex | np.complexfloating):
        return "a complex number"
    if isinstance(value, list | tuple | np.ndarray):
        return "a sequence where a number belongs (a ragged list?)"
    if value is None:
        return "not a number"
    return f"a {type(value).__name__}, not a real number"


def _at(name: str, index: tuple[int, ...]) -> str:
    return f"{name}[{', '.join(map(str, index))}]" if index else name


def short_repr(value: Any) -> str:
    """``repr(value)``, cut to 60 characters (an error message quotes what it was given)."""
    text = repr(value)
    return text if len(text) <= 60 else f"{text[:57]}..."


def real_array(value: Any, name: str, allowed: str) -> np.ndarray:
    """``value`` as a float64 array, or a ``ValueError`` naming ``name`` and ``allowed``.

    Accepted: Python and NumPy ints and floats, and (nested, rectangular) sequences and arrays
    of them. Refused: strings (also numeric ones such as ``"1.5"``), booleans, complex numbers,
    ``None``, other objects and ragged sequences. The first offending element is named with its
    index. Shape and range are the caller's to check.
    """
    if isinstance(value, str | bytes):
        raise ValueError(f"{name} = {short_repr(value)} is a string; allowed: {allowed}")
    try:
        arr = np.asarray(value)
    except ValueError as error:  # NumPy >= 1.24 refuses ragged nesting
        raise ValueError(
            f"{name} is a ragged sequence (its rows have different lengths); allowed: {allowed}"
        ) from error
    kind = arr.dtype.kind
    if kind in "iuf":
        return arr.astype(np.float64, copy=False)
    if not isinstance(value, np.ndarray):
        # NumPy turned a mixed list such as [1.5, "2"] into strings; look at what was given.
        arr, kind = np.asarray(value, dtype=object), "O"
    if kind == "O":
        flat = arr.reshape(-1)
        for k, element in enumerate(flat):
            if not is_real(element):
                index = np.unravel_index(k, arr.shape) if arr.ndim else ()
                index = tuple(int(i) for i in index)
                raise ValueError(
                    f"{_at(name, index)} = {short_repr(element)} is {_describe(element)}; "
                    f"allowed: {allowed}"
                )
        return arr.astype(np.float64)
    # A homogeneous array of something other than real numbers: name its first element.
    index = (0,) * arr.ndim if arr.size else ()
    element = arr[index] if arr.size else arr
    what = {
        "b": "a boolean",
        "c": "a complex number",
        "U": "a string",
        "S": "a string",
    }.get(kind, f"of dtype {arr.dtype}, not a real number")
    if arr.ndim and arr.size:
        detail = f"{_at(name, index)} = {short_repr(element.item())} is {what}"
    else:
        detail = f"{name} = {short_repr(value)} is {what}"
    raise ValueError(f"{detail}; allowed: {allowed}")


def finite_real(
    value: Any, name: str, low: float, high: float, unit: str = "", *, above: bool = False
) -> float:
    """A scalar real number in [low, high] as a float, or a ``ValueError`` naming it; ``above``:
    in (low, high] (``low`` itself refused, e.g. a step size that must be positive)."""
    unit = f" {unit}" if unit else ""
    if (
        not is_real(value)
        or not math.isfinite(value)
        or not (low < value if above else low <= value)
        or value > high
    ):
        lowest = f"above {low:g} and up to" if above else f"from {low:g} to"
        raise ValueError(
            f"{name} = {shown(value, low, high)}{unit}; allowed: a finite number {lowest} "
            f"{high:g}{unit}"
        )
    return float(value)
