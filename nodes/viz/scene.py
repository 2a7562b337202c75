"""Everything the viewer writes to Rerun, with plain numbers in (no Zenoh, no messages).

Entity layout (one subtree per robot namespace, so a deleted robot is one recursive Clear). A browser viewer
takes in a bounded number of *chunks* per second, whatever their size, and the SDK batches one chunk per
entity and flush for rows with the same components (docs/viewer.md). So everything of a robot that
changes is one row of one entity, logged with each joint_states sample:

- ``world/<ns>/robot``                               the robot: its URDF primitive visuals (Boxes3D,
                                                     Cylinders3D, Ellipsoids3D side by side, one instance per
                                                     visual, placed in the world through our tf tree: tf,
                                                     tf_static, the root from sim/model_states, or our own
                                                     FK); its built-in markers (Points3D: CoM, its ground
                                                     projection, ZMP, the measured centre of pressure, the
                                                     target's end effectors; LineStrips3D: end-effector and
                                                     CoM paths, support polygon, the target pose's skeleton;
                                                     Arrows3D: the feet's forces); and every plotted value as
                                                     columns the blueprint maps to its plots (``blueprint.py``):
                                                     ``position:<group>``, ``velocity:<group>``,
                                                     ``effort:<group>`` (one value per joint of the limb group),
                                                     ``<controller>:<group>`` (reference and actual per joint,
                                                     the latest controller_state), ``balance:values``
                                                     (CoM x y z, ZMP x y, is_balanced) and the IMUs'
                                                     ``angular_velocity:<imu>``, ``linear_acceleration:<imu>``
- ``world/<ns>/links/<link>/visual_<i>``              mesh visuals, one entity each with its world pose
- ``world/<ns>/cameras/...``, ``world/<ns>/ranges``   the rendered sensors (``sensors.py``)

The ground is the viewer's own line grid (a blueprint setting: no data, never dropped by the web server).

Time: every call takes the message stamp. Sim-time stamps go on the ``sim_time`` timeline (a duration from
the start of the simulation); stamps from the wall clock (nodes that run without a simulator, like
arm_viz's joint sweep: seconds since 1970) go on ``wall_time``, as timestamps, so no axis reads "+20780d".
Rerun adds ``log_time`` (when each row was logged) to every row.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import rerun as rr

from nodes.kinematics import KinematicTree, matrix_to_quaternion, pose_matrix
from nodes.urdf.model import RobotModel, UrdfError, Visual, parse_urdf
from nodes.urdf.validate import validate

from .ratelimit import RateLimiter

SIM_TIMELINE = "sim_time"
WALL_TIMELINE = "wall_time"
WORLD_FRAME = "tf#/world"  # Rerun's implicit frame of the entity "world": the 3-D view's root
SOLID = rr.components.FillMode.Solid
PLOT_ROWS_DRIVE = 0.5  # s after a row with plotted values during which only such rows are logged
PATH_LENGTH = 40  # points kept per marker path (20 s at the 2 Hz marker rate)
EPOCH_STAMP = 1e9  # s: a stamp past 2001-09-09 is the wall clock, not a simulation's time
MAX_GROUP = 8  # joints per plot: more series than this make an unreadable legend
LIMB_WORDS = {
    "leg": ("leg", "hip", "knee", "ankle", "foot", "toe"),
    "arm": ("arm", "shoulder", "elbow", "wrist", "hand", "finger", "gripper"),
}
SIDES = {"left": "left", "l": "left", "right": "right", "r": "right"}
SHAPES = {"box": "boxes", "cylinder": "cylinders", "sphere": "spheres"}  # URDF primitive -> entity name
FORCE_COLOR = (255, 120, 30, 255)  # the feet's force arrows
COP_COLOR = (40, 220, 240, 255)  # the measured centre of pressure
ARROW_RADIUS = 0.008
CONTACT_COLOR = (230, 40, 200, 255)  # contact points of a contact sensor (gazebo_ros' bumper)
CONTACT_RADIUS = 0.008


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


def visual_leaves(model: RobotModel) -> list[str]:
    """The default end effectors: links with a visual below which no link has one (hands, feet and the
    head, though sensor frames such as a camera's hang off it), else the URDF's leaf links."""
    def drawn_below(link: str) -> bool:
        return any(model.links[j.child].visuals or drawn_below(j.child) for j in model.children_of(link)
                   if j.child in model.links)

    leaves = [name for name, link in model.links.items() if link.visuals and not drawn_below(name)]
    return leaves or model.leaf_links()


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


def is_wall_stamp(stamp: float) -> bool:
    return stamp >= EPOCH_STAMP


class SceneTime:
    """Sets the timelines on a recording before each log call (see the module's docstring)."""

    def __init__(self, recording: rr.RecordingStream) -> None:
        self.recording = recording

    def __call__(self, stamp: float) -> None:
        if is_wall_stamp(stamp):
            # Time context is per thread and sticky: a sim_time set earlier on this thread must not
            # stay attached to wall-stamped rows.
            self.recording.disable_timeline(SIM_TIMELINE)
            self.recording.set_time(WALL_TIMELINE, timestamp=stamp)
            return
        # Sim stamps go on sim_time only: every timeline costs the viewer an index entry per row, and
        # Rerun's own log_time already holds the wall clock of each row.
        self.recording.disable_timeline(WALL_TIMELINE)
        self.recording.set_time(SIM_TIMELINE, duration=max(0.0, stamp))


def joint_groups(joint_names: Sequence[str]) -> dict[str, list[str]]:
    """Joints in plot groups, for legends that can be read: by limb when the names say it
    (``left_knee`` and ``l_leg_kny`` are both in "left leg"; waist, neck, back in "torso & head"),
    in URDF order otherwise, at most ``MAX_GROUP`` per group. A small robot is one group."""
    names = list(joint_names)
    if len(names) <= MAX_GROUP:
        return {"joints": names} if names else {}
    groups: dict[str, list[str]] = {}
    for name in names:
        tokens = name.lower().replace("-", "_").split("_")
        side = next((SIDES[t] for t in tokens[:1] if t in SIDES), "")
        limb = next((limb for limb, words in LIMB_WORDS.items() if any(w in t for t in tokens for w in words)), "")
        if side and limb:
            key = f"{side} {limb}"
        elif side:
            key = f"{side} side"
        else:
            key = "torso & head" if limb == "" else limb
        groups.setdefault(key, []).append(name)
    order = ["left leg", "right leg", "left arm", "right arm", "torso & head"]
    ordered = {k: groups[k] for k in order if k in groups}
    ordered.update({k: v for k, v in groups.items() if k not in ordered})
    result: dict[str, list[str]] = {}
    for key, members in ordered.items():
        chunks = [members[i:i + MAX_GROUP] for i in range(0, len(members), MAX_GROUP)]
        for index, chunk in enumerate(chunks):
            result[key if len(chunks) == 1 else f"{key} {index + 1}"] = chunk
    return result


QUANTITIES = ("position", "velocity", "effort")
BALANCE_SERIES = ["CoM x", "CoM y", "CoM z", "ZMP x", "ZMP y", "balanced"]
# Eight colours that stay apart on the viewer's dark background (one per joint of a group).
PALETTE = [[230, 85, 70], [80, 160, 240], [250, 190, 50], [90, 200, 120], [200, 110, 230], [60, 210, 210],
           [245, 130, 190], [170, 170, 170]]


def lighter(color: Sequence[int]) -> list[int]:
    return [int(c + (255 - c) * 0.55) for c in color]


def short_labels(members: Sequence[str]) -> list[str]:
    """Legend labels without the prefix every member shares (``left_knee`` -> ``knee`` in "left leg"), so
    the legend stays narrow; full names when that would leave a label empty or ambiguous."""
    if len(members) < 2:
        return list(members)
    split = [m.split("_") for m in members]
    common = 0
    while all(len(parts) > common + 1 and parts[common] == split[0][common] for parts in split):
        common += 1
    labels = ["_".join(parts[common:]) for parts in split]
    return labels if len(set(labels)) == len(labels) else list(members)


def group_part(group: str) -> str:
    """A plot group's name in component names (``left leg`` -> ``left_leg``)."""
    return "".join(c if c.isalnum() or c in "_-" else "_" for c in group.replace(" & ", "_").replace(" ", "_"))


@dataclass(frozen=True)
class PlotGroup:
    """One plot: its component name part (``left_leg``), the joints it plots and their legend labels."""

    part: str
    joints: tuple[str, ...]
    labels: tuple[str, ...]


def plot_groups(joint_names: Sequence[str]) -> list[PlotGroup]:
    return [PlotGroup(group_part(group), tuple(members), tuple(short_labels(members)))
            for group, members in joint_groups(joint_names).items()]


def robot_entity(namespace: str) -> str:
    """The entity of a robot: its primitives, markers and every plotted value."""
    return f"world/{namespace}/robot"


def series_component(kind: str, part: str) -> str:
    """The column a plot reads in ``world/<ns>/robot``: ``position:left_leg``, ``<controller>:left_leg``."""
    return f"{kind}:{part}"


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
    return mesh_archetype(visual, mesh_root)[0]


def mesh_archetype(visual: Visual, mesh_root: Path | None = None) -> tuple[rr.AsComponents | None, str]:
    """A mesh visual as a ``Mesh3D`` in its visual frame (scale applied, shaded, each material in its colour:
    the URDF's where the file gives none), read through ``nodes.meshes`` as the simulator reads it, so every
    format it takes (DAE too) is drawn; ``(None, reason)`` for one that resolves nowhere or is refused."""
    from nodes.meshes import MeshError, load_mesh  # noqa: PLC0415 - only robots with meshes pay for it
    from nodes.meshes.paths import resolve_mesh  # noqa: PLC0415

    try:
        mesh = load_mesh(resolve_mesh(visual.filename, mesh_root / "robot.urdf" if mesh_root else None))
    except MeshError as exc:
        return None, str(exc)
    scale = np.asarray(visual.scale, dtype=np.float64)
    positions, indices, colours, offset = [], [], [], 0
    for part in mesh.parts:
        positions.append(part.vertices * scale)
        indices.append(part.faces + offset)
        colours.append(np.tile(rgba8(part.rgba or visual.rgba), (len(part.vertices), 1)))
        offset += len(part.vertices)
    vertices, faces = np.concatenate(positions), np.concatenate(indices)
    return rr.Mesh3D(vertex_positions=vertices.astype(np.float32), triangle_indices=faces.astype(np.uint32),
                     vertex_normals=vertex_normals(vertices, faces), vertex_colors=np.concatenate(colours)), ""


def vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Area-weighted vertex normals (Rerun draws a mesh without normals unlit)."""
    corners = vertices[faces]
    face_normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    normals = np.zeros_like(vertices)
    for k in range(3):
        np.add.at(normals, faces[:, k], face_normals)
    lengths = np.linalg.norm(normals, axis=1, keepdims=True)
    return np.divide(normals, lengths, out=np.zeros_like(normals), where=lengths > 0).astype(np.float32)


def shape_fields(visuals: Sequence[tuple[str, Visual]]) -> dict[str, np.ndarray]:
    """What every row repeats about these primitive visuals (one kind): their origins in their links, sizes
    and colours, as arrays indexed like ``visuals``."""
    return {
        "origins": np.array([v.origin for _, v in visuals], float).reshape(-1, 4, 4),
        "colors": np.array([rgba8(v.rgba) for _, v in visuals], np.uint8).reshape(-1, 4),
        "half_sizes": np.array([[x / 2 for x in v.size] if v.kind == "box" else [v.radius] * 3
                                for _, v in visuals], float).reshape(-1, 3),
        "lengths": np.array([v.length if v.kind == "cylinder" else 0.0 for _, v in visuals], float),
        "radii": np.array([v.radius if v.kind == "cylinder" else 0.0 for _, v in visuals], float),
    }


class RobotScene:
    """The Rerun side of one robot: geometry, frames, plots and markers under its namespace."""

    def __init__(self, recording: rr.RecordingStream, namespace: str, model: RobotModel,
                 end_effectors: Sequence[str] = (), world_frames: Sequence[str] = ("world", "map", "odom"),
                 path_length: int = PATH_LENGTH, pose_limiter: RateLimiter | None = None) -> None:
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
        self.end_effectors = wanted or visual_leaves(model)
        self.world = f"world/{namespace}"
        self.entity = robot_entity(namespace)
        self.root_frame = frame_name(namespace, model.root, self.world_frames)
        # Our tf tree: child frame -> (parent frame, parent-from-child transform), from tf, tf_static, the
        # simulator's base pose or our own forward kinematics.
        self.frames: dict[str, tuple[str, np.ndarray]] = {}
        self.pose_limiter = pose_limiter
        self.parent_joint = {child: i for i, child in enumerate(self.fk.child_names)}  # link -> fk joint index
        self.shapes: dict[str, list[tuple[str, Visual]]] = {}
        self.shape_fields: dict[str, dict[str, np.ndarray]] = {}  # per kind: each visual's origin, size, colour
        self.meshes: list[tuple[str, np.ndarray, str, rr.AsComponents]] = []
        self.base_pose = np.eye(4)
        self.base_from_tf = False  # once tf names the root's parent, model_states no longer places it
        self.base_known = False  # no path points until the robot's place in the world is known
        self.positions: dict[str, float] = {}
        self.last_row = 0.0  # monotonic time of the last row of the robot entity
        self.last_plot_row = -PLOT_ROWS_DRIVE  # ... and of the last one with plotted values
        self.group_cache: dict[tuple[str, ...], list[tuple[PlotGroup, np.ndarray]]] = {}
        # The plot groups, for the blueprint: joint_states', and each controller's.
        self.plot_groups: list[PlotGroup] = []
        self.controller_groups: dict[str, list[PlotGroup]] = {}
        self.com_path = PathBuffer(path_length)
        self.ee_paths = {link: PathBuffer(path_length) for link in self.end_effectors}
        # The markers' current parts (name -> points or strips), drawn with every row.
        self.marker_points: dict[str, tuple[np.ndarray, list[float], list[list[int]]]] = {}
        self.marker_strips: dict[str, tuple[list[np.ndarray], float, list[int]]] = {}
        # Force arrows (name -> origin, vector, colour): the feet's force/torque sensors.
        self.marker_arrows: dict[str, tuple[np.ndarray, np.ndarray, list[int]]] = {}
        self.skipped_meshes: list[str] = []

    # -- model ---------------------------------------------------------------------------------------
    def log_model(self, sim_time: float, mesh_root: Path | None = None) -> int:
        """Prepare the robot's geometry and draw it (at the origin until a pose arrives); returns how many
        visuals it has. The primitives are instances of the robot entity (see the module docstring); meshes
        are an entity each (``world/<ns>/links/<link>/visual_<i>``)."""
        self.shapes = {}
        self.meshes = []
        for link, link_model in self.model.links.items():
            for index, visual in enumerate(link_model.visuals):
                if visual.kind in SHAPES:
                    self.shapes.setdefault(visual.kind, []).append((link, visual))
                    continue
                archetype, reason = mesh_archetype(visual, mesh_root)
                if archetype is None:
                    self.skipped_meshes.append(f"{visual.filename} ({reason})")
                    continue
                self.meshes.append((link, visual.origin, f"{self.world}/links/{link}/visual_{index}", archetype))
        self.shape_fields = {kind: shape_fields(visuals) for kind, visuals in self.shapes.items()}
        if not self.base_from_tf and self.root_frame not in self.frames:
            # Until a pose arrives, the robot stands at the origin rather than nowhere.
            self.frames[self.root_frame] = (WORLD_FRAME, np.eye(4))
        self.log_robot(sim_time, force=True)
        return sum(len(v) for v in self.shapes.values()) + len(self.meshes)

    def clear(self, sim_time: float) -> None:
        """The robot was deleted: hide its whole subtree from this time on."""
        self.set_time(sim_time)
        self.recording.log(self.world, rr.Clear(recursive=True))

    # -- frames --------------------------------------------------------------------------------------
    def log_transforms(self, sim_time: float,
                       transforms: Sequence[tuple[str, str, Sequence[float], Sequence[float]]]) -> None:
        """``(parent, child, xyz, quat_xyzw)`` rows from a TFMessage (tf or tf_static): our tf tree."""
        for parent, child, xyz, quat in transforms:
            parent_frame = frame_name(self.namespace, parent, self.world_frames)
            child_frame = frame_name(self.namespace, child, self.world_frames)
            if child_frame == WORLD_FRAME or child_frame == parent_frame:
                continue
            if child_frame == self.root_frame and parent_frame == WORLD_FRAME:
                self.base_from_tf = self.base_known = True
                self.base_pose = pose_matrix(xyz, quat)
            self.frames[child_frame] = (parent_frame, pose_matrix(xyz, quat))
        self.log_robot(sim_time)

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
        self.frames[self.root_frame] = (WORLD_FRAME, self.base_pose)
        self.log_robot(sim_time)

    def world_pose(self, frame: str) -> np.ndarray | None:
        """``frame`` (a Rerun frame name, see ``frame_name``) in the world through our tf tree; None when
        the chain to the world is broken."""
        pose = np.eye(4)
        seen = 0
        while frame != WORLD_FRAME:
            link = self.frames.get(frame)
            if link is None or seen > len(self.frames):
                return None
            pose = link[1] @ pose
            frame = link[0]
            seen += 1
        return pose

    def frame_pose(self, frame: str) -> np.ndarray | None:
        """A tf frame of this robot (``pelvis``, ``humanoid/pelvis``) in the world: tf, else the URDF."""
        name = frame_name(self.namespace, frame, self.world_frames)
        pose = self.world_pose(name)
        link = name.removeprefix(f"{self.namespace}/")
        if pose is None and link in self.fk.link_index:
            pose = self.link_poses(self.positions)[self.fk.link_index[link]]
        return pose

    def log_robot(self, sim_time: float, force: bool = False,
                  plots: Mapping[str, Mapping[str, np.ndarray]] | None = None) -> None:
        """One row of the robot entity: every visual at its link's world pose, the markers, and the plotted
        values when given (``plots``: column kind -> group -> values). Without plotted values, and unless
        ``force``, nothing is logged while joint_states rows come (the next one draws the new pose: one kind
        of row, one chunk per flush), and at most at ``pose_limiter``'s rate otherwise."""
        if plots is None and not force:
            if time.monotonic() - self.last_plot_row < PLOT_ROWS_DRIVE:
                return
            if self.pose_limiter is not None and not self.pose_limiter.ready():
                return
        self.set_time(sim_time)
        poses: dict[str, np.ndarray | None] = {}
        local: list[np.ndarray] = []

        def link_pose(link: str) -> np.ndarray | None:
            if link not in poses:
                pose = self.world_pose(frame_name(self.namespace, link, self.world_frames))
                joint = self.parent_joint.get(link)
                if pose is None and joint is not None:
                    # Not (yet) in tf, e.g. a fixed joint before tf_static: its parent's pose and the URDF
                    # joint at the last joint values.
                    if not local:
                        local.append(self.fk.local_transforms(self.fk.configuration(self.positions)))
                    parent = link_pose(self.fk.parent_names[joint])
                    pose = None if parent is None else parent @ local[0][joint]
                poses[link] = pose
            return poses[link]

        # Every kind on every row, empty when nothing of it is placed: rows with the same components are
        # batched into one chunk per flush. Sizes and colours come from ``shape_fields`` (fixed per model) and
        # the poses are converted in one vectorised call: this is the viewer's per-row cost.
        archetypes = []
        for kind, visuals in self.shapes.items():
            link_poses = [link_pose(link) for link, _ in visuals]
            placed = [i for i, pose in enumerate(link_poses) if pose is not None]
            fields = self.shape_fields[kind]
            if len(placed) < len(visuals):
                fields = {name: values[placed] for name, values in fields.items()}
            matrices = (np.stack([link_poses[i] for i in placed]) @ fields["origins"] if placed
                        else np.zeros((0, 4, 4)))
            centers = matrices[:, :3, 3]
            quats = matrix_to_quaternion(matrices[:, :3, :3]) if placed else np.zeros((0, 4))
            common = {"centers": centers, "quaternions": quats, "colors": fields["colors"], "fill_mode": SOLID}
            if kind == "box":
                archetypes.append(rr.Boxes3D(half_sizes=fields["half_sizes"], **common))
            elif kind == "cylinder":  # URDF and Rerun cylinders both run along local z
                archetypes.append(rr.Cylinders3D(lengths=fields["lengths"], radii=fields["radii"], **common))
            else:
                archetypes.append(rr.Ellipsoids3D(half_sizes=fields["half_sizes"], **common))
        archetypes += self.marker_archetypes()
        archetypes += [rr.DynamicArchetype(kind, components=parts) for kind, parts in (plots or {}).items()]
        self.recording.log(self.entity, *archetypes)
        self.last_row = time.monotonic()
        if plots is not None:  # a joint_states row (with no plotted values when no plot tab is shown)
            self.last_plot_row = self.last_row
        for link, origin, entity, archetype in self.meshes:
            pose = link_pose(link)
            if pose is None:
                continue
            world = pose @ origin
            # The mesh itself only with the model and key frames (``refresh``), not with every pose.
            parts = [archetype] if force and plots is None else []
            self.recording.log(entity, *parts, rr.Transform3D(
                translation=world[:3, 3], quaternion=matrix_to_quaternion(world[:3, :3])))

    # -- plots ---------------------------------------------------------------------------------------
    def _groups(self, names: tuple[str, ...]) -> list[tuple[PlotGroup, np.ndarray]]:
        """``(plot group, indices into names)`` per plot group of these joint names."""
        cached = self.group_cache.get(names)
        if cached is None:
            index = {name: i for i, name in enumerate(names)}
            cached = [(group, np.array([index[j] for j in group.joints])) for group in plot_groups(names)]
            self.group_cache[names] = cached
        return cached

    def log_joint_states(self, sim_time: float, names: Sequence[str], position: Sequence[float],
                         velocity: Sequence[float], effort: Sequence[float],
                         quantities: Sequence[str] = QUANTITIES,
                         controllers: Mapping[str, tuple[Sequence[str], Sequence[float], Sequence[float]]] | None = None,
                         balance: Sequence[float] | None = None,
                         extra: Mapping[str, Mapping[str, np.ndarray]] | None = None) -> None:
        """The robot's row for this joint_states sample, with every plotted value: positions, velocities and
        efforts per limb group (those of ``quantities``), each controller's reference and actual position per
        joint of its groups (``controllers``: name -> (joint names, reference, actual)), and the balance values
        (CoM x y z, ZMP x y, is_balanced); ``extra``: more columns (kind -> part -> values: the IMUs')."""
        names = tuple(names)
        self.positions.update(zip(names, position, strict=False))
        groups = self._groups(names)
        self.plot_groups = [g for g, _ in groups]
        columns: dict[str, dict[str, np.ndarray]] = {}
        for quantity, values in zip(QUANTITIES, (position, velocity, effort), strict=True):
            if quantity not in quantities or len(values) != len(names) or not names:
                continue
            array = np.asarray(values, float)
            columns[quantity] = {group.part: array[indices] for group, indices in groups}
        for controller, (joints, commanded, actual) in sorted((controllers or {}).items()):
            controller_groups = self._groups(tuple(joints))
            self.controller_groups[controller] = [g for g, _ in controller_groups]
            both = np.column_stack((np.asarray(commanded, float), np.asarray(actual, float)))
            columns[controller] = {group.part: both[indices].ravel() for group, indices in controller_groups}
        if balance is not None:
            columns["balance"] = {"values": np.asarray(balance, float)}
        for kind, parts in (extra or {}).items():
            columns.setdefault(kind, {}).update(parts)
        self.log_robot(sim_time, force=True, plots=columns)

    def refresh(self, sim_time: float, period: float) -> None:
        """A key frame when nothing was logged for ``period`` s (a paused simulation): the robot and its
        markers again, so that a viewer which only gets the last seconds of the stream (the server keeps a
        short history) still draws them."""
        if time.monotonic() - self.last_row >= period or self.meshes:
            self.log_robot(sim_time, force=True)

    # -- markers -------------------------------------------------------------------------------------
    def marker_archetypes(self) -> list:
        """Every built-in marker: points and line strips, each with its own radius and colour (both always
        present, empty or not, so that every row of the robot has the same components)."""
        points = [p for p, _, _ in self.marker_points.values()]
        strips = [(strip, radius, color) for parts, radius, color in self.marker_strips.values() for strip in parts]
        arrows = list(self.marker_arrows.values())
        return [rr.Points3D(np.concatenate(points) if points else np.zeros((0, 3)),
                            radii=[r for _, radii, _ in self.marker_points.values() for r in radii],
                            colors=[c for _, _, colors in self.marker_points.values() for c in colors]),
                rr.LineStrips3D([strip for strip, _, _ in strips], radii=[r for _, r, _ in strips],
                                colors=[c for _, _, c in strips]),
                rr.Arrows3D(origins=np.array([a[0] for a in arrows], float).reshape(-1, 3),
                            vectors=np.array([a[1] for a in arrows], float).reshape(-1, 3),
                            radii=[ARROW_RADIUS] * len(arrows), colors=[a[2] for a in arrows])]

    def update_arrow(self, name: str, origin: Sequence[float] | None, vector: Sequence[float] = (0.0, 0.0, 0.0),
                     color: Sequence[int] = FORCE_COLOR) -> None:
        """A force arrow drawn from the next row on (RViz's WrenchStamped display); ``origin`` None removes it."""
        if origin is None:
            self.marker_arrows.pop(name, None)
            return
        self.marker_arrows[name] = (np.asarray(origin, float), np.asarray(vector, float), list(color))

    def update_contacts(self, name: str, points: np.ndarray | None) -> None:
        """A contact sensor's contact points (world frame) drawn from the next row on; None removes them."""
        if points is None or not len(points):
            self.marker_points.pop(f"contacts:{name}", None)
            return
        self.marker_points[f"contacts:{name}"] = (np.asarray(points, float).reshape(-1, 3), [CONTACT_RADIUS] * len(points),
                                                   [list(CONTACT_COLOR)] * len(points))

    def update_balance(self, com: Sequence[float], zmp: Sequence[float], is_balanced: bool,
                       support_polygon: Sequence[Sequence[float]], cop: Sequence[float] | None = None) -> None:
        """The balance markers (drawn from the next row on): CoM, its ground projection and the ZMP
        (yellow), the centre of pressure the feet's force/torque sensors measured (cyan, when given), the
        support polygon on the ground, and a point of the CoM path."""
        self.com_path.append(com)
        color = [60, 200, 90, 255] if is_balanced else [230, 60, 50, 255]
        points, radii, colors = [com, [com[0], com[1], 0.0], [zmp[0], zmp[1], 0.003]], [0.03, 0.015, 0.02], \
            [color, color, [250, 220, 40, 255]]
        if cop is not None:
            points.append([cop[0], cop[1], 0.004])
            radii.append(0.018)
            colors.append(list(COP_COLOR))
        self.marker_points["com"] = (np.array(points, float), radii, colors)
        if len(support_polygon) >= 2:
            ring = [[p[0], p[1], max(p[2], 0.0) + 0.003] for p in support_polygon]
            self.marker_strips["support_polygon"] = ([np.array(ring + [ring[0]], float)], 0.006, color)
        if len(self.com_path) >= 2:
            self.marker_strips["com_path"] = ([self.com_path.array()], 0.004, [60, 200, 90, 255])

    def update_paths(self) -> None:
        """A point of each end-effector path (forward kinematics on the latest joint positions), once the
        robot's place in the world is known."""
        if not self.base_known:
            return
        poses = self.link_poses(self.positions)
        for link, path in self.ee_paths.items():
            path.append(poses[self.fk.link_index[link], :3, 3])
        strips = [path.array() for path in self.ee_paths.values() if len(path) >= 2]
        if strips:
            self.marker_strips["ee_paths"] = (strips, 0.004, [230, 60, 200, 255])

    def log_target(self, sim_time: float, controller: str, target: Mapping[str, float]) -> None:
        """The target pose of the active trajectory: a skeleton of the robot at the target joint values."""
        positions = dict(self.positions)
        positions.update(target)
        points = self.link_poses(positions)[:, :3, 3]
        index = self.fk.link_index
        segments = [np.array([points[index[parent]], points[index[child]]])
                    for parent, child in zip(self.fk.parent_names, self.fk.child_names, strict=True)]
        self.marker_strips["target"] = (segments, 0.006, [255, 140, 0, 160])
        self.marker_points["target"] = (np.array([points[index[link]] for link in self.end_effectors], float),
                                        [0.025] * len(self.end_effectors), [[255, 140, 0, 255]] * len(self.end_effectors))
        self.log_robot(sim_time)
