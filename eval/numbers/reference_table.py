"""The reference optima (docs/reference.md): the packaged table as the document shows it."""

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
