"""The shapes rays are cast against, as triangles: what a ``SceneShape`` describes, turned into a mesh once.

Embree only intersects triangles, so every primitive is triangulated here, in its own shape frame, with
enough facets that the error is below what the sensors resolve, and no more: every dynamic triangle is
uploaded again each frame (``raycast``), so facets cost time. Boxes are exact. Curved surfaces are
"balanced": the polygon's vertices sit slightly outside the true surface and its flat faces slightly inside,
so the surface is within +-e of the true radius instead of -2e..0:

- cylinders: the fewest sides (a multiple of 4, at least 12) that keep the side within
  ``CYLINDER_TOLERANCE`` (1 mm) of the radius: 12 sides up to r = 5.7 cm, 32 at r = 0.4 m, 256 at most;
- spheres: icospheres, the lowest subdivision (at least 2: 320 faces, +-0.9 % of the radius) that keeps the
  surface within ``SPHERE_TOLERANCE`` (2 mm): subdivision 2 up to r = 22 cm, 3 (1280 faces, +-0.23 %) up to
  88 cm, then 4 and 5. The error is always under 1 % of the radius.

Meshes arrive as bytes on the wire
(``SceneShape.vertices`` / ``.triangles``) and are checked before anything trusts them. Triangle counts are
capped (per mesh and per scene) before any large allocation, so a hostile scene costs an error message, not
the machine's memory.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

KINDS = ("box", "cylinder", "sphere", "mesh")
MAX_MESH_TRIANGLES = 200_000
MAX_MESH_VERTICES = 3 * MAX_MESH_TRIANGLES   # more than 3 a triangle are never used
MAX_SCENE_TRIANGLES = 2_000_000
CYLINDER_TOLERANCE = 0.001     # m, of a cylinder's side from its radius
CYLINDER_SECTIONS = (12, 256)   # fewest and most sides
SPHERE_TOLERANCE = 0.002       # m, of a sphere's surface from its radius
SPHERE_SUBDIVISIONS = (2, 5)   # icosphere subdivisions: 320 to 20480 faces
BOX_TRIANGLES = 12
MAX_SIZE = 1e4                 # m, of any primitive dimension (as nodes.sim.sdf bounds them)


class RenderError(ValueError):
    """A scene, shape or mesh the renderer refuses; the message names the shape and the reason."""


@dataclass
class Shape:
    """One visual and/or collision shape of a link, in the link frame.

    ``size``: box (x, y, z) full extents; cylinder (radius, length) along the local z, centred; sphere
    (radius,); unused for a mesh, whose ``vertices`` (N, 3) float32 (scale applied, shape frame) and
    ``triangles`` (M, 3) uint32 are given. ``rgba`` in [0, 1] is what cameras see; ``visual`` shapes are seen by
    cameras and gpu_ray / gpu_lidar, ``collision`` shapes by ray / lidar (a shape may be both).
    """

    kind: str
    size: tuple[float, ...] = ()
    pose: np.ndarray | None = None
    rgba: tuple[float, float, float, float] = (0.7, 0.7, 0.7, 1.0)
    visual: bool = True
    collision: bool = True
    vertices: np.ndarray | None = None
    triangles: np.ndarray | None = None
    name: str = ""          # for error messages ("model::link" and the shape's index are fine)

    def __post_init__(self) -> None:
        if self.pose is None:
            self.pose = np.eye(4)

    @property
    def label(self) -> str:
        return f"{self.kind} shape '{self.name}'" if self.name else f"{self.kind} shape"


def cylinder_sections(radius: float) -> int:
    """Sides of a balanced polygon within ``CYLINDER_TOLERANCE`` of a circle of ``radius``: its error is
    r (1 - cos(pi / n)) / (1 + cos(pi / n))."""
    low, high = CYLINDER_SECTIONS
    for sections in range(low, high, 4):
        half = math.cos(math.pi / sections)
        if radius * (1.0 - half) / (1.0 + half) <= CYLINDER_TOLERANCE:
            return sections
    return high


@functools.lru_cache(maxsize=8)
def _unit_sphere(subdivisions: int) -> tuple[np.ndarray, np.ndarray, float]:
    """The unit icosphere's vertices and faces, and the distance of its nearest face plane from the centre."""
    import trimesh

    mesh = trimesh.creation.icosphere(subdivisions=subdivisions, radius=1.0)
    vertices, faces = np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces, dtype=np.uint32)
    corners = vertices[faces]
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    nearest = float(np.abs(np.einsum("ij,ij->i", normals, corners[:, 0])).min())
    return vertices, faces, nearest


