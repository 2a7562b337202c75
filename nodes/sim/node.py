"""The simulator process: parameters, spawning, and the stepping loop of the three modes; its ``sim/*``
services are in ``services.py``, what it publishes besides hardware frames in ``outputs.py``, each robot's
hardware frames in ``robot_link.py``.

The physics thread is the node's executor thread: ``spin()`` is replaced by the stepping loop, which runs
service callbacks between control periods (and while it waits for the wall clock), so DART is only ever
touched from one thread. Hardware commands wait in Zenoh's buffer until that thread takes them: DART holds
the GIL while it steps, so a thread delivering them would have to wait for the step to end anyway.
"""

from __future__ import annotations

import gc
import time
from typing import Any

from nodes.core import Node, memory
from nodes.core.cpu import ExclusiveCpu
from nodes.core.endpoints import ServiceError
from nodes.core.params import ParameterError, load_params_file
from nodes.core.session import max_payload_bytes
from nodes.meshes import MeshError
from nodes.meshes.convert import set_collision_policy
from nodes.meshes.load import preload as preload_mesh_readers
from nodes.sim.config import DEFAULT_CONFIG, StartupEntity, parse_entities, parse_gains
from nodes.sim.entity import Entity, EntitySpec, Pose, SpawnError
from nodes.sim.entity_services import EntityServices
from nodes.sim.interfaces import MODES
from nodes.sim.outputs import SimOutputs
from nodes.sim.render_frames import RenderFrames
from nodes.sim.robot_files import ConfigError, fetch_robot_description, read_model_xml, resolve_robot_file
from nodes.sim.robot_link import RobotLink
from nodes.sim.scene import SceneError
from nodes.sim.sdf import WorldError, WorldSpec, is_sdf, load_world, parse_model
from nodes.sim.sdf_model import WorldModel
from nodes.sim.services import TIME_STEP_RANGE, SimServices, gravity_problem
from nodes.sim.simulation import Simulation
from nodes.sim.stepping import Pacer
from nodes.sim.urdf_info import UrdfError
from nodes.sim.world import COLLISION_DETECTORS, GROUND_NAME, PhysicsWorld

