"""The world's geometry as the renderer and the viewer see it: every model's links and shapes read from the
DART skeletons the simulator steps (``sim/scene``), and each link's world transform at one instant (the poses of
a ``sim/render/frame``).

Reading DART's shape nodes, not the files, covers everything alike: URDF robots (DART's loader built their
visual and collision shapes with the materials' colours), world files' and spawned SDF models, and the ground.
Meshes are read again through ``nodes.meshes`` (dartpy does not expose a mesh's triangles; DART was given the
checked, converted files) and sent as triangles, so a renderer on another host needs no file of ours; their
size is capped before they are read.
"""

from __future__ import annotations

from dataclasses import dataclass

import dartpy as dart
import numpy as np

from nodes.core.session import max_payload_bytes
from nodes.meshes import MeshError, load_mesh
from nodes.meshes.convert import source_of
from nodes.sim.model import Model
from nodes.sim.pose import Pose
from nodes.sim.world import GROUND_NAME, PhysicsWorld

BOX, CYLINDER, SPHERE, MESH = 1, 2, 3, 4
MAX_MESH_TRIANGLES = 200_000        # one mesh (nodes.render refuses more, too)
MAX_SCENE_TRIANGLES = 2_000_000     # all meshes of the scene together
COLLISION_GREY = (0.5, 0.5, 0.5, 1.0)
SCENE_MARGIN_BYTES = 512 * 1024     # of the payload limit, for everything in a scene but mesh triangles


class SceneError(ValueError):
    """A shape the renderer cannot be given (a mesh over the triangle cap, unreadable): names model and link."""


@dataclass
class SceneLinks:
    """The scene's links in ``Scene.links`` order, with their body nodes (for the poses of a frame)."""

    names: list[str]
    bodies: list

    def poses(self) -> list[float]:
        """12 numbers per link: the first three rows of its world transform, row-major."""
        out: list[float] = []
        for body in self.bodies:
            out.extend(body.getWorldTransform().matrix()[:3].ravel().tolist())
        return out


def _pose(matrix: np.ndarray) -> dict:
    pose = Pose.from_matrix(matrix)
    x, y, z = pose.position
    qx, qy, qz, qw = pose.orientation
    return {"position": {"x": x, "y": y, "z": z}, "orientation": {"x": qx, "y": qy, "z": qz, "w": qw}}


def _mesh_triangles(shape, where: str, budget: int) -> tuple[bytes, bytes, int]:
    """(vertices, triangles, count) of a DART mesh shape, scale applied; refuses more than ``budget``."""
    path = shape.getMeshPath()
    try:
        mesh = load_mesh(path)
    except MeshError as exc:
        raise SceneError(f"{where}: mesh {source_of(path)!r} cannot be given to the renderer: {exc}") from None
    count = mesh.triangles
    if count > min(MAX_MESH_TRIANGLES, budget):
        raise SceneError(f"{where}: mesh {source_of(path)!r} has {count} triangles, over the renderer's cap of "
                         f"{min(MAX_MESH_TRIANGLES, budget)}")
    vertices, faces = mesh.merged()
    vertices = vertices * np.asarray(shape.getScale(), dtype=np.float64)
    return (vertices.astype("<f4").tobytes(), np.asarray(faces, dtype="<u4").tobytes(), count)


