"""Where a URDF's file references point: ``package://pkg/...``, ``model://pkg/...``, ``file://...``, absolute and
relative paths, resolved to a file on this host, or refused with the reason and the places searched.

The one resolver of the project for robot files: the simulator, the state publisher, the viewer and the renderer
all come through here, so a path is judged the same everywhere. A reference may come from a spawn request
(untrusted): it must end inside a package's root (``..`` may not climb out of it) and be a regular file, never
``/etc/passwd`` or ``/dev/zero``.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Iterable
from pathlib import Path
from urllib.parse import unquote, urlparse

from nodes.urdf.model import UrdfError

SCHEMES = ("package", "model", "file")


class PathError(UrdfError):
    """A file reference that resolves nowhere or escapes its package; the message says which and why."""


def _prefixes() -> list[Path]:
    """Install prefixes whose ``share/ament_index`` lists packages: ``AMENT_PREFIX_PATH``, this Python's prefix
    and the ``cmeel.prefix`` that pip wheels of ROS-world packages (example-robot-data) install into."""
    found: list[Path] = []
    for entry in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep):
        if entry:
            found.append(Path(entry))
    import sysconfig

    for base in (Path(sys.prefix), Path(sysconfig.get_paths()["purelib"])):
        found += [base, base / "cmeel.prefix"]
    return list(dict.fromkeys(found))


def _index_share(package: str, searched: list[str]) -> Path | None:
    """The package's share directory from the project's package index (``nodes.packages``) when it is there,
    else from the ament index of the install prefixes."""
    try:
        from nodes.packages import find_share  # the package index (launch files, ros2 commands)
    except ImportError:
        find_share = None
    if find_share is not None:
        try:
            return Path(find_share(package))
        except Exception as exc:  # noqa: BLE001 - its message names what it searched
            searched.append(str(exc))
    for prefix in _prefixes():
        marker = prefix / "share" / "ament_index" / "resource_index" / "packages" / package
        searched.append(str(marker))
        if marker.is_file() and (prefix / "share" / package).is_dir():
            return prefix / "share" / package
    return None


def package_root(package: str, base: Path | None = None) -> tuple[Path, list[str]]:
    """The root of ``package``: a folder of that name among ``base``'s ancestors (a downloaded description
    repository is laid out so), else the package index. Returns the root and the places searched; raises
    PathError listing them when there is none."""
    searched: list[str] = []
    if base is not None:
        for folder in Path(base).resolve().parents:
            if folder.name == package:
                return folder, searched
        searched.append(f"folders named {package!r} above {Path(base).parent}")
    share = _index_share(package, searched)
    if share is not None:
        return share, searched
    raise PathError(f"package {package!r} not found (searched: {'; '.join(searched) or 'nothing'})")


def _owning_root(path: Path) -> Path:
    """The package a file belongs to: its nearest ancestor with a package.xml, else its own folder."""
    for folder in path.parents:
        if (folder / "package.xml").is_file():
            return folder
    return path.parent


def _inside(path: Path, roots: Iterable[Path]) -> bool:
    return any(path == root or root in path.parents for root in roots)


def _known_roots(base: Path | None) -> list[Path]:
    roots = []
    if base is not None:
        roots.append(_owning_root(Path(base).resolve()))
    for prefix in _prefixes():
        share = prefix / "share"
        if (share / "ament_index").is_dir():
            roots.append(share.resolve())
    return roots


def resolve_uri(uri: str, base: str | os.PathLike | None = None) -> Path:
    """The file ``uri`` names, as the URDF at ``base`` (a path or ``file://`` URI; None for a description
    from a topic) sees it. Raises PathError naming the uri and the reason."""
    text = uri.strip()
    base_path = _base_path(base)
    parsed = urlparse(text)
    scheme = parsed.scheme if len(parsed.scheme) > 1 else ""   # "C:" is a drive, not a scheme
    if scheme in ("package", "model"):
        package, rest = parsed.netloc, unquote(parsed.path).lstrip("/")
        if not package:   # package:///pkg/... (three slashes, as TALOS's URDF writes it) names pkg too
            package, _, rest = rest.partition("/")
        if not package:
            raise PathError(f"{text!r}: no package name after {scheme}://")
        root, _ = package_root(package, base_path)
        return _checked(text, root / rest, [root.resolve()])
    if scheme == "file":
        return _checked(text, Path(unquote(parsed.path)), _known_roots(base_path))
    if scheme:
        raise PathError(f"{text!r}: unsupported scheme {scheme}:// (package://, model://, file:// or a path)")
    path = Path(text)
    if path.is_absolute():
        return _checked(text, path, _known_roots(base_path))
    if base_path is None:
        raise PathError(f"{text!r}: a relative path needs the robot's file (this description came without one)")
    root = _owning_root(base_path.resolve())
    return _checked(text, base_path.resolve().parent / path, [root])


def robot_uri_path(text: str) -> Path | None:
    """The file a robot named by URI is (``package://pkg/urdf/robot.urdf.xacro``, ``model://...``,
    ``file:///abs/robot.urdf``), as ``robot_file:=`` and ``robot_description_file`` take it; None for a plain
    path. A ``package://`` file must lie inside its package; a ``file://`` one is the user's own path."""
    parsed = urlparse(text.strip())
    if len(parsed.scheme) <= 1:   # no scheme, or a drive letter
        return None
    if parsed.scheme == "file":
        return Path(unquote(parsed.path))
    return resolve_uri(text)


def _base_path(base: str | os.PathLike | None) -> Path | None:
    if base is None or str(base) == "":
        return None
    text = str(base)
    if text.startswith("file://"):
        return Path(unquote(urlparse(text).path))
    return Path(text)


def _checked(uri: str, path: Path, roots: list[Path]) -> Path:
    """``path`` resolved, inside one of ``roots`` and a regular file."""
    resolved = path.resolve()
    if not _inside(resolved, [r.resolve() for r in roots]):
        where = ", ".join(str(r) for r in roots) or "no package root"
        raise PathError(f"{uri!r} resolves to {resolved}, outside its package root ({where}): refused")
    if not resolved.is_file():
        raise PathError(f"{uri!r}: file {resolved} does not exist" if not resolved.exists()
                        else f"{uri!r}: {resolved} is not a regular file")
    return resolved
