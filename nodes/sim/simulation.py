"""The simulated world as a whole: entities with their hardware interfaces, physics steps, resets.

No networking here: the node (``nodes.sim.node``) decides when to step and what to publish.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from nodes.sim.config import Gains
from nodes.sim.entity import Entity, EntitySpec, Pose, SpawnError
from nodes.sim.hardware import HardwareInterface
from nodes.sim.humanoid_state import BalanceState, FootWrench, balance_state
from nodes.sim.interfaces import MODES
from nodes.sim.model import Model
from nodes.sim.pushes import Pushes
from nodes.sim.rest import RestKeeper
from nodes.sim.sdf import WorldSpec
from nodes.sim.sdf_model import WorldModel
from nodes.sim.sensors import SensorSuite
from nodes.sim.world import GROUND_NAME, PhysicsWorld
from nodes.urdf.rendered_sensors import message_size_problem
from nodes.urdf.sensors import SensorSpec

SUPPORT_WINDOW = 0.015  # s of contacts the support polygon spans (1.5 periods of the 100 Hz humanoid_state)
# Sensors of every robot together, and the IMU and force/torque samples they take per simulated second (each
# sample is a few dartpy reads, on the physics thread): a robot over these is refused at spawn. The shipped
# humanoid has 8 sensors and takes 3,000 samples a second (an IMU and two F/T sensors at 1 kHz).
MAX_SENSORS = 256
MAX_SENSOR_SAMPLES = 20_000


class Simulation:
    def __init__(self, world: PhysicsWorld, gains_for: Callable[[str], Gains | None],
                 warn: Callable[[str], None] | None = None, mode: str = "lockstep", *, sensor_seed: int = 0,
                 sensors_enabled: bool = True) -> None:
        """``sensor_seed``: the sensors' noise generators start from it; ``sensors_enabled``: False leaves every
        URDF sensor out (their state interfaces too), for measuring what they cost."""
        if mode not in MODES:
            raise ValueError(f"mode {mode!r} is not one of {', '.join(MODES)}")
        self.world = world
        self.gains_for = gains_for
        self.warn = warn or (lambda message: None)
        self.mode = mode
        self.entities: dict[str, Model] = {}             # robots (Entity) and world models (WorldModel)
        self.hardware: dict[str, HardwareInterface] = {}   # by robot namespace
        self.sensors: dict[str, SensorSuite] = {}           # by robot namespace
        self.sensor_seed = sensor_seed
        self.sensors_enabled = sensors_enabled
        self.max_message_bytes: int | None = None           # the payload limit a sensor's messages must fit
        self.step_count = 0                                  # physics steps since start / reset_simulation
        self.pushes = Pushes()                               # apply_link_wrench / apply_joint_effort
        self.rest = RestKeeper(world)                        # world models at rest sleep until touched
        self._still_poses: dict[str, tuple[bytes, Pose]] = {}   # model_states: poses of models that cannot move
        self._com_velocity: dict[str, tuple[float, list[float]]] = {}  # namespace -> (time, CoM velocity)
        self._recent_contacts: dict[str, list[tuple[float, list]]] = {}  # namespace -> [(time, contacts)]

    @property
    def physics_rate(self) -> float:
        """Physics steps per simulated second (changes with ``set_physics_properties time_step``)."""
        return self.world.physics_rate

    @property
    def kinematic(self) -> bool:
        return self.mode == "kinematic"

    # -- entities ---------------------------------------------------------------------------------------
    def spawn(self, spec: EntitySpec, reference_frame: str = "") -> Entity:
        """Add an entity; raises SpawnError / UrdfError with a clear reason and leaves the world unchanged."""
        if spec.name in self.entities or spec.name == GROUND_NAME:
            raise SpawnError(f"an entity named {spec.name!r} already exists")
        frame = reference_frame.strip()
        if frame not in ("", "world", "map"):
            parent = self.entities.get(frame.split("::")[0])
            if parent is None:
                raise SpawnError(f"reference_frame {frame!r} is neither 'world' nor an existing entity")
            spec.pose = parent.world_pose().compose(spec.pose.validated())
        entity = Entity(spec)
        if self.sensors_enabled:
            self._check_sensors(entity)
        if entity.namespace in self.hardware:
            raise SpawnError(f"robot namespace {entity.namespace!r} is already used by entity "
                             f"{self.hardware[entity.namespace].entity.name!r}")
        hardware = HardwareInterface(entity, self.gains_for, self.warn)
        try:
            sensors = SensorSuite(entity.info.sensors if self.sensors_enabled else [], entity.skeleton, entity.name,
                                  self.sensor_seed, self.world.contacts)
        except ValueError as exc:
            raise SpawnError(str(exc)) from None
        self.world.world.addSkeleton(entity.skeleton)
        self.rest.changed()
        self.entities[entity.name] = entity
        self.hardware[entity.namespace] = hardware
        self.sensors[entity.namespace] = sensors
        return entity

    def _sample_rate(self, spec: SensorSpec) -> float:
        """Samples a simulated second (without an update_rate: every control period, at most every step)."""
        return min(spec.update_rate or self.physics_rate, self.physics_rate)

    def _check_sensors(self, entity: Entity) -> None:
        """What the robot's sensors would add to the rest: refused over the caps (SpawnError naming the cap)."""
        info = entity.info
        for sensor in info.rendered_sensors:
            if sensor.update_rate > self.physics_rate:
                raise SpawnError(f"{sensor.where} <update_rate> {sensor.update_rate:g}: over the physics rate "
                                 f"({self.physics_rate:g} Hz)")
            if self.max_message_bytes is not None:
                problem = message_size_problem(sensor, self.max_message_bytes)
                if problem:
                    raise SpawnError(problem)
        others = sum(len(self.sensors[namespace].sensors) + len(hw.entity.info.rendered_sensors)
                     for namespace, hw in self.hardware.items())
        mine = len(info.sensors) + len(info.rendered_sensors)
        if others + mine > MAX_SENSORS:
            raise SpawnError(f"{mine} sensors more would make {others + mine} in the simulator, over its limit of "
                             f"{MAX_SENSORS} sensors in total")
        sampled = [s for s in info.sensors if s.type in ("imu", "force_torque")]
        rate = sum(self._sample_rate(s) for s in sampled)
        taken = sum(self._sample_rate(sensor.spec) for suite in self.sensors.values() for sensor in suite.sensors
                    if sensor.spec.type in ("imu", "force_torque"))
        if rate + taken > MAX_SENSOR_SAMPLES:
            others_part = f"; with the {taken:g} of the robots already here, {rate + taken:g}" if taken else ""
            raise SpawnError(f"its {len(sampled)} IMU and force/torque sensors take {rate:g} samples a simulated "
                             f"second{others_part}, over the limit of {MAX_SENSOR_SAMPLES} (lower their "
                             "<update_rate>)")

    def add_model(self, model: WorldModel) -> WorldModel:
        """Add a world file's (or an SDF spawn request's) model; raises SpawnError on a name already taken."""
        if model.name in self.entities or model.name == GROUND_NAME:
            raise SpawnError(f"an entity named {model.name!r} already exists")
        self.world.world.addSkeleton(model.skeleton)
        if model.static:
            self.world.mark_static(model.skeleton)
        else:
            self.rest.track(model.name, model.skeleton)
        self.rest.changed()
        self.entities[model.name] = model
        return model

    def load_world(self, spec: WorldSpec, ground_size: float, ground_friction: float) -> None:
        """A world file's physics, gravity, ground and models (models in file order: the same file builds the
        same world, so lockstep runs in it stay bit-identical)."""
        self.world.set_time_step(spec.physics.max_step_size)
        self.world.set_gravity(spec.gravity)
        self.world.remove_ground()
        if spec.ground is not None:
            self.world.add_ground(ground_size, ground_friction, spec.ground)
        built = [WorldModel(model) for model in spec.models]   # every model builds before any is added
        for model in built:
            self.add_model(model)

    def delete(self, name: str) -> bool:
        if name == GROUND_NAME:
            return self.world.remove_ground()
        entity = self.entities.pop(name, None)
        if entity is None:
            return False
        self.pushes.drop_model(name)
        self.rest.forget(name)
        self.rest.changed()
        self._still_poses.pop(name, None)
        self.hardware.pop(entity.namespace, None)
        self.sensors.pop(entity.namespace, None)
        self._com_velocity.pop(entity.namespace, None)
        self._recent_contacts.pop(entity.namespace, None)
        self.world.remove_skeleton(entity.skeleton)
        return True

    def clear(self) -> None:
        """Remove everything (shutdown): drop DART objects in an order that does not crash on exit."""
        for name in list(self.entities):
            self.delete(name)
        self.world.remove_ground()

    # -- stepping ---------------------------------------------------------------------------------------
    def step(self, count: int = 1) -> None:
        """``count`` physics steps with the current commands (kinematic: joints set, no dynamics)."""
        dt = self.world.time_step
        hardware = self.hardware.values()
        if self.mode == "kinematic":
            for _ in range(count):
                for hw in hardware:
                    hw.set_kinematic(dt)
                self.world.world.setTime(self.world.time + dt)
                self.step_count += 1
            return
        # looked up once: this loop runs at the physics rate, and its Python is part of every step's cost
        world_step, pushes, rest = self.world.world.step, self.pushes, self.rest   # DART's step itself
        for _ in range(count):
            for hw in hardware:
                hw.before_step(dt)
            if pushes.wrenches or pushes.efforts:   # bool(pushes) without the call
                pushes.apply(self.world.time, rest.wake)
            world_step()
            self.step_count += 1
            if rest.models:
                rest.after_step()

    def sample_sensors(self) -> None:
        """Every sensor that is due at the current sim time takes its reading (once per control period)."""
        if not self.sensors:
            return
        t, gravity = self.world.world.getTime(), self.world.gravity   # (DART's time, read directly: every period)
        for suite in self.sensors.values():
            suite.sample(t, gravity)

    def wake(self, name: str) -> None:
        """A request moves or pushes this model (``name`` or ``name::link``): if it sleeps, it wakes."""
        self.rest.wake(name.split("::")[0])

    def hold_all(self) -> None:
        for hw in self.hardware.values():
            hw.hold_position()

    def reset_world(self) -> None:
        """Robots back to their spawn poses and joint positions, at rest, holding position (time kept)."""
        self._com_velocity.clear()
        self._recent_contacts.clear()
        self.pushes.clear()
        self.rest.wake_all()
        for entity in self.entities.values():
            entity.reset()
        for suite in self.sensors.values():
            suite.reset()
        self.world.reset_collision()
        self.hold_all()

    def reset_simulation(self) -> None:
        """reset_world plus sim time and step counter back to zero."""
        self.reset_world()
        self.world.world.reset()   # time = 0 and the last collision result cleared
        self.step_count = 0

    # -- outputs ----------------------------------------------------------------------------------------
    def model_states(self) -> list[tuple[str, Pose, np.ndarray, np.ndarray]]:
        """(name, pose, linear, angular) per model, ``ground_plane`` first when present (as Gazebo does)."""
        rows = []
        if self.world.has_ground:
            rows.append((GROUND_NAME, Pose(), np.zeros(3), np.zeros(3)))
        for name, entity in self.entities.items():
            linear, angular = entity.world_twist()
            rows.append((name, self._model_pose(name, entity), linear, angular))
        return rows

    def _model_pose(self, name: str, entity: Model) -> Pose:
        """``entity.world_pose()``; for a model that cannot move by itself (static, or asleep) the last Pose
        again while its transform is the same (a world's furniture, 100 times a simulated second)."""
        matrix = entity.world_matrix()
        if entity.skeleton.isMobile():
            return Pose.from_matrix(matrix)
        key = matrix.tobytes()
        cached = self._still_poses.get(name)
        if cached is None or cached[0] != key:
            cached = self._still_poses[name] = (key, Pose.from_matrix(matrix))
        return cached[1]

    def link_states(self) -> list[tuple[str, Pose, np.ndarray, np.ndarray]]:
        """("model::link", pose, linear, angular) of every link of every model, in the world frame."""
        rows = []
        if self.world.has_ground:
            rows.append((f"{GROUND_NAME}::link", Pose(), np.zeros(3), np.zeros(3)))
        for name, model in self.entities.items():
            skeleton = model.skeleton
            for i in range(skeleton.getNumBodyNodes()):
                body = skeleton.getBodyNode(i)
                rows.append((f"{name}::{body.getName()}", Pose.from_matrix(body.getWorldTransform().matrix()),
                             np.asarray(body.getLinearVelocity()), np.asarray(body.getAngularVelocity())))
        return rows

    def balance(self, namespace: str) -> BalanceState:
        skeleton = self.hardware[namespace].skeleton
        sensors = self.sensors[namespace]
        now = self.world.time
        # one walk over the step's contacts, shared with the contact sensors sampled at this same time
        touching = None if self.kinematic else sensors.contacts(now)
        contacts = touching.points if touching is not None else []
        # The support polygon spans the contacts of the last SUPPORT_WINDOW s: a box foot flat on the ground
        # is sometimes reported by the collision detector as touching along one edge only for a step,
        # which alone would shrink the polygon to a line under a robot that stands still.
        recent = [(t, c) for t, c in self._recent_contacts.get(namespace, []) if 0.0 <= now - t <= SUPPORT_WINDOW]
        recent.append((now, contacts))
        self._recent_contacts[namespace] = recent
        contacts = [c for _, batch in recent for c in batch]
        # The ZMP needs the CoM acceleration averaged since the last sample, not DART's value of the last
        # step alone: when the set of contact points changes, one step's contact impulse swings that value
        # (and the ZMP by tens of cm) for a millisecond, though nothing tips.
        velocity = skeleton.getCOMLinearVelocity().tolist()
        previous = self._com_velocity.get(namespace)
        self._com_velocity[namespace] = (now, velocity)
        if previous is not None and 0.0 < now - previous[0] <= 0.05:
            dt = now - previous[0]
            acceleration = [(v - p) / dt for v, p in zip(velocity, previous[1], strict=True)]
        else:
            acceleration = skeleton.getCOMLinearAcceleration().tolist()
        # the foot sensors carry load where their links touch another model
        loaded = touching.links if touching is not None else set()
        feet = [FootWrench(*wrench) for wrench in sensors.force_torque(loaded)]
        gravity_z = self.world.gravity[2]
        return balance_state(skeleton.getCOM().tolist(), acceleration, gravity_z, contacts, feet,
                             skeleton.getMass() * abs(gravity_z))