def sphere_subdivisions(radius: float) -> int:
    """The icosphere subdivision whose balanced surface is within ``SPHERE_TOLERANCE`` of ``radius``."""
    low, high = SPHERE_SUBDIVISIONS
    for subdivisions in range(low, high):
        nearest = _unit_sphere(subdivisions)[2]
        if radius * (1.0 - nearest) / (1.0 + nearest) <= SPHERE_TOLERANCE:
            return subdivisions
    return high


def triangle_count(shape: Shape) -> int:
    """Triangles ``triangulate`` makes for ``shape``, known without building anything (for the caps)."""
    if shape.kind == "box":
        return BOX_TRIANGLES
    if shape.kind == "cylinder":
        return 4 * cylinder_sections(_sizes(shape, 2, "radius and length")[0])   # 2 a side, 2 cap fans
    if shape.kind == "sphere":
        return 20 * 4 ** sphere_subdivisions(_sizes(shape, 1, "a radius")[0])
    if shape.kind == "mesh":
        return 0 if shape.triangles is None else int(len(shape.triangles))
    raise RenderError(f"{shape.label}: kind '{shape.kind}' is not one of {', '.join(KINDS)}")


def _sizes(shape: Shape, count: int, what: str) -> tuple[float, ...]:
    size = tuple(float(s) for s in shape.size)
    if len(size) < count:
        raise RenderError(f"{shape.label}: needs {what}, got size {size}")
    size = size[:count]
    if not all(math.isfinite(s) and 0.0 < s <= MAX_SIZE for s in size):
        raise RenderError(f"{shape.label}: {what} {size} must be positive, finite and at most {MAX_SIZE:g} m")
    return size


def triangulate(shape: Shape) -> tuple[np.ndarray, np.ndarray]:
    """``(vertices (N, 3) float32, triangles (M, 3) uint32)`` of ``shape`` in its shape frame; RenderError
    naming the shape for a bad size, an unknown kind or a mesh over ``MAX_MESH_TRIANGLES``."""
    import trimesh

    count = triangle_count(shape)
    if count > MAX_MESH_TRIANGLES:
        raise RenderError(f"{shape.label}: {count} triangles, over the cap of {MAX_MESH_TRIANGLES} per mesh")
    if shape.kind == "box":
        mesh = trimesh.creation.box(extents=_sizes(shape, 3, "x y z extents"))
        vertices, triangles = mesh.vertices, mesh.faces
    elif shape.kind == "cylinder":
        radius, length = _sizes(shape, 2, "radius and length")
        sections = cylinder_sections(radius)
        half = math.cos(math.pi / sections)
        mesh = trimesh.creation.cylinder(radius=radius * 2.0 / (1.0 + half), height=length, sections=sections)
        vertices, triangles = mesh.vertices, mesh.faces
    elif shape.kind == "sphere":
        (radius,) = _sizes(shape, 1, "a radius")
        unit, triangles, nearest = _unit_sphere(sphere_subdivisions(radius))
        vertices = unit * (radius * 2.0 / (1.0 + nearest))
    else:
        if shape.vertices is None or shape.triangles is None:
            raise RenderError(f"{shape.label}: a mesh needs vertices and triangles")
        vertices, triangles = np.asarray(shape.vertices), np.asarray(shape.triangles)
        if len(vertices) > MAX_MESH_VERTICES:
            raise RenderError(f"{shape.label}: {len(vertices)} vertices, over the cap of {MAX_MESH_VERTICES} per mesh")
        if vertices.ndim != 2 or vertices.shape[1] != 3 or triangles.ndim != 2 or triangles.shape[1] != 3:
            raise RenderError(f"{shape.label}: vertices must be (N, 3) and triangles (M, 3), got "
                              f"{vertices.shape} and {triangles.shape}")
        _check_mesh(vertices, triangles, shape.label)
    return np.ascontiguousarray(vertices, dtype=np.float32), np.ascontiguousarray(triangles, dtype=np.uint32)


