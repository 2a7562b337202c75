"""The simulator process: parameters, sim/* services, outputs, and the stepping loop of the three modes.

The physics thread is the node's executor thread: ``spin()`` is replaced by the stepping loop, which runs
service callbacks between control periods (and while it waits for the wall clock), so DART is only ever
touched from one thread. Hardware commands arrive inline on Zenoh's thread into per-robot inboxes.
"""

from __future__ import annotations

import gc
import json
import math
import time
from collections import deque
from typing import Any

import msgs
from nodes.core import Node
from nodes.core.endpoints import ServiceError
from nodes.core.params import ParameterError, load_params_file
from nodes.sim.config import DEFAULT_CONFIG, StartupEntity, parse_entities, parse_gains
from nodes.sim.entity import EntitySpec, Pose, SpawnError
from nodes.sim.interfaces import (
    MODES,
    Clock,
    DeleteEntity,
    Empty,
    GetPhysicsProperties,
    ModelStates,
    SetPhysicsProperties,
    SpawnEntity,
    StepSimulation,
    String,
)
from nodes.sim.robot_files import ConfigError, fetch_robot_description, read_robot_xml, resolve_robot_file
from nodes.sim.robot_link import RobotLink
from nodes.sim.simulation import Simulation
from nodes.sim.stepping import Pacer
from nodes.sim.urdf_info import UrdfError
from nodes.sim.world import COLLISION_DETECTORS, PhysicsWorld

_Vector3 = msgs.get_type("geometry_msgs/msg/Vector3")
_pack_clock = msgs.packer("rosgraph_msgs/msg/Clock")
_pack_model_states = msgs.packer("gazebo_msgs/msg/ModelStates")
_pose = msgs.builder("geometry_msgs/msg/Pose")
_point = msgs.builder("geometry_msgs/msg/Point")
_quaternion = msgs.builder("geometry_msgs/msg/Quaternion")
_twist = msgs.builder("geometry_msgs/msg/Twist")
_vector3 = msgs.builder("geometry_msgs/msg/Vector3")

MAX_STEP_REQUEST = 1_000_000
STARTUP_SPAWN_RETRY_S = 0.5


# Plausible ranges of what a request may set (DART integrates anything, and a gravity of 1e308 or a time step
# of 5e-324 ends in non-finite states, millions of DART warnings or a crash, not in an error).
MAX_GRAVITY = 100.0                  # m/s^2 per axis (about 10 g)
# s: 100 kHz .. 100 Hz physics (the humanoid standing on its joint springs diverges at 0.05 s steps)
TIME_STEP_RANGE = (1e-5, 0.01)
REAL_TIME_FACTOR_RANGE = (0.01, 1000.0)
MAX_SHOWN_CHARS = 200                # of a refused text value quoted back to the caller


def _shown(text: str) -> str:
    """``text`` quoted, cut to MAX_SHOWN_CHARS (a refused 100,000-character value is not echoed back)."""
    if len(text) <= MAX_SHOWN_CHARS:
        return repr(text)
    return f"{text[:MAX_SHOWN_CHARS]!r}… ({len(text)} characters)"


def _gravity_problem(value: Any) -> str | None:
    if not (isinstance(value, (list, tuple)) and len(value) == 3):
        return "expected three numbers [x, y, z]"
    for axis, v in zip("xyz", value):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            return f"{axis} = {v!r} is not a finite number"
        if abs(v) > MAX_GRAVITY:
            return f"{axis} = {v:g} m/s^2 is outside [-{MAX_GRAVITY:g}, {MAX_GRAVITY:g}]"
    return None


_gravity_validator = _gravity_problem


