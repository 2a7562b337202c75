"""The hardware interface of one robot: command/state interfaces per joint, limits, and the joint servo.

Position commands are tracked with DART's implicit joint springs (stiffness = kp, damping = kd): integrated
implicitly they stay stable at gains where an explicit PD diverged (FACTS). DART's spring force is
-kp (q - rest + dt qd) - kd qd, linear in the rest position, so the rest position stays 0 and the target
enters as the joint force kp * target: every joint's force goes to DART in one ``setForces`` call a step
instead of one ``setRestPosition`` call per moving joint. When the spring-damper torque would exceed the URDF
effort limit, the joint gets exactly the limit as a plain force for that step instead (a saturated motor), so
no torque beyond the limit is applied or reported. Velocity commands use DART's SERVO actuator (a velocity
constraint bounded by the effort limit), effort commands a clamped FORCE. Position and velocity limits are
enforced by DART's joint limit constraint.

The per-step work is a handful of numpy operations on arrays in DART's DOF order (the floating base's six
included, with zero gains and no limit), cached between steps: two state reads, the torque, one comparison
with the limits and one ``setForces``.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Callable, Sequence

import dartpy as dart
import numpy as np

from nodes.sim.config import Gains
from nodes.sim.entity import Entity
from nodes.sim.servo_gains import physics_gains
from nodes.sim.urdf_info import INTERFACES

# Stand-in for an infinite effort limit where DART needs a number (SERVO force bounds).
UNLIMITED_EFFORT = 1e6

try:   # numpy's C functions themselves: the public ones wrap them in Python (callgrind, a call on 22 values:
    # np.count_nonzero 3.4 k instructions against 1.1 k, np.clip 18 k against 4.6 k)
    from numpy._core.multiarray import count_nonzero as _count_nonzero
    from numpy._core.umath import clip as _clip
except ImportError:   # another numpy layout
    _count_nonzero, _clip = np.count_nonzero, np.clip
_subtract, _multiply, _absolute, _less_equal = np.subtract, np.multiply, np.absolute, np.less_equal


def _magnitude(bounds: tuple[float, float]) -> float:
    """The symmetric limit inside a (low, high) range."""
    return max(0.0, min(-bounds[0], bounds[1]))


class CommandError(ValueError):
    """A hardware command that cannot be applied at all (wrong lengths, unknown interface...)."""


class _Plan:
    """Which entries of a command (by its name/interface lists) go to which joint, with their bounds."""

    __slots__ = ("count", "pack", "entries", "indices", "dofs", "low", "high", "modes", "epoch", "none_outside")

    def __init__(self, size: int, entries: list[int], indices: list[int], dofs: np.ndarray, low: list[float],
                 high: list[float], modes: list[str]) -> None:
        self.count = len(indices)
        self.pack = struct.Struct(f"{size}d").pack   # the command's values as doubles
        in_order = entries == list(range(size))
        self.entries = None if in_order else np.array(entries, dtype=np.intp)   # None: every value, in order
        self.indices = indices          # URDF joint index per applied entry
        self.dofs = dofs                # DART DOF index per applied entry
        self.low, self.high = np.array(low, dtype=float), np.array(high, dtype=float)
        self.modes = modes
        self.epoch = -1                 # the mode epoch at which every entry's interface was its joint's mode
        self.none_outside = bytes(self.count)   # the bounds check's (value != clamped) when all are within


class HardwareInterface:
    """Joints of one entity in URDF order, their active command interface and current command."""

    def __init__(self, entity: Entity, gains_for: Callable[[str], Gains | None],
                 warn_once: Callable[[str], None] | None = None) -> None:
        self.entity = entity
        self.skeleton = entity.skeleton
        self.joints = entity.info.joints
        self.names = [j.name for j in self.joints]
        self.index = {name: i for i, name in enumerate(self.names)}
        self.dofs = np.array([entity.dof_index[name] for name in self.names], dtype=np.intp)
        self.dart_joints = [self.skeleton.getJoint(name) for name in self.names]
        overrides = [gains_for(name) for name in self.names]
        physics = (physics_gains(self.skeleton, [n for n, g in zip(self.names, overrides, strict=True) if g is None],
                                 entity.floating) if None in overrides else {})
        self.gains = [g if g is not None else physics[n] for n, g in zip(self.names, overrides, strict=True)]
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
        # Per DOF of the skeleton, in DART's order (what getPositions returns): no gather or scatter per step.
        # The floating base's DOFs and joints not in position mode have zero gains and no effort limit, so the
        # same arithmetic covers every DOF with no mask.
        ndof = self.skeleton.getNumDofs()
        self._ndof = ndof
        self._joint_at = {int(d): i for i, d in enumerate(self.dofs)}
        self._kp_all = self._per_dof(self.kp, 0.0)
        self._kd_all = self._per_dof(self.kd, 0.0)
        self._effort_all = self._per_dof(self.max_effort, math.inf)
        # velocity limits per DOF (inf: none, the floating base); see before_step
        self._velocity_all = self._per_dof(np.where(self.max_velocity > 0, self.max_velocity, math.inf), math.inf)
        self._velocity_limited = bool(np.isfinite(self._velocity_all).any())
        self._velocity_low = -self._velocity_all
        self._speed = np.zeros(ndof)                  # scratch arrays of the step's velocity and effort checks
        self._damping = np.zeros(ndof)
        self._magnitude = np.zeros(ndof)
        self._within = np.zeros(ndof, dtype=bool)
        self._all_within = np.ones(ndof, dtype=bool).tobytes()   # _within when no DOF is at its limit
        self._servo_torque = np.zeros(ndof)           # the step's servo torque, computed in place
        self._target = np.zeros(ndof)                 # command per DOF, in its joint's active interface's unit
        self._position = np.zeros(ndof, dtype=bool)   # DOFs of position-mode joints
        self._effort_mode = np.zeros(ndof, dtype=bool)
        self._kp = np.zeros(ndof)                     # stiffness of position-mode DOFs, else 0
        self._kd = np.zeros(ndof)
        self._lead = np.zeros(ndof)                   # kp * dt + kd: DART's spring-damper term on the velocity
        self._gain = np.zeros(ndof)                   # joint force per unit of target: kp, 1 (effort) or 0
        self._limit = np.full(ndof, math.inf)         # effort limit of position-mode DOFs, else inf
        self._force = np.zeros(ndof)                  # gain * target, the forces of an unsaturated step
        self._stale = True                            # _force needs recomputing (target or modes changed)
        self._saturated = np.zeros(ndof, dtype=bool)  # position DOFs at their effort limit this step
        self._any_saturated = False
        self._torque = np.zeros(ndof)                 # the last step's servo torque, unclamped (for efforts())
        self._torque_limit = self._limit              # ... and the limits it is reported within
        self._velocity_dofs: list[int] = []
        self._has_effort = False
        self._dt = math.nan
        self._mode_epoch = 0                          # counts interface switches (plans check modes once per epoch)
        self._plans: dict[tuple[tuple[str, ...], tuple[str, ...]], _Plan] = {}
        self._last_names: list[str] = []
        self._last_interfaces: list[str] = []
        self._last_plan: _Plan | None = None
        for i in range(n):
            self.dart_joints[i].setRestPosition(0, 0.0)   # the target enters as a force (module docstring)
            self._set_mode(i, "position")
            self._limit_velocity(i)
        self.hold_position()

    def _per_dof(self, values: np.ndarray, other: float) -> np.ndarray:
        out = np.full(self._ndof, other)
        out[self.dofs] = values
        return out

    # -- state ------------------------------------------------------------------------------------------
    def positions(self) -> np.ndarray:
        return np.asarray(self.skeleton.getPositions())[self.dofs]

    def velocities(self) -> np.ndarray:
        """Within the velocity limits (a velocity over one is cut at the start of the next step)."""
        velocities = np.asarray(self.skeleton.getVelocities())[self.dofs]
        if self._velocity_limited:
            limit = self._velocity_all[self.dofs]
            velocities = np.minimum(np.maximum(velocities, -limit), limit)
        return velocities

    def efforts(self) -> np.ndarray:
        """Per joint, of the last step: the position servo's torque (within the limit), the commanded torque
        (effort control) or 0 (velocity control)."""
        limit = self._torque_limit
        return np.minimum(np.maximum(self._torque, -limit), limit)[self.dofs]

    @property
    def target(self) -> np.ndarray:
        """The command value per joint (URDF order), in its active interface's unit (a copy)."""
        return self._target[self.dofs]

    def saturated(self) -> np.ndarray:
        """Per joint: position-controlled and held at its effort limit (spring off) in the last step."""
        return self._saturated[self.dofs]

    # -- commands ---------------------------------------------------------------------------------------
    def hold_position(self) -> None:
        """Every joint back to position control at its current position (no controller / timeout)."""
        current = self.positions()
        for i in range(len(self.names)):
            if self.mode[i] != "position":
                self._set_mode(i, "position")
        self._target[self.dofs] = np.clip(current, self.position_bounds[:, 0], self.position_bounds[:, 1])
        self._stale = True

    def _warn(self, key: str, message: str) -> None:
        if key not in self._warned:
            self._warned.add(key)
            self._warn_once(message)

    def apply_command(self, names: Sequence[str], interfaces: Sequence[str], values: Sequence[float]) -> int:
        """Take a HardwareCommand; returns how many entries were applied.

        Entries with an unknown joint, an interface the joint does not have, or a non-finite value are
        skipped (logged once each); values outside the limits are clamped (logged once per joint).
        """
        plan = self._last_plan
        # A controller manager sends the same name and interface lists every period: equal to the last ones
        # (compared in C), they need no length check of their own and no plan lookup.
        if (plan is None or type(names) is not list or type(interfaces) is not list
                or names != self._last_names or interfaces != self._last_interfaces):
            if not (len(names) == len(interfaces) == len(values)):
                raise self._length_error(names, interfaces, values)
            plan = self._plan(names, interfaces)
        elif len(values) != len(names):
            raise self._length_error(names, interfaces, values)
        if not plan.count:
            return 0
        if plan.epoch != self._mode_epoch and all(
                self.mode[i] == m for i, m in zip(plan.indices, plan.modes, strict=True)):
            plan.epoch = self._mode_epoch
        # Fast path (every control period): no interface switch, every value a finite number within its
        # bounds. Anything else (a switch, NaN, a clamp to warn about, a value that is no number) goes the
        # slow way, which also says what was wrong.
        if plan.epoch == self._mode_epoch:
            try:
                chosen = np.frombuffer(plan.pack(*values))   # 1.3 k instructions under np.fromiter
            except (TypeError, ValueError, struct.error):
                return self._apply_checked(plan, values)
            if plan.entries is not None:
                chosen = chosen[plan.entries]
            # (compared as bytes, a little cheaper than a count; NaN != NaN: never here)
            if (_clip(chosen, plan.low, plan.high) != chosen).tobytes() == plan.none_outside:
                self._target[plan.dofs] = chosen
                self._stale = True
                return plan.count
        return self._apply_checked(plan, values)

    @staticmethod
    def _length_error(names: Sequence[str], interfaces: Sequence[str], values: Sequence[float]) -> CommandError:
        return CommandError(f"name ({len(names)}), interface ({len(interfaces)}) and value ({len(values)}) "
                            "must have the same length")

    def _apply_checked(self, plan: _Plan, values: Sequence[float]) -> int:
        """apply_command's general case: per-entry checks, warnings, clamps and interface switches."""
        indices, modes, lo, hi = plan.indices, plan.modes, plan.low, plan.high
        entries = range(plan.count) if plan.entries is None else plan.entries
        try:
            chosen = np.array([float(values[e]) for e in entries])
        except (TypeError, ValueError):
            raise CommandError("value must be a list of numbers") from None
        finite = np.isfinite(chosen)
        if not finite.all():
            for k in np.nonzero(~finite)[0]:
                name = self.names[indices[k]]
                self._warn(f"nan:{name}", f"{self.entity.name}: non-finite {modes[k]} command {chosen[k]!r} "
                                          f"for joint {name!r} rejected")
        clamped = np.clip(chosen, lo, hi)
        outside = finite & (clamped != chosen)
        if outside.any():
            for k in np.nonzero(outside)[0]:
                self._warn_clamped(indices[k], modes[k], chosen[k], lo[k], hi[k])
        for k, i in enumerate(indices):
            if finite[k] and self.mode[i] != modes[k]:
                self._set_mode(int(i), modes[k])
        self._target[plan.dofs[finite]] = clamped[finite]
        self._stale = True
        return int(finite.sum())

    def _warn_clamped(self, i: int, interface: str, value: float, low: float, high: float) -> None:
        name = self.names[i]
        self._warn(f"range:{name}:{interface}",
                   f"{self.entity.name}: {interface} command {value:.4g} for joint {name!r} is outside "
                   f"[{low:.4g}, {high:.4g}]; clamped")

    def _plan(self, names: Sequence[str], interfaces: Sequence[str]) -> _Plan:
        """The plan of a command's name/interface lists, cached by content (and remembered as the last one)."""
        key = (tuple(names), tuple(interfaces))
        plan = self._plans.get(key)
        if plan is None:
            plan = self._make_plan(*key)
            if len(self._plans) > 64:
                self._plans.clear()
            self._plans[key] = plan
        self._last_names, self._last_interfaces, self._last_plan = list(names), list(interfaces), plan
        return plan

    def _make_plan(self, names: tuple[str, ...], interfaces: tuple[str, ...]) -> _Plan:
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
        return _Plan(len(names), entries, indices, self.dofs[indices], lows, highs, modes)

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
        self.mode[i] = interface
        dof = self.dofs[i]
        self._position[dof] = interface == "position"
        self._effort_mode[dof] = interface == "effort"
        self._saturated[dof] = False
        self._any_saturated = bool(np.count_nonzero(self._saturated))
        # New arrays, not updates in place: the last step's torque keeps the limits it was computed with.
        self._kp = np.where(self._position, self._kp_all, 0.0)
        self._kd = np.where(self._position, self._kd_all, 0.0)
        self._gain = self._kp + self._effort_mode
        self._limit = np.where(self._position, self._effort_all, math.inf)
        self._velocity_dofs = [int(d) for d, i in self._joint_at.items() if self.mode[i] == "velocity"]
        self._has_effort = bool(np.count_nonzero(self._effort_mode))
        self._dt = math.nan                            # _lead from the new gains at the next step
        self._stale = True
        self._mode_epoch += 1

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
    def before_step(self, dt: float | None = None) -> None:
        """Feed the current commands to DART (forces and servo commands are cleared by every step); ``dt``:
        the world's time step (read from the skeleton when not given).

        A position joint's spring-damper torque, as DART evaluates it at the start of the step
        (kp * (target - q - dt * qd) - kd * qd), is kept within the URDF effort limit: while it is inside,
        the implicit spring tracks the target; when it would exceed the limit, the spring is switched off
        for that step and the joint gets exactly the saturated torque as a plain force. The reported
        effort is that torque, so neither what is applied nor what is reported exceeds the limit."""
        skeleton = self.skeleton
        if dt != self._dt:   # the time step can change at run time (set_physics_properties); None: ask DART
            if dt is None:
                dt = skeleton.getTimeStep()
            if dt != self._dt:
                self._dt, self._lead = dt, self._kp * dt + self._kd
        if self._stale:
            self._force = self._gain * self._target
            self._stale = False
        velocities = skeleton.getVelocities()
        # the velocity limits, exactly: what DART's joint limit constraint let over (it is not hard: a
        # saturating jump went 5 % over) is cut before the step, as ``velocities()`` reports it
        if self._velocity_limited:
            within = _clip(velocities, self._velocity_low, self._velocity_all, self._speed)
            # the bytes compared (a memcmp) where a comparison ufunc and a count cost ~2 k instructions more a step
            if within.tobytes() != velocities.tobytes():
                velocities = within
                skeleton.setVelocities(velocities)
        # kp * (target - q) - lead * qd, into arrays kept for it: the same operations in the same order as the
        # expression, without four temporary arrays a step (~2 k instructions)
        # (the output array passed by position: a keyword costs the ufunc an argument parse)
        torque = _subtract(self._target, skeleton.getPositions(), self._servo_torque)
        _multiply(self._kp, torque, torque)
        _subtract(torque, _multiply(self._lead, velocities, self._damping), torque)
        if self._has_effort:   # reported as applied: the commanded torque (their gains are 0, so torque is too)
            torque = torque + self._effort_mode * self._target
        # efforts() reads it before the next step overwrites it (and makes its own array from it)
        self._torque, self._torque_limit = torque, self._limit
        # abs(NaN) <= limit is False: a NaN torque takes the slow path, as a saturated one
        # (compared as bytes: counting the True values cost ~250 instructions more a step)
        inside = _less_equal(_absolute(torque, self._magnitude), self._limit, self._within)
        if inside.tobytes() == self._all_within and not self._any_saturated:
            skeleton.setForces(self._force)
        else:
            skeleton.setForces(self._saturate(torque))
        if self._velocity_dofs:   # (tested first: rarely any, and a test is cheaper than an empty loop)
            for dof in self._velocity_dofs:
                skeleton.setCommand(dof, self._target[dof])

    def _saturate(self, torque: np.ndarray) -> np.ndarray:
        """The forces of a step in which a position joint is, or was, at its effort limit: the saturated ones
        get the limit with their spring off, the others their spring back."""
        limit = self._limit
        effort = np.minimum(np.maximum(torque, -limit), limit)
        saturated = (effort != torque) & self._position
        for dof in np.flatnonzero(saturated != self._saturated):
            on = 0.0 if saturated[dof] else 1.0
            joint = self.dart_joints[self._joint_at[int(dof)]]
            joint.setSpringStiffness(0, on * float(self._kp_all[dof]))
            joint.setDampingCoefficient(0, on * float(self._kd_all[dof]))
        self._saturated, self._any_saturated = saturated, bool(np.count_nonzero(saturated))
        return np.where(saturated, effort, self._force)

    # -- kinematic mode ---------------------------------------------------------------------------------
    def set_kinematic(self, dt: float) -> None:
        """No dynamics: joints jump to their position commands (clamped); velocities are the finite difference."""
        q = self.positions()
        target = self.target
        new_q = q.copy()
        for i, mode in enumerate(self.mode):
            if mode == "position":
                new_q[i] = target[i]
            elif mode == "velocity":
                new_q[i] = q[i] + target[i] * dt
        new_q = np.clip(new_q, self.position_bounds[:, 0], self.position_bounds[:, 1])
        positions = np.array(self.skeleton.getPositions())
        velocities = np.zeros(self.skeleton.getNumDofs())
        positions[self.dofs] = new_q
        velocities[self.dofs] = (new_q - q) / dt if dt > 0 else 0.0
        self.skeleton.setPositions(positions)
        self.skeleton.setVelocities(velocities)
        self._torque = np.zeros(self._ndof)

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
