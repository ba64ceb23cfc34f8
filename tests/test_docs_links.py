"""The repository explains itself: every document it refers to is in it.

- Every relative Markdown link in README.md and docs/*.md resolves to a file in the repository,
  and a link to a heading (``file.md#anchor``) to a heading of that file.
- The model's statement is docs/model.md: nothing cites another model document, and every
  "docs/model.md §N" citation (in code, tests, docs) names a section that exists there.
- Upper-case document names (README.md, CONTRIBUTING.md, ...) and docs/*.md paths mentioned
  anywhere name files that exist.
- docs/model.md's copy of Table 4 is the code's (``stroke.table_4_markdown``).
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterator
from functools import cache
from pathlib import Path

import pytest

from tandem_env.physics.stroke import table_4_markdown

ROOT = Path(__file__).resolve().parents[1]
MODEL_DOC = ROOT / "docs" / "model.md"
MARKDOWN = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
#: Folders that hold no sources: generated output, environments, caches.
SKIP_DIRS = {".git", ".venv", "venv", "results", "logs", "runs", "build", "dist", "__pycache__"}
TEXT_SUFFIXES = {".py", ".md", ".toml", ".yml", ".yaml", ".txt", ".cfg", ".ini"}

LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")
SECTION_HEADING = re.compile(r"^#{2,4} §(\d+(?:\.\d+)?) ", re.MULTILINE)
SECTION = r"(\d+(?:\.\d+)?)"
MODEL_CITATION = re.compile(rf"docs/model\.md,? §{SECTION}(?:\s*[-–]\s*§?{SECTION})?")
ANY_MODEL_DOC = re.compile(r"[\w./-]*model\.md", re.IGNORECASE)
UPPER_DOC = re.compile(r"(?<![\w/.-])((?:[\w.-]+/)*[A-Z][A-Z_]+\.md)\b")
DOCS_PATH = re.compile(r"(?<![\w/.-])docs/[\w.-]+\.md\b")


def source_files() -> list[Path]:
    out = []
    for path in ROOT.rglob("*"):
        rel = path.relative_to(ROOT)
        if any(part in SKIP_DIRS or part.endswith(".egg-info") for part in rel.parts):
            continue
        if path.is_file() and path.suffix in TEXT_SUFFIXES and path != Path(__file__).resolve():
            out.append(path)
    return sorted(out)


def scan(check: Callable[[str, Path], Iterator[str]]) -> list[str]:
    """``file:line: problem`` for every problem ``check(line, path)`` finds in the sources."""
    found = []
    for path in source_files():
        for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            found += [f"{path.relative_to(ROOT)}:{n}: {p}" for p in check(line, path)]
    return found


def github_anchor(heading: str) -> str:
    """The anchor GitHub gives a heading: lower case, punctuation dropped, spaces to hyphens."""
    text = re.sub(r"[`*_]", "", heading.strip().lower())
    text = "".join(ch for ch in text if ch.isalnum() or ch in " -")
    return text.replace(" ", "-")


def anchors(path: Path) -> set[str]:
    seen: dict[str, int] = {}
    out = set()
    in_code = False
    for line in path.read_text(encoding="utf-8").splitlines():
        if line.startswith("```"):
            in_code = not in_code
        if in_code or not line.startswith("#"):
            continue
        base = github_anchor(line.lstrip("#"))
        count = seen.get(base, 0)
        out.add(base if count == 0 else f"{base}-{count}")
        seen[base] = count + 1
    return out


@cache
def model_sections() -> frozenset[str]:
    return frozenset(SECTION_HEADING.findall(MODEL_DOC.read_text(encoding="utf-8")))


def foreign_model_documents(line: str, path: Path) -> Iterator[str]:
    """Mentions of a model document other than docs/model.md (a bare ``model.md`` is allowed
    in Markdown: a link relative to docs/, or the README's listing of docs/)."""
    for token in ANY_MODEL_DOC.findall(line):
        if token.endswith("docs/model.md") or (path.suffix == ".md" and token == "model.md"):
            continue
        yield token


def missing_sections(line: str, path: Path) -> Iterator[str]:
    sections = model_sections()
    for first, last in MODEL_CITATION.findall(line):
        yield from (f"§{n}" for n in (first, last) if n and n not in sections)


def missing_documents(line: str, path: Path) -> Iterator[str]:
    for name in UPPER_DOC.findall(line) + DOCS_PATH.findall(line):
        if not (ROOT / name).is_file():
            yield name


def test_the_checks_catch_what_they_should() -> None:
    code = ROOT / "tandem_env" / "physics" / "blade.py"
    doc = ROOT / "docs" / "envs.md"
    # built from parts so that a grep of the repository for them finds nothing here
    spec, foreign = "MODEL" + ".md", "ARCHITECTURE" + ".md"
    assert list(foreign_model_documents(f"as {spec} §4 decides", code)) == [spec]
    assert list(foreign_model_documents(f"see shared/spec/{spec}", doc)) == [f"shared/spec/{spec}"]
    assert list(foreign_model_documents("see model.md §4", code)) == ["model.md"]
    assert not list(foreign_model_documents("as docs/model.md §4 decides", code))
    assert not list(foreign_model_documents("[§4](model.md#4-frames)", doc))
    assert list(missing_sections("docs/model.md §99 and docs/model.md §1-§98", code)) == [
        "§99",
        "§98",
    ]
    assert not list(missing_sections("docs/model.md §4, docs/model.md §1-§2", code))
    assert list(missing_documents(f"see {foreign} and docs/nowhere.md", code)) == [
        foreign,
        "docs/nowhere.md",
    ]
    assert not list(missing_documents("see README.md and docs/model.md", code))
    assert github_anchor("§10 Equations → code") == "10-equations--code"
    assert github_anchor("§5 Inflow: the fore-wing's slip") == "5-inflow-the-fore-wings-slip"


@pytest.mark.parametrize("doc", MARKDOWN, ids=lambda p: str(p.relative_to(ROOT)))
def test_relative_links_resolve(doc: Path) -> None:
    text = re.sub(r"```.*?```", "", doc.read_text(encoding="utf-8"), flags=re.DOTALL)
    broken = []
    for target in LINK.findall(text):
        if re.match(r"^[a-z][a-z0-9+.-]*:", target):  # http:, https:, mailto:
            continue
        path_part, _, anchor = target.partition("#")
        resolved = (doc.parent / path_part).resolve() if path_part else doc
        if not resolved.is_relative_to(ROOT) or not resolved.exists():
            broken.append(f"{target} (no such file)")
        elif anchor and resolved.suffix == ".md" and anchor not in anchors(resolved):
            broken.append(f"{target} (no heading with anchor #{anchor})")
    assert not broken, f"{doc.relative_to(ROOT)} has broken links: {broken}"


def test_model_statement_is_docs_model_md() -> None:
    bad = scan(foreign_model_documents)
    assert not bad, "cite the model as docs/model.md §N:\n" + "\n".join(bad)


def test_model_citations_name_existing_sections() -> None:
    assert {str(n) for n in range(1, 13)} <= model_sections()
    bad = scan(missing_sections)
    assert not bad, "docs/model.md has no such section:\n" + "\n".join(bad)


def test_model_internal_references_resolve() -> None:
    text = MODEL_DOC.read_text(encoding="utf-8")
    sections = model_sections()
    missing = sorted({m for m in re.findall(r"§(\d+(?:\.\d+)?)", text) if m not in sections})
    assert not missing, f"docs/model.md refers to its own missing sections: {missing}"


def test_named_documents_exist() -> None:
    bad = scan(missing_documents)
    assert not bad, "references to documents not in the repository:\n" + "\n".join(bad)


def test_table_4_in_docs_is_the_codes() -> None:
    assert table_4_markdown() in MODEL_DOC.read_text(encoding="utf-8")
