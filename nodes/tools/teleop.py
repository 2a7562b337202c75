"""``zenroid teleop``: nudge a trajectory controller's joints from the keyboard, in any terminal (ssh too).

    zenroid teleop [--ns humanoid] [--controller joint_trajectory_controller] [--step 0.05] [--move-time 0.2]

The screen lists the controller's joints with their measured position (``<ns>/joint_states``) and the
target being commanded. Keys: arrows or k/j select a joint, + / - move its target by one step (kept
inside the joint's limits from ``<ns>/robot_description``), 0 sends every joint to 0 (the zero pose,
clamped into the limits), q quits (exit 0). Each key press sends one JointTrajectory point for every
joint of the controller, reached in ``--move-time`` s (``--zero-time`` for the zero pose).

Targets start at the controller's own reference (``<controller>/controller_state``), not at the measured
positions, so a press never re-commands a servo's sag. The terminal UI is the standard library's curses.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from dataclasses import dataclass, field
from typing import Any

import msgs
from msgs import duration_from_sec
from msgs.control_msgs import JointTrajectoryControllerState as ControllerState
from msgs.sensor_msgs import JointState
from msgs.std_msgs import String
from msgs.trajectory_msgs import JointTrajectory, JointTrajectoryPoint
from nodes.core.delivery import Inline, Raw
from nodes.tools.cli import UsageError
from nodes.tools.common import add_common

KEYS_HELP = "up/down or k/j: select   +/-: nudge   0: zero pose   q: quit"


@dataclass
class TeleopModel:
    """What the screen shows and the keys change (no terminal, no Zenoh: unit tested)."""

    joints: list[str]
    targets: list[float]
    lower: list[float]
    upper: list[float]
    step: float = 0.05
    selected: int = 0
    measured: dict[str, float] = field(default_factory=dict)
    status: str = ""

    @classmethod
    def create(cls, joints: list[str], reference: list[float], limits: dict[str, tuple[float, float]],
               step: float) -> TeleopModel:
        lower = [limits.get(j, (-math.inf, math.inf))[0] for j in joints]
        upper = [limits.get(j, (-math.inf, math.inf))[1] for j in joints]
        targets = [min(max(float(v), lo), hi) for v, lo, hi in zip(reference, lower, upper, strict=True)]
        return cls(list(joints), targets, lower, upper, step)

    def select(self, delta: int) -> None:
        self.selected = (self.selected + delta) % len(self.joints)

    def nudge(self, direction: int) -> bool:
        """Move the selected joint's target one step; False (and a status line) when a limit stops it."""
        i = self.selected
        wanted = self.targets[i] + direction * self.step
        clamped = min(max(wanted, self.lower[i]), self.upper[i])
        if clamped == self.targets[i]:
            side = "upper" if direction > 0 else "lower"
            limit = self.upper[i] if direction > 0 else self.lower[i]
            self.status = f"{self.joints[i]} is at its {side} limit {limit:+.3f} rad"
            return False
        self.targets[i] = clamped
        self.status = f"{self.joints[i]} -> {clamped:+.3f} rad" + ("" if clamped == wanted else " (limit)")
        return True

    def zero(self) -> None:
        self.targets = [min(max(0.0, lo), hi) for lo, hi in zip(self.lower, self.upper, strict=True)]
        self.status = "zero pose"

    def trajectory(self, move_time: float) -> Any:
        point = JointTrajectoryPoint(positions=list(self.targets), time_from_start=duration_from_sec(move_time))
        return JointTrajectory(joint_names=list(self.joints), points=[point])

    def rows(self) -> list[str]:
        width = max(len(j) for j in self.joints)
        lines = []
        for i, joint in enumerate(self.joints):
            measured = self.measured.get(joint)
            shown = _number(measured) if measured is not None else "     n/a"
            lo, hi = self.lower[i], self.upper[i]
            limits = f"[{lo:+.2f}, {hi:+.2f}]" if math.isfinite(lo) and math.isfinite(hi) else "(no limits)"
            marker = ">" if i == self.selected else " "
            lines.append(f"{marker} {joint:<{width}}  {shown}  {_number(self.targets[i])}  {limits}")
        return lines

    def header(self) -> str:
        width = max(len(j) for j in self.joints)
        return f"  {'joint':<{width}}  {'position':>8}  {'target':>8}  limits (rad)"


def _number(value: float) -> str:
    return f"{round(value, 3) + 0.0:+8.3f}"  # + 0.0 turns -0.0 into 0.0: no "-0.000" on screen


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--ns", "--namespace", dest="namespace", default=os.environ.get("ZENROID_NS", "humanoid"),
                        help="robot namespace (default: $ZENROID_NS or humanoid)")
    parser.add_argument("--controller", default="joint_trajectory_controller", help="joint trajectory controller")
    parser.add_argument("--step", type=float, default=0.05, help="rad per key press (default 0.05)")
    parser.add_argument("--move-time", type=float, default=0.2, help="time_from_start of a nudge (s, default 0.2)")
    parser.add_argument("--zero-time", type=float, default=1.0, help="time_from_start of the zero pose (s)")
    parser.add_argument("--timeout", type=float, default=10.0, help="s to wait for the controller (default 10)")
    add_common(parser)


