"""The shape of the code base: which package may import what (docs/architecture.md, Processes; "one idea per module")."""

from __future__ import annotations

import ast
import os
import re
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import yaml

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10: pytest's own dependency
    import tomli as tomllib

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


# ------------------------------------------------------------------------------------------ imports
PACKAGES = ("ament_index_python", "launch", "launch_ros", "msgs", "nodes")
# what ROS 2 programs import as written (``import rclpy``): they start the product as entry points do
USER_PACKAGES = ("rclpy", "tf2_ros", "sensor_msgs_py")


def project_modules(packages: tuple[str, ...] = PACKAGES) -> dict[str, Path]:
    """Every module of the installable packages by dotted name (``__main__`` files run programs: left out)."""
    found: dict[str, Path] = {}
    for path in tracked_python_files():
        relative = path.relative_to(ROOT)
        # a ROS launch file shipped as data (nodes/share/packages/*/launch/*.launch.py) is not a module
        if relative.parts[0] not in packages or path.name == "__main__.py" or path.name.endswith(".launch.py"):
            continue
        parts = list(relative.with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        found[".".join(parts)] = path
    return found


def import_graph(modules: dict[str, Path]) -> dict[str, set[str]]:
    """module -> the project modules its import statements name: at module level, inside functions and under
    ``if TYPE_CHECKING:`` alike (a cycle hidden in either is still a cycle in the design). ``from pkg import x``
    counts as an import of ``pkg.x`` when that is a module, else of ``pkg``."""
    def owner(name: str) -> str | None:
        while name and name not in modules:
            name = name.rpartition(".")[0]
        return name or None

    graph: dict[str, set[str]] = {}
    for name, path in modules.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        targets: set[str | None] = set()
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            if isinstance(node, ast.Import):
                targets.update(owner(alias.name) for alias in node.names)
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    anchor = package.split(".")[: len(package.split(".")) - node.level + 1]
                    base = ".".join(anchor + ([node.module] if node.module else []))
                for alias in node.names:
                    full = f"{base}.{alias.name}"
                    targets.add(full if full in modules else owner(base))
        graph[name] = {t for t in targets if t is not None and t != name}
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph.get(child, ())))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


def test_no_import_cycles() -> None:
    found = cycles(import_graph(project_modules()))
    assert not found, f"modules that import each other (directly or around a loop): {found}"


def test_the_cycle_check_sees_a_cycle_hidden_behind_type_checking(tmp_path) -> None:
    (tmp_path / "a.py").write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from pkg import b\n")
    (tmp_path / "b.py").write_text("def f():\n    from pkg.a import thing\n")
    (tmp_path / "c.py").write_text("import pkg.a\n")
    modules = {"pkg.a": tmp_path / "a.py", "pkg.b": tmp_path / "b.py", "pkg.c": tmp_path / "c.py"}
    assert cycles(import_graph(modules)) == [["pkg.a", "pkg.b"]]


# Imports each module given on the command line in a child of its own (fork), so every module starts from an
# interpreter that has loaded no project module: one that only imports because another module happened to
# be imported first fails here. Third-party packages are loaded once up front (they cannot hide an import
# order problem of ours, and loading dartpy or rerun 150 times would take minutes).
_IMPORT_ALONE = r"""
import importlib, os, sys, traceback
modules, third_party = sys.argv[1].split(","), sys.argv[2].split(",")
for name in third_party:
    try:
        importlib.import_module(name)
    except Exception:
        pass
running, failed = {}, []

def reap():
    pid, status = os.wait()
    if status != 0:
        failed.append(running[pid])
    del running[pid]

for name in modules:
    while len(running) >= (os.cpu_count() or 1):
        reap()
    pid = os.fork()
    if pid == 0:
        try:
            importlib.import_module(name)
        except BaseException:
            traceback.print_exc()
            os._exit(1)
        os._exit(0)
    running[pid] = name
while running:
    reap()
print("FAILED:" + ",".join(sorted(failed)))
"""


def third_party_modules(modules: dict[str, Path]) -> set[str]:
    names: set[str] = set()
    for path in modules.values():
        names.update(m.partition(".")[0] for m in imported_modules(ast.parse(path.read_text())))
    return {n for n in names if n not in PACKAGES and n not in sys.stdlib_module_names}


