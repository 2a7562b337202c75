"""Robot state publisher: URDF -> ``robot_description``; ``joint_states`` -> forward kinematics -> ``tf``.

The ROS ``robot_state_publisher`` behaviour on Zenoh (docs/robots.md, Robot state publisher):

- ``<ns>/robot_description`` (std_msgs/String) published at start and on change, and latched (a queryable
  answers late joiners);
- ``<ns>/tf_static`` (tf2_msgs/TFMessage) latched: every fixed joint, once;
- ``<ns>/tf``: every movable joint (mimic included) from ``<ns>/joint_states``, at most ``publish_frequency``
  times per second; joints missing from a message keep their last value;
- the model's world pose from ``sim/model_states`` as ``world -> <root>`` (so a floating pelvis moves).

Run: ``python -m nodes.state_publisher --ns humanoid --param robot_description_file:=robots/humanoid.urdf``
(or ``--param robot_description:="<robot ...>"``; xacro args via ``--param xacro_args:="name:=value ..."``).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

import msgs
from msgs.gazebo_msgs import ModelStates
from msgs.sensor_msgs import JointState
from msgs.std_msgs import String
from msgs.tf2_msgs import TFMessage
from nodes.core import Node, ParameterError, run_node
from nodes.core.delivery import Batched
from nodes.kinematics import KinematicTree
from nodes.urdf import UrdfError, load_robot_description, parse_urdf, parse_xacro_args, validate

_stamp = msgs.time_map
_pack_tf = msgs.packer("tf2_msgs/msg/TFMessage")
_header = msgs.builder("std_msgs/msg/Header")
_transform_stamped = msgs.builder("geometry_msgs/msg/TransformStamped")
_transform_map = msgs.builder("geometry_msgs/msg/Transform")
_vector3 = msgs.builder("geometry_msgs/msg/Vector3")
_quaternion = msgs.builder("geometry_msgs/msg/Quaternion")


def _transform(stamp: dict[str, int], parent: str, child: str, xyz: Sequence[float], quat: Sequence[float]) -> dict:
    """One geometry_msgs/TransformStamped as its msgpack map."""
    return _transform_stamped(
        header=_header(stamp=stamp, frame_id=parent), child_frame_id=child,
        transform=_transform_map(translation=_vector3(x=xyz[0], y=xyz[1], z=xyz[2]),
                                 rotation=_quaternion(x=quat[0], y=quat[1], z=quat[2], w=quat[3])))


class TransformTree:
    """Pure logic (no Zenoh): joint values in, tf transform maps out. One instance per robot description."""

    def __init__(self, urdf_xml: str, frame_prefix: str = "") -> None:
        self.model = parse_urdf(urdf_xml)
        errors = [i.message for i in validate(self.model) if i.severity == "error"]
        if errors:
            raise UrdfError(errors[0])
        self.kinematics = KinematicTree(self.model)
        self.prefix = frame_prefix
        self.positions = self.kinematics.zero_configuration()
        k = self.kinematics
        self._parents = [frame_prefix + name for name in k.parent_names]
        self._children = [frame_prefix + name for name in k.child_names]
        self.movable = k.movable_indices
        self.fixed = np.flatnonzero(k.fixed_mask)
        self._names_cache: tuple[tuple[str, ...], np.ndarray, np.ndarray, list[str]] | None = None

    @property
    def root_frame(self) -> str:
        return self.prefix + self.kinematics.root

    def update(self, names: Sequence[str], positions: Sequence[float]) -> list[str]:
        """Set the named joints (others keep their value); returns names that are not degrees of freedom."""
        key = tuple(names)
        if self._names_cache is None or self._names_cache[0] != key:
            # Message layouts rarely change: map names to indices once per layout, then copy vectorised.
            index = self.kinematics.dof_index
            known = [i for i, n in enumerate(key) if n in index]
            self._names_cache = (
                key,
                np.array(known, dtype=np.intp),
                np.array([index[key[i]] for i in known], dtype=np.intp),
                [n for n in key if n not in index],
            )
        _, source, target, unknown = self._names_cache
        if len(source):
            self.positions[target] = np.asarray(positions, dtype=float)[source]
        return unknown

    def _transforms(self, indices: np.ndarray, stamp: dict[str, int]) -> list[dict]:
        translation, quaternion = self.kinematics.local_poses(self.positions)
        quats = quaternion[indices].tolist()
        xyz = translation[indices].tolist()
        return [
            _transform(stamp, self._parents[i], self._children[i], xyz[n], quats[n])
            for n, i in enumerate(indices.tolist())
        ]

    def movable_transforms(self, stamp: dict[str, int]) -> list[dict]:
        return self._transforms(self.movable, stamp) if len(self.movable) else []

    def static_transforms(self, stamp: dict[str, int]) -> list[dict]:
        return self._transforms(self.fixed, stamp) if len(self.fixed) else []


def _xacro_args_valid(value: Any) -> str | None:
    items = value.split() if isinstance(value, str) else value
    if not isinstance(items, list) or not all(isinstance(i, str) for i in items):
        return "expected 'name:=value ...' or a list of such strings"
    try:
        parse_xacro_args(items)
    except UrdfError as exc:
        return str(exc)
    return None


class RobotStatePublisher(Node):
    default_name = "robot_state_publisher"

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("robot_state_publisher", **kwargs)
        self._setup()

    def _setup(self) -> None:
        self.declare_parameter("robot_description", "", description="URDF (or xacro) XML text")
        self.declare_parameter("robot_description_file", "", description="URDF or .xacro file (if no XML text)")
        self.declare_parameter("xacro_args", "", type=object, validator=_xacro_args_valid,
                               description="xacro arguments, 'name:=value ...' or a list")
        self.frequency = self.declare_parameter("publish_frequency", 50.0, description="max tf rate (Hz)",
                                                min_value=0.1, max_value=1000.0)
        self.frame_prefix = self.declare_parameter("frame_prefix", "", description="prefix of every link frame")
        self.world_frame = self.declare_parameter("world_frame", "world", description="parent of the root link")
        self.declare_parameter("model_name", "", description="entity in sim/model_states (default: robot name)")
        self.use_model_states = self.declare_parameter(
            "use_model_states", True, description="publish world -> root from sim/model_states")

        # Fail at start (exit 2) on an unusable description: there is nothing to publish without one.
        urdf = self._load_description(self.get_parameter("robot_description"),
                                      self.get_parameter("robot_description_file"),
                                      self.get_parameter("xacro_args"))
        self.tree = TransformTree(urdf, self.frame_prefix)
        self.urdf = urdf
        self.add_on_set_parameter_callback(self._on_set_parameter)

        self.description_pub = self.create_publisher(String, "robot_description", latched=True)
        self.static_pub = self.create_publisher(TFMessage, "tf_static", latched=True)
        self.tf_pub = self.create_publisher(TFMessage, "tf", reliable=False)  # periodic: drop, never block
        # joint_states may come at 1 kHz: wake at the tf rate and take everything that arrived meanwhile
        self.create_subscription(JointState, "joint_states", self.on_joint_states,
                                 delivery=Batched(self.frequency))
        if self.use_model_states:
            self.create_subscription(ModelStates, "/sim/model_states", self.on_model_states)

        self.period = 1.0 / self.frequency
        self.tokens, self.token_time = 1.0, None  # token bucket: average <= frequency, tolerates jitter
        self.last_stamp: float | None = None
        self.stamp_s = 0.0
        self.dirty = False
        self.base_pose: tuple[list[float], list[float]] | None = None
        self.create_timer(self.period, self._flush)
        self._publish_description()
        self.logger.info(
            f"robot '{self.tree.model.name}': {self.tree.kinematics.num_dofs} joints, "
            f"{len(self.tree.fixed)} fixed frames, root '{self.tree.root_frame}', tf at most {self.frequency:g} Hz"
        )

    # ------------------------------------------------------------------------------ description
    @staticmethod
    def _load_description(xml: str, path: str, xacro_args: Any) -> str:
        mappings = parse_xacro_args(xacro_args)
        if xml:
            return load_robot_description(xml=xml, xacro_args=mappings)
        if path:
            return load_robot_description(path=path, xacro_args=mappings)
        raise ParameterError("set 'robot_description' (XML) or 'robot_description_file' (path)")

    def _on_set_parameter(self, name: str, value: Any) -> str | None:
        """A new description (or xacro args) is validated first; a bad one is refused, the old one stays."""
        if name not in ("robot_description", "robot_description_file", "xacro_args"):
            return None
        current = {n: self.get_parameter(n) for n in ("robot_description", "robot_description_file", "xacro_args")}
        current[name] = value
        if name == "robot_description_file" and value:
            current["robot_description"] = ""  # a new file replaces text given earlier
        try:
            urdf = self._load_description(current["robot_description"], current["robot_description_file"],
                                          current["xacro_args"])
            tree = TransformTree(urdf, self.frame_prefix)
        except (UrdfError, ParameterError, ValueError) as exc:
            self.logger.error(f"new robot description refused: {exc}")
            return str(exc)
        # Joints that still exist keep their positions.
        old = self.tree
        tree.update(old.kinematics.dof_names, old.positions)
        self.tree, self.urdf = tree, urdf
        self._publish_description()
        self.logger.info(f"robot description changed: robot '{tree.model.name}'")
        return None

    def _publish_description(self) -> None:
        self.description_pub.publish(String(data=self.urdf))
        stamp = _stamp(self.now())
        self.static_pub.publish(msgs.from_dict(TFMessage, {"transforms": self.tree.static_transforms(stamp)}))
        self.dirty = True

    # ------------------------------------------------------------------------------------ inputs
    def on_joint_states(self, msg: Any) -> None:
        # Length mismatches and NaN never reach here: the decoder drops them with a throttled warning.
        if msg.position and len(msg.position) != len(msg.name):
            self.logger.warn_throttle(5.0, f"joint_states: {len(msg.name)} names but {len(msg.position)} positions")
            return
        if not msg.position:
            return
        unknown = self.tree.update(msg.name, msg.position)
        if unknown:
            self.logger.warn_once(f"joint_states names joints not in robot '{self.tree.model.name}': "
                                  f"{', '.join(unknown)} (ignored)", key=f"unknown:{','.join(unknown)}")
        stamp = msgs.time_to_sec(msg.header.stamp)
        if stamp <= 0.0:
            stamp = self.now()
        if self.last_stamp is not None and stamp < self.last_stamp:
            self.logger.warn_throttle(
                1.0, f"joint_states time moved backwards ({self.last_stamp:.3f} -> {stamp:.3f} s; bag replay?): "
                     "republishing transforms", key="time-backwards")
            self.tokens = max(self.tokens, 1.0)  # publish this one now, whatever the rate limit
        self.last_stamp = stamp
        self.stamp_s = stamp
        if not self.dirty:
            self.dirty = True
            self.call_soon(self._maybe_publish, where="tf")   # after the rest of this batch: the newest state

    def on_model_states(self, msg: Any) -> None:
        name = self.get_parameter("model_name") or self.tree.model.name
        try:
            index = msg.name.index(name)
        except ValueError:
            return
        if index >= len(msg.pose):
            self.logger.warn_throttle(5.0, f"sim/model_states: '{name}' has no pose entry")
            return
        pose = msg.pose[index]
        p, o = pose.position, pose.orientation
        quat = np.array([o.x, o.y, o.z, o.w], dtype=float)
        norm = float(np.linalg.norm(quat))
        if not np.isfinite(norm) or norm < 1e-9:
            self.logger.warn_throttle(5.0, f"sim/model_states: '{name}' has an invalid orientation")
            return
        self.base_pose = ([float(p.x), float(p.y), float(p.z)], (quat / norm).tolist())
        if self.last_stamp is None:
            self.stamp_s = self.now()
        self.dirty = True
        self._maybe_publish()

    # ---------------------------------------------------------------------------------- output
    def _take_token(self) -> bool:
        """Rate limit as a token bucket (capacity 2): input jitter does not cost output rate."""
        now = self.now()
        if self.token_time is None or now < self.token_time:  # first call, or the (sim) clock was reset
            self.tokens = max(self.tokens, 1.0)
        else:
            self.tokens = min(2.0, self.tokens + (now - self.token_time) * self.frequency)
        self.token_time = now
        if self.tokens >= 1.0:
            self.tokens -= 1.0
            return True
        return False

    def _maybe_publish(self) -> None:
        if self.dirty and self._take_token():
            self._publish_tf()

    def _flush(self) -> None:
        if self.dirty and self._take_token():
            self._publish_tf()

    def _publish_tf(self) -> None:
        if self.last_stamp is None and self.base_pose is None:
            return  # nothing measured yet: publishing the zero pose would be a lie
        stamp = _stamp(self.stamp_s)
        transforms = self.tree.movable_transforms(stamp) if self.last_stamp is not None else []
        if self.base_pose is not None:
            xyz, quat = self.base_pose
            transforms.append(_transform(stamp, self.world_frame, self.tree.root_frame, xyz, quat))
        # Built as plain maps and packed directly: ~5x cheaper than through message objects.
        self.tf_pub.publish_raw(_pack_tf(transforms=transforms))
        self.dirty = False


def main(argv: list[str] | None = None) -> int:
    return run_node(RobotStatePublisher, argv)


if __name__ == "__main__":
    raise SystemExit(main())
