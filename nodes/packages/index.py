"""The package index: where each ROS package's share directory is, found as ROS finds packages, no build step.

A folder with a ``package.xml`` is a package and, unbuilt, its own share directory (``launch/``, ``urdf/``,
``config/``, ``msg/`` ...). Packages are looked for, first match wins, in:

1. the current workspace's ``src/`` (``$PWD/src``), searched recursively;
2. ``ROS_PACKAGE_PATH``: each folder searched recursively as rospack does (not into a package, nor into a
   folder holding ``CATKIN_IGNORE``/``COLCON_IGNORE``/``AMENT_IGNORE``);
3. ``AMENT_PREFIX_PATH``: each install prefix's ament resource index
   (``share/ament_index/resource_index/packages/<pkg>`` -> ``share/<pkg>``), and ``share/<pkg>/package.xml``;
4. installed Python distributions that ship an ament index under their prefix (``sys.prefix`` and prefixes
   inside site-packages such as ``cmeel.prefix``, where example-robot-data installs);
5. the packages the zenroid stack serves itself (``nodes/share/packages``, and ``zenroid_description`` for
   ``robots/``).

``ament_index_python``, xacro's ``$(find)``, ``package://`` URIs, ``FindPackageShare`` and ``zenroid pkg`` all
answer from here.
"""

from __future__ import annotations

import os
import re
import site
import sys
import threading
from dataclasses import dataclass
from pathlib import Path
from xml.etree import ElementTree

MARKERS = Path("share") / "ament_index" / "resource_index"
IGNORE_FILES = ("CATKIN_IGNORE", "COLCON_IGNORE", "AMENT_IGNORE")
STACK_DIR = Path(__file__).resolve().parent.parent / "share" / "packages"
ROBOTS_DIR = Path(__file__).resolve().parent.parent / "share" / "robots"
_SCHEME = re.compile(r"^[A-Za-z][A-Za-z0-9+.-]*://")


class PackageNotFoundError(KeyError):
    """A package no source knows; names the package and every place searched (ament_index_python's name)."""

    def __init__(self, package: str, searched: list[str] | None = None) -> None:
        self.package = package
        self.searched = list(searched or [])
        super().__init__(package)

    def __str__(self) -> str:
        where = "\n  ".join(self.searched) or "(nowhere: no package sources are set)"
        return f"package '{self.package}' not found; searched:\n  {where}"


class UriError(ValueError):
    """A ``package://``, ``model://`` or ``file://`` URI that does not resolve to a file inside its root."""


@dataclass(frozen=True)
class Package:
    name: str
    share: Path  # the share directory (a source package's own folder)
    prefix: Path  # the install prefix (a source package's own folder)
    source: str  # which source found it: "workspace", "ROS_PACKAGE_PATH", "AMENT_PREFIX_PATH", "python", "zenroid"


def package_name(folder: Path) -> str | None:
    """The ``<name>`` of ``folder/package.xml`` (the folder's name when the file has none); None when unreadable."""
    try:
        root = ElementTree.parse(folder / "package.xml").getroot()
    except (OSError, ElementTree.ParseError):
        return None
    name = (root.findtext("name") or "").strip()
    return name or folder.name


def _crawl(top: Path) -> list[Path]:
    """Package folders under ``top``: rospack's crawl (no descent into a package, ignore markers, hidden dirs)."""
    found: list[Path] = []
    seen: set[str] = set()
    for dirpath, dirnames, filenames in os.walk(top, followlinks=True):
        real = os.path.realpath(dirpath)
        if real in seen or any(name in filenames for name in IGNORE_FILES):
            dirnames[:] = []
            continue
        seen.add(real)
        if "package.xml" in filenames:
            found.append(Path(dirpath))
            dirnames[:] = []
            continue
        dirnames[:] = sorted(d for d in dirnames if not d.startswith(".") and d != "__pycache__")
    return found


def _env_paths(name: str) -> list[Path]:
    return [Path(p) for p in os.environ.get(name, "").split(os.pathsep) if p]


