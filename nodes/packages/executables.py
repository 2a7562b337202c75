"""A package's executables: what ``ros2 run PKG EXEC`` and launch_ros' ``Node(package=, executable=)`` start.

A package's own executables are, first match wins: its ``scripts/`` files, the files in ``<prefix>/lib/<pkg>/``
(where colcon installs them), and the ``console_scripts`` of its ``setup.py``/``setup.cfg`` that point at a
module in the package's source (no build step: the module is imported from the source folder). Then the
executables of the packages the zenroid stack serves (``nodes/packages/stack.py``), each one of our nodes or tools;
for those packages ours come first.
"""

from __future__ import annotations

import ast
import configparser
import os
import re
import sys
from dataclasses import dataclass, field
from pathlib import Path

from nodes.packages import stack
from nodes.packages.index import Package, PackageNotFoundError, find_package, index

ENTRY_RUNNER = "nodes.packages.entry"
SERVE = "nodes.packages.serve"  # runs a served executable with its ROS argument spellings mapped to ours
_ENTRY_RE = re.compile(r"^\s*([A-Za-z0-9_.\-]+)\s*=\s*([A-Za-z_][\w.]*)\s*:\s*([A-Za-z_][\w.]*)\s*$")


class ExecutableNotFoundError(LookupError):
    """An executable a package does not have; names what was searched and what the package offers."""


@dataclass(frozen=True)
class Executable:
    package: str
    name: str
    argv: tuple[str, ...]  # the command (no shell); the user's arguments go after it
    module: str | None = None  # ``python -m module`` when it is one of our nodes/tools
    module_args: tuple[str, ...] = field(default_factory=tuple)  # arguments between the module and the user's
    path: Path | None = None  # the file, for a package's own executable
    ros_node: bool = False  # takes our node options (--name, --ns, --param, --params-file, --remap)

    def command(self, args: list[str] | tuple[str, ...] = ()) -> list[str]:
        return [*self.argv, *args]


def _python_command(path: Path) -> tuple[str, ...]:
    """A script run with this Python when it is Python (so ROS code finds zenroid's rclpy), else as a program."""
    try:
        head = path.read_bytes()[:128]
    except OSError:
        head = b""
    first = head.split(b"\n", 1)[0]
    if path.suffix == ".py" or (first.startswith(b"#!") and b"python" in first):
        return (sys.executable, str(path))
    return (str(path),)


def _script_files(folder: Path) -> dict[str, Path]:
    if not folder.is_dir():
        return {}
    return {p.name: p for p in sorted(folder.iterdir())
            if p.is_file() and not p.name.startswith((".", "_")) and (os.access(p, os.X_OK) or p.suffix == ".py")}


class _Strings(ast.NodeVisitor):
    """String constants bound at a setup.py's top level (``package_name = 'x'``), to evaluate its
    entry points without running it."""

    def __init__(self) -> None:
        self.names: dict[str, str] = {}

    def value(self, node: ast.AST) -> object:
        if isinstance(node, ast.Constant):
            return node.value
        if isinstance(node, ast.Name):
            return self.names.get(node.id)
        if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Add):
            left, right = self.value(node.left), self.value(node.right)
            return left + right if isinstance(left, str) and isinstance(right, str) else None
        if isinstance(node, ast.JoinedStr):
            parts = []
            for piece in node.values:
                text = self.value(piece.value if isinstance(piece, ast.FormattedValue) else piece)
                if not isinstance(text, str):
                    return None
                parts.append(text)
            return "".join(parts)
        if isinstance(node, (ast.List, ast.Tuple)):
            return [self.value(item) for item in node.elts]
        if isinstance(node, ast.Dict):
            return {self.value(k): self.value(v) for k, v in zip(node.keys, node.values) if k is not None}
        return None


