"""The house rules above the physics that the source shows (docs/architecture.md): no module of
tandem_env/envs, agents, train or eval over 600 lines; Dask's ``submit`` and ``as_completed``
only inside agents (the one engine for scheduled work); and the formatter's layout everywhere
in the house (no ``# fmt: skip`` or ``# fmt: off``), so that its line count is the formatted
code's."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: The floors above the physics, the folders whose lines the house counts.
HOUSE = ("tandem_env/envs", "tandem_env/io", "agents", "train", "eval", "benchmarks")
#: Folders whose modules stay at most :data:`MAX_LINES` long.
SIZED = ("tandem_env/envs", "agents", "train", "eval")
MAX_LINES = 600


def modules(folders: tuple[str, ...]) -> list[Path]:
    return sorted(p for folder in folders for p in (ROOT / folder).rglob("*.py"))


@pytest.mark.parametrize("path", modules(SIZED), ids=lambda p: str(p.relative_to(ROOT)))
def test_no_module_is_over_600_lines(path: Path) -> None:
    lines = len(path.read_text(encoding="utf-8").splitlines())
    assert lines <= MAX_LINES, f"{path.relative_to(ROOT)} has {lines} lines (at most {MAX_LINES})"


def test_dask_scheduling_lives_in_agents() -> None:
    pattern = re.compile(r"\.submit\(|\bas_completed\b")
    outside = [
        f"{path.relative_to(ROOT)}:{number}"
        for path in modules(("tandem_env", "train", "eval", "benchmarks"))
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
        if pattern.search(line)
    ]
    assert not outside, f"Dask submit/as_completed outside agents: {outside}"


def test_the_house_keeps_the_formatters_layout() -> None:
    pattern = re.compile(r"#\s*fmt:\s*(skip|off)")
    packed = [
        f"{path.relative_to(ROOT)}:{number}"
        for path in modules(HOUSE)
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
        if pattern.search(line)
    ]
    assert not packed, f"lines kept out of the formatter's layout: {packed}"
