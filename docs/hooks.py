"""mkdocs hook: the repository's README.md is the site's home page (index.md) and CHANGELOG.md a page beside it.

The docs tests' markers after a fence's language (```` ```bash notest ````, ```` ```bash job=FILE ````) are
taken off before a page is rendered: Python-Markdown's fenced_code reads nothing after the language, so it
took such an opening line for text and the bare closing fence for an opening one, and everything to the next
fence rendered as code (headings and their anchors included).

The README links into the docs as ``docs/PAGE.md`` (what GitHub resolves from the repository root); in the
site the pages sit beside the home page, so that prefix is dropped. Every other link is left as written, so
a README link that works in neither place still fails the strict build.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from mkdocs.structure.files import File, Files

_ROOT = Path(__file__).resolve().parent.parent
_DOCS_PREFIX = re.compile(r"\]\(docs/")
_FENCE_MARKERS = re.compile(r"^(```+[A-Za-z0-9_+-]+)[ \t]+[^`{\n]*$", re.MULTILINE)


def on_files(files: Files, config: Any) -> Files:
    readme = (_ROOT / "README.md").read_text(encoding="utf-8")
    files.append(File.generated(config, "index.md", content=_DOCS_PREFIX.sub("](", readme)))
    files.append(File.generated(config, "CHANGELOG.md", content=(_ROOT / "CHANGELOG.md").read_text(encoding="utf-8")))
    return files


def on_page_markdown(markdown: str, page: Any, config: Any, files: Files) -> str:
    return _FENCE_MARKERS.sub(r"\1", markdown)
