"""The docs build as a site with mkdocs, strictly: a broken link or anchor (README's included) fails the build.

Anchors must also work on GitHub, whose heading slugs differ from mkdocs' for punctuation, so a heading that is
a link target keeps to letters, digits, spaces and hyphens (docs/contributing.md, "The docs site").
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import yaml

from tests.conftest import ROOT

_LINK = re.compile(r"\]\(([^)\s]*?)(?:#([^)\s]+))?\)")
_HEADING = re.compile(r"^#{1,6}\s+(.*?)\s*$")


def _strict_build(config: Path, site: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--config-file", str(config),
                           "--site-dir", str(site)], capture_output=True, text=True, timeout=240)


def test_the_docs_build_strictly(tmp_path: Path) -> None:
    built = _strict_build(ROOT / "mkdocs.yml", tmp_path / "site")
    assert built.returncode == 0, built.stdout[-3000:] + built.stderr[-3000:]
    assert (tmp_path / "site" / "index.html").is_file(), "the README is the home page"
    home = (tmp_path / "site" / "index.html").read_text()
    assert 'href="simulator/"' in home, "the README's docs/ links point at the pages"
    for page in (ROOT / "docs").glob("*.md"):
        assert (tmp_path / "site" / page.stem / "index.html").is_file(), f"{page.name} is not in the site"


def test_a_broken_link_fails_the_strict_build(tmp_path: Path) -> None:
    """The build is worth something only if it can fail: the same site with one bad link and one bad anchor."""
    docs = tmp_path / "docs"
    docs.mkdir()
    for page in (ROOT / "docs").iterdir():
        (docs / page.name).symlink_to(page)
    (docs / "broken.md").write_text("# Broken\n\n[gone](nowhere.md) and [no anchor](simulator.md#no-such-heading)\n")
    config = yaml.safe_load((ROOT / "mkdocs.yml").read_text())
    config["docs_dir"] = str(docs)
    config["hooks"] = [str(ROOT / "docs" / "hooks.py")]
    config["nav"].append({"Broken": "broken.md"})
    (tmp_path / "mkdocs.yml").write_text(yaml.safe_dump(config))
    built = _strict_build(tmp_path / "mkdocs.yml", tmp_path / "site")
    assert built.returncode != 0
    assert "nowhere.md" in built.stderr and "no-such-heading" in built.stderr


def _slug_mkdocs(text: str) -> str:
    text = re.sub(r"[^\w\s-]", "", text).strip().lower()
    return re.sub(r"[-\s]+", "-", text)


def _slug_github(text: str) -> str:
    return re.sub(r"[^\w\- ]", "", text.lower()).replace(" ", "-")


def test_anchors_are_the_same_on_github_and_in_the_site() -> None:
    pages = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
    headings: dict[Path, list[str]] = {}
    for page in pages:
        in_code = False
        for line in page.read_text().splitlines():
            if line.startswith("```"):
                in_code = not in_code
            elif not in_code and (match := _HEADING.match(line)):
                headings.setdefault(page.resolve(), []).append(re.sub(r"`", "", match.group(1)))
    problems = []
    for page in pages:
        for target, anchor in _LINK.findall(page.read_text()):
            if not anchor or "://" in target:
                continue
            resolved = (page.parent / target).resolve() if target else page.resolve()
            matching = [h for h in headings.get(resolved, []) if _slug_mkdocs(h) == anchor]
            if not matching:
                problems.append(f"{page.name}: #{anchor} is no heading of {target or page.name}")
            elif _slug_github(matching[0]) != anchor:
                problems.append(f"{page.name}: #{anchor} is #{_slug_github(matching[0])} on GitHub")
    assert not problems, "\n".join(problems)