class SimulatorNode(Node):
    """DART simulator: worlds, spawning, hardware interface, sim time, lockstep/realtime/kinematic modes."""

    default_name = "simulator"
    callbacks_on_spin_thread = True   # DART is only touched from the stepping loop, which serves requests

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("simulator", **kwargs)
        self._setup()

    def _setup(self) -> None:
        defaults = _file_defaults()

        def p(name: str, default: Any, **options: Any) -> Any:
            # config/sim.yaml is the single place for the tuned defaults (gains above all), so launch files
            # that set only a few parameters still get them
            return self.declare_parameter(name, defaults.get(name, default), **options)

        physics_rate = p("physics_rate", 1000.0, description="physics steps per simulated second",
                         min_value=1.0 / TIME_STEP_RANGE[1], max_value=1.0 / TIME_STEP_RANGE[0])
        mode = p("mode", "lockstep", description="lockstep | realtime | kinematic", choices=MODES)
        gravity = p("gravity", [0.0, 0.0, -9.81], description="m/s^2", validator=_gravity_validator)
        ground = p("ground_enabled", True, description="add the ground_plane model")
        ground_size = p("ground_size", 50.0, description="ground edge length (m)", min_value=0.1)
        ground_friction = p("ground_friction", 1.0, description="Coulomb friction", min_value=0.0)
        detector = p("collision_detector", "fcl", description="fcl | dart | bullet | ode",
                     choices=COLLISION_DETECTORS)
        self.clock_rate = p("clock_rate", 100.0, description="sim/clock messages per simulated second",
                            min_value=1.0, max_value=100000.0)
        self.state_rate = p("state_rate", 100.0, description="model_states/humanoid_state per simulated second",
                            min_value=0.1, max_value=10000.0)
        self.default_update_rate = p("update_rate", 1000.0, description="control rate (Hz) until a controller "
                                     "manager says its own", min_value=1.0, max_value=100000.0)
        self.pacer = Pacer(p("real_time_factor", 1.0, description="realtime and kinematic pacing target "
                             "(0: as fast as possible)", min_value=0.0,
                             max_value=1000.0))
        self.lockstep_timeout = p("lockstep_timeout", 1.0, description="wall s to wait for a command before "
                                  "holding position", min_value=0.01)
        self.lockstep_delay = int(p("lockstep_delay", 1, type=int, min_value=0, max_value=4,
                                    description="lockstep: control periods between a state and the period its "
                                    "command acts in; 0: the same period (Gazebo), 1+: the controllers compute "
                                    "while the physics steps"))
        self.command_timeout = p("command_timeout", 0.5, description="realtime: hold position after this many "
                                 "wall s without commands", min_value=0.01)
        self.paused = p("paused", False, description="start paused")
        gains_table = p("gains", {"*": {"p": 2000.0, "d": 20.0}}, description="joint pattern -> {p, d}",
                        type=dict)
        entities = p("entities", [], description="entities spawned at start", type=list)
        try:
            gains_for = parse_gains(gains_table)
            self._startup: list[StartupEntity] = parse_entities(entities)
        except ConfigError as exc:
            raise ValueError(str(exc)) from None

        self.world = PhysicsWorld(physics_rate, tuple(gravity), detector)
        if ground:
            self.world.add_ground(ground_size, ground_friction)
        self.sim = Simulation(self.world, gains_for, self.logger.warn, mode)
        self.robots: dict[str, RobotLink] = {}
        self._next_clock = 0.0
        self._next_state = 0.0
        self._lateness: deque[float] = deque(maxlen=5000)
        self._diag_wall = time.monotonic()
        self._diag_sim = 0.0
        self._diag_steps = 0
        self._startup_deadline = time.monotonic() + 30.0
        self._next_startup_try = 0.0
        self._next_drain = 0.0

        # drop, never block the physics loop on a stalled subscriber (see robot_link)
        self.clock_pub = self.create_publisher(Clock, "/sim/clock", express=True, reliable=False)
        self.model_states_pub = self.create_publisher(ModelStates, "/sim/model_states", reliable=False)
        self.diagnostics_pub = self.create_publisher(String, "/sim/diagnostics")
        self.create_service(SpawnEntity, "/sim/spawn_entity", self._srv_spawn)
        self.create_service(DeleteEntity, "/sim/delete_entity", self._srv_delete)
        self.create_service(Empty, "/sim/pause_physics", self._srv_pause)
        self.create_service(Empty, "/sim/unpause_physics", self._srv_unpause)
        self.create_service(Empty, "/sim/reset_world", self._srv_reset_world)
        self.create_service(Empty, "/sim/reset_simulation", self._srv_reset_simulation)
        self.create_service(StepSimulation, "/sim/step", self._srv_step)
        self.create_service(SetPhysicsProperties, "/sim/set_physics_properties", self._srv_set_physics)
        self.create_service(GetPhysicsProperties, "/sim/get_physics_properties", self._srv_get_physics)
        self._spawn_startup_entities()
        self.logger.info(f"simulator ready: mode {mode}, {physics_rate:g} Hz physics, gravity {list(gravity)}, "
                         f"ground {'on' if ground else 'off'}, detector {detector}"
                         + (", paused" if self.paused else ""))

    # ------------------------------------------------------------------------------------- spawning
    def _spawn(self, spec: EntitySpec, reference_frame: str = "") -> str:
        """Spawn and wire up a robot; returns a status line, raises SpawnError/UrdfError on failure."""
        entity = self.sim.spawn(spec, reference_frame)
        try:
            self.robots[entity.namespace] = RobotLink(self, self.sim, self.sim.hardware[entity.namespace],
                                                      self.command_timeout)
        except Exception:
            self.sim.delete(entity.name)
            raise
        joints = len(entity.info.joints)
        base = "fixed" if spec.fixed else "floating"
        pos = entity.pose.position
        return (f"spawned {entity.name!r} ({joints} joints, {base} base) at "
                f"({pos[0]:.3f}, {pos[1]:.3f}, {pos[2]:.3f}) in namespace {entity.namespace!r}")

    def _spawn_startup_entities(self) -> None:
        """Entities from the ``entities`` parameter; ones from a topic are retried until it answers."""
        pending = []
        for item in self._startup:
            try:
                xml, base_uri = self._startup_xml(item)
            except (ServiceError, ConfigError) as exc:
                if item.topic and time.monotonic() < self._startup_deadline:
                    pending.append(item)
                    continue
                self.logger.error(f"cannot spawn {item.name!r}: {exc}")
                continue
            spec = EntitySpec(name=item.name, xml=xml, namespace=item.namespace, fixed=item.fixed,
                              pose=Pose.from_xyz_rpy(*item.xyz, *item.rpy), initial_positions=item.joints,
                              base_uri=base_uri)
            try:
                self.logger.info(self._spawn(spec))
            except (SpawnError, UrdfError) as exc:
                self.logger.error(f"cannot spawn {item.name!r}: {exc}")
        self._startup = pending
        self._next_startup_try = time.monotonic() + STARTUP_SPAWN_RETRY_S

    def _startup_xml(self, item: StartupEntity) -> tuple[str, str]:
        if item.file:
            path = resolve_robot_file(item.file)
            return read_robot_xml(path), path.as_uri()
        return fetch_robot_description(self, item.topic, timeout=0.5), ""

    def _srv_spawn(self, request: Any) -> Any:
        def fail(reason: str) -> Any:
            self.logger.error(f"spawn_entity {request.name!r} failed: {reason}")
            return SpawnEntity.Response(success=False, status_message=reason)

        if len(request.initial_joint_names) != len(request.initial_joint_positions):
            return fail(f"initial_joint_names has {len(request.initial_joint_names)} entries but "
                        f"initial_joint_positions has {len(request.initial_joint_positions)}")
        if not request.xml.strip():
            return fail("xml is empty: pass the URDF text (spawn from a file or robot_description)")
        pose = request.initial_pose
        spec = EntitySpec(
            name=request.name, xml=request.xml, namespace=request.robot_namespace, fixed=request.fixed,
            pose=Pose((pose.position.x, pose.position.y, pose.position.z),
                      (pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w)),
            initial_positions=dict(zip(request.initial_joint_names, request.initial_joint_positions, strict=True)),
        )
        try:
            message = self._spawn(spec, request.reference_frame)
        except (SpawnError, UrdfError) as exc:
            return fail(str(exc))
        self.logger.info(message)
        return SpawnEntity.Response(success=True, status_message=message)

    def _srv_delete(self, request: Any) -> Any:
        entity = self.sim.entities.get(request.name)
        if entity is not None:
            link = self.robots.pop(entity.namespace, None)
            if link is not None:
                link.destroy()
        if not self.sim.delete(request.name):
            return DeleteEntity.Response(success=False, status_message=f"no entity named {request.name!r}")
        self.logger.info(f"deleted {request.name!r}")
        return DeleteEntity.Response(success=True, status_message=f"deleted {request.name!r}")

    # ------------------------------------------------------------------------------------- world control
    def _srv_pause(self, _request: Any) -> Any:
        self.paused = True
        self._publish_outputs(force=True)   # outputs are otherwise published at the start of a period
        return Empty.Response()

    def _srv_unpause(self, _request: Any) -> Any:
        self.paused = False
        self.pacer.restart()
        return Empty.Response()

    def _after_reset(self) -> None:
        for link in self.robots.values():
            link.inbox.clear()
            link.answer_due.clear()
            link.holding = True
        self.pacer.restart()
        self._next_clock = self._next_state = self.world.time
        self._publish_outputs(force=True)

    def _srv_reset_world(self, _request: Any) -> Any:
        self.sim.reset_world()
        self._after_reset()
        self.logger.info("world reset: models back to their spawn poses")
        return Empty.Response()

    def _srv_reset_simulation(self, _request: Any) -> Any:
        self.sim.reset_simulation()
        self._after_reset()
        self.logger.info("simulation reset: models back to spawn poses, time 0")
        return Empty.Response()

    def _srv_step(self, request: Any) -> Any:
        if not self.paused:
            return StepSimulation.Response(success=False, status_message="physics is running: pause it first")
        if not 1 <= request.steps <= MAX_STEP_REQUEST:
            return StepSimulation.Response(success=False,
                                           status_message=f"steps must be in 1..{MAX_STEP_REQUEST}")
        # full control periods (hardware frames, lockstep hand-off), as Gazebo runs its plugins while stepping
        target = self.sim.step_count + request.steps
        while self.sim.step_count < target:
            self._control_period(max_steps=target - self.sim.step_count, pace=False)
        self._publish_outputs(force=True)
        return StepSimulation.Response(success=True, status_message=f"stepped {request.steps}, "
                                       f"sim time {self.world.time:.4f} s")

    def _srv_set_physics(self, request: Any) -> Any:
        reason = _physics_request_problem(request)
        if reason:
            self.logger.warn(f"set_physics_properties refused: {reason}")
            return SetPhysicsProperties.Response(success=False, status_message=reason)
        changes = []
        g = request.gravity
        gravity = [g.x, g.y, g.z]
        if request.set_gravity:
            self.world.set_gravity(gravity)
            changes.append(f"gravity {gravity}")
        if request.time_step:
            self.world.world.setTimeStep(request.time_step)
            changes.append(f"time_step {request.time_step}")
        if request.real_time_factor:
            self.pacer.real_time_factor = request.real_time_factor
            self.pacer.restart()
            changes.append(f"real_time_factor {request.real_time_factor}")
        if request.remove_ground:
            changes.append("ground removed" if self.world.remove_ground() else "no ground to remove")
        if request.add_ground:
            self.world.add_ground(self.world.ground_size or 50.0, self.world.ground_friction)
            changes.append("ground added")
        if request.mode and request.mode != self.sim.mode:
            self.sim.mode = request.mode
            self.sim.hold_all()
            self.pacer.restart()
            changes.append(f"mode {request.mode}")
        message = "; ".join(changes) or "nothing to change"
        self.logger.info(f"physics properties: {message}")
        return SetPhysicsProperties.Response(success=True, status_message=message)

    def _srv_get_physics(self, _request: Any) -> Any:
        gx, gy, gz = self.world.gravity
        rtf = self.pacer.real_time_factor
        return GetPhysicsProperties.Response(
            time_step=self.world.time_step, pause=self.paused,
            max_update_rate=self.world.physics_rate * rtf if self.sim.mode == "realtime" else 0.0,
            gravity=_Vector3(x=gx, y=gy, z=gz), has_ground=self.world.has_ground, mode=self.sim.mode,
            collision_detector=self.world.collision_detector, real_time_factor=rtf,
            sim_time=self.world.time, step=self.sim.step_count, success=True, status_message="")

    # ------------------------------------------------------------------------------------- outputs
    def _publish_outputs(self, force: bool = False) -> None:
        t = self.world.time
        eps = 1e-9
        if force or t + eps >= self._next_clock:
            self.clock_pub.publish_raw(_pack_clock(clock=msgs.time_map(t)))
            self._next_clock = _next_due(self._next_clock, t, 1.0 / self.clock_rate)
        if force or t + eps >= self._next_state:
            self._publish_model_states()
            for link in self.robots.values():
                if link.humanoid_pub.has_subscribers:   # CoM, contacts and ZMP cost ~0.15 ms: only when read
                    link.publish_humanoid_state(t)
            self._next_state = _next_due(self._next_state, t, 1.0 / self.state_rate)

    def _publish_model_states(self) -> None:
        names, poses, twists = [], [], []
        for name, pose, linear, angular in self.sim.model_states():
            names.append(name)
            px, py, pz = pose.position
            qx, qy, qz, qw = pose.orientation
            poses.append(_pose(position=_point(x=px, y=py, z=pz), orientation=_quaternion(x=qx, y=qy, z=qz, w=qw)))
            lx, ly, lz = linear.tolist()
            ax, ay, az = angular.tolist()
            twists.append(_twist(linear=_vector3(x=lx, y=ly, z=lz), angular=_vector3(x=ax, y=ay, z=az)))
        self.model_states_pub.publish_raw(_pack_model_states(name=names, pose=poses, twist=twists))

    def _publish_diagnostics(self) -> None:
        now = time.monotonic()
        wall = now - self._diag_wall
        if wall < 1.0:
            return
        late = sorted(self._lateness)
        p99 = late[min(len(late) - 1, int(0.99 * len(late)))] * 1e3 if late else 0.0
        report = {
            "mode": self.sim.mode, "paused": self.paused, "sim_time": self.world.time,
            "real_time_factor": (self.world.time - self._diag_sim) / wall,
            "steps_per_s": (self.sim.step_count - self._diag_steps) / wall,
            "p99_late_ms": p99, "max_late_ms": late[-1] * 1e3 if late else 0.0,
            "robots": {ns: ("holding" if link.holding else "commanded") for ns, link in self.robots.items()},
        }
        self.diagnostics_pub.publish(String(data=json.dumps(report)))
        self._lateness.clear()
        self._diag_wall, self._diag_sim, self._diag_steps = now, self.world.time, self.sim.step_count

    # ------------------------------------------------------------------------------------- stepping loop
    def _idle(self, max_wait: float) -> None:
        """Serve requests while waiting for the wall clock."""
        self.spin_once(min(max_wait, 0.01))

    def _drain(self) -> None:
        """Run every queued service/timer callback (bounded, so a request flood cannot stall physics)."""
        if self.executor.idle and time.monotonic() < self._next_drain:
            return   # nothing queued: skip the executor's bookkeeping (this runs every control period)
        self._next_drain = time.monotonic() + 0.01
        for _ in range(100):
            if not self.spin_once(0.0):
                return

    def _period_steps(self) -> int:
        rates = [link.update_rate for link in self.robots.values() if link.update_rate > 0 and not link.holding]
        update_rate = max(rates) if rates else self.default_update_rate
        return max(1, int(round(self.world.physics_rate / update_rate)))

    def _control_period(self, max_steps: int | None = None, pace: bool = True) -> None:
        """One control period: hardware frames out, commands in (waiting for them in lockstep), physics."""
        step, t = self.sim.step_count, self.world.time
        lockstep = self.sim.mode != "realtime"
        for link in self.robots.values():
            link.publish_state(step, t)
        # clock / model_states / humanoid_state of this same instant, while the controllers compute
        self._publish_outputs()
        waited = False
        for link in self.robots.values():
            if lockstep and not link.inbox.connected and not link.gave_up and link.state_pub.has_subscribers:
                link.inbox.connected = True   # a controller manager listens: lockstep from this very period
            if lockstep and link.inbox.connected:
                # pipelined (lockstep_delay periods): this period applies the answer to an earlier state, and
                # the controller manager computes the answer to this one while the physics runs
                link.answer_due.append(step)
                if len(link.answer_due) <= self.lockstep_delay:
                    continue   # the first pipelined periods: the last command stays in effect
                due = link.answer_due.popleft()
                waited = True
                command = link.inbox.wait_for_step(due, self.lockstep_timeout)
                if command is None:
                    link.inbox.connected = False
                    link.gave_up = True        # until its next command: a mere listener must not stall us
                    link.answer_due.clear()
                    link.hold(f"no hardware/command for step {due} within {self.lockstep_timeout:g} s "
                              "(controller manager gone?)")
                    continue
                link.apply(command)
                continue
            command = link.inbox.take()
            if command is not None:
                link.apply(command)
                link.inbox.connected = lockstep
                link.gave_up = False
                link.answer_due.clear()
                if lockstep:
                    link.answer_due.append(step)
            elif (not lockstep and not link.holding
                  and time.monotonic() - link.inbox.last_wall > self.command_timeout):
                link.hold(f"no hardware/command for {self.command_timeout:g} s")
        if (waited and not self.sim.kinematic) or not pace:
            self.pacer.restart()   # lockstep: as fast as the controller manager answers (kinematic: paced)
        else:
            self._lateness.append(self.pacer.wait_until_due(t, self._idle))
            if self.paused or self.sim.step_count != step:
                return   # paused or reset by a request served while waiting: this period is void
        steps = self._period_steps()
        self.sim.step(steps if max_steps is None else min(steps, max_steps))

    def spin(self) -> None:
        # Everything long-lived exists now: keep the cyclic GC from pausing the physics loop for
        # milliseconds scanning it (realtime lateness), and collect young objects less often.
        gc.collect()
        gc.freeze()
        gc.set_threshold(50_000, 20, 100)
        try:
            while self.ok:
                self._drain()
                if self._startup and time.monotonic() >= self._next_startup_try:
                    self._spawn_startup_entities()
                if self.paused:
                    self.spin_once(0.02)
                    self._publish_diagnostics()
                    continue
                self._control_period()
                self._publish_diagnostics()
        finally:
            for link in self.robots.values():
                link.destroy()
            self.robots.clear()
            self.sim.clear()

    def on_process_exit(self) -> None:
        self.logger.info(f"simulator stopping at sim time {self.world.time:.3f} s after {self.sim.step_count} steps")


def _physics_request_problem(request: Any) -> str | None:
    """Why a set_physics_properties request is refused (naming the field), or None."""
    if request.mode and request.mode not in MODES:
        return f"mode: {_shown(request.mode)} is not one of {', '.join(MODES)}"
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
        problem = _gravity_problem([g.x, g.y, g.z])
        if problem:
            return f"gravity.{problem}"
    return None


def _file_defaults() -> dict[str, Any]:
    """Parameter defaults from ``config/sim.yaml`` (empty if it is missing or unreadable)."""
    try:
        return load_params_file(DEFAULT_CONFIG, "simulator")
    except ParameterError:
        return {}


def _next_due(previous_due: float, now: float, period: float) -> float:
    """The next publication time after ``now`` on the grid ``previous_due + k * period`` (no bursts)."""
    due = previous_due + period
    if due <= now:
        due = previous_due + period * (math.floor((now - previous_due) / period) + 1)
    return due
