"""Info columns: name -> (B,) array (or a nested dict of columns, ``"stroke"``) for B envs,
split into per-env dicts or Gymnasium's masked dict of arrays without a loop per metric.
"""

from __future__ import annotations

from typing import Any

import numpy as np

Columns = dict[str, Any]
"""Info columns: name -> (B,) array, or a nested dict of columns (``"stroke"``)."""


def row(columns: Columns, index: int) -> dict[str, Any]:
    """One env's info dict: plain Python floats, bools and ints (nested dicts stay dicts)."""
    return {
        key: row(value, index) if isinstance(value, dict) else value[index].item()
        for key, value in columns.items()
    }


def take_columns(columns: Columns, index: np.ndarray) -> Columns:
    """The rows ``index`` of info columns (nested dicts too)."""
    return {
        key: take_columns(value, index) if isinstance(value, dict) else value[index]
        for key, value in columns.items()
    }


def rows(columns: Columns, count: int) -> list[dict[str, Any]]:
    """All ``count`` info dicts at once (``tolist`` per column, not per value)."""
    keys = list(columns)
    lists = [
        rows(columns[key], count) if isinstance(columns[key], dict) else columns[key].tolist()
        for key in keys
    ]
    if not keys:
        return [{} for _ in range(count)]
    return [dict(zip(keys, values, strict=True)) for values in zip(*lists, strict=True)]


def add_columns(
    infos: dict[str, Any], columns: Columns, index: np.ndarray, num_envs: int
) -> dict[str, Any]:
    """Scatter columns for envs ``index`` into Gymnasium's vector info dict with ``_key``
    masks, as ``VectorEnv._add_info`` env by env would (so infos equal SyncVectorEnv's)."""
    for key, values in columns.items():
        if isinstance(values, dict):
            array = add_columns(infos.get(key, {}), values, index, num_envs)
        else:
            array = infos.get(key)
            array = np.zeros(num_envs, dtype=values.dtype) if array is None else array
            array[index] = values
        mask = infos.get(f"_{key}")
        mask = np.zeros(num_envs, dtype=np.bool_) if mask is None else mask
        mask[index] = True
        infos[key], infos[f"_{key}"] = array, mask
    return infos
