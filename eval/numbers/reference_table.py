"""The reference optima (docs/reference.md): the packaged table
``tandem_env/data/reference_optima.json`` as the document shows it. The table is made by
``python -m eval reference`` (an hour of optimisations on 2 cores); this measurement reads it,
so that the document says what the package holds (tests/envs/test_reference.py checks that the
stored copy is the package's)."""

from __future__ import annotations

import json
from typing import Any

from eval.numbers.framework import Measurement
from tandem_env.envs.reference import reference_path


def measure() -> dict[str, Any]:
    """The packaged table, as it is."""
    return json.loads(reference_path().read_text(encoding="utf-8"))


def render(data: dict[str, Any]) -> str:
    from eval.reference import reference_markdown

    return reference_markdown(data)


MEASUREMENT = Measurement("reference-table", measure, render)
