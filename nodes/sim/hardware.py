"""The hardware interface of one robot: command/state interfaces per joint, limits, and the joint servo.

Position commands are tracked with DART's implicit joint springs (stiffness = kp, damping = kd, rest
position = target): integrated implicitly they stay stable at gains where an explicit PD diverged
(FACTS). When the spring-damper torque would exceed the URDF effort limit, the joint gets exactly the
limit as a plain force for that step instead (a saturated motor), so no torque beyond the limit is
applied or reported. Velocity commands use DART's SERVO actuator (a velocity
constraint bounded by the effort limit), effort commands a clamped FORCE. Position and velocity limits are
enforced by DART's joint limit constraint.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import dartpy as dart
import numpy as np

from nodes.sim.config import Gains
from nodes.sim.entity import Entity
from nodes.sim.urdf_info import INTERFACES

# Stand-in for an infinite effort limit where DART needs a number (SERVO force bounds).
UNLIMITED_EFFORT = 1e6


def _magnitude(bounds: tuple[float, float]) -> float:
    """The symmetric limit inside a (low, high) range."""
    return max(0.0, min(-bounds[0], bounds[1]))


class CommandError(ValueError):
    """A hardware command that cannot be applied at all (wrong lengths, unknown interface...)."""


class HardwareInterface:
    """Joints of one entity in URDF order, their active command interface and current command."""

    def __init__(self, entity: Entity, gains_for: Callable[[str], Gains],
                 warn_once: Callable[[str], None] | None = None) -> None:
        self.entity = entity
        self.skeleton = entity.skeleton
        self.joints = entity.info.joints
        self.names = [j.name for j in self.joints]
        self.index = {name: i for i, name in enumerate(self.names)}
        self.dofs = np.array([entity.dof_index[name] for name in self.names], dtype=int)
        self.dart_joints = [self.skeleton.getJoint(name) for name in self.names]
        self.gains = [gains_for(name) for name in self.names]
        self._warn_once = warn_once or (lambda message: None)
        self._warned: set[str] = set()
        n = len(self.names)
        # URDF <limit> narrowed by <ros2_control> min/max of a velocity / effort command interface
        self.max_velocity = np.array([_magnitude(j.bounds("velocity")) for j in self.joints])
        self.max_effort = np.array([_magnitude(j.bounds("effort")) for j in self.joints])
        self.kp = np.array([g.kp for g in self.gains])
        self.kd = np.array([g.kd for g in self.gains])
        self.position_bounds = np.array([j.bounds("position") for j in self.joints]).reshape(n, 2)
        self.mode: list[str] = ["position"] * n
        self.target = np.zeros(n)          # command value per joint, in its active interface's unit
        self._rest = np.full(n, np.nan)    # rest positions last given to DART (skip redundant calls)
        self.last_effort = np.zeros(n)
        self._saturated = np.zeros(n, dtype=bool)  # position joints at their effort limit this step
        self._any_saturated = False
        self._low_effort = -self.max_effort
        self._dt = math.nan
        self._lead = self.kd.copy()                # kp * dt + kd: DART's spring term on the velocity
        self._position_mask = np.ones(n, dtype=bool)
        self._velocity_joints: list[int] = []
        self._effort_joints: list[int] = []
        self._plans: dict = {}
        for i in range(n):
            self._set_mode(i, "position")
            self._limit_velocity(i)
        self.hold_position()

    # -- state ------------------------------------------------------------------------------------------
    def positions(self) -> np.ndarray:
        return np.asarray(self.skeleton.getPositions())[self.dofs]

    def velocities(self) -> np.ndarray:
        return np.asarray(self.skeleton.getVelocities())[self.dofs]

    def efforts(self) -> np.ndarray:
        return self.last_effort.copy()

    # -- commands ---------------------------------------------------------------------------------------
    def hold_position(self) -> None:
        """Every joint back to position control at its current position (no controller / timeout)."""
        current = self.positions()
        for i in range(len(self.names)):
            if self.mode[i] != "position":
                self._set_mode(i, "position")
        self.target = np.clip(current, self.position_bounds[:, 0], self.position_bounds[:, 1])

    def _warn(self, key: str, message: str) -> None:
        if key not in self._warned:
            self._warned.add(key)
            self._warn_once(message)

    def apply_command(self, names: Sequence[str], interfaces: Sequence[str], values: Sequence[float]) -> int:
        """Take a HardwareCommand; returns how many entries were applied.

        Entries with an unknown joint, an interface the joint does not have, or a non-finite value are
        skipped (logged once each); values outside the limits are clamped (logged once per joint).
        """
        if not (len(names) == len(interfaces) == len(values)):
            raise CommandError(f"name ({len(names)}), interface ({len(interfaces)}) and value ({len(values)}) "
                               "must have the same length")
        plan = self._plan(tuple(names), tuple(interfaces))
        entries, indices, lo, hi, modes = plan
        if not len(indices):
            return 0
        try:
            chosen_list = [float(values[e]) for e in entries]
        except (TypeError, ValueError):
            raise CommandError("value must be a list of numbers") from None
        # Fast path (every control period): all finite, no interface switch. Plain Python beats numpy's
        # per-call overhead on 20-odd values.
        if math.isfinite(sum(chosen_list)) and all(self.mode[i] == m for i, m in zip(indices, modes, strict=True)):
            clamped_list = [min(max(v, low), high) for v, low, high in zip(chosen_list, lo, hi, strict=True)]
            if clamped_list != chosen_list:
                for k, (v, c) in enumerate(zip(chosen_list, clamped_list, strict=True)):
                    if v != c:
                        self._warn_clamped(indices[k], modes[k], v, lo[k], hi[k])
            self.target[indices] = clamped_list
            return len(clamped_list)
        chosen = np.array(chosen_list)
        finite = np.isfinite(chosen)
        if not finite.all():
            for k in np.nonzero(~finite)[0]:
                name = self.names[indices[k]]
                self._warn(f"nan:{name}", f"{self.entity.name}: non-finite {modes[k]} command {chosen[k]!r} "
                                          f"for joint {name!r} rejected")
        clamped = np.clip(chosen, np.array(lo), np.array(hi))
        outside = finite & (clamped != chosen)
        if outside.any():
            for k in np.nonzero(outside)[0]:
                self._warn_clamped(indices[k], modes[k], chosen[k], lo[k], hi[k])
        for k, i in enumerate(indices):
            if finite[k] and self.mode[i] != modes[k]:
                self._set_mode(int(i), modes[k])
        self.target[np.array(indices)[finite]] = clamped[finite]
        return int(finite.sum())

    def _warn_clamped(self, i: int, interface: str, value: float, low: float, high: float) -> None:
        name = self.names[i]
        self._warn(f"range:{name}:{interface}",
                   f"{self.entity.name}: {interface} command {value:.4g} for joint {name!r} is outside "
                   f"[{low:.4g}, {high:.4g}]; clamped")

    def _plan(self, names: tuple[str, ...], interfaces: tuple[str, ...]):
        """Which entries of a command (by its name/interface lists) apply to which joint, with bounds.

        Controller managers send the same lists every period, so the plan is computed once and cached.
        """
        key = (names, interfaces)
        plan = self._plans.get(key)
        if plan is not None:
            return plan
        entries, indices, lows, highs, modes = [], [], [], [], []
        for k, (name, interface) in enumerate(zip(names, interfaces, strict=True)):
            i = self.index.get(name)
            if i is None:
                self._warn(f"unknown:{name}", f"{self.entity.name}: command for unknown joint {name!r} ignored")
                continue
            joint = self.joints[i]
            if interface not in joint.command_interfaces:
                self._warn(f"iface:{name}:{interface}",
                           f"{self.entity.name}: joint {name!r} has no {interface!r} command interface "
                           f"(has {joint.command_interfaces}); command ignored")
                continue
            lo, hi = joint.bounds(interface)
            entries.append(k)
            indices.append(i)
            lows.append(lo)
            highs.append(hi)
            modes.append(interface)
        plan = (entries, indices, lows, highs, modes)
        if len(self._plans) > 64:
            self._plans.clear()
        self._plans[key] = plan
        return plan

    def _set_mode(self, i: int, interface: str) -> None:
        assert interface in INTERFACES
        joint = self.dart_joints[i]
        if interface == "position":
            joint.setActuatorType(dart.dynamics.ActuatorType.FORCE)
            joint.setSpringStiffness(0, float(self.kp[i]))
            joint.setDampingCoefficient(0, float(self.kd[i]))
        elif interface == "velocity":
            joint.setActuatorType(dart.dynamics.ActuatorType.SERVO)
            limit = min(float(self.max_effort[i]), UNLIMITED_EFFORT)
            joint.setForceLowerLimit(0, -limit)
            joint.setForceUpperLimit(0, limit)
            joint.setSpringStiffness(0, 0.0)
            joint.setDampingCoefficient(0, 0.0)
        else:
            joint.setActuatorType(dart.dynamics.ActuatorType.FORCE)
            joint.setSpringStiffness(0, 0.0)
            joint.setDampingCoefficient(0, 0.0)
        self._rest[i] = np.nan
        self._saturated[i] = False
        self._any_saturated = bool(self._saturated.any())
        self.mode[i] = interface
        self._position_mask = np.array([m == "position" for m in self.mode], dtype=bool)
        self._velocity_joints = [k for k, m in enumerate(self.mode) if m == "velocity"]
        self._effort_joints = [k for k, m in enumerate(self.mode) if m == "effort"]

    def _limit_velocity(self, i: int) -> None:
        """DART's joint limit constraint holds the velocity limit (ours, narrowed by <ros2_control>; none: inf)
        within the step, so positions integrate a velocity within it too. A continuous joint has no position
        limits, so enforcing its limits enforces its velocity limit only."""
        joint = self.dart_joints[i]
        limit = float(self.max_velocity[i])
        joint.setVelocityLowerLimit(0, -limit)
        joint.setVelocityUpperLimit(0, limit)
        if self.joints[i].type == "continuous":
            joint.setPositionLowerLimit(0, -math.inf)
            joint.setPositionUpperLimit(0, math.inf)
        joint.setLimitEnforcement(True)

    # -- physics-rate servo -----------------------------------------------------------------------------
    def before_step(self) -> None:
        """Feed the current commands to DART (forces and servo commands are cleared by every step).

        A position joint's spring-damper torque, as DART evaluates it at the start of the step
        (kp * (target - q - dt * qd) - kd * qd), is kept within the URDF effort limit: while it is inside,
        the implicit spring tracks the target; when it would exceed the limit, the spring is switched off
        for that step and the joint gets exactly the saturated torque as a plain force. The reported
        effort is that torque, so neither what is applied nor what is reported exceeds the limit."""
        q = self.positions()
        qd = self.velocities()
        dt = self.skeleton.getTimeStep()
        if dt != self._dt:  # the time step can change at run time (set_physics_properties)
            self._dt, self._lead = dt, self.kp * dt + self.kd
        torque = self.kp * (self.target - q) - self._lead * qd
        effort = np.minimum(np.maximum(torque, self._low_effort), self.max_effort)
        saturated = (effort != torque) & self._position_mask
        any_saturated = saturated.any()
        if any_saturated or self._any_saturated:
            switched = saturated != self._saturated
            for i in np.nonzero(switched)[0]:
                on = 0.0 if saturated[i] else 1.0
                self.dart_joints[i].setSpringStiffness(0, on * float(self.kp[i]))
                self.dart_joints[i].setDampingCoefficient(0, on * float(self.kd[i]))
            self._saturated, self._any_saturated = saturated, bool(any_saturated)
            changed = (self.target != self._rest) & self._position_mask & ~saturated
        else:
            changed = (self.target != self._rest) & self._position_mask
        if changed.any():
            for i in np.nonzero(changed)[0]:
                self.dart_joints[i].setRestPosition(0, float(self.target[i]))
            self._rest[changed] = self.target[changed]
        self.last_effort = np.where(self._position_mask, effort, 0.0)
        if any_saturated:
            for i in np.nonzero(saturated)[0]:
                self.skeleton.setForce(int(self.dofs[i]), float(effort[i]))
        for i in self._velocity_joints:
            self.skeleton.setCommand(int(self.dofs[i]), float(self.target[i]))
        for i in self._effort_joints:
            self.skeleton.setForce(int(self.dofs[i]), float(self.target[i]))
            self.last_effort[i] = self.target[i]

    # -- kinematic mode ---------------------------------------------------------------------------------
    def set_kinematic(self, dt: float) -> None:
        """No dynamics: joints jump to their position commands (clamped); velocities are the finite difference."""
        q = self.positions()
        new_q = q.copy()
        for i, mode in enumerate(self.mode):
            if mode == "position":
                new_q[i] = self.target[i]
            elif mode == "velocity":
                new_q[i] = q[i] + self.target[i] * dt
        new_q = np.clip(new_q, self.position_bounds[:, 0], self.position_bounds[:, 1])
        positions = np.array(self.skeleton.getPositions())
        velocities = np.zeros(self.skeleton.getNumDofs())
        positions[self.dofs] = new_q
        velocities[self.dofs] = (new_q - q) / dt if dt > 0 else 0.0
        self.skeleton.setPositions(positions)
        self.skeleton.setVelocities(velocities)
        self.last_effort[:] = 0.0

    def joint_table(self) -> list[dict]:
        """The ``hardware/info`` joint list (infinite limits as ±inf are replaced by 0 = "none")."""
        rows = []
        for joint, velocity, effort in zip(self.joints, self.max_velocity, self.max_effort, strict=True):
            rows.append({
                "name": joint.name,
                "command_interfaces": list(joint.command_interfaces),
                "state_interfaces": list(joint.state_interfaces),
                "min_position": joint.bounds("position")[0] if math.isfinite(joint.min_position) else 0.0,
                "max_position": joint.bounds("position")[1] if math.isfinite(joint.max_position) else 0.0,
                "max_velocity": velocity if math.isfinite(velocity) else 0.0,
                "max_effort": effort if math.isfinite(effort) else 0.0,
            })
        return rows