STARTUP_SPAWN_RETRY_S = 0.5
# Paused, each robot's hardware/heartbeat goes out this often (wall s): well within a controller manager's
# hardware_timeout (1 s by default), so it reports "paused", not "lost"
HEARTBEAT_S = 0.25


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
        gravity = p("gravity", [0.0, 0.0, -9.81], description="m/s^2", validator=gravity_problem)
        ground = p("ground_enabled", True, description="add the ground_plane model")
        ground_size = p("ground_size", 50.0, description="ground edge length (m)", min_value=0.1)
        ground_friction = p("ground_friction", 1.0, description="Coulomb friction", min_value=0.0)
        detector = p("collision_detector", "fcl", description="fcl | dart | bullet | ode",
                     choices=COLLISION_DETECTORS)
        clock_rate = p("clock_rate", 100.0, description="sim/clock messages per simulated second",
                            min_value=1.0, max_value=100000.0)
        state_rate = p("state_rate", 100.0, description="model_states/humanoid_state per simulated second",
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
        gains_table = p("gains", {}, description="joint pattern -> {p, d} (other joints: from the physics)",
                        type=dict)
        entities = p("entities", [], description="entities spawned at start", type=list)
        sensor_seed = int(p("sensor_seed", 0, type=int, min_value=0, max_value=2**63 - 1,
                            description="seed of the sensors' noise (the same seed, the same noise)"))
        sensors = p("sensors", True, description="simulate the URDF's IMU, force/torque and contact sensors "
                    "(false: left out, with their state interfaces)")
        world_file = p("world", "", description="SDF world file (a path or a name in worlds/); its physics, "
                       "gravity and ground replace physics_rate, gravity, real_time_factor and ground_enabled")
        collision_mesh = p("collision_mesh", "hull", description="what a collision mesh collides as: hull | "
                           "decompose | exact, for every link, then LINK=MODE for some (hull,left_hand=decompose)")
        try:
            set_collision_policy(collision_mesh)
        except MeshError as exc:
            raise ValueError(str(exc)) from None
        try:
            gains_for = parse_gains(gains_table)
            self._startup: list[StartupEntity] = parse_entities(entities)
        except ConfigError as exc:
            raise ValueError(str(exc)) from None

        self.world = PhysicsWorld(physics_rate, tuple(gravity), detector)
        if ground:
            self.world.add_ground(ground_size, ground_friction)
        self.sim = Simulation(self.world, gains_for, self.logger.warn, mode, sensor_seed=sensor_seed,
                              sensors_enabled=sensors)
        self.sim.max_message_bytes = max_payload_bytes()   # what a sensor's messages must fit in
        self.world_spec: WorldSpec | None = None
        if world_file:
            self._load_world(world_file, ground_size, ground_friction)
        self._check_startup_names(world_file)
        self.robots: dict[str, RobotLink] = {}
        self._sensor_keys: dict[str, tuple[str, str, str]] = {}   # key -> entity, sensor, frame id
        self._warned_keys: set[tuple[str, str]] = set()
        self.outputs = SimOutputs(self, self.sim, self.robots, clock_rate=clock_rate, state_rate=state_rate)
        self.render = RenderFrames(self, self.sim, self._idle, enabled=sensors,
                                   camera_pose=self.world_spec.camera_pose if self.world_spec else None)
        try:
            self.render.refresh_scene()
        except SceneError as exc:   # a world whose meshes the renderer cannot take: as any bad world file
            self.logger.error(f"world {world_file!r} refused: {exc}")
            raise ValueError(f"world {world_file!r} refused: {exc}") from None
        self._startup_deadline = time.monotonic() + 30.0
        self._next_startup_try = 0.0
        self._next_drain = 0.0
        SimServices(self).serve()
        EntityServices(self).serve()
        self._spawn_startup_entities()
        self.logger.info(f"simulator ready: mode {mode}, {self.world.physics_rate:g} Hz physics, gravity "
                         f"{list(self.world.gravity)}, ground {'on' if self.world.has_ground else 'off'}, "
                         f"detector {detector}" + (f", world {self.world_spec.name!r}" if self.world_spec else "")
                         + (", paused" if self.paused else ""))
        preload_mesh_readers()   # the first mesh a spawn brings must not stall the physics for an import

    def _check_startup_names(self, world_file: str) -> None:
        """An entity to spawn at start named like a model the world already has could never be spawned: the
        robot would be missing and its controllers wait for ever. A configuration error instead (status 2)."""
        for item in self._startup:
            if item.name in self.sim.entities or (item.name == GROUND_NAME and self.world.has_ground):
                where = f"world {world_file!r}" if world_file else "the ground plane"
                message = (f"{where} has a model named {item.name!r}, the name of an entity to spawn at start "
                           f"(parameter 'entities'): rename the world's model or the entity")
                self.logger.error(message)
                raise ValueError(message)

    def _load_world(self, name: str, ground_size: float, ground_friction: float) -> None:
        """The world file's physics, gravity, ground and models; a file that cannot be used is logged with the
        reason and ends the start-up (ValueError: exit status 2, which the launcher does not respawn)."""
        started = time.perf_counter()
        try:
            spec = load_world(name)
            self.sim.load_world(spec, ground_size, ground_friction)
        except (WorldError, SpawnError) as exc:
            self.logger.error(f"world {name!r} refused: {exc}")
            raise ValueError(f"world {name!r} refused: {exc}") from None
        self.world_spec = spec
        self.pacer.real_time_factor = spec.physics.real_time_factor
        self.logger.info(f"{spec.summary()}; loaded in {(time.perf_counter() - started) * 1e3:.1f} ms")
        if spec.not_simulated_line():
            self.logger.info(spec.not_simulated_line())

    # ------------------------------------------------------------------------------------- entities
    def spawn_entity(self, spec: EntitySpec, reference_frame: str = "") -> str:
        """Spawn and wire up a robot (URDF) or add a model (SDF); returns a status line, raises
        SpawnError/UrdfError/WorldError on failure."""
        if is_sdf(spec.xml):
            status = self._spawn_sdf(spec, reference_frame)
            self._publish_scene_or_undo(spec.name)
            return status
        entity = self.sim.spawn(spec, reference_frame)
        for warning in entity.info.warnings:
            self.logger.warn(f"{entity.name!r}: {warning}")
        for warning in entity.mesh_warnings:
            self.logger.warn(warning)
        if entity.mesh_note:
            self.logger.info(f"{entity.name!r}: {entity.mesh_note}")
        try:
            self.robots[entity.namespace] = RobotLink(self, self.sim, self.sim.hardware[entity.namespace],
                                                      self.command_timeout)
        except Exception:
            self.sim.delete(entity.name)
            raise
        self._publish_scene_or_undo(entity.name)
        self._note_sensor_keys(entity)
        joints = len(entity.info.joints)
        base = "floating" if entity.floating else "fixed"
        pos = entity.pose.position
        return (f"spawned {entity.name!r} ({joints} joints, {base} base) at "
                f"({pos[0]:.3f}, {pos[1]:.3f}, {pos[2]:.3f}) in namespace {entity.namespace!r}")

    def _note_sensor_keys(self, entity: Entity) -> None:
        """Say once, on rosout, when a new robot's sensor publishes on a key another sensor already does with
        another frame id (a lidar remapped onto the humanoid's scan): the key's readers get both, mixed."""
        for sensor, key, frame in entity.sensor_keys:
            other = self._sensor_keys.get(key)
            if other is None:
                self._sensor_keys[key] = (entity.name, sensor, frame)
                continue
            if other[2] != frame and (key, entity.name) not in self._warned_keys:
                self._warned_keys.add((key, entity.name))
                self.logger.warn(f"sensor {entity.name}::{sensor} publishes on '/{key}' with frame id {frame!r}, "
                                 f"as {other[0]}::{other[1]} does with frame id {other[2]!r}: its readers get "
                                 "both, mixed")

    def _forget_sensor_keys(self, name: str) -> None:
        self._sensor_keys = {k: v for k, v in self._sensor_keys.items() if v[0] != name}
        self._warned_keys = {w for w in self._warned_keys if w[1] != name}

    def _publish_scene_or_undo(self, name: str) -> None:
        """The new scene out, or, when the renderer could not be given it (a mesh over its triangle cap), the
        entity removed again and the spawn refused with the reason."""
        try:
            self.render.refresh_scene()
        except SceneError as exc:
            self.delete_entity(name)
            raise SpawnError(str(exc)) from None

    def _spawn_sdf(self, spec: EntitySpec, reference_frame: str) -> str:
        """An SDF model: its own pose composed after the spawn pose (no hardware interface: no ros2_control)."""
        model_spec = parse_model(spec.xml, f"spawn_entity {spec.name!r}")
        model_spec.name = spec.name or model_spec.name
        model_spec.static = model_spec.static or spec.fixed
        pose = spec.pose.validated()
        frame = reference_frame.strip()
        if frame not in ("", "world", "map"):
            parent = self.sim.entities.get(frame.split("::")[0])
            if parent is None:
                raise SpawnError(f"reference_frame {frame!r} is neither 'world' nor an existing entity")
            pose = parent.world_pose().compose(pose)
        model_spec.pose = pose.to_isometry().matrix() @ model_spec.pose
        if self.sim.entities.get(model_spec.name) is not None:
            raise SpawnError(f"an entity named {model_spec.name!r} already exists")
        model = self.sim.add_model(WorldModel(model_spec))
        x, y, z = model.world_pose().position
        return (f"spawned SDF model {model.name!r} ({len(model_spec.links)} links, {len(model_spec.joints)} joints, "
                f"{'static' if model.static else 'dynamic'}) at ({x:.3f}, {y:.3f}, {z:.3f})")

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
            try:
                joints = {**self._named_pose(item, xml), **item.joints}
                spec = EntitySpec(name=item.name, xml=xml, namespace=item.namespace, fixed=item.fixed,
                                  pose=Pose.from_xyz_rpy(*item.xyz, *item.rpy), initial_positions=joints,
                                  base_uri=base_uri, auto_z=item.auto_z)
                self.logger.info(self.spawn_entity(spec))
            except (SpawnError, UrdfError, WorldError) as exc:
                self.logger.error(f"cannot spawn {item.name!r}: {exc}")
        self._startup = pending
        self._next_startup_try = time.monotonic() + STARTUP_SPAWN_RETRY_S

    @staticmethod
    def _named_pose(item: StartupEntity, xml: str) -> dict[str, float]:
        """The joint positions of the entity's ``initial_pose`` (an SRDF group_state beside its file), for the
        joints the robot moves."""
        if not item.initial_pose:
            return {}
        if not item.file:
            raise UrdfError(f"initial_pose {item.initial_pose!r}: needs the robot's file (its SRDF is beside it)")
        from nodes.urdf.model import parse_urdf as parse_model
        from nodes.urdf.srdf import named_pose

        model = parse_model(xml)
        movable = {j.name for j in model.movable_joints()}
        pose = named_pose(resolve_robot_file(item.file), model.name, item.initial_pose)
        return {name: value for name, value in pose.items() if name in movable}

    def _startup_xml(self, item: StartupEntity) -> tuple[str, str]:
        if item.file:
            path = resolve_robot_file(item.file)
            return read_model_xml(path), path.as_uri()
        return fetch_robot_description(self, item.topic, timeout=0.5), ""

    def delete_entity(self, name: str) -> bool:
        """Remove an entity (and its robot's endpoints); False when there is none of that name."""
        entity = self.sim.entities.get(name)
        if entity is not None:
            link = self.robots.pop(entity.namespace, None)
            if link is not None:
                link.destroy()
        deleted = self.sim.delete(name)
        self._forget_sensor_keys(name)
        self.render.refresh_scene()
        memory.release_soon()   # a skeleton's meshes and DART's copies of them leave the heap fragmented
        return deleted

    # ------------------------------------------------------------------------------------- world control
    def pause(self) -> None:
        self.paused = True
        self.outputs.publish(force=True)   # outputs are otherwise published at the start of a period

    def unpause(self) -> None:
        self.paused = False
        self.pacer.restart()

    def reset(self, *, simulation: bool) -> None:
        """Models back to their spawn poses; ``simulation``: sim time back to 0 as well."""
        if simulation:
            self.sim.reset_simulation()
        else:
            self.sim.reset_world()
        for link in self.robots.values():
            link.reset()
        self.pacer.restart()
        self.outputs.restart_schedule()
        self.render.restart_schedule()
        self.outputs.publish(force=True)

    def step_paused(self, steps: int) -> None:
        """``steps`` physics steps in full control periods (hardware frames, lockstep hand-off), as Gazebo
        runs its plugins while stepping."""
        target = self.sim.step_count + steps
        while self.sim.step_count < target:
            self._control_period(max_steps=target - self.sim.step_count, pace=False)
        self.outputs.publish(force=True)

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
        self.sim.sample_sensors()
        self.render.publish_due(step, t, self.sim.mode == "lockstep")
        for link in self.robots.values():
            link.publish_state(step, t)
            link.publish_plugins(t)
        # clock / model_states / humanoid_state of this same instant, while the controllers compute
        self.outputs.publish()
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
                command = link.command_for(due, self.lockstep_timeout)
                if command is None:
                    link.inbox.connected = False
                    link.gave_up = True        # until its next command: a mere listener must not stall us
                    link.answer_due.clear()
                    link.hold(f"no hardware/command for step {due} within {self.lockstep_timeout:g} s "
                              "(controller manager gone?)")
                    continue
                link.apply(command)
                continue
            command = link.newest_command()
            if command is not None:
                link.apply(command)
                link.inbox.connected = lockstep
                link.gave_up = False
                link.answer_due.clear()
                # the answer to this period's state may already be the one taken (a composed controller
                # manager answers during publish_state): then nothing is due, else waiting for it would
                # wait for a command already applied, a lockstep_timeout every period
                if lockstep and command.step != step:
                    link.answer_due.append(step)
            elif (not lockstep and not link.holding
                  and time.monotonic() - link.inbox.last_wall > self.command_timeout):
                link.hold(f"no hardware/command for {self.command_timeout:g} s")
        if (waited and not self.sim.kinematic) or not pace:
            self.pacer.restart()   # lockstep: as fast as the controller manager answers (kinematic: paced)
        else:
            self.outputs.lateness.append(self.pacer.wait_until_due(t, self._idle))
            if self.paused or self.sim.step_count != step:
                return   # paused or reset by a request served while waiting: this period is void
        steps = self._period_steps()
        self.sim.step(steps if max_steps is None else min(steps, max_steps))

    def _claim_exclusive_cpu(self) -> ExclusiveCpu | None:
        """The launch's ``exclusive_cpu``: this (stepping) thread alone on its CPU, the others off it."""
        try:
            exclusive = ExclusiveCpu.from_environment()
            if exclusive is not None:
                exclusive.claim()
        except (ValueError, OSError) as exc:
            self.logger.error(f"exclusive_cpu: {exc}; stepping on any CPU")
            return None
        if exclusive is not None:
            self.logger.info(f"stepping thread alone on CPU {exclusive.cpu}, the other threads on CPU "
                             f"{','.join(map(str, sorted(exclusive.rest)))}")
        return exclusive

    def spin(self) -> None:
        # Everything long-lived exists now: keep the cyclic GC from pausing the physics loop for
        # milliseconds scanning it (realtime lateness), and collect young objects less often.
        gc.collect()
        gc.freeze()
        gc.set_threshold(50_000, 20, 100)
        exclusive = self._claim_exclusive_cpu()
        next_sweep = time.monotonic() + 1.0
        next_heartbeat = 0.0
        try:
            while self.ok:
                if exclusive is not None and time.monotonic() >= next_sweep:
                    exclusive.sweep()   # threads started since (Zenoh's, a new robot's) inherited the CPU
                    next_sweep = time.monotonic() + 1.0
                self._drain()
                if self._startup and time.monotonic() >= self._next_startup_try:
                    self._spawn_startup_entities()
                if self.paused:
                    self.spin_once(0.02)
                    self.outputs.publish_diagnostics(self.paused)
                    if time.monotonic() >= next_heartbeat:
                        for link in self.robots.values():
                            link.publish_heartbeat(self.sim.step_count, self.world.time)
                        next_heartbeat = time.monotonic() + HEARTBEAT_S
                    continue
                self._control_period()
                self.outputs.publish_diagnostics(self.paused)
        finally:
            for link in self.robots.values():
                link.destroy()
            self.robots.clear()
            self.sim.clear()

    def on_process_exit(self) -> None:
        self.logger.info(f"simulator stopping at sim time {self.world.time:.3f} s after {self.sim.step_count} steps")


def _file_defaults() -> dict[str, Any]:
    """Parameter defaults from ``config/sim.yaml`` (empty if it is missing or unreadable)."""
    try:
        return load_params_file(DEFAULT_CONFIG, "simulator")
    except ParameterError:
        return {}