def test_every_module_imports_alone() -> None:
    modules = project_modules()
    result = subprocess.run(
        [sys.executable, "-c", _IMPORT_ALONE, ",".join(sorted(modules)), ",".join(sorted(third_party_modules(modules)))],
        cwd=ROOT, capture_output=True, text=True, timeout=600,
        env={**os.environ, "PYTHONPATH": str(ROOT), "ZENROID_ROS2": "0"})
    failed = result.stdout.strip().rpartition("FAILED:")[2]
    assert result.returncode == 0 and "FAILED:" in result.stdout and not failed, \
        f"modules that fail to import on their own: {failed}\n{result.stderr[-4000:]}"


# ------------------------------------------------------------------------------------------ encapsulation
def private_attributes_from_elsewhere(path: Path) -> list[str]:
    """``obj._name`` where ``obj`` is not ``self``/``cls`` and nothing in this module defines ``_name``, and
    ``from our.module import _name``: reaches into another module's private members. Private names of
    third-party and stdlib modules are not ours."""
    tree = ast.parse(path.read_text())
    defined: set[str] = set()
    foreign_aliases: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            defined.add(node.name)
        elif isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store):
            defined.add(node.attr)
        elif isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
            defined.add(node.id)
        elif isinstance(node, ast.arg):
            defined.add(node.arg)
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            module = getattr(node, "module", None) or ""
            for alias in node.names:
                top = (module or alias.name).partition(".")[0]
                if top not in PACKAGES:
                    foreign_aliases.add(alias.asname or alias.name.partition(".")[0])
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and (node.module or "").partition(".")[0] in PACKAGES:
            found += [f"{path.relative_to(ROOT)}:{node.lineno}: from {node.module} import {alias.name}"
                      for alias in node.names if alias.name.startswith("_") and not alias.name.startswith("__")]
        if not (isinstance(node, ast.Attribute) and node.attr.startswith("_") and not node.attr.startswith("__")):
            continue
        owner = node.value.id if isinstance(node.value, ast.Name) else None
        # ``_type`` is the message classes' public type name (like namedtuple's ``_fields``)
        if owner in ("self", "cls") or owner in foreign_aliases or node.attr in defined or node.attr == "_type":
            continue
        found.append(f"{path.relative_to(ROOT)}:{node.lineno}: {ast.unparse(node)}")
    return found


def test_no_private_member_access_across_modules() -> None:
    offenders = [hit for path in project_modules().values() for hit in private_attributes_from_elsewhere(path)]
    assert not offenders, "private members used outside their module:\n" + "\n".join(offenders)


def test_endpoints_depend_on_the_runtime_interface_not_on_node() -> None:
    graph = import_graph(project_modules())
    for module in ("nodes.core.endpoints", "nodes.core.action", "nodes.core.latched", "nodes.core.factory"):
        assert "nodes.core.node" not in graph[module], f"{module} imports nodes.core.node"


# ------------------------------------------------------------------------------------------ product vs tooling
def _strings(value: object) -> Iterator[str]:
    if isinstance(value, str):
        yield value
    elif isinstance(value, dict):
        for item in value.values():
            yield from _strings(item)
    elif isinstance(value, list):
        for item in value:
            yield from _strings(item)


def _named_modules(texts: Iterator[str] | set[str], modules: dict[str, Path]) -> set[str]:
    """The modules these strings name; ``nodes.commanders.$(var commander)`` (a launch file's ``module:``)
    names every module of that package, as the launch argument may pick any."""
    found: set[str] = set()
    for text in texts:
        if "$(" in text:
            pattern = re.compile(re.sub(r"\\\$\\\(.*?\\\)", "[A-Za-z0-9_]+", re.escape(text)))
            found.update(name for name in modules if pattern.fullmatch(name))
        elif text in modules:
            found.add(text)
    return found


