"""visualization_msgs/Marker and MarkerArray drawn in Rerun, as RViz's Marker display draws them.

Each marker (topic, ``ns``, ``id``) is one entity, ``world/markers/<topic>/<ns>/<id>``, placed in the world
through the viewer's tf tree (``header.frame_id``). Types: ARROW, CUBE, SPHERE, CYLINDER, LINE_STRIP,
LINE_LIST, CUBE_LIST, SPHERE_LIST, POINTS, TEXT_VIEW_FACING, TRIANGLE_LIST and MESH_RESOURCE (a local mesh
file); actions ADD/MODIFY, DELETE, DELETEALL (all of the topic, or of ``ns`` when set); ``lifetime``;
``frame_locked`` markers follow their frame, others stay where their frame was when they came.

A marker RViz would refuse (unknown type or action, a zero scale, too few points, as many colours as
points or none, ...) raises ``MarkerError`` naming the field and the reason; the caller logs it and goes on.
Updates are coalesced: ``flush()`` (called a few times a second) logs each changed marker once, so a
marker published at 1 kHz costs the viewer no more than one at 5 Hz.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import rerun as rr

from msgs import duration_to_sec
from nodes.kinematics import matrix_to_quaternion, pose_matrix
from nodes.packages.index import UriError, resolve_uri

ARROW, CUBE, SPHERE, CYLINDER, LINE_STRIP, LINE_LIST, CUBE_LIST, SPHERE_LIST, POINTS, TEXT_VIEW_FACING, \
    MESH_RESOURCE, TRIANGLE_LIST, ARROW_STRIP = range(13)
ADD, DELETE, DELETEALL = 0, 2, 3
TYPE_NAMES = ["ARROW", "CUBE", "SPHERE", "CYLINDER", "LINE_STRIP", "LINE_LIST", "CUBE_LIST", "SPHERE_LIST",
              "POINTS", "TEXT_VIEW_FACING", "MESH_RESOURCE", "TRIANGLE_LIST", "ARROW_STRIP"]
MAX_MARKERS = 10_000  # live markers kept; more are refused (bounded memory)
SOLID = rr.components.FillMode.Solid

# (topic, frame_id) -> world pose of that frame (4x4), or None while tf does not know it
FrameResolver = Callable[[str, str], "np.ndarray | None"]


class MarkerError(ValueError):
    """A marker that cannot be drawn: the message names the field and the reason."""


@dataclass
class LiveMarker:
    topic: str
    ns: str
    id: int
    entity: str
    msg: Any
    expires_at: float | None  # monotonic time, None: forever
    parts: list = field(default_factory=list)  # the Rerun archetypes last logged
    dirty: bool = True
    drawn: bool = False


def marker_entity(topic: str, ns: str, marker_id: int) -> str:
    """``world/markers/<topic>/<ns>/<id>`` (the topic's levels as entity levels; an empty ns is ``_``)."""
    parts = [rr.escape_entity_path_part(p) for p in topic.strip("/").split("/") if p]
    return "/".join(("world", "markers", *parts, rr.escape_entity_path_part(ns or "_"), str(marker_id)))


def color8(c: Any) -> list[int]:
    return [int(round(max(0.0, min(1.0, v)) * 255)) for v in (c.r, c.g, c.b, c.a)]


def local_pose(msg: Any) -> np.ndarray:
    """The marker's pose; an all-zero quaternion (an unset one) is the identity, as in RViz."""
    q = msg.pose.orientation
    quat = np.array([q.x, q.y, q.z, q.w], float)
    norm = float(np.linalg.norm(quat))
    quat = np.array([0.0, 0.0, 0.0, 1.0]) if norm < 1e-9 else quat / norm
    p = msg.pose.position
    return pose_matrix((p.x, p.y, p.z), quat)


def validate(msg: Any) -> None:
    """Raise ``MarkerError`` for a marker RViz would refuse or could not show."""
    if msg.action not in (ADD, DELETE, DELETEALL):
        hint = " (1 is deprecated)" if msg.action == 1 else ""
        raise MarkerError(f"action {msg.action} is not ADD (0), DELETE (2) or DELETEALL (3){hint}")
    if msg.action != ADD:
        return
    if not 0 <= msg.type < len(TYPE_NAMES):
        raise MarkerError(f"type {msg.type} is not a Marker type (0..12)")
    kind = msg.type
    if kind == ARROW_STRIP:
        raise MarkerError("type ARROW_STRIP (12) is not implemented (RViz does not draw it either)")
    scale = (msg.scale.x, msg.scale.y, msg.scale.z)
    n = len(msg.points)
    if msg.colors and len(msg.colors) != n:
        raise MarkerError(f"colors has {len(msg.colors)} entries for {n} points (give one per point, or none)")
    if kind in (CUBE, SPHERE, CYLINDER, CUBE_LIST, SPHERE_LIST) or (kind == ARROW and n == 0):
        zero = [axis for axis, v in zip("xyz", scale, strict=True) if v <= 0.0]
        if zero:
            raise MarkerError(f"scale.{zero[0]} is {getattr(msg.scale, zero[0])}: a {TYPE_NAMES[kind]} needs a "
                              "positive size on x, y and z")
    if kind in (LINE_STRIP, LINE_LIST, POINTS, ARROW) and n and scale[0] <= 0.0:
        raise MarkerError(f"scale.x is {msg.scale.x}: the line width / point size must be positive")
    if kind == ARROW and n not in (0, 2):
        raise MarkerError(f"points has {n} entries: an ARROW takes 2 (start, end) or none (pose and scale)")
    if kind == LINE_STRIP and n < 2:
        raise MarkerError(f"points has {n} entries: a LINE_STRIP needs at least 2")
    if kind == LINE_LIST and (n < 2 or n % 2):
        raise MarkerError(f"points has {n} entries: a LINE_LIST needs pairs (an even number, at least 2)")
    if kind in (POINTS, CUBE_LIST, SPHERE_LIST) and n == 0:
        raise MarkerError(f"points is empty: a {TYPE_NAMES[kind]} draws one shape per point")
    if kind == TRIANGLE_LIST and (n < 3 or n % 3):
        raise MarkerError(f"points has {n} entries: a TRIANGLE_LIST needs triangles (a multiple of 3)")
    if kind == TEXT_VIEW_FACING and not msg.text:
        raise MarkerError("text is empty: a TEXT_VIEW_FACING marker shows its text")
    if kind == MESH_RESOURCE:
        mesh_path(msg.mesh_resource)


def mesh_path(resource: str) -> Path:
    """The file a marker's ``mesh_resource`` names: ``package://`` through the package index, ``file://`` or a path."""
    if resource.startswith(("http://", "https://", "embedded://")):
        raise MarkerError(f"mesh_resource '{resource}': only local mesh files (package://, file:///path or /path) "
                          "are drawn here")
    try:
        path = resolve_uri(resource)
    except UriError as exc:
        raise MarkerError(f"mesh_resource: {exc}") from None
    if not path.is_file():
        raise MarkerError(f"mesh_resource '{resource}': {path} is not a file")
    return path


def archetypes(msg: Any, world: np.ndarray) -> list:
    """The Rerun archetypes of an ADD marker whose frame is at ``world`` (validated before)."""
    pose = world @ local_pose(msg)
    rotation, origin = pose[:3, :3], pose[:3, 3]
    quat = matrix_to_quaternion(rotation)
    color = color8(msg.color)
    points = np.array([[p.x, p.y, p.z] for p in msg.points], float).reshape(-1, 3)
    placed = points @ rotation.T + origin
    colors = [color8(c) for c in msg.colors] or None
    sx, sy, sz = msg.scale.x, msg.scale.y, msg.scale.z
    kind = msg.type
    if kind == ARROW:
        if len(placed) == 2:  # start and end; scale.x the shaft diameter
            return [rr.Arrows3D(origins=[placed[0]], vectors=[placed[1] - placed[0]], radii=[sx / 2], colors=[color])]
        return [rr.Arrows3D(origins=[origin], vectors=[rotation[:, 0] * sx], radii=[sy / 2], colors=[color])]
    if kind == CUBE:
        return [rr.Boxes3D(centers=[origin], half_sizes=[[sx / 2, sy / 2, sz / 2]], quaternions=[quat],
                           colors=[color], fill_mode=SOLID)]
    if kind == SPHERE:
        return [rr.Ellipsoids3D(centers=[origin], half_sizes=[[sx / 2, sy / 2, sz / 2]], quaternions=[quat],
                                colors=[color], fill_mode=SOLID)]
    if kind == CYLINDER:  # along local z like RViz's; Rerun's cylinders are round: scale.x is the diameter
        return [rr.Cylinders3D(centers=[origin], lengths=[sz], radii=[sx / 2], quaternions=[quat], colors=[color],
                               fill_mode=SOLID)]
    if kind == LINE_STRIP:
        if colors:  # a colour per vertex: one segment per colour
            segments = [[placed[i], placed[i + 1]] for i in range(len(placed) - 1)]
            return [rr.LineStrips3D(segments, radii=sx / 2, colors=colors[:-1])]
        return [rr.LineStrips3D([placed], radii=sx / 2, colors=[color])]
    if kind == LINE_LIST:
        pairs = [[placed[i], placed[i + 1]] for i in range(0, len(placed), 2)]
        return [rr.LineStrips3D(pairs, radii=sx / 2, colors=colors[::2] if colors else [color])]
    if kind == POINTS:
        return [rr.Points3D(placed, radii=sx / 2, colors=colors or [color])]
    if kind == CUBE_LIST:
        return [rr.Boxes3D(centers=placed, half_sizes=[[sx / 2, sy / 2, sz / 2]] * len(placed),
                           quaternions=[quat] * len(placed), colors=colors or [color], fill_mode=SOLID)]
    if kind == SPHERE_LIST:
        return [rr.Ellipsoids3D(centers=placed, half_sizes=[[sx / 2, sy / 2, sz / 2]] * len(placed),
                                colors=colors or [color], fill_mode=SOLID)]
    if kind == TEXT_VIEW_FACING:
        return [rr.Points3D([origin], radii=[max(sz, 0.01) * 0.05], labels=[msg.text], colors=[color],
                            show_labels=True)]
    if kind == TRIANGLE_LIST:
        return [rr.Mesh3D(vertex_positions=placed, triangle_indices=np.arange(len(placed)).reshape(-1, 3),
                          vertex_colors=colors, albedo_factor=None if colors else color)]
    path = mesh_path(msg.mesh_resource)  # MESH_RESOURCE
    return [rr.Asset3D(path=path), rr.Transform3D(translation=origin, quaternion=quat,
                                                  scale=[sx or 1.0, sy or 1.0, sz or 1.0])]


class MarkerLayer:
    """The live markers of every marker topic, and their Rerun entities."""

    def __init__(self, recording: rr.RecordingStream, resolve_frame: FrameResolver,
                 clock: Callable[[], float] = time.monotonic, max_markers: int = MAX_MARKERS) -> None:
        self.recording = recording
        self.resolve_frame = resolve_frame
        self.clock = clock
        self.max_markers = max_markers
        self.live: dict[tuple[str, str, int], LiveMarker] = {}
        self.cleared: list[str] = []  # entities to clear at the next flush
        self.unresolved: dict[tuple[str, str], str] = {}  # (topic, frame) -> message, reported by the caller

    def handle(self, topic: str, msg: Any) -> None:
        """Apply one marker (raises ``MarkerError`` if it is refused; the layer is unchanged then)."""
        validate(msg)
        if msg.action == DELETEALL:
            for key in [k for k in self.live if k[0] == topic and (not msg.ns or k[1] == msg.ns)]:
                self._remove(key)
            return
        key = (topic, msg.ns, msg.id)
        if msg.action == DELETE:
            self._remove(key)
            return
        if key not in self.live and len(self.live) >= self.max_markers:
            raise MarkerError(f"{self.max_markers} markers are shown already: delete some (DELETE, DELETEALL) "
                              "or give them a lifetime")
        lifetime = duration_to_sec(msg.lifetime)
        expires = self.clock() + lifetime if lifetime > 0 else None
        marker = self.live.get(key)
        if marker is None:
            marker = self.live[key] = LiveMarker(topic, msg.ns, msg.id, marker_entity(topic, msg.ns, msg.id), msg,
                                                 expires)
        marker.msg, marker.expires_at, marker.dirty = msg, expires, True

    def _remove(self, key: tuple[str, str, int]) -> None:
        marker = self.live.pop(key, None)
        if marker is not None and marker.drawn:
            self.cleared.append(marker.entity)

    def flush(self, refresh: bool = False) -> None:
        """Log what changed since the last flush: expired and deleted markers cleared, new or modified ones
        drawn, frame-locked ones re-placed; with ``refresh`` every live marker again (a key frame)."""
        now = self.clock()
        for key in [k for k, m in self.live.items() if m.expires_at is not None and m.expires_at <= now]:
            self._remove(key)
        for entity in self.cleared:
            self.recording.log(entity, rr.Clear(recursive=False))
        self.cleared = []
        for marker in self.live.values():
            if not (marker.dirty or refresh or (marker.msg.frame_locked and marker.drawn)):
                continue
            if marker.dirty or marker.msg.frame_locked or not marker.parts:
                world = self.resolve_frame(marker.topic, marker.msg.header.frame_id)
                if world is None:
                    self.unresolved[(marker.topic, marker.msg.header.frame_id)] = (
                        f"{marker.topic}: marker '{marker.ns}' {marker.id}: frame_id "
                        f"'{marker.msg.header.frame_id}' is not in tf (yet); drawn once it is")
                    continue
                marker.parts = archetypes(marker.msg, world)
            self.recording.log(marker.entity, *marker.parts)
            marker.dirty, marker.drawn = False, True

