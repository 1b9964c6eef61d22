"""Sphinx configuration of somite's documentation: the user guide (the Markdown pages of docs/,
read by MyST) and the API reference (api.rst, autodoc of the public names of ``import somite``).

Built by ``make docs`` (``sphinx-build -W``: a warning is an error) and by
tests/test_docs_site.py. Links from these pages to files outside docs/ (the README, audits/,
reports/, benchmarks/) are not Sphinx documents: they are turned into links to the files
themselves, relative to the built site's folder, and tests/test_docs_site.py checks that each
one's target exists (and each #heading), as it does for the links between the pages.
"""

from __future__ import annotations

import html
import os
import re
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path.insert(0, str(ROOT / "src"))

project = "somite"
author = "somite's authors"
copyright = "2026, somite's authors"  # noqa: A001 - Sphinx's name
release = version = "0.1.0"

extensions = ["sphinx.ext.autodoc", "sphinx.ext.napoleon", "myst_parser"]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["img/README.md"]
myst_heading_anchors = 4  # "page.md#a-heading" links, as GitHub shows them
html_theme = "alabaster"
html_title = "somite"
html_static_path: list[str] = []
autodoc_member_order = "bysource"
autodoc_typehints = "description"
autodoc_default_options = {"members": True, "undoc-members": False}
suppress_warnings: list[str] = []

OUTSIDE = re.compile(r"\[([^\]]*)\]\(((?:\.\./)+[^)#\s]*)(#[^)\s]*)?\)")
"""A Markdown link that leaves docs/ (``[text](../audits/x.md#a-heading)``)."""


def _outside_links(app, docname, source) -> None:
    """Links that leave docs/ become links to the repository's files from the built page's
    folder: they are no Sphinx documents, which MyST would refuse to link."""
    page = (DOCS / docname).parent
    built = (Path(app.outdir) / docname).parent

    def link(match: re.Match) -> str:
        target = (page / match.group(2)).resolve()
        if target == DOCS or DOCS in target.parents:
            return match.group(0)
        href = html.escape(os.path.relpath(target, built.resolve()) + (match.group(3) or ""))
        text = re.sub(r"`([^`]*)`", r"<code>\1</code>", match.group(1))
        return f'<a href="{href}">{text}</a>'

    source[0] = OUTSIDE.sub(link, source[0])


def setup(app):
    app.connect("source-read", _outside_links)
