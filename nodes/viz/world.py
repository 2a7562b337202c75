"""The world's models (``sim/scene``) drawn in Rerun, as Gazebo's client shows them beside the robots.

The simulator's ``zenroid_msgs/Scene`` lists every model with its links and shapes (boxes, cylinders,
spheres, meshes as triangles) in their link frames; ``sim/link_states`` gives each link's world pose. Robots
(models with a namespace) are left out: the viewer draws them from their URDF (``scene.py``). So is
``ground_plane``, a 50 m box whose top is z = 0: the 3-D view's own grid is the ground, and a surface that
size over it would hide the grid and cost a software-rendered page fill time in every frame.

Entities, one row for all the world's models at a time (the web page takes in a bounded number of chunks a
second, one per entity and flush, whatever their size: docs/viewer.md):

- ``world/models``         every primitive of every world model at its world pose: ``Boxes3D``,
                           ``Cylinders3D``, ``Ellipsoids3D`` (always all three, empty when none, so every
                           row has the same components and a flush is one chunk). Logged when the scene
                           changes, when a dynamic model moved (at the ``world_rate`` the node lets
                           ``sim/link_states`` through) and again when nothing was logged for a key-frame
                           period: a late page, which gets only the newest message from the server, then
                           draws the whole world from one row within that period.
- ``world/models/meshes``  every mesh of the world models in one ``Mesh3D`` (world coordinates, a colour per
                           vertex), logged with the scene, at key frames and when a mesh moved.

Bad input (a shape naming a link that does not exist, a size of the wrong length, a non-finite number, mesh
bytes that are not whole triangles, a NaN pose) raises or returns ``WorldProblem`` lines naming the field and
the reason; the shape or link is skipped and the rest is drawn.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import rerun as rr

from nodes.kinematics import matrix_to_quaternion, pose_matrix

from .scene import SOLID, SceneTime, rgba8

BOX, CYLINDER, SPHERE, MESH = 1, 2, 3, 4  # zenroid_msgs/SceneShape kinds
SIZES = {BOX: 3, CYLINDER: 2, SPHERE: 1, MESH: 0}  # numbers in SceneShape.size per kind
KIND_NAMES = {BOX: "BOX", CYLINDER: "CYLINDER", SPHERE: "SPHERE", MESH: "MESH"}
GROUND_MODEL = "ground_plane"
WORLD_ENTITY = "world/models"
MESH_ENTITY = "world/models/meshes"
MAX_VIEWER_TRIANGLES = 200_000  # every world mesh together: more would stall the page taking it in
KEYFRAME_SLACK = 0.2  # s
MOVED_M = 1e-3  # a link moved when it went further than this ...
MOVED_RAD = 3e-3  # ... or turned more (resting objects jitter by micrometres: no rows for that)


class WorldProblem(ValueError):
    """A part of the scene that cannot be drawn: the message names the field and the reason."""


def pose_of(pose: Any, where: str) -> np.ndarray:
    """A geometry_msgs/Pose as a 4x4 matrix; ``WorldProblem`` for non-finite numbers or a zero quaternion."""
    p, q = pose.position, pose.orientation
    values = (p.x, p.y, p.z, q.x, q.y, q.z, q.w)
    if not all(math.isfinite(v) for v in values):
        raise WorldProblem(f"{where}: not finite: {values}")
    if math.sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w) < 1e-9:
        raise WorldProblem(f"{where}: orientation is the zero quaternion")
    return pose_matrix((p.x, p.y, p.z), (q.x, q.y, q.z, q.w))


def camera_eye(pose: np.ndarray) -> tuple[list[float], list[float]]:
    """(eye position, look target) of a Gazebo GUI camera pose: it looks along its +x. The target is where
    that ray meets the ground when it does within 1-30 m, else 5 m ahead (the orbit turns about it)."""
    eye = pose[:3, 3]
    forward = pose[:3, 0] / max(np.linalg.norm(pose[:3, 0]), 1e-9)
    distance = 5.0
    if forward[2] < -1e-3 and eye[2] > 0.0:
        distance = float(np.clip(eye[2] / -forward[2], 1.0, 30.0))
    return eye.tolist(), (eye + forward * distance).tolist()


@dataclass
class WorldShape:
    """One drawable shape of a world model: its link, kind, size, pose in the link frame and colour."""

    link: int  # index into Scene.links
    kind: int
    size: tuple[float, ...]
    local: np.ndarray  # 4x4, in the link frame
    color: list[int]  # RGBA8
    vertices: np.ndarray | None = None  # MESH: (N, 3) float32 in the shape frame
    normals: np.ndarray | None = None  # MESH: (N, 3) per vertex
    triangles: np.ndarray | None = None  # MESH: (M, 3) uint32


def mesh_arrays(shape: Any, where: str) -> tuple[np.ndarray, np.ndarray]:
    """(vertices, triangles) of a MESH SceneShape, checked: whole float32 triples, whole uint32 triples,
    finite vertices, indices inside the vertex list."""
    vertices, triangles = bytes(shape.vertices), bytes(shape.triangles)
    if not vertices and shape.mesh_uri:   # too big for the scene message: a file of the mesh cache
        from nodes.meshes import MeshError  # noqa: PLC0415
        from nodes.meshes.convert import by_reference  # noqa: PLC0415

        try:
            return by_reference(shape.mesh_uri, shape.size)
        except MeshError as exc:
            raise WorldProblem(f"{where}: {exc}") from None
    if len(vertices) % 12 or not vertices:
        raise WorldProblem(f"{where}: vertices has {len(vertices)} bytes: not float32 x y z triples")
    if len(triangles) % 12 or not triangles:
        raise WorldProblem(f"{where}: triangles has {len(triangles)} bytes: not uint32 index triples")
    v = np.frombuffer(vertices, dtype="<f4").reshape(-1, 3)
    t = np.frombuffer(triangles, dtype="<u4").reshape(-1, 3)
    if not np.isfinite(v).all():
        raise WorldProblem(f"{where}: vertices has non-finite coordinates")
    if int(t.max()) >= len(v):
        raise WorldProblem(f"{where}: triangles has index {int(t.max())} for {len(v)} vertices")
    return v.astype(np.float32), t.astype(np.uint32)


def vertex_normals(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Area-weighted vertex normals, so a mesh is shaded (Rerun draws a mesh without normals flat)."""
    corners = vertices[triangles].astype(float)
    faces = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    normals = np.zeros((len(vertices), 3))
    for i in range(3):
        np.add.at(normals, triangles[:, i], faces)
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    return (normals / np.where(length > 0, length, 1.0)).astype(np.float32)


