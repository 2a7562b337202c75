"""Entities: a URDF turned into a DART skeleton, placed at its spawn pose, and put back there on reset."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import dartpy as dart
import numpy as np

from nodes.core import names
from nodes.meshes import MeshError
from nodes.meshes.convert import cache_dir, collision_policy
from nodes.meshes.urdf import PreparedUrdf, base_path, prepare_urdf
from nodes.sim.model import Model
from nodes.sim.pose import Pose, SpawnError
from nodes.sim.servo_gains import lowest_points
from nodes.sim.urdf_info import RobotInfo, parse_urdf
from nodes.urdf.rendered_sensors import parse_rendered_sensors
from nodes.urdf.xml_safety import parse_xml

GROUND_CLEARANCE = 0.001   # m between the lowest collision geometry and the ground at an automatic spawn height


def ros2_control_initial_positions(xml: str) -> dict[str, float]:
    """Each ``<ros2_control>`` joint's position ``initial_value``: where gazebo_ros2_control's hardware puts the
    joint when the robot is spawned, whoever asked for the spawn. SpawnError names a value that is no number."""
    if "initial_value" not in xml:
        return {}
    found: dict[str, float] = {}
    for joint in parse_xml(xml).iterfind("ros2_control/joint"):
        for param in joint.iterfind("state_interface[@name='position']/param[@name='initial_value']"):
            text = (param.text or "").strip()
            try:
                value = float(text)
            except ValueError:
                raise SpawnError(f"joint {joint.get('name')!r}: <ros2_control> initial_value {text!r:.60} is not a "
                                 "number") from None
            if not math.isfinite(value):
                raise SpawnError(f"joint {joint.get('name')!r}: <ros2_control> initial_value must be finite")
            found[joint.get("name", "")] = value
    return found


@dataclass
class EntitySpec:
    """Everything a spawn needs (the SpawnEntity request plus our fixed-base / initial-joint options)."""

    name: str
    xml: str
    namespace: str = ""
    pose: Pose = field(default_factory=Pose)
    fixed: bool = False
    initial_positions: dict[str, float] = field(default_factory=dict)
    base_uri: str = ""            # where relative mesh paths resolve (the URDF file's path)
    auto_z: bool = False          # a floating base: lowered (or raised) until its lowest collision touches z = 0
    # its meshes checked and converted beforehand, off the physics thread (``prepare_meshes``): (the URDF they
    # were prepared from, the result)
    meshes: tuple[str, PreparedUrdf] | None = None


def _physics_xml(spec: EntitySpec, info: RobotInfo) -> str:
    return spec.xml if info.physics is None else info.physics.xml   # frame links merged into their bodies


def prepare_meshes(spec: EntitySpec) -> None:
    """Read, check and convert the meshes of ``spec``'s URDF into ``spec.meshes``. No DART here: this runs
    beside the physics (a cold conversion of a real robot's meshes takes seconds), and the spawn on the
    stepping thread then only loads the result. A robot that fails here is left as it is: the spawn repeats
    the work and reports the error, named, as it always does."""
    if "<mesh" not in spec.xml:
        return
    try:
        xml = _physics_xml(spec, parse_urdf(spec.xml, spec.base_uri or None))
        spec.meshes = (xml, prepare_urdf(xml, base_path(spec.base_uri), f"robot {spec.name!r}", collision_policy(),
                                         resolved=True))
    except Exception:  # noqa: BLE001 - reported by the spawn itself
        spec.meshes = None


def sensor_keys(info: RobotInfo, xml: str, namespace: str) -> list[tuple[str, str, str]]:
    """(sensor, key, frame id) of every topic the robot's sensors publish on in ``namespace``."""
    keys = []
    for sensor in info.sensors:
        if sensor.plugin is not None:
            frame = sensor.plugin.frame_name or (sensor.link if sensor.type != "contact" else "world")
            keys.append((sensor.name, sensor.plugin.key(namespace), frame))
    if info.rendered_sensors:
        keys += [(spec.name, key, spec.frame_id) for spec in parse_rendered_sensors(parse_xml(xml.encode()), namespace)
                 for key in spec.keys.values()]
    return keys


def sensor_key_problems(keys: list[tuple[str, str, str]]) -> list[str]:
    """Each key checked as the full topic name it is (a long namespace and a long remapping may be valid
    alone and too long together)."""
    return [f"sensor {names.shown(sensor)} publishes on {names.shown('/' + key)}: {problem}"
            for sensor, key, _ in keys if (problem := names.topic_problem("/" + key)) is not None]


class Entity(Model):
    """A spawned model: its skeleton, URDF info and spawn state (for reset_world)."""

    def __init__(self, spec: EntitySpec) -> None:
        try:
            names.check(names.node_name_problem(spec.name), "name", spec.name)
            names.check(names.namespace_problem(spec.namespace), "robot_namespace", spec.namespace)
        except names.NameError_ as exc:
            raise SpawnError(str(exc)) from None
        self.spec = spec
        self.name = spec.name
        # "/" is the root namespace: the layout the ROS tutorials' programs expect (/joint_states ...)
        self.namespace = (spec.namespace or spec.name).strip("/")
        self.info: RobotInfo = parse_urdf(spec.xml, spec.base_uri or None)
        self.sensor_keys = sensor_keys(self.info, spec.xml, self.namespace)
        problems = sensor_key_problems(self.sensor_keys)
        if problems:
            raise SpawnError("; ".join(problems[:5]))
        self.pose = spec.pose.validated()
        self.mesh_warnings: list[str] = []     # visual meshes left out (missing files), for the log
        self.mesh_note = ""                    # how many meshes were converted, how many from the cache
        self.skeleton = self._load_skeleton(spec, self.info)
        self.skeleton.setName(spec.name)
        self.floating = not spec.fixed and isinstance(self.skeleton.getRootJoint(), dart.dynamics.FreeJoint)
        if self.floating and self.info.physics is not None and self.info.physics.massless_root:
            raise SpawnError(f"root link {self.info.physics.massless_root!r} of a floating base has no mass or "
                             "inertia, even with its fixed children (a physics engine would invent them): give it "
                             "an <inertial>, or spawn it fixed")
        # DART's DOF order differs from the URDF: map every movable joint by name once.
        self.dof_index: dict[str, int] = {}
        for joint in self.info.joints:
            dart_joint = self.skeleton.getJoint(joint.name)
            if dart_joint is None or dart_joint.getNumDofs() != 1:
                raise SpawnError(f"joint {joint.name!r} was not loaded by DART as a 1-DOF joint")
            dart_joint.setLimitEnforcement(joint.type != "continuous")
            self.dof_index[joint.name] = int(dart_joint.getIndexInSkeleton(0))
        self._place(self.pose)
        # the request's own positions (spawn -J, a named pose) over the ros2_control initial_values
        self._apply_initial_positions({**ros2_control_initial_positions(spec.xml), **spec.initial_positions})
        if spec.auto_z and self.floating:
            self._stand_on_ground()
        self.remember_spawn()

    def _load_skeleton(self, spec: EntitySpec, info: RobotInfo) -> dart.dynamics.Skeleton:
        loader = dart.utils.DartLoader()
        flags = dart.utils.DartLoaderFlags.FIXED_BASE_LINK if spec.fixed else dart.utils.DartLoaderFlags.NONE
        uri = dart.common.Uri(spec.base_uri or "file:///")
        xml = self._with_meshes(spec, _physics_xml(spec, info))
        skeleton = loader.parseSkeletonString(xml, uri, dart.common.LocalResourceRetriever(), flags)
        if skeleton is None:
            raise SpawnError(f"DART could not load the URDF of {spec.name!r} (a mesh file that cannot be read? "
                             "see the simulator log)")
        return skeleton

    def _with_meshes(self, spec: EntitySpec, xml: str) -> str:
        """The description DART loads: its meshes checked and converted (``nodes.meshes``), so DART never
        reads a file the user named."""
        if spec.meshes is not None and spec.meshes[0] == xml:
            prepared = spec.meshes[1]
        else:
            try:
                prepared = prepare_urdf(xml, base_path(spec.base_uri), f"robot {spec.name!r}", collision_policy(),
                                        resolved=True)
            except MeshError as exc:
                raise SpawnError(str(exc)) from None
        self.mesh_warnings = prepared.warnings
        if prepared.meshes:
            self.mesh_note = (f"{prepared.meshes} mesh(es) checked and converted, {prepared.cached} from the "
                              f"mesh cache {cache_dir()} (collision_mesh {collision_policy()})")
        return prepared.xml

    def _place(self, pose: Pose) -> None:
        root = self.skeleton.getRootJoint()
        iso = pose.to_isometry()
        if isinstance(root, dart.dynamics.FreeJoint):
            root.setPositions(dart.dynamics.FreeJoint.convertToPositions(iso))
        else:
            # fixed base: the weld joint's offset from the world is the spawn pose
            root.setTransformFromParentBodyNode(iso)

    def _stand_on_ground(self) -> None:
        """The spawn pose moved up or down so the lowest collision geometry (in the initial joint positions)
        is at z = 0 plus a hair of clearance: the robot lands without a drop."""
        lows = lowest_points(self.skeleton)
        if not lows:
            return
        lift = GROUND_CLEARANCE - min(lows.values())
        matrix = np.array(self.pose.to_isometry().matrix())
        matrix[2, 3] += lift
        self.pose = Pose.from_matrix(matrix)
        self._place(self.pose)   # the root's free joint only: the joint positions stay

    def _apply_initial_positions(self, positions: dict[str, float]) -> None:
        for joint_name, value in positions.items():
            if joint_name not in self.dof_index:
                raise SpawnError(f"initial joint position for unknown joint {joint_name!r}")
            if not isinstance(value, (int, float)) or not math.isfinite(value):
                raise SpawnError(f"initial position of joint {joint_name!r} is not a finite number: {value!r}")
            joint = self.info.joint(joint_name)
            if not joint.min_position <= value <= joint.max_position:
                raise SpawnError(f"initial position {value} of joint {joint_name!r} is outside "
                                 f"[{joint.min_position}, {joint.max_position}]")
            self.skeleton.setPosition(self.dof_index[joint_name], float(value))
