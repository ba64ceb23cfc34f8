"""The env layer's validators: each value is checked once, where an env receives it (a config
field when built, an action in ``step``, a reset option in ``reset``), with a ``ValueError``
naming it, its value and what is allowed."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any, TypeVar

import numpy as np

from ..physics import N_PARAMETERS, PARAMETER_NAMES
from ..physics.checks import is_integer, is_real, real_array, shown

#: A task's config class (``FlightConfig`` or a subclass; not imported: config.py imports this).
Config = TypeVar("Config")

RENDER_MODES: tuple[str, ...] = ("human", "rgb_array")


def check_real(owner: str, name: str, value: Any, unit: str, low: float, high: float) -> float:
    """``value`` as a float if it is a finite real number in [low, high]; else a ValueError."""
    if not is_real(value) or not math.isfinite(value) or not low <= value <= high:
        unit = f" {unit}" if unit else ""
        raise ValueError(
            f"{owner}.{name} = {value!r}{unit}; allowed: a finite number from {low:g} to "
            f"{high:g}{unit}"
        )
    return float(value)


def check_count(owner: str, name: str, value: Any, low: int, high: int, what: str) -> int:
    """``value`` as an int if it is an integer in [low, high]; else a ValueError."""
    if not is_integer(value) or not low <= value <= high:
        raise ValueError(
            f"{owner}.{name} = {value!r}; allowed: an integer from {low} to {high} ({what})"
        )
    return int(value)


def check_interval(
    owner: str, name: str, value: Any, unit: str, limits: tuple[float, float]
) -> tuple[float, float]:
    """``value`` as a ``(low, high)`` float pair with limits[0] <= low < high <= limits[1]."""
    pair = () if isinstance(value, str | bytes) or not hasattr(value, "__len__") else tuple(value)
    finite = len(pair) == 2 and all(is_real(v) and math.isfinite(v) for v in pair)
    if not (finite and limits[0] <= pair[0] < pair[1] <= limits[1]):
        raise ValueError(
            f"{owner}.{name} = {value!r} {unit}; allowed: a pair (low, high) of finite numbers "
            f"with {limits[0]:g} <= low < high <= {limits[1]:g} {unit}"
        )
    return float(pair[0]), float(pair[1])


def store_checked(config: Any, name: str, check: Callable[..., Any], *limits: Any) -> Any:
    """Check the field ``name`` of the frozen dataclass ``config`` with ``check(owner, name,
    value, *limits)`` (a validator above) and store what it returns; that value."""
    value = check(type(config).__name__, name, getattr(config, name), *limits)
    object.__setattr__(config, name, value)
    return value


def check_render_mode(render_mode: Any) -> str | None:
    """``render_mode`` if it is None or one of :data:`RENDER_MODES`."""
    if render_mode is not None and render_mode not in RENDER_MODES:
        raise ValueError(
            f"render_mode = {render_mode!r}; allowed: None, {', '.join(map(repr, RENDER_MODES))}"
        )
    return render_mode


def check_actions(actions: Any, shape: tuple[int, ...], clip: bool) -> np.ndarray:
    """Normalised strokes of ``shape`` ((28,) or (B, 28)) as a float64 array: real numbers,
    finite, and inside [-1, 1] (or clipped into it when ``clip``)."""
    return action_values(action_array(actions, shape), clip)


def action_array(actions: Any, shape: tuple[int, ...]) -> np.ndarray:
    """``actions`` as a float64 array of ``shape`` (real numbers; values not checked yet)."""
    if len(shape) == 1:
        what, allowed = "action", f"{N_PARAMETERS} real numbers in [-1, 1] (a normalised stroke)"
    else:
        what, allowed = "actions", f"real numbers of shape {shape} (one normalised stroke per env)"
    arr = real_array(actions, what, allowed)
    if arr.shape != shape:
        raise ValueError(
            f"{what} must have shape {shape} here (one normalised stroke of {N_PARAMETERS} "
            f"parameters per env, fore-wing first); got shape {arr.shape}"
        )
    return arr


def action_values(arr: np.ndarray, clip: bool) -> np.ndarray:
    """Actions (an array from :func:`action_array`) finite and inside [-1, 1], or clipped into
    it when ``clip``; only the actions that are evaluated are checked (a vector env ignores the
    actions of the sub-envs it resets)."""
    flat = arr.reshape(-1, N_PARAMETERS)
    finite = np.isfinite(flat)
    if not finite.all():
        row, col = np.argwhere(~finite)[0]
        raise ValueError(
            f"action {row}: {PARAMETER_NAMES[col]} = {flat[row, col]!r} is not finite; "
            "allowed: finite numbers in [-1, 1]"
        )
    if clip:
        return np.clip(arr, -1.0, 1.0)
    outside = np.abs(flat) > 1.0
    if outside.any():
        row, col = np.argwhere(outside)[0]
        raise ValueError(
            f"action {row}: {PARAMETER_NAMES[col]} = {shown(flat[row, col], -1, 1)} is outside "
            "the action space; allowed: [-1, 1]. A client that does not clip its policy's "
            "actions to the space (skrl, a hand-written loop) should make the env with "
            "clip_actions=True, which clips them"
        )
    return arr


def reset_options(
    owner: str,
    options: Any,
    ranges: Mapping[str, tuple[float, float, str, str]],
    renamed: Mapping[str, str],
) -> dict[str, float]:
    """The numbers ``options`` of ``reset`` set (empty for None): its keys all of ``ranges``
    (key -> (low, high, unit, what that range is)), each value finite and in its range; an
    old key of ``renamed`` is refused naming its new one."""
    if not options:
        return {}
    if not isinstance(options, Mapping):
        raise ValueError(f"reset options = {options!r}; allowed: None or a dict")
    for key in options:
        if key in renamed:
            raise ValueError(f"{owner}: reset option {key!r} was renamed; use {renamed[key]!r}")
    unknown = sorted(set(options) - set(ranges))
    if unknown:
        raise ValueError(
            f"{owner}: unknown reset option(s) {unknown}; allowed: {', '.join(map(repr, ranges))}"
        )
    values = {}
    for key, value in options.items():
        low, high, unit, where = ranges[key]
        if not is_real(value) or not math.isfinite(value) or not low <= value <= high:
            raise ValueError(
                f"{owner}: reset option {key} = {value!r}; allowed: a number in {where} {low:g} "
                f"to {high:g} {unit}"
            )
        values[key] = float(value)
    return values


def build_config(
    config_class: type[Config], config: Config | None, kwargs: dict[str, Any]
) -> Config:
    """The env's config: ``config`` as given, or built from the ``gym.make`` kwargs
    (``config_class.from_kwargs``)."""
    if config is None:
        return config_class.from_kwargs(**kwargs)  # type: ignore[attr-defined, no-any-return]
    if kwargs:
        raise ValueError(
            f"give either config= or keyword options, not both; got config and {sorted(kwargs)}"
        )
    if not isinstance(config, config_class):
        raise ValueError(
            f"config = {config!r}; allowed: a {config_class.__name__} (or keyword options)"
        )
    return config