@dataclass
class WorldLayout:
    """What one Scene version says about the world's drawable models (robots and the ground left out)."""

    version: int = -1
    links: dict[str, int] = field(default_factory=dict)  # "model::link" -> index, links with shapes only
    static: set[int] = field(default_factory=set)  # link indices of static models
    shapes: list[WorldShape] = field(default_factory=list)
    models: list[str] = field(default_factory=list)  # the world models drawn
    eye: tuple[list[float], list[float]] | None = None  # the GUI camera: (eye, look target)


def read_scene(msg: Any, max_triangles: int = MAX_VIEWER_TRIANGLES) -> tuple[WorldLayout, list[str]]:
    """The drawable world of a zenroid_msgs/Scene and the problems met (each a skipped shape or model)."""
    problems: list[str] = []
    layout = WorldLayout(version=int(msg.version))
    n_models = len(msg.models)
    for name, values in (("namespaces", msg.namespaces), ("static_models", msg.static_models)):
        if len(values) != n_models:
            raise WorldProblem(f"sim/scene: {name} has {len(values)} entries for {n_models} models")
    if len(msg.link_models) != len(msg.links):
        raise WorldProblem(f"sim/scene: link_models has {len(msg.link_models)} entries for {len(msg.links)} links")
    drawn_models = {i for i, (name, ns) in enumerate(zip(msg.models, msg.namespaces, strict=True))
                    if not ns and name != GROUND_MODEL}
    if msg.has_camera_pose:
        try:
            layout.eye = camera_eye(pose_of(msg.camera_pose, "sim/scene: camera_pose"))
        except WorldProblem as exc:
            problems.append(str(exc))
    triangles = 0
    for index, shape in enumerate(msg.shapes):
        where = f"sim/scene: shapes[{index}]"
        link = int(shape.link)
        if link >= len(msg.links):
            problems.append(f"{where}: link {link} is not one of the {len(msg.links)} links")
            continue
        model = int(msg.link_models[link])
        if model >= n_models:
            problems.append(f"{where}: link_models[{link}] is {model}, not one of the {n_models} models")
            continue
        if model not in drawn_models or not shape.visual:
            continue  # a robot (drawn from its URDF), the ground (the grid), a collision-only shape
        where = f"{where} ({msg.links[link]})"
        if shape.kind not in SIZES:
            problems.append(f"{where}: kind {shape.kind} is not BOX (1), CYLINDER (2), SPHERE (3) or MESH (4)")
            continue
        size = tuple(float(v) for v in shape.size)
        if shape.kind != MESH and (len(size) != SIZES[shape.kind] or not all(math.isfinite(v) and v > 0
                                                                              for v in size)):
            problems.append(f"{where}: size {list(size)}: a {KIND_NAMES[shape.kind]} needs "
                            f"{SIZES[shape.kind]} positive number(s)")
            continue
        c = shape.color
        try:
            entry = WorldShape(link, int(shape.kind), size, pose_of(shape.pose, f"{where}: pose"),
                               rgba8((c.r, c.g, c.b, c.a)))
            if shape.kind == MESH:
                entry.vertices, entry.triangles = mesh_arrays(shape, where)
                if triangles + len(entry.triangles) > max_triangles:
                    raise WorldProblem(f"{where}: {len(entry.triangles)} more triangles would pass the viewer's "
                                       f"cap of {max_triangles} for the world's meshes: not drawn")
                triangles += len(entry.triangles)
                entry.normals = vertex_normals(entry.vertices, entry.triangles)
        except WorldProblem as exc:
            problems.append(str(exc))
            continue
        layout.shapes.append(entry)
        layout.links[msg.links[link]] = link
        if msg.static_models[model]:
            layout.static.add(link)
        if msg.models[model] not in layout.models:
            layout.models.append(msg.models[model])
    return layout, problems


