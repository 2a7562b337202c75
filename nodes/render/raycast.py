"""Nearest-hit ray casting against the world's shapes with Embree: the one primitive every sensor is built on.

Why two Embree scenes per layer: the world's static links (walls, tables, the ground) never move, so their
triangles are transformed and their BVH built once; everything else (robots, free objects) is transformed
with the newest link poses and rebuilt when those poses change (a few milliseconds for a humanoid made of
primitives: embreex copies vertices element by element, about 0.3 us a triangle). A cast runs the static
scene first, then the dynamic one with the static hit as its far limit, so the second finds only nearer hits
and the result is the nearest of both. All the dynamic shapes of a layer go into ONE Embree geometry: the
build cost is per triangle, and one geometry makes the triangle -> shape lookup a single array index.

Layers: ``visual`` shapes are what cameras and gpu_ray / gpu_lidar see, ``collision`` shapes what ray /
lidar see (Gazebo's split); a shape may be in both, and each layer is built only when it is first cast
against after a change (a frame with only a camera due never builds the collision layer).

Back faces are culled (by default): a ray that meets a surface from inside its shape is cast on from just
past it, so a sensor inside its own housing sees out, as it does in Gazebo (Ogre culls back faces). Only
rays that met a back face are cast again: none, in the usual scene.

Threads: ``EmbreeScene.run`` loops over rays in C without the GIL, so a big cast can be split into
contiguous chunks run on a small pool (``threads``). Every chunk writes only its own slice of the
preallocated results, and one ray's hit does not depend on the others, so the output is bit-identical
whatever the thread count or the order the chunks finish in. ``bench/render.py`` measures whether it pays.
"""

from __future__ import annotations

import threading
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np
from numpy.lib.stride_tricks import as_strided

from nodes.render.geometry import RenderError, Shape, check_scene_triangles, rotate, triangulate

LAYERS = ("visual", "collision")
NO_LIMIT = np.float32(1e37)          # embreex's own "no far limit"
DEFAULT_THREADS = 2                  # bench/render.py: a 320x240 RGB-D frame 1.7x sooner, no more CPU time
MIN_CHUNK_RAYS = 4096                # below this a cast is not split (the pool's overhead is ~50 us a task)
OBJECT_UPLOAD_TRIANGLES = 50_000     # up to this many, uploaded from an object array (faster, bigger)
MAX_BACK_FACES = 4                   # back faces a ray passes through (nested housings) before one counts
BACK_FACE_STEP = np.float32(1e-4)    # m past a back face before casting on (float32 at 100 m: 8 um)


_device = None


def shared_device():  # noqa: ANN201 - an embreex EmbreeDevice
    """The process's one Embree device: scenes come and go with every spawn and delete, and a device of
    their own each would keep its thread-local memory after they are gone."""
    global _device
    if _device is None:
        from embreex import rtcore

        _device = rtcore.EmbreeDevice()
    return _device


@dataclass
class Hits:
    """The nearest hit of each ray: ``distance`` float32 (N,) along the (unit) ray, +inf for none;
    ``shape`` int32 (N,) index into the scene's shapes, -1 for none; ``normal`` float32 (N, 3) unit, world
    frame, facing the ray (zero for none)."""

    distance: np.ndarray
    shape: np.ndarray
    normal: np.ndarray


@dataclass(frozen=True)
class View:
    """What a sensor can see, for leaving the moving links it cannot out of a cast: its origin and axes
    (columns of ``rotation``: x forward, z up) in the world, and either a cone about its x axis
    (``half_angle``, rad: a camera, its half diagonal field of view) or a band of elevations above its x-y
    plane (``elevation``, rad: a laser or a lidar), within ``far`` metres. A link is left out only when its
    bounding sphere lies wholly outside: the test is conservative, so no surface in view is ever missed."""

    origin: np.ndarray
    rotation: np.ndarray
    far: float
    half_angle: float | None = None
    elevation: tuple[float, float] | None = None

    def sees(self, centers: np.ndarray, radii: np.ndarray) -> np.ndarray:
        """Per sphere (world centres (S, 3), radii (S,)): may any of it be in view?"""
        local = (centers - self.origin) @ self.rotation            # in the sensor frame
        distance = np.sqrt(np.einsum("ij,ij->i", local, local))
        inside = distance <= radii
        spread = np.arcsin(np.minimum(1.0, radii / np.maximum(distance, 1e-12)))   # the sphere's angular radius
        near = distance - radii <= self.far
        if self.half_angle is not None:
            cosine = np.clip(local[:, 0] / np.maximum(distance, 1e-12), -1.0, 1.0)
            angular = np.arccos(cosine) <= self.half_angle + spread
        else:
            low, high = self.elevation
            elevation = np.arctan2(local[:, 2], np.hypot(local[:, 0], local[:, 1]))
            angular = (elevation + spread >= low) & (elevation - spread <= high)
        return inside | (near & angular)


