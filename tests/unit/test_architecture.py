"""The shape of the code base: which package may import what (DESIGN §9, "one idea per module")."""

from __future__ import annotations

import ast
import subprocess
from pathlib import Path

from tests.conftest import ROOT

# Where importing zenoh is part of the job: the transport layer itself, and benches and examples that
# play an independent Zenoh client (tests do too: they prove the wire from the other side).
ZENOH_ALLOWED = ("nodes/core/", "bench/", "examples/", "tests/")


def tracked_python_files() -> list[Path]:
    listed = subprocess.run(["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard", "*.py"],
                            cwd=ROOT, capture_output=True, check=True).stdout.decode().split("\0")
    return [ROOT / name for name in listed if name and (ROOT / name).is_file()]


def imported_modules(tree: ast.AST) -> set[str]:
    """Every module an ``import`` statement names, wherever it stands (module level, functions, TYPE_CHECKING)."""
    found: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            found.add(node.module)
    return found


def test_only_nodes_core_imports_zenoh() -> None:
    offenders = []
    for path in tracked_python_files():
        relative = path.relative_to(ROOT).as_posix()
        if relative.startswith(ZENOH_ALLOWED):
            continue
        modules = imported_modules(ast.parse(path.read_text(), filename=relative))
        if any(m == "zenoh" or m.startswith("zenoh.") for m in modules):
            offenders.append(relative)
    assert not offenders, f"only nodes/core talks to Zenoh; these import zenoh: {offenders}"


def test_the_zenoh_check_sees_a_zenoh_import() -> None:
    assert "zenoh.ext" in imported_modules(ast.parse("def f():\n    import zenoh.ext\n"))
    assert "zenoh" in imported_modules(ast.parse("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
                                                 "    from zenoh import Session\n"))