class WorldModels:
    """The world's models in Rerun: the shapes of the newest scene at the newest link poses."""

    def __init__(self, recording: rr.RecordingStream) -> None:
        self.recording = recording
        self.set_time = SceneTime(recording)
        self.layout = WorldLayout()
        self.poses: dict[int, np.ndarray] = {}  # link index -> world pose
        self.logged: dict[int, np.ndarray] = {}  # ... as last drawn
        self.moved: set[int] = set()  # links placed or moved since the last row
        self.last_row = 0.0  # monotonic
        self.had_meshes = False

    @property
    def version(self) -> int:
        return self.layout.version

    def load(self, layout: WorldLayout, sim_time: float) -> None:
        """A new scene: keep the poses of links that are still there, draw what is placed."""
        kept = {index for name, index in layout.links.items() if self.layout.links.get(name) == index}
        self.poses = {i: p for i, p in self.poses.items() if i in kept}
        self.layout = layout
        self.moved = set(self.poses)
        self.log(sim_time, meshes=True)

    def needs_link_states(self) -> bool:
        """Dynamic links move; static ones need one pose each (the scene gives shapes, not link poses)."""
        return any(i not in self.layout.static or i not in self.poses for i in self.layout.links.values())

    def update_poses(self, names: Sequence[str], poses: Sequence[Any]) -> tuple[bool, list[str]]:
        """Poses of a gazebo_msgs/LinkStates: (whether a link was placed or moved since the last row,
        problems). A link with a NaN pose keeps its last pose."""
        problems: list[str] = []
        for name, pose in zip(names, poses, strict=False):
            index = self.layout.links.get(name)
            if index is None:
                continue
            try:
                matrix = pose_of(pose, f"sim/link_states: {name}")
            except WorldProblem as exc:
                problems.append(str(exc))
                continue
            self.poses[index] = matrix
            last = self.logged.get(index)
            if last is None or float(np.abs(matrix[:3, 3] - last[:3, 3]).max()) > MOVED_M or \
                    float(np.abs(matrix[:3, :3] - last[:3, :3]).max()) > MOVED_RAD:
                self.moved.add(index)
        return bool(self.moved), problems

    def log(self, sim_time: float, meshes: bool = False) -> None:
        """One row of ``world/models`` (and of ``world/models/meshes`` with ``meshes`` or when a mesh moved)."""
        self.set_time(sim_time)
        kinds: dict[int, list[tuple[WorldShape, np.ndarray]]] = {BOX: [], CYLINDER: [], SPHERE: [], MESH: []}
        mesh_moved = False
        for shape in self.layout.shapes:
            pose = self.poses.get(shape.link)
            if pose is None:
                continue
            kinds[shape.kind].append((shape, pose @ shape.local))
            mesh_moved = mesh_moved or (shape.kind == MESH and shape.link in self.moved)

        def fields(entries: list[tuple[WorldShape, np.ndarray]]) -> dict[str, Any]:
            matrices = np.array([m for _, m in entries], float).reshape(-1, 4, 4)
            return {"centers": matrices[:, :3, 3],
                    "quaternions": matrix_to_quaternion(matrices[:, :3, :3]) if entries else np.zeros((0, 4)),
                    "colors": np.array([s.color for s, _ in entries], np.uint8).reshape(-1, 4), "fill_mode": SOLID}

        boxes, cylinders, spheres = kinds[BOX], kinds[CYLINDER], kinds[SPHERE]
        self.recording.log(WORLD_ENTITY, rr.Boxes3D(
            half_sizes=np.array([[v / 2 for v in s.size] for s, _ in boxes], float).reshape(-1, 3), **fields(boxes)),
            rr.Cylinders3D(radii=[s.size[0] for s, _ in cylinders], lengths=[s.size[1] for s, _ in cylinders],
                           **fields(cylinders)),
            rr.Ellipsoids3D(half_sizes=np.array([[s.size[0]] * 3 for s, _ in spheres], float).reshape(-1, 3),
                            **fields(spheres)))
        if meshes or mesh_moved:
            self.log_meshes(kinds[MESH])
        self.logged = dict(self.poses)
        self.moved = set()
        self.last_row = time.monotonic()

    def log_meshes(self, entries: list[tuple[WorldShape, np.ndarray]]) -> None:
        if not entries:
            if self.had_meshes:
                self.recording.log(MESH_ENTITY, rr.Clear(recursive=False))
            self.had_meshes = False
            return
        positions, normals, colors, triangles = [], [], [], []
        offset = 0
        for shape, matrix in entries:
            assert shape.vertices is not None and shape.triangles is not None and shape.normals is not None
            positions.append(shape.vertices @ matrix[:3, :3].T.astype(np.float32) + matrix[:3, 3].astype(np.float32))
            normals.append(shape.normals @ matrix[:3, :3].T.astype(np.float32))
            colors.append(np.repeat(np.array([shape.color], np.uint8), len(shape.vertices), axis=0))
            triangles.append(shape.triangles + offset)
            offset += len(shape.vertices)
        self.recording.log(MESH_ENTITY, rr.Mesh3D(
            vertex_positions=np.concatenate(positions), vertex_normals=np.concatenate(normals),
            vertex_colors=np.concatenate(colors), triangle_indices=np.concatenate(triangles)))
        self.had_meshes = True

    def refresh(self, sim_time: float, period: float) -> None:
        """A key frame: the whole world again when nothing was logged for ``period`` s (see the docstring)."""
        # (a timer of that period calls this: a row 0.2 s short of it would otherwise wait a whole period more)
        if self.layout.version >= 0 and time.monotonic() - self.last_row >= period - KEYFRAME_SLACK:
            self.log(sim_time, meshes=True)
