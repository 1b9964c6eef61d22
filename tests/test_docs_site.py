"""The documentation site builds without a warning (``make docs``: Sphinx, MyST and autodoc),
its API reference names every public name, and every relative link of the Markdown pages
(README, BENCHMARKS, docs/) leads to a file that exists, and to a heading there."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

import somite

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
PAGES = [ROOT / "README.md", ROOT / "BENCHMARKS.md", *sorted(DOCS.glob("*.md"))]
LINK = re.compile(r"(?<!!)\[[^\]]*\]\(([^)\s]+)\)|!\[[^\]]*\]\(([^)\s]+)\)")
FENCE = re.compile(r"^```.*?^```", re.S | re.M)


def test_the_site_builds_with_warnings_as_errors(tmp_path):
    pytest.importorskip("sphinx", reason="the docs extra (make test installs it)")
    pytest.importorskip("myst_parser", reason="the docs extra (make test installs it)")
    result = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q",
                             "-b", "html", str(DOCS), str(tmp_path / "html")],
                            capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr[-4000:]
    api = (tmp_path / "html" / "api.html").read_text()
    for name in ("somite.simulate", "somite.Table", "somite.Episode", "somite.GraphEA"):
        assert f'id="{name}"' in api, name
    # a link that leaves docs/ points at the repository's file from the built page
    page = tmp_path / "html" / "results.html"
    hrefs = re.findall(r'href="([^"#]*validation-gap\.md)"', page.read_text())
    assert hrefs and all((page.parent / h).resolve() == ROOT / "audits" / "validation-gap.md"
                         for h in hrefs), hrefs


def test_the_api_reference_names_every_public_name():
    listed = set(re.findall(r"^\.\. auto\w+:: somite\.(\w+)\s*$",
                            (DOCS / "api.rst").read_text(), re.M))
    assert listed >= set(somite.__all__), sorted(set(somite.__all__) - listed)


def _slug(heading: str) -> str:
    """A heading's anchor as GitHub (and MyST's heading anchors) make it."""
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", heading.strip()).lower()
    return re.sub(r"[^\w\- ]", "", text).replace(" ", "-")


def _anchors(path: Path) -> set[str]:
    text = FENCE.sub("", path.read_text(encoding="utf-8"))
    return {_slug(m.group(1)) for m in re.finditer(r"^#{1,6}\s+(.+)$", text, re.M)}


def _links(path: Path) -> list[str]:
    text = FENCE.sub("", path.read_text(encoding="utf-8"))
    text = re.sub(r"`[^`\n]*`", "", text)  # code spans show links, they are none
    return [a or b for a, b in LINK.findall(text)]


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_relative_link_leads_to_a_file_and_heading(page):
    broken = []
    for link in _links(page):
        if re.match(r"[a-z][a-z0-9+.-]*:", link):  # http:, https:, mailto:
            continue
        target, _, anchor = link.partition("#")
        path = (page.parent / target).resolve() if target else page
        if not path.exists():
            broken.append(link)
        elif anchor and path.suffix == ".md" and anchor not in _anchors(path):
            broken.append(link)
    assert not broken, broken
