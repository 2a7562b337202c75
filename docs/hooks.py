"""mkdocs hook: the repository's README.md is the site's home page (index.md) and CHANGELOG.md a page beside it.

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


def on_files(files: Files, config: Any) -> Files:
    readme = (_ROOT / "README.md").read_text(encoding="utf-8")
    files.append(File.generated(config, "index.md", content=_DOCS_PREFIX.sub("](", readme)))
    files.append(File.generated(config, "CHANGELOG.md", content=(_ROOT / "CHANGELOG.md").read_text(encoding="utf-8")))
    return files