def _limits(node: Any, timeout: float) -> tuple[dict[str, tuple[float, float]], str]:
    """Position limits from the latched robot description (none if it is not published)."""
    from nodes.urdf.model import UrdfError, parse_urdf

    msg = node.fetch_latched(String, "robot_description", timeout=timeout)
    if msg is None:
        return {}, f"no {node.resolve('robot_description')}: joint limits unknown"
    try:
        model = parse_urdf(msg.data)
    except UrdfError as exc:
        return {}, f"robot_description unusable ({exc}): joint limits unknown"
    limits = {j.name: (j.lower if j.lower is not None else -math.inf, j.upper if j.upper is not None else math.inf)
              for j in model.joints.values() if j.movable}
    return limits, ""


def run(args: argparse.Namespace) -> int:
    for name in ("step", "move_time", "zero_time", "timeout"):
        value = getattr(args, name)
        if not (math.isfinite(value) and value > 0):
            raise UsageError(f"--{name.replace('_', '-')} must be a positive number of seconds/radians, got {value}")
    if not os.isatty(0) or not os.isatty(1):
        raise UsageError("teleop needs a terminal (stdin and stdout must be a TTY)")
    from nodes.core import Node, connect_from_args

    node = Node(f"teleop_{os.getpid()}", namespace=args.namespace, connect=connect_from_args(args), log_level="warn")
    try:
        latest: dict[str, Any] = {}
        node.create_subscription(ControllerState, f"{args.controller}/controller_state",
                                 lambda raw: latest.__setitem__("state", raw),
                                 delivery=Inline(), message=Raw())
        node.create_subscription(JointState, "joint_states",
                                 lambda raw: latest.__setitem__("joints", raw),
                                 delivery=Inline(), message=Raw())
        deadline = time.monotonic() + args.timeout
        while "state" not in latest:
            if time.monotonic() > deadline:
                print(f"zenroid teleop: no {node.resolve(args.controller + '/controller_state')} within "
                      f"{args.timeout:g} s: is the controller running and active?", file=sys.stderr)
                return 1
            time.sleep(0.05)
        state = msgs.decode(ControllerState, latest["state"])
        reference = list(state.reference.positions) or list(state.desired.positions)
        limits, note = _limits(node, timeout=2.0)
        model = TeleopModel.create(list(state.joint_names), reference, limits, args.step)
        model.status = note or f"{len(model.joints)} joints; targets start at the controller's reference"
        publisher = node.create_publisher(JointTrajectory, f"{args.controller}/joint_trajectory")
        import curses

        curses.wrapper(_ui, model, latest, publisher, args, node.resolve(args.controller))
        return 0
    finally:
        node.destroy()


def _ui(screen: Any, model: TeleopModel, latest: dict[str, Any], publisher: Any, args: argparse.Namespace,
        title: str) -> None:
    import curses

    curses.curs_set(0)
    screen.timeout(100)  # redraw at 10 Hz with the latest joint_states
    while True:
        raw = latest.get("joints")
        if raw is not None:
            try:
                js = msgs.decode(JointState, raw)
                model.measured.update(zip(js.name, js.position, strict=False))
            except msgs.DecodeError as exc:
                model.status = f"joint_states not decodable: {exc}"
        _draw(screen, model, args, title)
        key = screen.getch()
        if key in (ord("q"), ord("Q")):
            return
        if key in (curses.KEY_UP, ord("k")):
            model.select(-1)
        elif key in (curses.KEY_DOWN, ord("j")):
            model.select(+1)
        elif key in (ord("+"), ord("=")):
            if model.nudge(+1):
                publisher.publish(model.trajectory(args.move_time))
        elif key in (ord("-"), ord("_")):
            if model.nudge(-1):
                publisher.publish(model.trajectory(args.move_time))
        elif key == ord("0"):
            model.zero()
            publisher.publish(model.trajectory(args.zero_time))


def _draw(screen: Any, model: TeleopModel, args: argparse.Namespace, title: str) -> None:
    import curses

    screen.erase()
    height, width = screen.getmaxyx()
    lines = [f"zenroid teleop  {title}  step {model.step:.3f} rad  move {args.move_time:g} s", KEYS_HELP, "",
             model.header()]
    rows = model.rows()
    visible = max(1, height - len(lines) - 2)
    first = min(max(0, model.selected - visible // 2), max(0, len(rows) - visible))
    for y, text in enumerate(lines):
        _put(screen, y, text, width, curses.A_BOLD if y == 0 else curses.A_NORMAL)
    for k, text in enumerate(rows[first:first + visible]):
        selected = first + k == model.selected
        _put(screen, len(lines) + k, text, width, curses.A_REVERSE if selected else curses.A_NORMAL)
    _put(screen, min(height - 1, len(lines) + visible + 1), model.status, width, curses.A_NORMAL)
    screen.refresh()


def _put(screen: Any, y: int, text: str, width: int, attr: int) -> None:
    import curses

    try:
        screen.addnstr(y, 0, text, max(0, width - 1), attr)
    except curses.error:  # a terminal smaller than the text: show what fits
        pass