def entry_points(modules: dict[str, Path], root: Path = ROOT) -> set[str]:
    """The modules something other than product code starts: a package with a ``__main__.py`` (``python -m
    pkg``), the ``[project.scripts]`` and ``[project.entry-points]`` of pyproject.toml, and the ``module:`` of
    the launch files."""
    found = {name for name, path in modules.items() if path.name == "__init__.py"
             and (path.parent / "__main__.py").is_file()}
    project = tomllib.loads((root / "pyproject.toml").read_text())["project"]
    targets = list(project.get("scripts", {}).values())
    targets += [t for group in project.get("entry-points", {}).values() for t in group.values()]
    found.update(t.partition(":")[0].strip() for t in targets)
    for path in sorted((root / "launch").glob("*.yaml")):
        found |= _named_modules(set(_strings(yaml.safe_load(path.read_text()))), modules)
    return found


def unreached_modules(modules: dict[str, Path], root: Path = ROOT) -> list[str]:
    """Product modules that no entry point (or package ROS 2 programs import) reaches through product code:
    code only tests or benches use (it belongs in tests/support or bench), or nothing at all. Product code reaches a module by importing it
    (importing ``a.b`` runs ``a`` first) or by naming it in a string (``"-m", "launch.reaper"``, a CLI verb's
    module for ``importlib``)."""
    mains = {f"{name}.__main__": path.parent / "__main__.py" for name, path in modules.items()
             if path.name == "__init__.py" and (path.parent / "__main__.py").is_file()}
    users = project_modules(USER_PACKAGES)
    everything = {**modules, **mains, **users}
    graph = import_graph(everything)
    for name, path in everything.items():
        graph[name] |= _named_modules({node.value for node in ast.walk(ast.parse(path.read_text()))
                                       if isinstance(node, ast.Constant) and isinstance(node.value, str)}, modules)
    reached: set[str] = set()
    todo = [*entry_points(modules, root), *mains, *users]
    while todo:
        name = todo.pop()
        if name in reached:
            continue
        reached.add(name)
        parent = name.rpartition(".")[0]
        todo += [*graph.get(name, ()), *([parent] if parent in modules else [])]
    return sorted(set(modules) - reached)


def test_every_product_module_is_used_by_the_product() -> None:
    unreached = unreached_modules(project_modules())
    assert not unreached, ("modules under nodes/, msgs/ or launch/ that no entry point (python -m, pyproject "
                           "scripts and entry points, launch files) reaches through product imports; code "
                           f"only tests or benches use belongs in tests/support or bench: {unreached}")


def test_the_product_check_sees_a_module_only_tests_use(tmp_path: Path) -> None:
    files = {"pkg/__init__.py": "", "pkg/__main__.py": "from pkg import app\n",
             "pkg/app.py": "import subprocess\nsubprocess.run(['python', '-m', 'pkg.helper'])\n",
             "pkg/helper.py": "from pkg.util import x\n", "pkg/util.py": "x = 1\n",
             "pkg/plugins/__init__.py": "", "pkg/plugins/wave.py": "", "pkg/cli.py": "",
             "pkg/probe.py": "import pkg.tooling\n", "pkg/tooling.py": "'pkg.feeder'\n", "pkg/feeder.py": "",
             "launch/demo.yaml": "launch:\n  - node: {module: pkg.plugins.$(var name)}\n",
             "pyproject.toml": '[project]\nname = "x"\n[project.scripts]\nx = "pkg.cli:main"\n'}
    for name, text in files.items():
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text(text)
    modules = {name: tmp_path / path for name, path in (
        ("pkg", "pkg/__init__.py"), ("pkg.app", "pkg/app.py"), ("pkg.helper", "pkg/helper.py"),
        ("pkg.util", "pkg/util.py"), ("pkg.plugins", "pkg/plugins/__init__.py"),
        ("pkg.plugins.wave", "pkg/plugins/wave.py"), ("pkg.cli", "pkg/cli.py"), ("pkg.probe", "pkg/probe.py"),
        ("pkg.tooling", "pkg/tooling.py"), ("pkg.feeder", "pkg/feeder.py"))}
    # probe and tooling name each other and feeder, but nothing the product starts reaches them
    assert unreached_modules(modules, tmp_path) == ["pkg.feeder", "pkg.probe", "pkg.tooling"]