class _Group:
    """The shapes of one layer that are rebuilt together (the static ones, or the dynamic ones), their
    triangles in their links' frames, sorted by link so that each link's transform applies to one slice."""

    def __init__(self, links: list[int], local: np.ndarray, prim_shape: np.ndarray,
                 slices: list[tuple[int, int, int]]) -> None:
        self.links = np.array(links, dtype=np.intp)         # the links whose poses this group depends on
        self.local = local                                   # (T * 3, 3) float32, triangle corners, link frame
        self.prim_shape = prim_shape                         # (T,) int32: Embree primID -> shape index
        self.slices = slices                                 # (link, first corner, end corner)
        self.scene = None                                    # an embreex EmbreeScene, once built
        self.built_with: np.ndarray | None = None            # the poses of self.links it was built with
        self.built_slices: bytes | None = None               # ... and which slices went in
        self.seen_version = -1                               # RayScene.version last checked against
        self.seen_slices: bytes | None = None
        # each slice's (one link's) bounding sphere in its link frame, for leaving links out of view out
        self.slice_links = np.array([link for link, _, _ in slices], dtype=np.intp)
        self.centers = np.zeros((len(slices), 3))
        self.radii = np.zeros(len(slices))
        for k, (_, start, end) in enumerate(slices):
            corners = local[start:end].astype(np.float64)
            center = (corners.min(axis=0) + corners.max(axis=0)) / 2
            self.centers[k] = center
            self.radii[k] = float(np.sqrt(((corners - center) ** 2).sum(axis=1).max()))

    @property
    def empty(self) -> bool:
        return len(self.prim_shape) == 0

    def visible(self, poses: np.ndarray, view: View) -> np.ndarray:
        """Per slice: may its link be in ``view`` (its bounding sphere at the link's pose)?"""
        rotations, offsets = poses[self.slice_links, :3, :3], poses[self.slice_links, :3, 3]
        centers = np.einsum("sij,sj->si", rotations, self.centers) + offsets
        return view.sees(centers, self.radii)

    def refresh(self, poses: np.ndarray, version: int, device: object, include: np.ndarray | None = None) -> None:
        """Rebuild the Embree scene if the poses of this group's links, or the slices wanted (``include``:
        per slice, None for all), changed since it was built."""
        if include is None:
            include = np.ones(len(self.slices), dtype=bool)
        wanted = include.tobytes()
        if self.empty or (version == self.seen_version and wanted == self.seen_slices):
            return
        self.seen_version, self.seen_slices = version, wanted
        mine = poses[self.links]
        if self.built_with is not None and wanted == self.built_slices and np.array_equal(mine, self.built_with):
            return
        self.built_with, self.built_slices = mine.copy(), wanted
        if not include.any():
            self.scene = None   # nothing of this group in view: the cast skips it
            return
        from embreex import rtcore_scene as rtcs
        from embreex.mesh_construction import TriangleMesh

        kept = [(link, start, end) for (link, start, end), keep in zip(self.slices, include, strict=True) if keep]
        size = sum(end - start for _, start, end in kept)
        world = np.empty((size, 3), dtype=np.float64)
        prim = np.empty(size // 3, dtype=np.int32)
        at = 0
        for link, start, end in kept:
            pose = poses[link]
            world[at:at + end - start] = rotate(self.local[start:end], pose[:3, :3], pose[:3, 3])
            prim[at // 3:(at + end - start) // 3] = self.prim_shape[start // 3:end // 3]
            at += end - start
        self.scene_prim_shape = prim
        scene = rtcs.EmbreeScene(device)
        # embreex reads the array element by element through Python indexing; from an object array that is
        # a stored float, not a new numpy scalar: 2.2x faster uploads (bench/render.py, rebuild), but 32
        # bytes a coordinate, so only for the few thousand triangles of moving links
        corners = world.reshape(-1, 3, 3)
        TriangleMesh(scene, corners.astype(object) if len(corners) <= OBJECT_UPLOAD_TRIANGLES else corners)
        # run() commits the scene (builds the BVH) on its first call: do it here, on one thread, so that
        # chunks cast in parallel never race to commit it.
        scene.run(np.zeros((1, 3), np.float32), np.array([[1.0, 0.0, 0.0]], np.float32), query="DISTANCE")
        self.scene = scene


class RayScene:
    """The shapes of every link, ready for ``cast``: ``links`` names them (poses follow this order),
    ``shapes`` are (link index, Shape) pairs (``Hits.shape`` indexes this sequence), ``static_links`` never
    move. ``update(poses)`` gives the links' world transforms; ``threads`` > 1 splits big casts over a pool.
    Not thread-safe itself: one thread updates and casts (the pool is internal)."""

    def __init__(self, links: Sequence[str], shapes: Sequence[tuple[int, Shape]], static_links: set[int] = frozenset(),
                 *, threads: int = DEFAULT_THREADS) -> None:
        self.links = list(links)
        self.shapes = [shape for _, shape in shapes]
        self.shape_links = np.array([link for link, _ in shapes], dtype=np.intp)
        if threads < 1:
            raise RenderError(f"threads must be at least 1, got {threads}")
        self.threads = threads
        for index, (link, shape) in enumerate(shapes):
            if not 0 <= link < len(self.links):
                raise RenderError(f"{shape.label} (shape {index}): link index {link} is not one of the "
                                  f"{len(self.links)} links")
        check_scene_triangles(self.shapes)   # refuse before building anything
        self.static_links = {int(i) for i in static_links}
        self.rgba = np.array([shape.rgba for shape in self.shapes], dtype=np.float32).reshape(-1, 4)
        self._groups = self._build_groups(shapes)
        self._poses: np.ndarray | None = None
        self.version = 0
        self._device = None
        self._pool: ThreadPoolExecutor | None = None
        self._lock = threading.Lock()

    # ------------------------------------------------------------------ building
    def _build_groups(self, shapes: Sequence[tuple[int, Shape]]) -> dict[str, tuple[_Group, _Group]]:
        """Per layer, its (static, dynamic) groups; every shape is triangulated once, in its link frame."""
        corners: list[np.ndarray] = []
        for _, shape in shapes:
            vertices, triangles = triangulate(shape)
            pose = np.asarray(shape.pose, dtype=np.float64)
            if pose.shape != (4, 4) or not np.isfinite(pose).all():
                raise RenderError(f"{shape.label}: pose must be a finite 4x4 matrix")
            in_link = rotate(vertices.astype(np.float64), pose[:3, :3], pose[:3, 3])
            corners.append(in_link[triangles.reshape(-1)].astype(np.float32))   # (T * 3, 3)
        groups = {}
        for layer in LAYERS:
            chosen = [i for i, (_, s) in enumerate(shapes) if (s.visual if layer == "visual" else s.collision)]
            static = [i for i in chosen if shapes[i][0] in self.static_links]
            dynamic = [i for i in chosen if shapes[i][0] not in self.static_links]
            groups[layer] = (self._group(static, corners), self._group(dynamic, corners))
        return groups

    def _group(self, indices: list[int], corners: list[np.ndarray]) -> _Group:
        order = sorted(indices, key=lambda i: (self.shape_links[i], i))   # by link, then shape order
        parts, prim, slices = [], [], []
        start = 0
        for i in order:
            link = int(self.shape_links[i])
            end = start + len(corners[i])
            if slices and slices[-1][0] == link:
                slices[-1] = (link, slices[-1][1], end)
            else:
                slices.append((link, start, end))
            parts.append(corners[i])
            prim.append(np.full(len(corners[i]) // 3, i, dtype=np.int32))
            start = end
        local = np.concatenate(parts) if parts else np.zeros((0, 3), dtype=np.float32)
        prim_shape = np.concatenate(prim) if prim else np.zeros(0, dtype=np.int32)
        return _Group(sorted({s[0] for s in slices}), local, prim_shape, slices)

    def update(self, poses: np.ndarray) -> None:
        """The links' world transforms, (L, 4, 4) in ``links`` order. Cheap: a layer's Embree scenes are
        rebuilt on its next ``cast``, and only those whose links moved (the static one, normally never)."""
        poses = np.asarray(poses, dtype=np.float64)
        if poses.shape != (len(self.links), 4, 4):
            raise RenderError(f"poses must be ({len(self.links)}, 4, 4), one per link; got {poses.shape}")
        if not np.isfinite(poses).all():
            bad = sorted({self.links[i] for i in np.nonzero(~np.isfinite(poses).all(axis=(1, 2)))[0]})
            raise RenderError(f"a link pose is not finite: {', '.join(bad[:5])}")
        self._poses = poses.copy()
        self.version += 1

    def _refresh(self, layer: str, view: View | None = None) -> tuple[_Group, _Group]:
        if layer not in self._groups:
            raise RenderError(f"layer '{layer}' is not one of {', '.join(LAYERS)}")
        if self._poses is None:
            raise RenderError("cast before the first update(poses): where the links are is not known")
        if self._device is None:
            self._device = shared_device()
        static, dynamic = self._groups[layer]
        static.refresh(self._poses, self.version, self._device)
        # the moving links out of view are left out: each of them costs its triangles' upload every frame
        include = None if view is None or dynamic.empty else dynamic.visible(self._poses, view)
        dynamic.refresh(self._poses, self.version, self._device, include)
        return static, dynamic

    def triangles(self, layer: str = "visual") -> tuple[int, int]:
        """(static, dynamic) triangles of a layer: the dynamic ones are uploaded again on every change."""
        static, dynamic = self._groups[layer]
        return len(static.prim_shape), len(dynamic.prim_shape)

    def dynamic_triangles_cast(self, layer: str = "visual") -> int:
        """The moving triangles of ``layer`` its last cast was made against (those in view)."""
        dynamic = self._groups[layer][1]
        return 0 if dynamic.scene is None else len(dynamic.scene_prim_shape)

    # ------------------------------------------------------------------ casting
    def prepare(self, layer: str = "visual") -> None:
        """Build the ``layer``'s Embree scenes for the newest poses now (``cast`` does it when needed)."""
        self._refresh(layer)

    def cast(self, origins: np.ndarray, directions: np.ndarray, *, layer: str = "visual",
             max_distance: float | np.ndarray | None = None, cull_back_faces: bool = True,
             view: View | None = None) -> Hits:
        """The nearest hit along each ray from ``origins`` (N, 3), or one origin (3,) for all (a sensor's), in
        unit ``directions`` (N, 3), world frame, among the ``layer``'s shapes. ``max_distance`` (a number, or one per ray) stops the search there:
        farther surfaces are not hit (cheaper than finding and discarding them).

        ``cull_back_faces``: a ray that meets a surface from inside its shape goes on through it, as a GPU
        renderer culls back faces. A sensor inside its own link's housing (a camera at the centre of its
        box visual, a lidar inside its collision cylinder: common in URDFs, and fine in Gazebo) then sees
        out instead of seeing the housing from inside. Primitives are wound outwards; a mesh wound inwards
        is seen from inside only, as in Gazebo.

        ``view``: what the rays can reach (a sensor's field of view): the moving links wholly outside it are
        left out of the cast (the same hits, fewer triangles to upload)."""
        groups = self._refresh(layer, view)
        directions = np.ascontiguousarray(directions, dtype=np.float32).reshape(-1, 3)
        count = len(directions)
        origins = np.asarray(origins, dtype=np.float32)
        if origins.shape == (3,):
            # one origin, repeated by a zero stride (no copy): Embree only reads it, but embreex's typed
            # buffer argument asks for a writable array
            one = origins.copy()
            origins = as_strided(one, shape=(count, 3), strides=(0, one.itemsize), writeable=True)
        else:
            origins = np.ascontiguousarray(origins).reshape(-1, 3)
        if len(origins) != count:
            raise RenderError(f"{len(origins)} origins but {count} directions")
        limit = np.empty(count, dtype=np.float32)
        limit[:] = NO_LIMIT if max_distance is None else np.minimum(max_distance, NO_LIMIT)
        live = [g for g in groups if not g.empty and g.scene is not None]
        distance, shape, normal = self._nearest(live, origins, directions, limit.copy())
        if cull_back_faces:
            travelled = np.zeros(count, dtype=np.float32)   # to the last back face passed through
            for _ in range(MAX_BACK_FACES):
                back = np.nonzero((shape >= 0) & (np.einsum("ij,ij->i", normal, directions) > 0))[0]
                if not len(back):
                    break
                travelled[back] += distance[back] + BACK_FACE_STEP
                rest = limit[back] - travelled[back]
                d = directions[back]
                sub_distance, sub_shape, sub_normal = self._nearest(
                    live, origins[back] + d * travelled[back, None], d, np.maximum(rest, 0.0))
                sub_shape[rest <= 0] = -1
                distance[back], shape[back], normal[back] = sub_distance, sub_shape, sub_normal
            distance = np.where(shape >= 0, travelled + distance, distance)
        hit = shape >= 0
        distance = np.where(hit, distance, np.float32(np.inf)).astype(np.float32, copy=False)
        # unit, and facing the ray (Embree's geometric normal follows the triangle's winding: outwards);
        # misses keep their zero normal
        length = np.sqrt(np.einsum("ij,ij->i", normal, normal))
        scale = np.where(np.einsum("ij,ij->i", normal, directions) > 0, np.float32(-1.0), np.float32(1.0))
        np.divide(scale, length, out=scale, where=length > 0)
        normal *= scale[:, None]
        return Hits(distance, shape, normal)

    def _nearest(self, groups: list[_Group], origins: np.ndarray, directions: np.ndarray,
                 limit: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(distance, shape, raw Embree normal) of the nearest hit of each ray within ``limit`` (overwritten
        with the hit distances), in chunks on the pool when it is worth it."""
        count = len(origins)
        shape = np.full(count, -1, dtype=np.int32)
        normal = np.zeros((count, 3), dtype=np.float32)
        chunks = self._chunks(count)
        if len(chunks) == 1 or not groups:
            self._cast_chunk(groups, origins, directions, limit, shape, normal, 0, count)
        else:
            pool = self._executor()
            futures = [pool.submit(self._cast_chunk, groups, origins, directions, limit, shape, normal, a, b)
                       for a, b in chunks]
            for future in futures:
                future.result()
        return limit, shape, normal

    def _chunks(self, count: int) -> list[tuple[int, int]]:
        if self.threads == 1 or count < 2 * MIN_CHUNK_RAYS:
            return [(0, count)]
        # 4 chunks a thread: a camera's sky rows are cheaper than its floor rows, small chunks even that out
        n = min(4 * self.threads, count // MIN_CHUNK_RAYS)
        bounds = np.linspace(0, count, n + 1).astype(int)
        return [(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:])]

    def _executor(self) -> ThreadPoolExecutor:
        with self._lock:
            if self._pool is None:
                self._pool = ThreadPoolExecutor(max_workers=self.threads, thread_name_prefix="raycast")
            return self._pool

    @staticmethod
    def _cast_chunk(groups: list[_Group], origins: np.ndarray, directions: np.ndarray, limit: np.ndarray,
                    shape: np.ndarray, normal: np.ndarray, start: int, end: int) -> None:
        """Cast rays ``start:end`` against every group in turn, writing only that slice of the outputs."""
        o, d, far = origins[start:end], directions[start:end], limit[start:end]   # views: run() writes far
        for group in groups:
            result = group.scene.run(o, d, dists=far, output=1)
            prim = result["primID"]
            hit = prim >= 0      # a miss's -1 indexes prim_shape's last entry: masked out by copyto
            np.copyto(shape[start:end], group.scene_prim_shape[prim], where=hit)
            np.copyto(normal[start:end], result["Ng"], where=hit[:, None])

    def close(self) -> None:
        """End the thread pool (if one was started)."""
        with self._lock:
            if self._pool is not None:
                self._pool.shutdown(wait=True)
                self._pool = None

    def __enter__(self) -> RayScene:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
