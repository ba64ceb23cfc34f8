"""Every ```python block in README.md and docs/*.md runs as written, on its own.

Each block runs in a namespace of its own, as a reader pasting just that block into a fresh
Python session would run it (so every block carries its imports), in a fresh working directory
per document (so a block that writes ``results/...`` writes there, not into the checkout). Two
first-line markers change that:

- ``# excerpt``: a deliberate excerpt of a larger program (a protocol, a fragment of a module);
  it is compiled, so it stays valid Python, but not run;
- ``# needs: MODULE [MODULE ...]``: an optional dependency; the block is skipped, saying so,
  where one of them is not installed.
"""

from __future__ import annotations

import importlib.util
import os
import re
from dataclasses import dataclass
from pathlib import Path

import matplotlib
import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = (ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")))
BLOCK = re.compile(r"^```python[ \t]*\n(.*?)^```", flags=re.MULTILINE | re.DOTALL)
EXCERPT = "# excerpt"
NEEDS = "# needs:"


@dataclass(frozen=True)
class Block:
    path: Path
    line: int  # 1-based line of the block's first code line
    code: str

    @property
    def first_line(self) -> str:
        return self.code.lstrip().splitlines()[0].strip() if self.code.strip() else ""

    @property
    def where(self) -> str:
        return f"{self.path.relative_to(ROOT)}:{self.line}"


def blocks(path: Path) -> list[Block]:
    text = path.read_text(encoding="utf-8")
    return [
        Block(path, text.count("\n", 0, m.start(1)) + 1, m.group(1)) for m in BLOCK.finditer(text)
    ]


def missing_modules(block: Block) -> list[str]:
    if not block.first_line.startswith(NEEDS):
        return []
    names = block.first_line[len(NEEDS) :].replace(",", " ").split()
    return [name for name in names if importlib.util.find_spec(name) is None]


def test_markers_are_known() -> None:
    """A comment on a block's first line that looks like a marker is one of the two markers."""
    for path in DOCS:
        for block in blocks(path):
            first = block.first_line.lower()
            if first.startswith(("# excerpt", "# needs")):
                assert first == EXCERPT or first.startswith(NEEDS), (
                    f"{block.where}: unknown marker {block.first_line!r} "
                    f"(use {EXCERPT!r} or '{NEEDS} MODULE')"
                )


def test_docs_have_python_blocks() -> None:
    """The collection below found the blocks (a changed fence style would silently run none)."""
    assert sum(len(blocks(path)) for path in DOCS) >= 10


@pytest.mark.parametrize(
    "path", [p for p in DOCS if blocks(p)], ids=lambda p: str(p.relative_to(ROOT))
)
def test_python_blocks_run(path: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    found = blocks(path)
    matplotlib.use("Agg")
    monkeypatch.chdir(tmp_path)
    skipped: list[str] = []
    for block in found:
        code = compile(block.code, block.where, "exec")  # an excerpt stays valid Python
        if block.first_line == EXCERPT:
            continue
        missing = missing_modules(block)
        if missing:
            skipped.append(f"{block.where} needs {', '.join(missing)}")
            continue
        try:
            exec(code, {"__name__": "__docs__"})  # on its own: nothing from the blocks before
        except Exception as error:  # name the block; the traceback follows
            raise AssertionError(f"{block.where} fails as written: {error!r}") from error
    assert os.getcwd() == str(tmp_path), "a block changed the working directory"
    runnable = [b for b in found if b.first_line != EXCERPT]
    if skipped and len(skipped) == len(runnable):
        pytest.skip("; ".join(skipped))
