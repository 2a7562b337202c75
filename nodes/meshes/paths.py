"""Where a mesh a robot file names lives: the project's one resolver (``nodes.urdf.paths``: ``package://``,
``model://``, ``file://``, absolute and relative paths, each kept inside its package's root), with its refusals
as MeshError, and a missing file told apart (a missing visual mesh is a warning, not an error)."""

from __future__ import annotations

from pathlib import Path

from nodes.meshes.load import MeshError
from nodes.urdf.paths import PathError, resolve_uri


class MissingMesh(MeshError):
    """The reference is allowed but no file is there."""


def resolve_mesh(uri: str, base: Path | str | None) -> Path:
    """The file ``uri`` names for a robot read from the file ``base`` (None: sent without a file)."""
    try:
        return resolve_uri(uri, base)
    except PathError as exc:
        message = str(exc).removeprefix(f"{uri.strip()!r}: ")   # the callers name the reference already
        raise (MissingMesh if "does not exist" in message else MeshError)(message) from None
