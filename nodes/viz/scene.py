"""Everything the visualiser writes to Rerun, with plain numbers in (no Zenoh, no messages).

Entity layout (one subtree per robot namespace, so a deleted robot is one recursive Clear):

- ``world/ground``                                   the ground plane
- ``world/<ns>/links/<link>/visual_<i>``              URDF visual geometry, in named frame ``<ns>/<link>``
- ``world/<ns>/frames/<child>``                      one frame relation each: tf, tf_static, and the
                                                     root link in ``tf#/world`` from sim/model_states
- ``world/<ns>/markers/{com,zmp,com_path,support_polygon,ee_paths,target}``
- ``plots/<ns>/joint_states/{position,velocity,effort}``  one series per joint
- ``plots/<ns>/<controller>/<joint>``                 commanded vs actual (the rqt_plot view)
- ``plots/<ns>/balance/{com,zmp,is_balanced}``

Time: every call takes the sim time (``sim_time`` timeline, a duration) and stamps the wall clock
(``wall_time`` timeline) itself.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import rerun as rr

from nodes.kinematics import KinematicTree, matrix_to_quaternion, pose_matrix
from nodes.urdf.model import RobotModel, UrdfError, Visual, parse_urdf
from nodes.urdf.validate import validate

SIM_TIMELINE = "sim_time"
WALL_TIMELINE = "wall_time"
WORLD_FRAME = "tf#/world"  # Rerun's implicit frame of the entity "world": the 3-D view's root
SOLID = rr.components.FillMode.Solid
PATH_LENGTH = 300  # points kept per marker path (30 s at the 10 Hz marker rate)
TRANSLATION = rr.Transform3D.descriptor_translation()
QUATERNION = rr.Transform3D.descriptor_quaternion()
POSE_EPSILON = 1e-4  # m and quaternion units (~0.2 mrad): changes below this are invisible, not re-logged


def frame_name(namespace: str, frame: str, world_frames: Sequence[str] = ("world", "map", "odom")) -> str:
    """A tf frame id as a Rerun frame: world-like frames map to the scene root, others get ``<ns>/``."""
    frame = frame.lstrip("/")
    if frame in world_frames or frame == "":
        return WORLD_FRAME
    if frame.startswith(f"{namespace}/"):
        return frame
    return f"{namespace}/{frame}"


def parse_model(xml_text: str) -> RobotModel:
    """A ``robot_description`` as a drawable model: the project's URDF parser (with its XML safety check:
    entity declarations and external DTDs are refused) plus its tree checks. Raises ``UrdfError``."""
    if not xml_text or not xml_text.strip():
        raise UrdfError("robot_description: empty")
    model = parse_urdf(xml_text)
    errors = [issue.message for issue in validate(model) if issue.severity == "error"]
    if errors:
        raise UrdfError(errors[0])
    return model


def rgba8(rgba: Sequence[float]) -> list[int]:
    return [int(round(max(0.0, min(1.0, c)) * 255)) for c in rgba]


class PathBuffer:
    """The last ``capacity`` points of a path in a numpy ring (no per-log list-to-array conversion)."""

    def __init__(self, capacity: int) -> None:
        self.points = np.zeros((capacity, 3), dtype=np.float32)
        self.count = 0  # points ever appended

    def append(self, point: Sequence[float]) -> None:
        self.points[self.count % len(self.points)] = point
        self.count += 1

    def __len__(self) -> int:
        return min(self.count, len(self.points))

    def array(self) -> np.ndarray:
        """Oldest to newest."""
        if self.count <= len(self.points):
            return self.points[: self.count]
        split = self.count % len(self.points)
        return np.concatenate((self.points[split:], self.points[:split]))


class SceneTime:
    """Sets both timelines on a recording before each log call."""

    def __init__(self, recording: rr.RecordingStream) -> None:
        self.recording = recording

    def __call__(self, sim_time: float) -> None:
        self.recording.set_time(SIM_TIMELINE, duration=max(0.0, sim_time))
        self.recording.set_time(WALL_TIMELINE, timestamp=time.time())


def log_ground(recording: rr.RecordingStream, half_extent: float = 2.0) -> None:
    recording.log("world/ground", rr.Boxes3D(
        half_sizes=[[half_extent, half_extent, 0.002]], centers=[[0.0, 0.0, -0.002]],
        colors=[[90, 95, 100, 255]], fill_mode=SOLID), static=True)
    ticks = np.arange(-half_extent, half_extent + 1e-9, 0.5)
    lines = [[[x, -half_extent, 0.001], [x, half_extent, 0.001]] for x in ticks]
    lines += [[[-half_extent, y, 0.001], [half_extent, y, 0.001]] for y in ticks]
    recording.log("world/ground/grid", rr.LineStrips3D(lines, colors=[[140, 145, 150, 255]], radii=0.002),
                  static=True)


def visual_archetype(visual: Visual, mesh_root: Path | None = None) -> rr.AsComponents | None:
    """The Rerun archetype of one URDF visual in its link frame (None for an unresolvable mesh)."""
    center = [visual.origin[:3, 3].tolist()]
    quat = [matrix_to_quaternion(visual.origin[:3, :3]).tolist()]
    color = [rgba8(visual.rgba)]
    if visual.kind == "box":
        return rr.Boxes3D(half_sizes=[[s / 2 for s in visual.size]], centers=center, quaternions=quat,
                          colors=color, fill_mode=SOLID)
    if visual.kind == "cylinder":  # URDF and Rerun cylinders both run along local z
        return rr.Cylinders3D(lengths=[visual.length], radii=[visual.radius], centers=center,
                              quaternions=quat, colors=color, fill_mode=SOLID)
    if visual.kind == "sphere":
        return rr.Ellipsoids3D(half_sizes=[[visual.radius] * 3], centers=center, quaternions=quat,
                               colors=color, fill_mode=SOLID)
    path = Path(visual.filename.removeprefix("file://"))
    if not path.is_absolute() and mesh_root is not None:
        path = mesh_root / path
    if visual.filename.startswith("package://") or not path.is_file():
        return None
    return rr.Asset3D(path=path, albedo_factor=color[0])


class RobotScene:
    """The Rerun side of one robot: geometry, frames, plots and markers under its namespace."""

    def __init__(self, recording: rr.RecordingStream, namespace: str, model: RobotModel,
                 end_effectors: Sequence[str] = (), world_frames: Sequence[str] = ("world", "map", "odom"),
                 path_length: int = PATH_LENGTH) -> None:
        self.recording = recording
        self.namespace = namespace
        self.model = model
        self.fk = KinematicTree(model)
        self.world_frames = tuple(world_frames)
        self.set_time = SceneTime(recording)
        wanted = [link for link in end_effectors if link]
        unknown = [link for link in wanted if link not in model.links]
        if unknown:
            raise ValueError(f"end_effectors: unknown links {unknown} in robot '{model.name}'")
        self.end_effectors = wanted or model.leaf_links()
        self.world = f"world/{namespace}"
        self.plots = f"plots/{namespace}"
        self.root_frame = frame_name(namespace, model.root, self.world_frames)
        self.relations: dict[str, tuple[str, list]] = {}  # child frame -> (parent frame, frame components)
        self.last_pose: dict[str, tuple[float, ...]] = {}  # child frame -> last logged xyz + quaternion
        self.base_pose = np.eye(4)
        self.base_from_tf = False  # once tf names the root's parent, model_states no longer places it
        self.base_known = False  # no path points until the robot's place in the world is known
        self.positions: dict[str, float] = {}
        self.joint_series: tuple[str, ...] = ()
        self.controller_series: set[tuple[str, str]] = set()
        self.com_path = PathBuffer(path_length)
        self.ee_paths = {link: PathBuffer(path_length) for link in self.end_effectors}
        self.skipped_meshes: list[str] = []

    # -- model ---------------------------------------------------------------------------------------
    def log_model(self, sim_time: float, mesh_root: Path | None = None) -> int:
        """Log every visual in its link frame; returns how many entities were logged."""
        self.set_time(sim_time)
        count = 0
        for link, link_model in self.model.links.items():
            frame = rr.CoordinateFrame(frame_name(self.namespace, link, self.world_frames))
            for index, visual in enumerate(link_model.visuals):
                archetype = visual_archetype(visual, mesh_root)
                if archetype is None:
                    self.skipped_meshes.append(visual.filename)
                    continue
                self.recording.log(f"{self.world}/links/{link}/visual_{index}", archetype, frame)
                count += 1
        # Until a pose arrives, the robot stands at the origin rather than floating in no frame at all.
        if not self.base_from_tf:
            self._log_relation(WORLD_FRAME, self.root_frame, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
        return count

    def clear(self, sim_time: float) -> None:
        """The robot was deleted: hide its whole subtree from this time on."""
        self.set_time(sim_time)
        self.recording.log(self.world, rr.Clear(recursive=True))
        self.recording.log(self.plots, rr.Clear(recursive=True))

    # -- frames --------------------------------------------------------------------------------------
    def log_transforms(self, sim_time: float,
                       transforms: Sequence[tuple[str, str, Sequence[float], Sequence[float]]]) -> None:
        """``(parent, child, xyz, quat_xyzw)`` rows from a TFMessage (tf or tf_static).

        One entity per child frame (``world/<ns>/frames/<child>``): the viewer resolves only one
        frame relation per Transform3D row, and a relation may live on one entity only. The frame-name
        components are built once per relation and reused, which halves the cost of a log call.
        """
        self.set_time(sim_time)
        for parent, child, xyz, quat in transforms:
            parent_frame = frame_name(self.namespace, parent, self.world_frames)
            child_frame = frame_name(self.namespace, child, self.world_frames)
            if child_frame == WORLD_FRAME or child_frame == parent_frame:
                continue
            if child_frame == self.root_frame and parent_frame == WORLD_FRAME:
                self.base_from_tf = self.base_known = True
                self.base_pose = pose_matrix(xyz, quat)
            self._log_relation(parent_frame, child_frame, xyz, quat)

    def _log_relation(self, parent_frame: str, child_frame: str, xyz: Sequence[float],
                      quat: Sequence[float]) -> None:
        cached = self.relations.get(child_frame)
        if cached is None or cached[0] != parent_frame:
            frames = list(rr.Transform3D.from_fields(parent_frame=parent_frame,
                                                     child_frame=child_frame).as_component_batches())
            cached = (parent_frame, frames)
            self.relations[child_frame] = cached
            self.last_pose.pop(child_frame, None)
        # Most joints of a moving robot are still at any instant: an unchanged frame is not logged again
        # (the viewer holds the latest value), which removes most of the per-frame log calls.
        pose = (*xyz, *quat)
        last = self.last_pose.get(child_frame)
        if last is not None and all(abs(a - b) < POSE_EPSILON for a, b in zip(pose, last, strict=True)):
            return
        self.last_pose[child_frame] = pose
        entity = f"{self.world}/frames/{rr.escape_entity_path_part(child_frame.removeprefix(self.namespace + '/'))}"
        self.recording.log(entity, [
            *cached[1],
            rr.components.Translation3DBatch([list(xyz)]).described(TRANSLATION),
            rr.components.RotationQuatBatch([list(quat)]).described(QUATERNION),
        ])

    def log_fk_transforms(self, sim_time: float, positions: Mapping[str, float]) -> None:
        """Fallback without a state publisher: link frames from our own forward kinematics."""
        translation, quat = self.fk.local_poses(self.fk.configuration(positions))
        self.log_transforms(sim_time, list(zip(self.fk.parent_names, self.fk.child_names, translation.tolist(),
                                               quat.tolist(), strict=True)))

    def link_poses(self, positions: Mapping[str, float]) -> np.ndarray:
        """World pose of every link (``fk.link_names`` order) at ``positions`` (joints not named at 0)."""
        return self.base_pose @ self.fk.link_transforms(self.fk.configuration(positions))

    def log_base_pose(self, sim_time: float, position: Sequence[float], orientation_xyzw: Sequence[float]) -> None:
        """The root link in the world (from sim/model_states), unless tf already places it."""
        if self.base_from_tf:  # tf places the root (a state publisher relays model_states): it wins
            return
        self.base_pose = pose_matrix(position, orientation_xyzw)
        self.base_known = True
        self.set_time(sim_time)
        self._log_relation(WORLD_FRAME, self.root_frame, position, orientation_xyzw)

    # -- plots ---------------------------------------------------------------------------------------
    def log_joint_states(self, sim_time: float, names: Sequence[str], position: Sequence[float],
                         velocity: Sequence[float], effort: Sequence[float]) -> None:
        """One Scalars batch per quantity (one series per joint), not one log call per joint."""
        names = tuple(names)
        self.positions.update(zip(names, position, strict=False))
        if names != self.joint_series:
            self.joint_series = names
            for quantity in ("position", "velocity", "effort"):
                self.recording.log(f"{self.plots}/joint_states/{quantity}",
                                   rr.SeriesLines(names=list(names)), static=True)
        self.set_time(sim_time)
        for quantity, values in (("position", position), ("velocity", velocity), ("effort", effort)):
            if len(values) == len(names) and names:
                self.recording.log(f"{self.plots}/joint_states/{quantity}", rr.Scalars(np.asarray(values, float)))

    def log_controller_state(self, sim_time: float, controller: str, joint_names: Sequence[str],
                             commanded: Sequence[float], actual: Sequence[float]) -> None:
        """Commanded vs actual position per joint: ``plots/<ns>/<controller>/<joint>``."""
        self.set_time(sim_time)
        for joint, cmd, act in zip(joint_names, commanded, actual, strict=False):
            entity = f"{self.plots}/{controller}/{joint}"
            if (controller, joint) not in self.controller_series:
                self.controller_series.add((controller, joint))
                self.recording.log(entity, rr.SeriesLines(names=["commanded", "actual"],
                                                          colors=[[255, 140, 0], [40, 120, 255]]), static=True)
            self.recording.log(entity, rr.Scalars([cmd, act]))

    def log_balance(self, sim_time: float, com: Sequence[float], zmp: Sequence[float], is_balanced: bool,
                    support_polygon: Sequence[Sequence[float]], markers: bool = True) -> None:
        """Plots every call; the 3-D markers (CoM, ZMP, support polygon) only when ``markers``."""
        self.set_time(sim_time)
        self.recording.log(f"{self.plots}/balance/com", rr.Scalars(np.asarray(com, float)))
        self.recording.log(f"{self.plots}/balance/zmp", rr.Scalars(np.asarray(zmp, float)))
        self.recording.log(f"{self.plots}/balance/is_balanced", rr.Scalars([1.0 if is_balanced else 0.0]))
        if not markers:
            return
        self.com_path.append(com)
        markers_path = f"{self.world}/markers"
        color = [60, 200, 90, 255] if is_balanced else [230, 60, 50, 255]
        self.recording.log(f"{markers_path}/com", rr.Points3D([com, [com[0], com[1], 0.0]], radii=[0.03, 0.015],
                                                          colors=[color, color]))
        self.recording.log(f"{markers_path}/zmp", rr.Points3D([[zmp[0], zmp[1], 0.003]], radii=0.02,
                                                          colors=[[250, 220, 40, 255]]))
        if len(support_polygon) >= 2:
            ring = [[p[0], p[1], max(p[2], 0.0) + 0.003] for p in support_polygon]
            self.recording.log(f"{markers_path}/support_polygon", rr.LineStrips3D(
                [ring + [ring[0]]], colors=[color], radii=0.006))

    def log_paths(self, sim_time: float) -> None:
        """End-effector (from forward kinematics on the latest joint positions) and CoM paths as line strips."""
        if not self.base_known:
            return
        poses = self.link_poses(self.positions)
        for link, path in self.ee_paths.items():
            path.append(poses[self.fk.link_index[link], :3, 3])
        self.set_time(sim_time)
        markers = f"{self.world}/markers"
        strips = [path.array() for path in self.ee_paths.values() if len(path) >= 2]
        if strips:
            self.recording.log(f"{markers}/ee_paths", rr.LineStrips3D(
                strips, radii=0.004, colors=[[230, 60, 200, 255]]))
        if len(self.com_path) >= 2:
            self.recording.log(f"{markers}/com_path", rr.LineStrips3D([self.com_path.array()],
                                                                       radii=0.004,
                                                                       colors=[[60, 200, 90, 255]]))

    def log_target(self, sim_time: float, controller: str, target: Mapping[str, float]) -> None:
        """The target pose of the active trajectory: a skeleton of the robot at the target joint values."""
        positions = dict(self.positions)
        positions.update(target)
        points = self.link_poses(positions)[:, :3, 3]
        index = self.fk.link_index
        segments = [[points[index[parent]].tolist(), points[index[child]].tolist()]
                    for parent, child in zip(self.fk.parent_names, self.fk.child_names, strict=True)]
        self.set_time(sim_time)
        entity = f"{self.world}/markers/target"
        self.recording.log(entity, rr.LineStrips3D(segments, radii=0.006, colors=[[255, 140, 0, 160]]))
        self.recording.log(f"{entity}/end_effectors", rr.Points3D(
            [points[index[link]].tolist() for link in self.end_effectors], radii=0.025,
            colors=[[255, 140, 0, 255]]))