def python_prefixes() -> list[Path]:
    """Install prefixes of Python distributions holding an ament index: ``sys.prefix``, then prefixes inside
    site-packages (cmeel wheels such as example-robot-data install under ``site-packages/cmeel.prefix``)."""
    prefixes = [Path(sys.prefix)]
    sites = list(site.getsitepackages()) if hasattr(site, "getsitepackages") else []
    user = site.getusersitepackages() if hasattr(site, "getusersitepackages") else None
    for folder in [*sites, *([user] if isinstance(user, str) else [])]:
        try:
            entries = sorted(os.scandir(folder), key=lambda e: e.name)
        except OSError:
            continue
        prefixes += [Path(e.path) for e in entries if e.name.endswith(".prefix") and e.is_dir()]
    return [p for p in dict.fromkeys(prefixes) if (p / MARKERS / "packages").is_dir()]


def _prefix_packages(prefix: Path) -> list[tuple[str, Path]]:
    """(name, share) in an install prefix: its ament index markers, then share/*/package.xml."""
    found: dict[str, Path] = {}
    markers = prefix / MARKERS / "packages"
    if markers.is_dir():
        for marker in sorted(markers.iterdir()):
            if not marker.name.startswith("."):
                found.setdefault(marker.name, prefix / "share" / marker.name)
    share = prefix / "share"
    if share.is_dir():
        for folder in sorted(share.iterdir()):
            if (folder / "package.xml").is_file():
                found.setdefault(folder.name, folder)
    return list(found.items())


class Index:
    """Every package the sources above know, scanned once per environment (``refresh()`` scans again)."""

    def __init__(self, cwd: Path | None = None, environ: dict[str, str] | None = None) -> None:
        self.cwd = cwd
        self.environ = environ
        self.packages: dict[str, Package] = {}
        self.searched: list[str] = []
        self._scan()

    def _env(self, name: str) -> list[Path]:
        raw = (self.environ if self.environ is not None else os.environ).get(name, "")
        # absolute, so that a share directory (and what $(find) gives) means the same from any folder
        return [(self.cwd or Path.cwd()) / p for p in raw.split(os.pathsep) if p]

    def _add(self, name: str | None, share: Path, prefix: Path, source: str) -> None:
        if name and name not in self.packages:
            self.packages[name] = Package(name, share, prefix, source)

    def _scan(self) -> None:
        workspace_src = (self.cwd or Path.cwd()) / "src"
        self.searched.append(f"{workspace_src} (the workspace's src/)")
        if workspace_src.is_dir():
            for folder in _crawl(workspace_src):
                self._add(package_name(folder), folder, folder, "workspace")
        rpp = self._env("ROS_PACKAGE_PATH")
        self.searched += [f"{p} (ROS_PACKAGE_PATH)" for p in rpp] or ["ROS_PACKAGE_PATH (not set)"]
        for top in rpp:
            if top.is_dir():
                for folder in _crawl(top):
                    self._add(package_name(folder), folder, folder, "ROS_PACKAGE_PATH")
        apm = self._env("AMENT_PREFIX_PATH")
        self.searched += [f"{p}/share (AMENT_PREFIX_PATH)" for p in apm] or ["AMENT_PREFIX_PATH (not set)"]
        for prefix in apm:
            for name, share in _prefix_packages(prefix):
                self._add(name, share, prefix, "AMENT_PREFIX_PATH")
        prefixes = python_prefixes()
        self.searched += [f"{p}/share (installed Python distributions)" for p in prefixes]
        for prefix in prefixes:
            for name, share in _prefix_packages(prefix):
                self._add(name, share, prefix, "python")
        self.searched.append(f"{STACK_DIR} (served by zenroid)")
        self._add("zenroid_description", ROBOTS_DIR.resolve(), ROBOTS_DIR.resolve(), "zenroid")
        if STACK_DIR.is_dir():
            for folder in sorted(STACK_DIR.iterdir()):
                if (folder / "package.xml").is_file():
                    self._add(package_name(folder), folder.resolve(), folder.resolve(), "zenroid")

    def get(self, name: str) -> Package:
        package = self.packages.get(name)
        if package is None:
            raise PackageNotFoundError(name, self.searched)
        return package


_lock = threading.Lock()
_cached: tuple[tuple, Index] | None = None


def _key() -> tuple:
    return (os.getcwd(), os.environ.get("ROS_PACKAGE_PATH", ""), os.environ.get("AMENT_PREFIX_PATH", ""))


