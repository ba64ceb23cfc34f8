"""The README's Quick start runs (and so does the snippet proposed for it in docs/envs.md)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
HEADING = "## Quick start"


def quick_start(path: Path) -> str:
    """Every ```python block of the "## Quick start" section of a Markdown file, in order."""
    text = path.read_text(encoding="utf-8")
    lines = text.splitlines()
    try:
        start = next(i for i, line in enumerate(lines) if line.strip().lower() == HEADING.lower())
    except StopIteration:
        pytest.fail(
            f"{path.name} has no {HEADING!r} heading (docs/envs.md has the snippet to copy)"
        )
    section = "\n".join(lines[start + 1 :])
    section = re.split(r"^## ", section, flags=re.MULTILINE)[0]
    blocks = re.findall(r"^```python[ \t]*\n(.*?)^```", section, flags=re.MULTILINE | re.DOTALL)
    if not blocks:
        pytest.fail(f"no ```python block under {HEADING!r} in {path.name}")
    return "\n".join(blocks)


def run(path: Path) -> None:
    code = quick_start(path)
    exec(compile(code, f"{path.name}:{HEADING}", "exec"), {"__name__": "__quick_start__"})


def test_readme_quick_start_runs() -> None:
    run(ROOT / "README.md")


def test_docs_envs_quick_start_runs() -> None:
    run(ROOT / "docs" / "envs.md")
