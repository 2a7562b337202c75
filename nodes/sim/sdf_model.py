"""An SDF model description (``sdf.ModelSpec``) built as a DART skeleton: links with their inertia, collision
and visual shapes (material colours), joints, a static model welded where it stands.

Links that no joint connects are separate trees of one skeleton, each free (or welded, in a static model),
as Gazebo simulates them. Meshes are checked and converted by ``nodes.meshes`` (collision: a hull, convex parts
or the mesh; visual: one part per material with its colour) and DART loads only those converted files, through
its URDF loader (its only path to assimp in dartpy).
"""

from __future__ import annotations

import math
from functools import lru_cache
from pathlib import Path
from xml.sax.saxutils import quoteattr

import dartpy as dart
import numpy as np

from nodes.meshes import MeshBudget, MeshError, load_mesh
from nodes.meshes.convert import collision_files, collision_policy, visual_files
from nodes.sim.model import Model, isometry
from nodes.sim.sdf import JointSpec, LinkSpec, ModelSpec, ShapeSpec, WorldError

PLANE_THICKNESS = 0.1     # a plane is simulated as a box this thick whose top face is the plane
DEFAULT_FRICTION = 1.0    # SDF's mu


class WorldModel(Model):
    """A model read from an SDF world file or spawned from SDF text (no hardware interface)."""

    def __init__(self, spec: ModelSpec) -> None:
        self.spec = spec
        self.name = spec.name
        self.namespace = ""
        self.static = spec.static
        self.skeleton = build_skeleton(spec)
        root_link = self.skeleton.getRootBodyNode().getName()
        self.root_offset = next(link.pose for link in spec.links if link.name == root_link)
        self.remember_spawn()


def build_skeleton(spec: ModelSpec) -> dart.dynamics.Skeleton:
    """The model's skeleton in its world pose; raises WorldError naming the model and the reason."""
    links = {link.name: link for link in spec.links}
    parent_joint: dict[str, JointSpec] = {}
    for joint in spec.joints:
        where = f"{spec.source}: model {spec.name!r}: joint {joint.name!r}"
        if joint.child not in links:
            raise WorldError(f"{where}: child link {joint.child!r} does not exist")
        if joint.parent != "world" and joint.parent not in links:
            raise WorldError(f"{where}: parent link {joint.parent!r} does not exist")
        if joint.child in parent_joint:
            raise WorldError(f"{where}: link {joint.child!r} is already the child of joint "
                             f"{parent_joint[joint.child].name!r}")
        if joint.parent == joint.child:
            raise WorldError(f"{where}: the link {joint.child!r} is its own parent")
        parent_joint[joint.child] = joint
    skeleton = dart.dynamics.Skeleton(spec.name)
    bodies: dict[str, object] = {}
    budget = MeshBudget(f"{spec.source}: model {spec.name!r}")
    # roots (links no joint holds, or held by a joint to the world) first, then each tree breadth first, in
    # file order: the same file always builds the same skeleton (lockstep runs stay bit-identical)
    order = [link.name for link in spec.links if link.name not in parent_joint
             or parent_joint[link.name].parent == "world"]
    children: dict[str, list[str]] = {}
    for joint in spec.joints:
        if joint.parent != "world":
            children.setdefault(joint.parent, []).append(joint.child)
    i = 0
    while i < len(order):
        order.extend(children.get(order[i], []))
        i += 1
    if len(order) != len(links):
        stuck = sorted(set(links) - set(order))
        raise WorldError(f"{spec.source}: model {spec.name!r}: the joints between {stuck} form a loop")
    for name in order:
        link = links[name]
        joint = parent_joint.get(name)
        parent = bodies[joint.parent] if joint is not None and joint.parent != "world" else None
        body = _add_body(skeleton, spec, link, joint, parent, links)
        _set_inertia(body, link)
        for shape in link.collisions:
            _add_shape(body, shape, spec, collision=True, link=link.name, budget=budget)
        for shape in link.visuals:
            _add_shape(body, shape, spec, collision=False, link=link.name, budget=budget)
        body.setGravityMode(link.gravity)
        bodies[name] = body
    if spec.static:
        skeleton.setMobile(False)
    return skeleton


