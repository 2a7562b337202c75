"""What the simulator is given for a checked mesh: binary STL files it can load, written once per file content
and kept in a cache folder.

- Collision: one convex hull (``hull``, the default: FCL collides convex shapes fast and robustly), a convex
  decomposition by V-HACD (``decompose``: where one hull is too coarse, a hand or a U-shaped part), or the
  mesh itself (``exact``: slow and fragile contacts, for a static world part).
- Visual: one file per material, with its colour beside it, so the simulator's shapes carry the colours the
  renderer and the viewer draw.

A degenerate mesh (flat: its points span no volume) has no hull and is refused here, with the file named.
The cache key is the SHA-256 of the file's bytes and the conversion, so an edited file is converted again and
a copy of the same file is not. ``ZENROID_MESH_CACHE`` names the folder (default
``$XDG_CACHE_HOME/zenroid/meshes``, i.e. ``~/.cache/zenroid/meshes``).
"""

from __future__ import annotations

import json
import os
import tempfile
import threading
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from nodes.meshes.load import MeshData, MeshError

MODES = ("hull", "decompose", "exact")
CACHE_ENV = "ZENROID_MESH_CACHE"
VERSION = 1                     # of what is written: a change makes every entry stale
DECOMPOSE_HULLS = 16            # V-HACD's most hulls for one mesh
DECOMPOSE_VERTICES = 64         # and most vertices per hull
DECOMPOSE_RESOLUTION = 100_000  # voxels: finer costs seconds per mesh for no contact a robot notices
_LOCK = threading.Lock()
_sources: dict[str, str] = {}    # converted file -> the file it was made from


@dataclass(frozen=True)
class CollisionPolicy:
    """``hull|decompose|exact``, for every link, or per link: ``hull,left_hand=decompose,head=exact``."""

    default: str = "hull"
    links: dict[str, str] = field(default_factory=dict)

    @classmethod
    def parse(cls, text: str) -> CollisionPolicy:
        items = [item.strip() for item in str(text or "hull").split(",") if item.strip()]
        default, links = "hull", {}
        for item in items:
            link, sep, mode = item.rpartition("=") if "=" in item else ("", "", item)
            mode = mode.strip()
            if mode not in MODES:
                raise MeshError(f"collision_mesh: {mode!r} is not one of {', '.join(MODES)} (in {text!r})")
            if sep:
                if not link.strip():
                    raise MeshError(f"collision_mesh: {item!r} names no link (LINK=MODE)")
                links[link.strip()] = mode
            else:
                default = mode
        return cls(default, links)

    def mode(self, link: str) -> str:
        return self.links.get(link, self.default)

    def __str__(self) -> str:
        return ",".join([self.default, *(f"{k}={v}" for k, v in self.links.items())])


_policy = CollisionPolicy()


def set_collision_policy(policy: CollisionPolicy | str) -> CollisionPolicy:
    """The simulator's choice (its ``collision_mesh`` parameter) for every mesh it converts from now on."""
    global _policy
    _policy = policy if isinstance(policy, CollisionPolicy) else CollisionPolicy.parse(policy)
    return _policy


def collision_policy() -> CollisionPolicy:
    return _policy


def cache_dir() -> Path:
    configured = os.environ.get(CACHE_ENV)
    if configured:
        return Path(configured)
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "zenroid" / "meshes"


def write_stl(path: Path, vertices: np.ndarray, faces: np.ndarray) -> None:
    """A binary STL of the triangles (normals computed), written whole or not at all (rename)."""
    corners = np.asarray(vertices, dtype=np.float64)[np.asarray(faces)]
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    lengths = np.linalg.norm(normals, axis=1)
    normals = np.divide(normals, lengths[:, None], out=np.zeros_like(normals), where=lengths[:, None] > 0)
    records = np.zeros(len(corners), dtype=[("normal", "<f4", (3,)), ("corners", "<f4", (3, 3)),
                                            ("attribute", "<u2")])
    records["normal"], records["corners"] = normals, corners
    # assimp takes a binary file starting with "solid" for ASCII: the header must not
    header = b"binary STL written by zenroid".ljust(80, b" ")
    _write_atomic(path, header + len(records).to_bytes(4, "little") + records.tobytes())


def _write_atomic(path: Path, data: bytes) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-", suffix=path.suffix)
    try:
        with os.fdopen(fd, "wb") as handle:
            handle.write(data)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _entry(mesh: MeshData, kind: str) -> Path:
    return cache_dir() / mesh.digest[:2] / f"{mesh.digest}-v{VERSION}-{kind}"


def _cached(manifest: Path) -> list | None:
    try:
        listed = json.loads(manifest.read_text())
    except (OSError, ValueError):
        return None
    if not isinstance(listed, list) or not all(isinstance(item, dict) and "file" in item for item in listed):
        return None
    if not all((manifest.parent / item["file"]).is_file() for item in listed):
        return None
    return listed


def _store(base: Path, pieces: list[tuple[np.ndarray, np.ndarray, tuple | None]]) -> list:
    listed = []
    for i, (vertices, faces, rgba) in enumerate(pieces):
        name = f"{base.name}-{i}.stl"
        write_stl(base.parent / name, vertices, faces)
        listed.append({"file": name, "rgba": list(rgba) if rgba is not None else None})
    _write_atomic(base.with_name(base.name + ".json"), json.dumps(listed).encode())
    return listed


