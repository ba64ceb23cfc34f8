"""The numbers README and docs quote are the stored measurements, and the measurements are true.

``python -m eval numbers`` measures and writes them (eval/numbers.py). Here: every marked region
of every document equals its rendering from ``docs/numbers/*.json`` (no hand edit, no stale
text), every measurement has a region, and seed 0 of each deterministic comparison row, rerun by
its documented command at its stated settings, gives the stored objective.
"""

from __future__ import annotations

import math

import pytest

from eval import numbers


def test_every_region_is_its_rendering() -> None:
    rendered = numbers.rendered_all()
    seen = set()
    for path in numbers.DOCUMENTS:
        text = path.read_text(encoding="utf-8")
        for match in numbers.regions(text):
            name = match["name"]
            assert name in rendered, f"{path.name}: unknown numbers region {name!r}"
            assert match["body"] == rendered[name], (
                f"{path.name}: the {name!r} region differs from docs/numbers/{name}.json "
                "(run `python -m eval numbers --render`, or `python -m eval numbers` to remeasure)"
            )
            seen.add(name)
    assert seen == set(numbers.MEASUREMENTS), (
        f"measurements without a region: {set(numbers.MEASUREMENTS) - seen}"
    )


def test_render_document_rejects_unknown_region() -> None:
    with pytest.raises(KeyError, match="unknown numbers region 'nope'"):
        numbers.render_document("<!-- numbers: nope -->\nx\n<!-- /numbers -->", {})


@pytest.mark.slow
@pytest.mark.parametrize("row", numbers.COMPARISON_ROWS, ids=lambda r: r.label.split(",")[0])
@pytest.mark.parametrize("method", numbers.COMPARISON_METHODS)
def test_comparison_seed0_reproduces(row: numbers.ComparisonRow, method: str) -> None:
    stored = next(
        r
        for r in numbers.load("comparison")["rows"]
        if r["label"] == row.label and r["method"] == method
    )
    (fresh,) = numbers.run_optimize(row, method, [0])
    (old,) = [s for s in stored["seeds"] if s["seed"] == 0]
    # The model is deterministic; summation order across thread counts moves the last bits only.
    assert math.isclose(fresh["objective"], old["objective"], rel_tol=1e-9), (
        f"{stored['command']}: seed 0 gives {fresh['objective']!r}, docs say {old['objective']!r} "
        "(rerun `python -m eval numbers`)"
    )
    assert fresh["feasible"] == old["feasible"]
