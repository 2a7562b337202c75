"""The simulator's ``sim/*`` services (gazebo_ros' spawn/delete/pause/reset/step/physics properties): each
request is checked here, the reason for a refusal names the field, and the work is done through the
simulator's public operations (``Simulator`` below) on the stepping thread, between control periods. A robot's
meshes are converted before, on a thread of their own, so a spawn does not stop the physics for seconds."""

from __future__ import annotations

import math
import threading
from collections.abc import Callable
from typing import Any, Protocol

from msgs.geometry_msgs import Vector3
from nodes.core import Deferred, names
from nodes.core.log import Logger
from nodes.sim.entity import EntitySpec, Pose, SpawnError, prepare_meshes
from nodes.sim.interfaces import (
    MODES,
    DeleteEntity,
    Empty,
    GetPhysicsProperties,
    SetPhysicsProperties,
    SpawnEntity,
    StepSimulation,
)
from nodes.sim.sdf import WorldError, is_sdf
from nodes.sim.simulation import Simulation
from nodes.sim.stepping import Pacer
from nodes.sim.urdf_info import UrdfError

MAX_STEP_REQUEST = 1_000_000
# Plausible ranges of what a request may set (DART integrates anything, and a gravity of 1e308 or a time step
# of 5e-324 ends in non-finite states, millions of DART warnings or a crash, not in an error).
MAX_GRAVITY = 100.0                  # m/s^2 per axis (about 10 g)
# s: 100 kHz .. 100 Hz physics (the humanoid standing on its joint springs diverges at 0.05 s steps)
TIME_STEP_RANGE = (1e-5, 0.01)
REAL_TIME_FACTOR_RANGE = (0.01, 1000.0)
MAX_SHOWN_CHARS = 200                # of a refused text value quoted back to the caller


class Simulator(Protocol):
    """What the services need of the simulator node."""

    logger: Logger
    sim: Simulation
    pacer: Pacer
    paused: bool
    executor: Any     # runs a callable on the stepping thread (``dispatch``)

    def create_service(self, srv_type: Any, name: str, handler: Any) -> Any: ...
    def spawn_entity(self, spec: EntitySpec, reference_frame: str = "") -> str: ...
    def delete_entity(self, name: str) -> bool: ...
    def pause(self) -> None: ...
    def unpause(self) -> None: ...
    def reset(self, *, simulation: bool) -> None: ...
    def step_paused(self, steps: int) -> None: ...