def _files(mesh: MeshData, kind: str, build) -> tuple[list[tuple[Path, tuple | None]], bool]:
    """The cached files of ``kind`` for ``mesh`` (built and stored on a miss), and whether it was a hit."""
    base = _entry(mesh, kind)
    manifest = base.with_name(base.name + ".json")
    with _LOCK:
        listed = _cached(manifest)
        hit = listed is not None
        if listed is None:
            pieces = build()
            try:
                listed = _store(base, pieces)
            except OSError as exc:
                raise MeshError(f"{mesh.path}: the mesh cache {cache_dir()} cannot be written ({exc.strerror or exc}); "
                                f"set {CACHE_ENV} to a writable folder") from None
        files = [(base.parent / item["file"], tuple(item["rgba"]) if item["rgba"] else None) for item in listed]
        for path, _ in files:
            _sources[str(path)] = str(mesh.path)
    return files, hit


def source_of(path: str | Path) -> str:
    """The user's file a converted file was made from in this process (``path`` itself when unknown): what
    messages and the scene name."""
    return _sources.get(str(path), str(path))


def hull(vertices: np.ndarray, where: str) -> tuple[np.ndarray, np.ndarray]:
    """The convex hull's vertices and outward faces; MeshError for points that span no volume."""
    from scipy.spatial import ConvexHull, QhullError  # noqa: PLC0415

    points = np.unique(np.asarray(vertices, dtype=np.float64), axis=0)
    extent = float(np.ptp(points, axis=0).max()) if len(points) else 0.0
    if len(points) < 4 or extent <= 0.0:
        raise MeshError(f"{where}: degenerate ({len(points)} distinct points): no convex hull")
    try:
        result = ConvexHull(points)
    except QhullError:
        raise MeshError(f"{where}: flat (its points lie in a plane or on a line): no convex hull, nothing to "
                        "collide with") from None
    if result.volume <= 1e-9 * extent ** 3:
        raise MeshError(f"{where}: flat (its hull has no volume): nothing to collide with")
    faces = result.simplices.astype(np.int64)
    # qhull's simplices are not consistently wound: turn each to face away from the centroid
    corners = points[faces]
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    inward = np.einsum("ij,ij->i", normals, corners[:, 0] - points[result.vertices].mean(axis=0)) < 0
    faces[inward] = faces[inward][:, ::-1]
    used, faces = np.unique(faces, return_inverse=True)
    return points[used], faces.reshape(-1, 3)


def collision_files(mesh: MeshData, mode: str) -> tuple[list[Path], bool]:
    """STL files to collide with for ``mode``, and whether they came from the cache."""
    if mode not in MODES:
        raise MeshError(f"collision mode {mode!r} is not one of {', '.join(MODES)}")
    where = str(mesh.path)

    def build():
        vertices, faces = mesh.merged()
        outer = hull(vertices, where)     # also the check that the mesh has a volume at all
        if mode == "hull":
            return [(*outer, None)]
        if mode == "exact":
            return [(vertices, faces, None)]
        return [(*hull(part, where), None) for part in _decompose(vertices, faces, where)] or [(*outer, None)]

    files, hit = _files(mesh, mode, build)
    return [path for path, _ in files], hit


def _decompose(vertices: np.ndarray, faces: np.ndarray, where: str) -> list[np.ndarray]:
    try:
        from vhacdx import compute_vhacd  # noqa: PLC0415
    except ImportError:
        raise MeshError(f"{where}: collision_mesh 'decompose' needs vhacdx (pip install vhacdx)") from None
    polygons = np.column_stack([np.full(len(faces), 3, dtype=np.uint32), faces.astype(np.uint32)]).ravel()
    parts = compute_vhacd(np.ascontiguousarray(vertices, dtype=np.float64), polygons,
                          maxConvexHulls=DECOMPOSE_HULLS, maxNumVerticesPerCH=DECOMPOSE_VERTICES,
                          resolution=DECOMPOSE_RESOLUTION)
    out = []
    for part_vertices, _ in parts:
        points = np.asarray(part_vertices, dtype=np.float64)
        if len(points) >= 4 and np.isfinite(points).all():
            try:
                hull(points, where)
            except MeshError:
                continue   # a sliver V-HACD left: the other parts cover it
            out.append(points)
    return out


def visual_files(mesh: MeshData) -> tuple[list[tuple[Path, tuple | None]], bool]:
    """One STL per material with the file's own colour (None: none given), and whether from the cache."""
    return _files(mesh, "visual", lambda: [(p.vertices, p.faces, p.rgba) for p in mesh.parts])


def by_reference(uri: str, scale) -> tuple[np.ndarray, np.ndarray]:
    """The triangles of a scene mesh sent by reference (too big for the scene message): a converted file of
    this host's mesh cache, read and checked again, ``scale`` applied, as (float32 (N, 3), uint32 (M, 3)).
    A path outside the cache is refused: a scene comes from the network."""
    from nodes.meshes.load import check_scale, load_mesh  # noqa: PLC0415 - load imports this module's users

    path = Path(uri)
    if not path.resolve().is_relative_to(cache_dir().resolve()):
        raise MeshError(f"{uri[:200]}: a mesh sent by reference must be a file of the mesh cache "
                        f"{cache_dir()} (is the renderer on another host, or given another ZENROID_MESH_CACHE?)")
    vertices, faces = load_mesh(path).merged()
    vertices = vertices * np.asarray(check_scale(scale, str(path)))
    return vertices.astype(np.float32), faces.astype(np.uint32)
