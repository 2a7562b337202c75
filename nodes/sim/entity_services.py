"""gazebo_ros' entity services on ``sim/*`` with gazebo_msgs' layouts: get_model_list, get_entity_state,
set_entity_state, apply_link_wrench, clear_link_wrenches, apply_joint_effort, clear_joint_efforts.

Entities are named as Gazebo names them: a model (``box``) or a link of it (``box::link``); joints as
``model::joint`` (or a joint name only one model has). A refused request answers ``success: false`` and the
reason (naming the field) goes to the log, as gazebo_ros does where the layout has no status message.
They run on the stepping thread between control periods, like every ``sim/*`` service.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

import msgs
from nodes.core.log import Logger
from nodes.sim.interfaces import (
    ApplyJointEffort,
    ApplyLinkWrench,
    GetEntityState,
    GetModelList,
    JointRequest,
    LinkRequest,
    SetEntityState,
)
from nodes.sim.model import Model
from nodes.sim.pose import Pose, SpawnError
from nodes.sim.pushes import JointEffort, LinkWrench, Pushes, PushLimitError
from nodes.sim.sdf import MAX_COORDINATE
from nodes.sim.simulation import Simulation
from nodes.sim.world import GROUND_NAME

WORLD_FRAMES = ("", "world", "map")
MAX_SPEED = 1000.0          # m/s and rad/s a set_entity_state may give
MAX_FORCE = 1e6             # N, N m: of a wrench or a joint effort (DART integrates anything)

_EntityState = msgs.get_type("gazebo_msgs/msg/EntityState")
_Header = msgs.get_type("std_msgs/msg/Header")


class EntityError(ValueError):
    """A request naming something that is not there, or asking for what cannot be done (field and reason)."""


@dataclass
class Target:
    """A model, or one link of it (``body`` set)."""

    name: str
    model: Model | None      # None: the built-in ground plane
    body: Any = None         # DART BodyNode of a link

    def matrix(self) -> np.ndarray:
        if self.body is not None:
            return np.asarray(self.body.getWorldTransform().matrix())
        return self.model.world_matrix() if self.model is not None else np.eye(4)

    def twist(self) -> tuple[np.ndarray, np.ndarray]:
        if self.body is not None:
            return np.asarray(self.body.getLinearVelocity()), np.asarray(self.body.getAngularVelocity())
        return self.model.world_twist() if self.model is not None else (np.zeros(3), np.zeros(3))


def resolve(sim: Simulation, name: str, field: str) -> Target:
    """``model`` or ``model::link`` (links of nested models: ``model::nested::link``)."""
    model_name, _, link = name.strip().partition("::")
    if model_name == GROUND_NAME and sim.world.has_ground and link in ("", "link"):
        return Target(name, None)
    model = sim.entities.get(model_name)
    if model is None:
        known = ", ".join(([GROUND_NAME] if sim.world.has_ground else []) + list(sim.entities)) or "none"
        raise EntityError(f"{field}: no model named {model_name[:100]!r} (models: {known})")
    if not link:
        return Target(name, model)
    body = model.body(link)
    if body is None:
        raise EntityError(f"{field}: model {model_name!r} has no link {link[:100]!r} (links: "
                          f"{', '.join(model.link_names())})")
    return Target(name, model, body)


def _vector(value: Any) -> np.ndarray:
    return np.array([value.x, value.y, value.z], dtype=float)


def _finite(field: str, values, limit: float, unit: str) -> np.ndarray:
    array = np.asarray(values, dtype=float)
    if not np.all(np.isfinite(array)):
        raise EntityError(f"{field}: {array.tolist()} is not finite")
    if np.any(np.abs(array) > limit):
        raise EntityError(f"{field}: {array.tolist()} is beyond ±{limit:g} {unit}")
    return array


class EntityServices:
    def __init__(self, node: Any) -> None:
        """``node``: the simulator node (create_service, logger, sim)."""
        self.node = node
        self.sim: Simulation = node.sim
        self.logger: Logger = node.logger

    @property
    def pushes(self) -> Pushes:
        return self.sim.pushes

    def serve(self) -> None:
        create = self.node.create_service
        create(GetModelList, "/sim/get_model_list", self.get_model_list)
        create(GetEntityState, "/sim/get_entity_state", self.get_entity_state)
        create(SetEntityState, "/sim/set_entity_state", self.set_entity_state)
        create(ApplyLinkWrench, "/sim/apply_link_wrench", self.apply_link_wrench)
        create(LinkRequest, "/sim/clear_link_wrenches", self.clear_link_wrenches)
        create(ApplyJointEffort, "/sim/apply_joint_effort", self.apply_joint_effort)
        create(JointRequest, "/sim/clear_joint_efforts", self.clear_joint_efforts)

    def _header(self, frame: str = "") -> Any:
        return _Header(stamp=msgs.time_from_sec(self.sim.world.time), frame_id=frame)

    def _frame(self, name: str, field: str) -> Target | None:
        """None for the world frame."""
        return None if name.strip() in WORLD_FRAMES else resolve(self.sim, name, field)

    # ----------------------------------------------------------------------------------------- queries
    def get_model_list(self, _request: Any) -> Any:
        names = ([GROUND_NAME] if self.sim.world.has_ground else []) + list(self.sim.entities)
        return GetModelList.Response(header=self._header(), model_names=names, success=True)

    def get_entity_state(self, request: Any) -> Any:
        try:
            target = resolve(self.sim, request.name, "name")
            frame = self._frame(request.reference_frame, "reference_frame")
        except EntityError as exc:
            self.logger.error(f"get_entity_state {request.name[:100]!r}: {exc}")
            return GetEntityState.Response(header=self._header(), success=False)
        matrix = target.matrix()
        linear, angular = target.twist()
        if frame is not None:
            reference = frame.matrix()
            ref_linear, ref_angular = frame.twist()
            rotation = reference[:3, :3]
            matrix = np.linalg.inv(reference) @ matrix
            linear = rotation.T @ (linear - ref_linear)
            angular = rotation.T @ (angular - ref_angular)
        pose = Pose.from_matrix(matrix)
        state = _EntityState(name=request.name, reference_frame=request.reference_frame)
        self._fill(state, pose, linear, angular)
        return GetEntityState.Response(header=self._header(request.reference_frame), state=state, success=True)

    @staticmethod
    def _fill(state: Any, pose: Pose, linear: np.ndarray, angular: np.ndarray) -> None:
        p, q = state.pose.position, state.pose.orientation
        p.x, p.y, p.z = pose.position
        q.x, q.y, q.z, q.w = pose.orientation
        t = state.twist
        t.linear.x, t.linear.y, t.linear.z = (float(v) for v in linear)
        t.angular.x, t.angular.y, t.angular.z = (float(v) for v in angular)

    # ----------------------------------------------------------------------------------------- changes
    def set_entity_state(self, request: Any) -> Any:
        state = request.state
        try:
            message = self._set_state(state)
        except (EntityError, SpawnError) as exc:
            self.logger.error(f"set_entity_state {state.name[:100]!r} refused: {exc}")
            return SetEntityState.Response(success=False)
        self.logger.info(message)
        return SetEntityState.Response(success=True)

    def _set_state(self, state: Any) -> str:
        target = resolve(self.sim, state.name, "state.name")
        frame = self._frame(state.reference_frame, "state.reference_frame")
        p, q = state.pose.position, state.pose.orientation
        _finite("state.pose.position", [p.x, p.y, p.z], MAX_COORDINATE, "m")
        pose = Pose((p.x, p.y, p.z), (q.x, q.y, q.z, q.w)).validated()
        linear = _finite("state.twist.linear", _vector(state.twist.linear), MAX_SPEED, "m/s")
        angular = _finite("state.twist.angular", _vector(state.twist.angular), MAX_SPEED, "rad/s")
        matrix = pose.to_isometry().matrix()
        if frame is not None:
            reference = frame.matrix()
            matrix = reference @ matrix
            linear, angular = reference[:3, :3] @ linear, reference[:3, :3] @ angular
        if np.any(np.abs(matrix[:3, 3]) > MAX_COORDINATE):
            raise EntityError(f"state.pose: the world position {matrix[:3, 3].tolist()} is beyond "
                              f"±{MAX_COORDINATE:g} m")
        if target.model is None:
            raise EntityError(f"state.name: {GROUND_NAME} is the built-in ground: it does not move")
        world_pose = Pose.from_matrix(matrix)
        self.sim.wake(target.model.name)   # asleep at rest, it would not move on from its new state
        if target.body is None:
            target.model.set_world_pose(world_pose)
            target.model.set_world_twist(linear, angular)
        else:
            if not Model.set_free_link_state(target.body, matrix, linear, angular):
                raise EntityError(f"state.name: link {target.name!r} is held by joint "
                                  f"{target.body.getParentJoint().getName()!r}: set the state of its model instead")
        x, y, z = world_pose.position
        return f"set_entity_state: {target.name!r} at ({x:.3f}, {y:.3f}, {z:.3f})"

    def apply_link_wrench(self, request: Any) -> Any:
        try:
            message = self._apply_wrench(request)
        except EntityError as exc:
            self.logger.error(f"apply_link_wrench {request.link_name[:100]!r} refused: {exc}")
            return ApplyLinkWrench.Response(success=False, status_message=str(exc))
        self.logger.info(message)
        return ApplyLinkWrench.Response(success=True, status_message=message)

    def _apply_wrench(self, request: Any) -> str:
        target = resolve(self.sim, request.link_name, "link_name")
        if target.model is None or target.model.static:
            raise EntityError(f"link_name: {target.name!r} belongs to a static model: nothing to push")
        body = target.body if target.body is not None else target.model.skeleton.getRootBodyNode()
        link = f"{target.name.partition('::')[0]}::{body.getName()}"
        frame = self._frame(request.reference_frame, "reference_frame")
        force = _finite("wrench.force", _vector(request.wrench.force), MAX_FORCE, "N")
        torque = _finite("wrench.torque", _vector(request.wrench.torque), MAX_FORCE, "N m")
        point = _finite("reference_point", _vector(request.reference_point), MAX_COORDINATE, "m")
        duration = msgs.time_to_sec(request.duration)
        if duration == 0:
            raise EntityError("duration: 0 s applies nothing (negative: until cleared)")
        body_matrix = np.asarray(body.getWorldTransform().matrix())
        if frame is None:
            # the world's axes; the point is where the force acts relative to the link's origin
            point_world = body_matrix[:3, 3] + point
        else:
            reference = frame.matrix()
            force, torque = reference[:3, :3] @ force, reference[:3, :3] @ torque
            point_world = (reference @ np.append(point, 1.0))[:3]
        offset = body_matrix[:3, :3].T @ (point_world - body_matrix[:3, 3])
        now, dt = self.sim.world.time, self.sim.world.time_step
        start, end = Pushes.span(now, msgs.time_to_sec(request.start_time), duration, dt)
        try:
            self.pushes.add_wrench(LinkWrench(model=target.model.name, link=link, body=body, force=force,
                                              torque=torque, offset=offset, start=start, end=end), now)
        except PushLimitError as exc:
            raise EntityError(str(exc)) from None
        span = "until cleared" if math.isinf(end) else f"for {end - start:g} s"
        return (f"apply_link_wrench: force {force.round(6).tolist()} N, torque {torque.round(6).tolist()} N m on "
                f"{link!r} {span} from sim time {start:.3f} s")

    def clear_link_wrenches(self, request: Any) -> Any:
        name = request.link_name.strip()
        if "::" not in name and name in self.sim.entities:
            name = f"{name}::{self.sim.entities[name].skeleton.getRootBodyNode().getName()}"
        cleared = self.pushes.clear_link(name)
        self.logger.info(f"clear_link_wrenches {name[:100]!r}: {cleared} cleared")
        return LinkRequest.Response()

    def apply_joint_effort(self, request: Any) -> Any:
        try:
            message = self._apply_effort(request)
        except EntityError as exc:
            self.logger.error(f"apply_joint_effort {request.joint_name[:100]!r} refused: {exc}")
            return ApplyJointEffort.Response(success=False, status_message=str(exc))
        self.logger.info(message)
        return ApplyJointEffort.Response(success=True, status_message=message)

    def find_joint(self, name: str) -> tuple[Model, Any, str]:
        model_name, _, joint_name = name.strip().rpartition("::") if "::" in name else ("", "", name.strip())
        models = [self.sim.entities[model_name]] if model_name in self.sim.entities else (
            [] if model_name else list(self.sim.entities.values()))
        found = [(m, m.joint(joint_name)) for m in models if m.joint(joint_name) is not None]
        if not found:
            raise EntityError(f"joint_name: no joint {name[:100]!r} with a degree of freedom "
                              "(name it model::joint)")
        if len(found) > 1:
            raise EntityError(f"joint_name: {joint_name!r} is a joint of {[m.name for m, _ in found]}: name it "
                              "model::joint")
        model, joint = found[0]
        return model, joint, f"{model.name}::{joint_name}"

    def _apply_effort(self, request: Any) -> str:
        model, joint, scoped = self.find_joint(request.joint_name)
        if joint.getNumDofs() != 1:
            raise EntityError(f"joint_name: {scoped!r} has {joint.getNumDofs()} degrees of freedom; efforts go to "
                              "1-DOF joints")
        if model.static:
            raise EntityError(f"joint_name: {scoped!r} belongs to a static model")
        (effort,) = _finite("effort", [request.effort], MAX_FORCE, "N or N m")
        duration = msgs.time_to_sec(request.duration)
        if duration == 0:
            raise EntityError("duration: 0 s applies nothing (negative: until cleared)")
        now = self.sim.world.time
        start, end = Pushes.span(now, msgs.time_to_sec(request.start_time), duration, self.sim.world.time_step)
        try:
            self.pushes.add_effort(JointEffort(model=model.name, joint=scoped, dart_joint=joint,
                                               effort=float(effort), start=start, end=end), now)
        except PushLimitError as exc:
            raise EntityError(str(exc)) from None
        span = "until cleared" if math.isinf(end) else f"for {end - start:g} s"
        return f"apply_joint_effort: {effort:g} on {scoped!r} {span} from sim time {start:.3f} s"

    def clear_joint_efforts(self, request: Any) -> Any:
        try:
            _, _, scoped = self.find_joint(request.joint_name)
        except EntityError as exc:
            self.logger.warn(f"clear_joint_efforts: {exc}")
            return JointRequest.Response()
        cleared = self.pushes.clear_joint(scoped)
        self.logger.info(f"clear_joint_efforts {scoped!r}: {cleared} cleared")
        return JointRequest.Response()