def _add_body(skeleton, spec: ModelSpec, link: LinkSpec, joint: JointSpec | None, parent, links):
    world_link = spec.pose @ link.pose
    if joint is None:
        if spec.static or link.fixed_to_world:
            dart_joint, body = skeleton.createWeldJointAndBodyNodePair(None)
            dart_joint.setTransformFromParentBodyNode(isometry(world_link))
        else:
            dart_joint, body = skeleton.createFreeJointAndBodyNodePair(None)
            dart_joint.setPositions(dart.dynamics.FreeJoint.convertToPositions(isometry(world_link)))
        dart_joint.setName(f"{link.name}_root")
        body.setName(link.name)
        return body
    if joint.parent == "world":
        parent_to_joint = world_link @ joint.pose
    else:
        parent_to_joint = np.linalg.inv(links[joint.parent].pose) @ link.pose @ joint.pose
    axis = np.asarray(joint.axis, dtype=float)
    if joint.axis_in_model:
        axis = (link.pose[:3, :3] @ joint.pose[:3, :3]).T @ axis
    kind = joint.type
    if kind in ("revolute", "continuous"):
        props = dart.dynamics.RevoluteJointProperties()
        props.mAxis = axis
    elif kind == "prismatic":
        props = dart.dynamics.PrismaticJointProperties()
        props.mAxis = axis
    elif kind == "ball":
        props = dart.dynamics.BallJointProperties()
    else:
        props = None
    if props is None:
        dart_joint, body = skeleton.createWeldJointAndBodyNodePair(parent)
    else:
        props.mName = joint.name
        if kind in ("revolute", "prismatic"):
            props.mPositionLowerLimits = [joint.lower]
            props.mPositionUpperLimits = [joint.upper]
            props.mIsPositionLimitEnforced = math.isfinite(joint.lower) or math.isfinite(joint.upper)
        if kind != "ball":
            props.mDampingCoefficients = [joint.damping]
            props.mFrictions = [joint.friction]
            if math.isfinite(joint.effort):
                props.mForceLowerLimits, props.mForceUpperLimits = [-joint.effort], [joint.effort]
        creator = {"revolute": skeleton.createRevoluteJointAndBodyNodePair,
                   "continuous": skeleton.createRevoluteJointAndBodyNodePair,
                   "prismatic": skeleton.createPrismaticJointAndBodyNodePair,
                   "ball": skeleton.createBallJointAndBodyNodePair}[kind]
        dart_joint, body = creator(parent, props)
    dart_joint.setName(joint.name)
    dart_joint.setTransformFromParentBodyNode(isometry(parent_to_joint))
    dart_joint.setTransformFromChildBodyNode(isometry(joint.pose))
    body.setName(link.name)
    return body


def _set_inertia(body, link: LinkSpec) -> None:
    if link.inertial is None:
        body.setInertia(dart.dynamics.Inertia(1.0, np.zeros(3), np.eye(3)))   # SDF's defaults
        return
    rotation = link.inertial.pose[:3, :3]
    moments = rotation @ link.inertial.moments @ rotation.T
    body.setInertia(dart.dynamics.Inertia(link.inertial.mass, link.inertial.pose[:3, 3], moments))


def _add_shape(body, shape: ShapeSpec, spec: ModelSpec, *, collision: bool, link: str, budget: MeshBudget) -> None:
    offset = shape.pose
    if shape.kind == "box":
        parts = [(dart.dynamics.BoxShape(list(shape.size)), None)]
    elif shape.kind == "sphere":
        parts = [(dart.dynamics.SphereShape(shape.size[0]), None)]
    elif shape.kind == "cylinder":
        parts = [(dart.dynamics.CylinderShape(shape.size[0], shape.size[1]), None)]
    elif shape.kind == "plane":
        parts = [(dart.dynamics.BoxShape([shape.size[0], shape.size[1], PLANE_THICKNESS]), None)]
        offset = shape.pose @ _plane_frame(shape.normal)
    else:
        parts = _mesh_parts(shape, spec, link, collision, budget)
    for dart_shape, rgba in parts:
        node = body.createShapeNode(dart_shape)
        node.setRelativeTransform(isometry(offset))
        if collision:
            node.createCollisionAspect()
            node.createDynamicsAspect().setFrictionCoeff(DEFAULT_FRICTION if shape.friction is None
                                                         else shape.friction)
        else:
            # the model's <material> wins over the mesh file's own colour, as in Gazebo
            colour = shape.colour or rgba or (0.7, 0.7, 0.7, 1.0)
            node.createVisualAspect().setRGBA(np.asarray(colour, dtype=float))


def _mesh_parts(shape: ShapeSpec, spec: ModelSpec, link: str, collision: bool, budget: MeshBudget) -> list:
    """DART shapes of a mesh, each with the file's colour for it: converted files only (``nodes.meshes``)."""
    where = f"{spec.source}: model {spec.name!r} link {link!r}"
    try:
        mesh = load_mesh(shape.mesh)
        budget.add(mesh)
        if collision:
            files = [(path, None) for path in collision_files(mesh, collision_policy().mode(link))[0]]
        else:
            files = visual_files(mesh)[0]
    except MeshError as exc:
        raise WorldError(f"{where}: {'collision' if collision else 'visual'} mesh: {exc}") from None
    return [(_mesh(str(path), tuple(shape.scale), where), rgba) for path, rgba in files]


def _plane_frame(normal: tuple[float, float, float]) -> np.ndarray:
    """The box standing for a plane: its z axis along the normal, its top face through the origin."""
    z = np.asarray(normal, dtype=float)
    helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    frame = np.eye(4)
    frame[:3, :3] = np.column_stack([x, np.cross(z, x), z])
    frame[:3, 3] = -z * PLANE_THICKNESS / 2
    return frame


@lru_cache(maxsize=64)
def _mesh(path: str, scale: tuple[float, float, float], where: str):
    """A mesh shape loaded by DART's URDF loader (assimp); the same file and scale share one shape."""
    urdf = (f"<robot name='mesh'><link name='m'><visual><geometry><mesh filename={quoteattr(Path(path).as_uri())} "
            f"scale='{scale[0]!r} {scale[1]!r} {scale[2]!r}'/></geometry></visual></link></robot>")
    loader = dart.utils.DartLoader()
    skeleton = loader.parseSkeletonString(urdf, dart.common.Uri("file:///"), dart.common.LocalResourceRetriever(),
                                          dart.utils.DartLoaderFlags.FIXED_BASE_LINK)
    body = skeleton.getBodyNode(0) if skeleton is not None else None
    if body is None or body.getNumShapeNodes() == 0:
        raise WorldError(f"{where}: mesh {path}: DART could not read it (not a mesh format assimp reads?)")
    return body.getShapeNode(0).getShape()
