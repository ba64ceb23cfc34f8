"""The README's Quick start runs (and so does the snippet proposed for it in docs/envs.md)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
HEADING = "## Quick start"


def quick_start(path: Path) -> str:
    """The first ```python block under the "## Quick start" heading of a Markdown file."""
    text = path.read_text(encoding="utf-8")
    lines = text.splitlines()
    try:
        start = next(i for i, line in enumerate(lines) if line.strip().lower() == HEADING.lower())
    except StopIteration:
        pytest.fail(
            f"{path.name} has no {HEADING!r} heading (docs/envs.md has the snippet to copy)"
        )
    section = "\n".join(lines[start + 1 :])
    match = re.search(r"^```python[ \t]*\n(.*?)^```", section, flags=re.MULTILINE | re.DOTALL)
    if match is None:
        pytest.fail(f"no ```python block under {HEADING!r} in {path.name}")
    return match.group(1)


def run(path: Path) -> None:
    code = quick_start(path)
    exec(compile(code, f"{path.name}:{HEADING}", "exec"), {"__name__": "__quick_start__"})


def test_readme_quick_start_runs() -> None:
    readme = ROOT / "README.md"
    if not readme.exists():
        pytest.skip(
            "README.md does not exist yet (it is being written); docs/envs.md is checked below"
        )
    run(readme)


def test_docs_envs_quick_start_runs() -> None:
    run(ROOT / "docs" / "envs.md")