def _shape_entry(node, link_index: int, where: str, budget: int) -> tuple[dict, int] | None:
    shape = node.getShape()
    visual = node.getVisualAspect() is not None
    collision = node.getCollisionAspect() is not None
    if not (visual or collision):
        return None
    entry = {"link": link_index, "pose": _pose(node.getRelativeTransform().matrix()), "visual": visual,
             "collision": collision}
    rgba = node.getVisualAspect().getRGBA() if visual else COLLISION_GREY
    entry["color"] = dict(zip("rgba", (float(c) for c in rgba)))
    triangles = 0
    if isinstance(shape, dart.dynamics.BoxShape):
        entry.update(kind=BOX, size=[float(v) for v in shape.getSize()])
    elif isinstance(shape, dart.dynamics.CylinderShape):
        entry.update(kind=CYLINDER, size=[float(shape.getRadius()), float(shape.getHeight())])
    elif isinstance(shape, dart.dynamics.SphereShape):
        entry.update(kind=SPHERE, size=[float(shape.getRadius())])
    elif isinstance(shape, dart.dynamics.MeshShape):
        vertices, faces, triangles = _mesh_triangles(shape, where, budget)
        entry.update(kind=MESH, size=[], mesh_uri=source_of(shape.getMeshPath()), vertices=vertices, triangles=faces,
                     _file=shape.getMeshPath(), _scale=[float(v) for v in shape.getScale()])
    else:
        return None   # shapes our files never build (capsules, cones, height maps): nothing to render
    return entry, triangles


def build_scene(world: PhysicsWorld, models: dict[str, Model], version: int,
                camera_pose: np.ndarray | None = None) -> tuple[dict, SceneLinks]:
    """The plain data of a zenroid_msgs/Scene (the ground first, then the models in order) and its links."""
    skeletons = [(GROUND_NAME, world.ground, "", True, "")] if world.ground is not None else []
    for name, model in models.items():
        # a robot's URDF, at the root namespace too (the tutorials' layout); an SDF model has none
        description = getattr(getattr(model, "spec", None), "xml", "") or ""
        description = description if "<robot" in description else ""
        skeletons.append((name, model.skeleton, model.namespace, model.static, description))
    scene = {"version": version, "models": [], "namespaces": [], "static_models": [], "descriptions": [],
             "links": [], "link_models": [], "shapes": [], "has_camera_pose": camera_pose is not None,
             "camera_pose": _pose(camera_pose if camera_pose is not None else np.eye(4))}
    bodies = []
    budget = MAX_SCENE_TRIANGLES
    for model_index, (name, skeleton, namespace, static, description) in enumerate(skeletons):
        scene["models"].append(name)
        scene["namespaces"].append(namespace)
        scene["static_models"].append(bool(static))
        scene["descriptions"].append(description)
        for i in range(skeleton.getNumBodyNodes()):
            body = skeleton.getBodyNode(i)
            link_index = len(bodies)
            scene["links"].append(f"{name}::{body.getName()}")
            scene["link_models"].append(model_index)
            bodies.append(body)
            for j in range(body.getNumShapeNodes()):
                made = _shape_entry(body.getShapeNode(j), link_index, f"model {name!r} link {body.getName()!r}",
                                    budget)
                if made is not None:
                    scene["shapes"].append(made[0])
                    budget -= made[1]
    _fit(scene["shapes"])
    return scene, SceneLinks(list(scene["links"]), bodies)


def _fit(shapes: list[dict]) -> None:
    """Meshes go inline while the scene stays under the payload limit; the biggest beyond it go by reference:
    no triangles, ``size`` their scale, ``mesh_uri`` their converted file in the mesh cache (a renderer on this
    host reads it; ``nodes.meshes.convert.by_reference``). A G1's visual meshes alone are 16 MB inline."""
    inline = sum(len(s["vertices"]) + len(s["triangles"]) for s in shapes if s["kind"] == MESH)
    limit = max_payload_bytes() - SCENE_MARGIN_BYTES
    for shape in sorted((s for s in shapes if s["kind"] == MESH),
                        key=lambda s: len(s["vertices"]) + len(s["triangles"]), reverse=True):
        if inline <= limit:
            break
        inline -= len(shape["vertices"]) + len(shape["triangles"])
        shape.update(vertices=b"", triangles=b"", size=shape["_scale"], mesh_uri=shape["_file"])
    for shape in shapes:
        shape.pop("_file", None)
        shape.pop("_scale", None)