def index() -> Index:
    """The index for the current directory and environment (scanned again when either changes)."""
    global _cached
    with _lock:
        key = _key()
        if _cached is None or _cached[0] != key:
            _cached = (key, Index())
        return _cached[1]


def refresh() -> None:
    """Forget the scan (a package was added on disk since)."""
    global _cached
    with _lock:
        _cached = None


def add_own_package(file: Path) -> str | None:
    """Make the package ``file`` lies in (its nearest folder with a ``package.xml``) findable by name, for this
    process and the processes it starts, when no source knows that name: the package folder is appended to
    ``ROS_PACKAGE_PATH``. A description repository used where it was downloaded then runs as it is: its xacro's
    ``$(find pkg)`` and its ``package://`` meshes resolve in every node, also from ``robot_description``.
    Returns the line to log, or None when nothing was added."""
    folder = next((f for f in Path(file).resolve().parents if (f / "package.xml").is_file()), None)
    name = package_name(folder) if folder is not None else None
    if folder is None or not name or name in index().packages:
        return None
    os.environ["ROS_PACKAGE_PATH"] = os.pathsep.join(
        [p for p in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep) if p] + [str(folder)])
    return f"package '{name}' of {file} is in no package path: added {folder} to ROS_PACKAGE_PATH"


def find_package(name: str) -> Package:
    """The package called ``name``; PackageNotFoundError names it and every path searched."""
    return index().get(name)


def find_share(name: str) -> Path:
    """The share directory of package ``name`` (a source package's own folder)."""
    return find_package(name).share


def list_packages() -> dict[str, Package]:
    """Every known package by name, sorted."""
    return dict(sorted(index().packages.items()))


def _inside(root: Path, relative: str, uri: str) -> Path:
    """``root/relative``, refused when ``..`` leaves ``root`` (checked on the names: links inside a package,
    such as a ``--symlink-install`` share folder's, may point anywhere)."""
    root = Path(os.path.abspath(root))
    path = Path(os.path.normpath(root / relative.lstrip("/")))
    if path != root and root not in path.parents:
        raise UriError(f"{uri}: the path leaves {root}")
    return path


def model_paths() -> list[Path]:
    """Where ``model://NAME`` looks: the simulator's model path variables and Gazebo's other resource
    variables, then our worlds/ (its models/ folder)."""
    found: list[Path] = []
    for name in ("ZENROID_MODEL_PATH", "GAZEBO_MODEL_PATH", "GZ_SIM_RESOURCE_PATH", "IGN_GAZEBO_RESOURCE_PATH", "SDF_PATH"):
        found += _env_paths(name)
    worlds = ROBOTS_DIR.parent / "worlds"
    return [*found, worlds / "models", worlds]


def resolve_uri(uri: str, base: str | os.PathLike[str] | None = None) -> Path:
    """The file a resource URI names: ``package://pkg/path`` (inside the package's share folder),
    ``model://name/path`` (Gazebo's model path, then a package of that name), ``file://`` paths, and plain
    paths (relative to ``base`` when given). Missing files are not an error here: callers say what they wanted.
    """
    if uri.startswith("package://"):
        rest = uri[len("package://"):]
        package, _, relative = rest.partition("/")
        if not package:
            raise UriError(f"{uri}: no package name")
        try:
            share = find_share(package)
        except PackageNotFoundError as exc:
            raise UriError(f"{uri}: {exc}") from None
        return _inside(share, relative, uri)
    if uri.startswith("model://"):
        rest = uri[len("model://"):]
        model, _, relative = rest.partition("/")
        if not model:
            raise UriError(f"{uri}: no model name")
        roots = [p / model for p in model_paths() if (p / model).is_dir()]
        if not roots and model in index().packages:
            roots = [find_share(model)]
        if not roots:
            searched = ", ".join(str(p) for p in model_paths())
            raise UriError(f"{uri}: model '{model}' not found (searched {searched} and the package index)")
        return _inside(roots[0], relative, uri)
    if uri.startswith("file://"):
        return Path(uri[len("file://"):])
    if _SCHEME.match(uri):
        raise UriError(f"{uri}: unsupported scheme (package://, model:// and file:// are)")
    path = Path(uri).expanduser()
    return path if path.is_absolute() or base is None else Path(base) / path