def _check_mesh(vertices: np.ndarray, triangles: np.ndarray, label: str) -> None:
    if not np.isfinite(vertices).all():
        raise RenderError(f"{label}: a vertex coordinate is not finite")
    if len(triangles) and (int(triangles.max()) >= len(vertices) or int(triangles.min()) < 0):
        raise RenderError(f"{label}: a triangle index ({int(triangles.max())}) is out of range of the "
                          f"{len(vertices)} vertices")


def mesh_from_bytes(vertices: bytes, triangles: bytes, label: str = "mesh") -> tuple[np.ndarray, np.ndarray]:
    """A mesh from its wire form (``SceneShape``): float32 little-endian x y z triples and uint32
    little-endian index triples, as ``(V (N, 3) float32, F (M, 3) uint32)``. RenderError naming ``label``
    for lengths that are not whole triples, more than ``MAX_MESH_TRIANGLES`` triangles or
    ``MAX_MESH_VERTICES`` vertices (checked on the lengths, before anything is copied), indices out of range
    or non-finite vertices."""
    if len(vertices) % 12:
        raise RenderError(f"{label}: vertices are {len(vertices)} bytes, not a whole number of float32 x y z "
                          "triples (12 bytes each)")
    if len(triangles) % 12:
        raise RenderError(f"{label}: triangles are {len(triangles)} bytes, not a whole number of uint32 index "
                          "triples (12 bytes each)")
    count = len(triangles) // 12
    if count > MAX_MESH_TRIANGLES:
        raise RenderError(f"{label}: {count} triangles, over the cap of {MAX_MESH_TRIANGLES} per mesh")
    if len(vertices) // 12 > MAX_MESH_VERTICES:
        raise RenderError(f"{label}: {len(vertices) // 12} vertices, over the cap of {MAX_MESH_VERTICES} per mesh")
    v = np.frombuffer(vertices, dtype="<f4").reshape(-1, 3).astype(np.float32)
    f = np.frombuffer(triangles, dtype="<u4").reshape(-1, 3).astype(np.uint32)
    _check_mesh(v, f, label)
    return v, f


def rotate(rows: np.ndarray, rotation: np.ndarray, translation: np.ndarray | None = None) -> np.ndarray:
    """``rows @ rotation.T (+ translation)`` for (N, 3) rows, one output column at a time from the three input
    columns. Not ``@``: numpy hands it to OpenBLAS, whose worker threads then spin for a while after each call,
    burning the other core (measured: a 320x240 camera frame took twice the CPU time). Not (N, 1) * (3,)
    broadcasts either: their inner loops are 3 long, and a camera's 76,800 rays took 1.0-1.3 ms against 0.32
    here (float64 2.4 against 0.40), the same sums in the same order, so the same bits."""
    x, y, z = rows[:, 0], rows[:, 1], rows[:, 2]
    out = np.empty(rows.shape, dtype=np.result_type(rows, rotation))
    for k in range(3):
        column = out[:, k]
        np.multiply(x, rotation[k, 0], out=column)
        column += y * rotation[k, 1]
        column += z * rotation[k, 2]
    if translation is not None:
        if np.result_type(out, translation) != out.dtype:
            return out + translation      # a wider translation widens the result, as the plain sum does
        out += translation
    return out


def dot(rows: np.ndarray, vector: np.ndarray) -> np.ndarray:
    """``rows @ vector`` for (N, 3) rows without BLAS (see ``rotate``)."""
    return rows[:, 0] * vector[0] + rows[:, 1] * vector[1] + rows[:, 2] * vector[2]


def check_scene_triangles(shapes: list[Shape]) -> int:
    """The triangles of every shape together; RenderError over ``MAX_SCENE_TRIANGLES`` (nothing built yet)."""
    total = 0
    for shape in shapes:
        count = triangle_count(shape)
        if count > MAX_MESH_TRIANGLES:
            raise RenderError(f"{shape.label}: {count} triangles, over the cap of {MAX_MESH_TRIANGLES} per mesh")
        total += count
        if total > MAX_SCENE_TRIANGLES:
            raise RenderError(f"the scene has over {MAX_SCENE_TRIANGLES} triangles (reached at {shape.label}), "
                              "over the cap for a scene")
    return total
