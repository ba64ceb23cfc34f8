"""Option sets generated from ``ModelOptions``' own fields, so a new option or a new value of a
choice is tested without a hand edit: a choice's values come from its ``Literal`` type, a
numeric option's from :data:`NUMERIC_ALTERNATIVES` (the test says when one is missing).

:func:`all_pairs` covers every pair of values of two different options in a few sets (a
greedy covering array, deterministic), far fewer than the full product: every value of every
option appears, and every value of one option meets every value of each other.
"""

from __future__ import annotations

import typing
from collections.abc import Mapping, Sequence
from dataclasses import fields
from itertools import combinations
from typing import Any

from tandem_env.physics import ModelOptions

#: A second allowed value of each numeric option (a choice's values come from its Literal). A
#: new numeric option needs one here: tests/physics/test_toy_model_option.py says so.
NUMERIC_ALTERNATIVES: dict[str, Any] = {
    "n_time": 64,
    "n_blade": 12,
    "interference": 0.5,
    "tolerance": 1e-2,
    "max_evaluations": 2,
}
HINTS = typing.get_type_hints(ModelOptions)
FIELDS: tuple[str, ...] = tuple(f.name for f in fields(ModelOptions))


def choices(name: str) -> tuple[Any, ...] | None:
    """The allowed values of a choice option (its ``Literal``), None for a numeric one."""
    hint = HINTS[name]
    return typing.get_args(hint) if typing.get_origin(hint) is typing.Literal else None


def levels(extra: Mapping[str, Sequence[Any]] | None = None) -> dict[str, tuple[Any, ...]]:
    """Every option's values to test: a choice's all, a numeric option's default, its
    alternative (if named) and ``extra``'s."""
    defaults = ModelOptions()
    out: dict[str, tuple[Any, ...]] = {}
    for name in FIELDS:
        values = choices(name)
        if values is None:
            named = [NUMERIC_ALTERNATIVES[name]] if name in NUMERIC_ALTERNATIVES else []
            values = (getattr(defaults, name), *named)
        out[name] = tuple(dict.fromkeys([*values, *(extra or {}).get(name, ())]))
    return out


def alternatives() -> list[tuple[str, Any]]:
    """(option, value) for each value other than the default (None: a numeric option without
    an alternative in :data:`NUMERIC_ALTERNATIVES`)."""
    defaults = ModelOptions()
    out: list[tuple[str, Any]] = []
    for name in FIELDS:
        if choices(name) is None and name not in NUMERIC_ALTERNATIVES:
            out.append((name, None))
            continue
        out.extend((name, v) for v in levels()[name] if v != getattr(defaults, name))
    return out


def all_pairs(
    values: Mapping[str, Sequence[Any]], seeds: Sequence[Mapping[str, Any]] = ()
) -> list[dict[str, Any]]:
    """Option sets (option -> value) in which every pair of values of two options occurs.

    ``seeds`` are partial sets that must appear (e.g. a combination that only acts together);
    each is completed, then new sets are built greedily: the first pair not yet covered, and
    for every other option the value that covers the most pairs not yet covered (the first on
    ties), so the result is the same on every run.
    """
    names = list(values)
    uncovered = {
        ((a, x), (b, y)) for a, b in combinations(names, 2) for x in values[a] for y in values[b]
    }

    def gain(row: dict[str, Any], name: str, value: Any) -> int:
        pairs = {
            tuple(sorted(((name, value), (o, row[o])), key=lambda p: names.index(p[0])))
            for o in row
        }
        return len(pairs & uncovered)

    def complete(row: dict[str, Any]) -> dict[str, Any]:
        for name in names:
            if name not in row:
                row[name] = max(values[name], key=lambda v: gain(row, name, v))
        return row

    rows: list[dict[str, Any]] = []
    pending = [dict(seed) for seed in seeds]
    while pending or uncovered:
        if pending:
            row = complete(pending.pop(0))
        else:
            (a, x), (b, y) = min(
                uncovered,
                key=lambda p: (
                    names.index(p[0][0]),
                    names.index(p[1][0]),
                    values[p[0][0]].index(p[0][1]),
                    values[p[1][0]].index(p[1][1]),
                ),
            )
            row = complete({a: x, b: y})
        for a, b in combinations(names, 2):
            uncovered.discard(((a, row[a]), (b, row[b])))
        rows.append(row)
    return rows