class SimServices:
    def __init__(self, simulator: Simulator) -> None:
        self.simulator = simulator
        self.logger = simulator.logger

    def serve(self) -> None:
        create = self.simulator.create_service
        create(SpawnEntity, "/sim/spawn_entity", self.spawn)
        create(DeleteEntity, "/sim/delete_entity", self.delete)
        create(Empty, "/sim/pause_physics", self.pause)
        create(Empty, "/sim/unpause_physics", self.unpause)
        create(Empty, "/sim/reset_world", self.reset_world)
        create(Empty, "/sim/reset_simulation", self.reset_simulation)
        create(StepSimulation, "/sim/step", self.step)
        create(SetPhysicsProperties, "/sim/set_physics_properties", self.set_physics)
        create(GetPhysicsProperties, "/sim/get_physics_properties", self.get_physics)

    # ------------------------------------------------------------------------------------- entities
    def spawn(self, request: Any) -> Any:
        def fail(reason: str) -> Any:
            self.logger.error(f"spawn_entity {names.shown(request.name)} failed: {reason}")
            return SpawnEntity.Response(success=False, status_message=reason)

        # names first: a name no ROS graph could carry never reaches a key expression
        try:
            if request.name:   # empty: an SDF model's own name
                names.check(names.node_name_problem(request.name), "name", request.name)
            names.check(names.namespace_problem(request.robot_namespace), "robot_namespace",
                        request.robot_namespace)
        except names.NameError_ as exc:
            return fail(str(exc))

        if len(request.initial_joint_names) != len(request.initial_joint_positions):
            return fail(f"initial_joint_names has {len(request.initial_joint_names)} entries but "
                        f"initial_joint_positions has {len(request.initial_joint_positions)}")
        if not request.xml.strip():
            return fail("xml is empty: pass the URDF or SDF text (spawn from a file or robot_description)")
        pose = request.initial_pose
        spec = EntitySpec(
            name=request.name, xml=request.xml, namespace=request.robot_namespace, fixed=request.fixed,
            pose=Pose((pose.position.x, pose.position.y, pose.position.z),
                      (pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w)),
            initial_positions=dict(zip(request.initial_joint_names, request.initial_joint_positions, strict=True)),
        )
        if "<mesh" not in spec.xml or is_sdf(spec.xml):
            return self._spawn(spec, request.reference_frame, fail)
        # A robot's meshes are read and converted on a thread of their own, the physics running on meanwhile;
        # the spawn itself (DART) comes back to the stepping thread, and the request is answered then.
        answer = Deferred()
        self.logger.info(f"spawn_entity {names.shown(spec.name)}: reading its meshes beside the physics")

        def convert() -> None:
            prepare_meshes(spec)
            try:
                self.simulator.executor.dispatch(
                    lambda: answer.resolve(self._spawn(spec, request.reference_frame, fail)), where="spawn_entity")
            except Exception as exc:  # noqa: BLE001 - the simulator is shutting down: the caller hears why
                answer.fail(exc)
        threading.Thread(target=convert, name="spawn-meshes", daemon=True).start()
        return answer

    def _spawn(self, spec: EntitySpec, reference_frame: str, fail: Callable[[str], Any]) -> Any:
        try:
            message = self.simulator.spawn_entity(spec, reference_frame)
        except (SpawnError, UrdfError, WorldError) as exc:
            return fail(str(exc))
        self.logger.info(message)
        return SpawnEntity.Response(success=True, status_message=message)

    def delete(self, request: Any) -> Any:
        if not self.simulator.delete_entity(request.name):
            return DeleteEntity.Response(success=False, status_message=f"no entity named {names.shown(request.name)}")
        self.logger.info(f"deleted {request.name!r}")
        return DeleteEntity.Response(success=True, status_message=f"deleted {request.name!r}")

    # ------------------------------------------------------------------------------------- world control
    def pause(self, _request: Any) -> Any:
        self.simulator.pause()
        return Empty.Response()

    def unpause(self, _request: Any) -> Any:
        self.simulator.unpause()
        return Empty.Response()

    def reset_world(self, _request: Any) -> Any:
        self.simulator.reset(simulation=False)
        self.logger.info("world reset: models back to their spawn poses")
        return Empty.Response()

    def reset_simulation(self, _request: Any) -> Any:
        self.simulator.reset(simulation=True)
        self.logger.info("simulation reset: models back to spawn poses, time 0")
        return Empty.Response()

    def step(self, request: Any) -> Any:
        if not self.simulator.paused:
            return StepSimulation.Response(success=False, status_message="physics is running: pause it first")
        if not 1 <= request.steps <= MAX_STEP_REQUEST:
            return StepSimulation.Response(success=False,
                                           status_message=f"steps must be in 1..{MAX_STEP_REQUEST}")
        self.simulator.step_paused(request.steps)
        return StepSimulation.Response(success=True, status_message=f"stepped {request.steps}, "
                                       f"sim time {self.simulator.sim.world.time:.4f} s")

    # ------------------------------------------------------------------------------------- physics properties
    def set_physics(self, request: Any) -> Any:
        reason = physics_request_problem(request)
        if reason:
            self.logger.warn(f"set_physics_properties refused: {reason}")
            return SetPhysicsProperties.Response(success=False, status_message=reason)
        sim, world, pacer = self.simulator.sim, self.simulator.sim.world, self.simulator.pacer
        changes = []
        g = request.gravity
        gravity = [g.x, g.y, g.z]
        if request.set_gravity:
            world.set_gravity(gravity)
            changes.append(f"gravity {gravity}")
        if request.time_step:
            world.set_time_step(request.time_step)
            changes.append(f"time_step {request.time_step}")
        if request.real_time_factor:
            pacer.real_time_factor = request.real_time_factor
            pacer.restart()
            changes.append(f"real_time_factor {request.real_time_factor}")
        if request.remove_ground:
            changes.append("ground removed" if world.remove_ground() else "no ground to remove")
        if request.add_ground:
            world.add_ground(world.ground_size or 50.0, world.ground_friction)
            changes.append("ground added")
        if request.mode and request.mode != sim.mode:
            sim.mode = request.mode
            sim.hold_all()
            pacer.restart()
            changes.append(f"mode {request.mode}")
        message = "; ".join(changes) or "nothing to change"
        self.logger.info(f"physics properties: {message}")
        return SetPhysicsProperties.Response(success=True, status_message=message)

    def get_physics(self, _request: Any) -> Any:
        sim, world = self.simulator.sim, self.simulator.sim.world
        gx, gy, gz = world.gravity
        rtf = self.simulator.pacer.real_time_factor
        return GetPhysicsProperties.Response(
            time_step=world.time_step, pause=self.simulator.paused,
            max_update_rate=world.physics_rate * rtf if sim.mode == "realtime" else 0.0,
            gravity=Vector3(x=gx, y=gy, z=gz), has_ground=world.has_ground, mode=sim.mode,
            collision_detector=world.collision_detector, real_time_factor=rtf,
            sim_time=world.time, step=sim.step_count, success=True, status_message="")


def shown(text: str) -> str:
    """``text`` quoted, cut to MAX_SHOWN_CHARS (a refused 100,000-character value is not echoed back)."""
    if len(text) <= MAX_SHOWN_CHARS:
        return repr(text)
    return f"{text[:MAX_SHOWN_CHARS]!r}… ({len(text)} characters)"


def gravity_problem(value: Any) -> str | None:
    """Why ``value`` is not a plausible gravity vector (three finite numbers within ±MAX_GRAVITY), or None."""
    if not (isinstance(value, (list, tuple)) and len(value) == 3):
        return "expected three numbers [x, y, z]"
    for axis, v in zip("xyz", value):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            return f"{axis} = {v!r} is not a finite number"
        if abs(v) > MAX_GRAVITY:
            return f"{axis} = {v:g} m/s^2 is outside [-{MAX_GRAVITY:g}, {MAX_GRAVITY:g}]"
    return None


def physics_request_problem(request: Any) -> str | None:
    """Why a set_physics_properties request is refused (naming the field), or None."""
    if request.mode and request.mode not in MODES:
        return f"mode: {shown(request.mode)} is not one of {', '.join(MODES)}"
    low, high = TIME_STEP_RANGE
    if request.time_step and not (math.isfinite(request.time_step) and low <= request.time_step <= high):
        return f"time_step: {request.time_step!r} s is outside [{low:g}, {high:g}] s (0 keeps the current one)"
    low, high = REAL_TIME_FACTOR_RANGE
    if request.real_time_factor and not (math.isfinite(request.real_time_factor)
                                         and low <= request.real_time_factor <= high):
        return (f"real_time_factor: {request.real_time_factor!r} is outside [{low:g}, {high:g}] "
                "(0 keeps the current one)")
    if request.add_ground and request.remove_ground:
        return "add_ground and remove_ground are both set"
    if request.set_gravity:
        g = request.gravity
        problem = gravity_problem([g.x, g.y, g.z])
        if problem:
            return f"gravity.{problem}"
    return None