def console_scripts(folder: Path) -> dict[str, str]:
    """``name -> module:function`` from ``setup.py`` (read, never run) and ``setup.cfg``."""
    found: dict[str, str] = {}
    setup_py = folder / "setup.py"
    if setup_py.is_file():
        try:
            tree = ast.parse(setup_py.read_text(encoding="utf-8"))
        except (OSError, SyntaxError, ValueError):
            tree = None
        strings = _Strings()
        for node in tree.body if tree else []:
            if isinstance(node, ast.Assign) and len(node.targets) == 1 and isinstance(node.targets[0], ast.Name):
                value = strings.value(node.value)
                if isinstance(value, str):
                    strings.names[node.targets[0].id] = value
        for node in ast.walk(tree) if tree else []:
            if isinstance(node, ast.keyword) and node.arg == "entry_points":
                points = strings.value(node.value)
                if isinstance(points, dict):
                    for line in points.get("console_scripts") or []:
                        match = _ENTRY_RE.match(line) if isinstance(line, str) else None
                        if match:
                            found.setdefault(match[1], f"{match[2]}:{match[3]}")
    setup_cfg = folder / "setup.cfg"
    if setup_cfg.is_file():
        parser = configparser.ConfigParser()
        try:
            parser.read(setup_cfg, encoding="utf-8")
            lines = parser.get("options.entry_points", "console_scripts", fallback="").splitlines()
        except configparser.Error:
            lines = []
        for line in lines:
            match = _ENTRY_RE.match(line)
            if match:
                found.setdefault(match[1], f"{match[2]}:{match[3]}")
    return found


def _own(package: Package) -> dict[str, Executable]:
    found: dict[str, Executable] = {}
    folders = [package.share / "scripts", package.prefix / "lib" / package.name]
    if package.share != package.prefix:
        folders.append(package.share / "scripts")
    for folder in folders:
        for name, path in _script_files(folder).items():
            found.setdefault(name, Executable(package.name, name, _python_command(path), path=path))
    source = package.share
    for name, target in console_scripts(source).items():
        module = target.partition(":")[0]
        if (source / Path(*module.split("."))).with_suffix(".py").is_file() or \
                (source / Path(*module.split(".")) / "__init__.py").is_file():
            argv = (sys.executable, "-m", ENTRY_RUNNER, str(source), target)
            found.setdefault(name, Executable(package.name, name, argv, module=ENTRY_RUNNER,
                                              module_args=(str(source), target)))
    return found


def executables(package: str) -> dict[str, Executable]:
    """Every executable of ``package`` by name: its own, then the ones zenroid serves for it."""
    known = index().packages.get(package)
    served = {name: Executable(package, name, (sys.executable, "-m", SERVE, package, name), module=SERVE,
                               module_args=(package, name), ros_node=item.ros_node)
              for name, item in stack.entries(package).items()}
    if known is None and not served:
        find_package(package)  # raises PackageNotFoundError with the paths searched
    own = _own(known) if known is not None else {}
    # a package zenroid serves runs ours even where ROS's is installed too (a sourced ROS 2 on
    # AMENT_PREFIX_PATH): its scripts would start ROS's own stack, which is not there to talk to
    return {**own, **served} if served else own


def find_executable(package: str, name: str) -> Executable:
    """``package``'s executable ``name``; errors name it, where it was looked for and what is served."""
    try:
        found = executables(package)
    except PackageNotFoundError as exc:
        raise PackageNotFoundError(package, [*exc.searched, f"served by zenroid: {', '.join(stack.served())}"]) \
            from None
    if name in found:
        return found[name]
    known = index().packages.get(package)
    where = [] if known is None else [str(known.share / "scripts"), str(known.prefix / "lib" / package),
                                     f"console_scripts of {known.share / 'setup.py'} and setup.cfg"]
    offered = ", ".join(sorted(found)) or "none"
    raise ExecutableNotFoundError(
        f"package '{package}' has no executable '{name}' (looked in {'; '.join(where) or 'what zenroid serves'}; "
        f"it has: {offered})")
