"""docs/envs.md's keyword table gives the model options' defaults that ``ModelOptions`` has: every
field of ``tandem_env.ModelOptions`` has a row, and the row's default is the field's."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

from tandem_env import ModelOptions

ENVS_MD = Path(__file__).resolve().parents[1] / "docs" / "envs.md"
#: Keywords that set a ModelOptions field of another name.
FIELD_OF = {"power_convention": "power"}
FIELDS = {f.name for f in dataclasses.fields(ModelOptions)}


def _rows() -> dict[str, str]:
    """{ModelOptions field: its default as the table writes it}."""
    found = {}
    for line in ENVS_MD.read_text(encoding="utf-8").splitlines():
        if not line.startswith("| `"):
            continue
        cells = [c.strip() for c in re.split(r"(?<!\\)\|", line)[1:-1]]
        names = [FIELD_OF.get(n, n) for n in re.findall(r"`(\w+)`", cells[0])]
        # the keyword table's rows of options every env takes (other tables have other columns)
        if len(cells) != 4 or cells[1] not in ("both", "all") or not set(names) & FIELDS:
            continue
        defaults = [d.strip() for d in cells[2].split(",")][-len(names) :]
        found.update(zip(names, defaults, strict=True))
    return found


def test_the_table_gives_model_options_defaults() -> None:
    rows = _rows()
    defaults = ModelOptions()
    assert set(rows) >= FIELDS, f"no row in docs/envs.md for {FIELDS - set(rows)}"
    for name in sorted(FIELDS):
        value, written = getattr(defaults, name), rows[name]
        if isinstance(value, str):
            assert written == f'"{value}"', f"docs/envs.md: {name} default {written}, not {value!r}"
        else:
            assert float(written) == value, f"docs/envs.md: {name} default {written}, not {value}"
