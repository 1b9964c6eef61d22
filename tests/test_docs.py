"""The documents the code cites are in the repository, under the names and headings cited.

somite's docstrings, comments and help strings cite ``docs/decisions.md`` (by heading) and
``docs/original-system.md`` (by section number). These tests read the sources as text, so a
citation of a file, heading or section that does not exist fails here, and so does a bare
``decisions.md``, ``original-system.md`` or ``STYLE.md``: documents that live outside the
repository, which a reader of it cannot open.
"""

from __future__ import annotations

import ast
import io
import re
import tokenize
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SOURCE = ROOT / "src" / "somite"
DOCS = ROOT / "docs"
SOURCES = sorted(SOURCE.rglob("*.py"))
TOP_DOCUMENTS = [ROOT / "README.md", ROOT / "BENCHMARKS.md"]

DOCS_PATH = re.compile(r"docs/[\w./-]+\.md")
MARKDOWN_NAME = re.compile(r"[\w./-]*\w\.md\b")
OUTSIDE_NAME = re.compile(r"[\w./-]*\b(?:decisions|original-system|STYLE)\.md\b")
ALLOWED_FORMS = {"docs/decisions.md", "docs/original-system.md"}
OUTPUT_FILES = {"index.md"}
"""Markdown files somite writes (a report's ``index.md``), named in docstrings as outputs."""

HEADING_CITATION = re.compile(r'docs/decisions\.md,\s+"([^"]+)"')
BARE_HEADING_CITATION = re.compile(r"docs/decisions\.md,\s+([A-Z][\w' -]*\w)")
SECTION_CITATION = re.compile(
    r"docs/original-system\.md,?\s+sections?\s+(\d[\d.]*(?:(?:\s*,\s*|\s+and\s+)\d[\d.]*)*)")


def _text(path: Path) -> str:
    return path.read_text(encoding="utf-8")


def _flat(text: str) -> str:
    """``text`` with line breaks, indentation and comment markers turned into single spaces,
    so that a citation wrapped over two lines reads as one."""
    return re.sub(r"\s*\n\s*(?:#\s*)?", " ", text)


def _prose(path: Path) -> list[str]:
    """The docstrings (string statements, attribute docstrings included) and comments of a
    source file."""
    source = _text(path)
    pieces = [node.value.value for node in ast.walk(ast.parse(source))
              if isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant)
              and isinstance(node.value.value, str)]
    for token in tokenize.generate_tokens(io.StringIO(source).readline):
        if token.type == tokenize.COMMENT:
            pieces.append(token.string)
    return pieces


def _headings(path: Path) -> list[str]:
    return [m.group(1).strip() for m in re.finditer(r"^#{1,6}\s+(.+)$", _text(path), re.M)]


def _section_numbers(path: Path) -> set[str]:
    numbers = set()
    for heading in _headings(path):
        match = re.match(r"(\d+(?:\.\d+)*)\.?\s", heading)
        if match:
            numbers.add(match.group(1))
    return numbers


def _where(path: Path) -> str:
    return str(path.relative_to(ROOT))


def test_the_cited_documents_exist():
    for name in ALLOWED_FORMS:
        assert (ROOT / name).is_file(), name
    assert "Presets" in _headings(DOCS / "decisions.md")


@pytest.mark.parametrize("path", SOURCES + TOP_DOCUMENTS, ids=_where)
def test_every_docs_path_exists(path):
    missing = sorted({m for m in DOCS_PATH.findall(_text(path)) if not (ROOT / m).is_file()})
    assert not missing, f"{_where(path)} names {missing}, which the repository lacks"


@pytest.mark.parametrize("path", SOURCES, ids=_where)
def test_every_markdown_file_cited_in_docstrings_and_comments_exists(path):
    cited = {m for piece in _prose(path) for m in MARKDOWN_NAME.findall(piece)}
    missing = sorted(m for m in cited - OUTPUT_FILES if not (ROOT / m).is_file())
    assert not missing, f"{_where(path)} cites {missing}, which the repository lacks"


@pytest.mark.parametrize("path", SOURCES + TOP_DOCUMENTS, ids=_where)
def test_no_citation_of_a_document_outside_the_repository(path):
    bare = sorted({m for m in OUTSIDE_NAME.findall(_text(path)) if m not in ALLOWED_FORMS})
    assert not bare, (f"{_where(path)} cites {bare}: say docs/decisions.md or "
                      "docs/original-system.md (STYLE.md is not in the repository)")


@pytest.mark.parametrize("path", SOURCES, ids=_where)
def test_cited_headings_and_sections_exist(path):
    text = _flat(_text(path))
    headings = set(_headings(DOCS / "decisions.md"))
    cited = set(HEADING_CITATION.findall(text)) | set(BARE_HEADING_CITATION.findall(text))
    wrong = sorted(h for h in cited if h not in headings)
    assert not wrong, f"{_where(path)} cites headings of docs/decisions.md that it lacks: {wrong}"
    sections = _section_numbers(DOCS / "original-system.md")
    numbers = {n.rstrip(".") for group in SECTION_CITATION.findall(text)
               for n in re.split(r"\s*,\s*|\s+and\s+", group)}
    wrong = sorted(n for n in numbers if n not in sections)
    assert not wrong, f"{_where(path)} cites sections of docs/original-system.md it lacks: {wrong}"


def test_the_checks_see_the_citations():
    """The patterns find what they are for (else the tests above would pass on nothing)."""
    text = _flat('(docs/decisions.md, "Cut\n    ratios"); docs/original-system.md sections 4.3, 5.3'
                 " and 6.2; (docs/decisions.md, Presets)")
    assert HEADING_CITATION.findall(text) == ["Cut ratios"]
    assert BARE_HEADING_CITATION.findall(text) == ["Presets"]
    assert SECTION_CITATION.findall(text) == ["4.3, 5.3 and 6.2"]
    assert OUTSIDE_NAME.findall("see decisions.md and docs/original-system.md, STYLE.md") == [
        "decisions.md", "docs/original-system.md", "STYLE.md"]
    assert sum(len(HEADING_CITATION.findall(_flat(_text(p)))) for p in SOURCES) > 5
    assert sum(len(SECTION_CITATION.findall(_flat(_text(p)))) for p in SOURCES) > 20
