"""docs/architecture.md, "Where to add a model option": a field of ``ModelOptions``
(options.py), its use in the model, and its line in docs/model.md's options table. This test
keeps each of the three honest for every field there is, so an option added without a docs
line, or without any effect on a ``Result``, fails here:

* every field has one row in the table, with its default and (for a choice) exactly its
  allowed values;
* changing the field to each other allowed value changes some ``Result`` field on a batch of
  random Table 4 strokes, half of them in hover (V = 0) and half at 1.5 m/s;
* the field is an env keyword (``MODEL_OPTION_KWARGS``, read from the dataclass).

The values come from tests/physics/option_cases.py (a choice's from its ``Literal``, a numeric
option's from ``NUMERIC_ALTERNATIVES``); the torch equality test
(tests/physics/test_torch_backend.py) generates its option sets from the same source, so each
value here is also checked on both backends.
"""

from __future__ import annotations

import re
import sys
from dataclasses import fields, replace
from pathlib import Path

import numpy as np
import pytest

from tandem_env.envs.config import MODEL_OPTION_KWARGS
from tandem_env.physics import ModelOptions, evaluate, normalised_to_physical
from tandem_env.physics.model import Result

sys.path.insert(0, str(Path(__file__).parent))
from option_cases import FIELDS, alternatives, choices

ROOT = Path(__file__).resolve().parents[2]
HEADER = "| option | default | allowed | section |"


def docs_table() -> dict[str, tuple[str, str]]:
    """option -> (default, allowed) cells of docs/model.md's options table."""
    lines = (ROOT / "docs/model.md").read_text(encoding="utf-8").splitlines()
    start = lines.index(HEADER) + 2  # the header and its |---| line
    rows: dict[str, tuple[str, str]] = {}
    for line in lines[start:]:
        if not line.startswith("|"):
            break
        option, default, allowed, _ = (cell.strip() for cell in line.strip("|").split("|"))
        name = option.strip("`")
        assert name not in rows, f"{name} has two rows in docs/model.md"
        rows[name] = (default, allowed)
    return rows


def test_every_option_has_its_docs_line() -> None:
    rows = docs_table()
    assert sorted(rows) == sorted(FIELDS), "docs/model.md's options table vs ModelOptions"
    defaults = ModelOptions()
    for name in FIELDS:
        default, allowed = rows[name]
        value = getattr(defaults, name)
        if isinstance(value, str):
            assert default == f'`"{value}"`', name
        else:
            assert float(default) == value, name
        values = choices(name)
        if values is not None:
            assert set(re.findall(r'`"([^"]+)"`', allowed)) == set(values), name


def _strokes() -> tuple[np.ndarray, np.ndarray]:
    strokes = normalised_to_physical(np.random.default_rng(5).uniform(-1.0, 1.0, (8, 28)))
    return strokes, np.array([0.0] * 4 + [1.5] * 4)


def _arrays(result: Result) -> dict[str, np.ndarray]:
    return {
        f.name: np.asarray(getattr(result, f.name))
        for f in fields(result)
        if isinstance(getattr(result, f.name), np.ndarray)
    }


@pytest.fixture(scope="module")
def reference() -> dict[str, np.ndarray]:
    strokes, speed = _strokes()
    return _arrays(evaluate(strokes, speed))


@pytest.mark.parametrize(("name", "value"), alternatives())
def test_every_option_changes_a_result(
    name: str, value: object, reference: dict[str, np.ndarray]
) -> None:
    assert value is not None, (
        f"ModelOptions.{name}: add a second allowed value to NUMERIC_ALTERNATIVES "
        "(tests/physics/option_cases.py)"
    )
    strokes, speed = _strokes()
    changed = _arrays(evaluate(strokes, speed, options=replace(ModelOptions(), **{name: value})))
    assert changed.keys() == reference.keys()
    moved = [k for k in reference if not np.array_equal(reference[k], changed[k])]
    assert moved, f"ModelOptions.{name} = {value!r} changes no Result field"


def test_every_option_is_an_env_keyword() -> None:
    """A field needs nothing in the envs: ``gym.make`` takes it (``power`` as
    ``power_convention``), so records and studies can set it."""
    assert sorted(MODEL_OPTION_KWARGS.values()) == sorted(FIELDS)
