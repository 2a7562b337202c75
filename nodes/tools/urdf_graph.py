"""``zenroid urdf_to_graphviz FILE [name:=value ...]``: the link/joint tree as Graphviz (ROS ``urdf_to_graphviz``).

Writes ``<robot>.gv`` (links as boxes, joints as blue ellipses, each joint's origin on the edge from its
parent, as the ROS tool draws it) and, when Graphviz's ``dot`` is installed, ``<robot>.pdf`` (or
``--format png|svg``). Without ``dot`` it says so and keeps the ``.gv``.
"""

from __future__ import annotations

import argparse
import math
import shutil
import subprocess
from pathlib import Path

import numpy as np

from nodes.tools.common import write_line
from nodes.tools.errors import Failed, UsageError
from nodes.urdf import RobotModel, UrdfError, load_robot_description, parse_urdf, parse_xacro_args


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("file", help="URDF or .xacro file")
    parser.add_argument("xacro_args", nargs="*", metavar="name:=value", help="xacro arguments")
    parser.add_argument("-o", "--output", default="", help="output path without extension (default: the robot's name)")
    parser.add_argument("--format", choices=["pdf", "png", "svg"], default="pdf", help="what dot renders (default pdf)")


def _number(value: float) -> str:
    return f"{0.0 if abs(value) < 1e-12 else value:.6g}"


def xyz_rpy(transform: np.ndarray) -> tuple[list[float], list[float]]:
    """Translation and URDF roll-pitch-yaw (R = Rz(yaw) Ry(pitch) Rx(roll)) of a 4x4 transform."""
    r = transform[:3, :3]
    pitch = math.asin(max(-1.0, min(1.0, -float(r[2, 0]))))
    if abs(math.cos(pitch)) > 1e-9:
        roll = math.atan2(float(r[2, 1]), float(r[2, 2]))
        yaw = math.atan2(float(r[1, 0]), float(r[0, 0]))
    else:  # gimbal lock: fold the rotation into yaw
        roll, yaw = 0.0, math.atan2(-float(r[0, 1]), float(r[1, 1]))
    return [float(v) for v in transform[:3, 3]], [roll, pitch, yaw]


def _quote(name: str) -> str:
    return '"' + name.replace("\\", "\\\\").replace('"', '\\"') + '"'


def to_dot(model: RobotModel) -> str:
    lines = ["digraph G {", "node [shape=box];"]
    lines += [f"{_quote(link)} [label={_quote(link)}];" for link in model.links]
    lines.append("node [shape=ellipse, color=blue, fontcolor=blue];")
    for joint in model.joints.values():
        xyz, rpy = xyz_rpy(joint.origin)
        label = f"xyz: {' '.join(map(_number, xyz))} \\nrpy: {' '.join(map(_number, rpy))}"
        lines.append(f'{_quote(joint.parent)} -> {_quote(joint.name)} [label="{label}"]')
        lines.append(f"{_quote(joint.name)} -> {_quote(joint.child)}")
    lines.append("}")
    return "\n".join(lines) + "\n"


def run(args: argparse.Namespace) -> int:
    try:
        model = parse_urdf(load_robot_description(args.file, xacro_args=parse_xacro_args(args.xacro_args)))
    except UrdfError as exc:
        raise UsageError(f"{args.file}: {exc}") from None
    prefix = Path(args.output or model.name)
    gv = prefix.with_name(prefix.name + ".gv")
    try:
        gv.write_text(to_dot(model))
    except OSError as exc:
        raise Failed(f"cannot write {gv}: {exc.strerror}") from None
    write_line(f"Created file {gv}")
    dot = shutil.which("dot")
    if dot is None:
        write_line(f"Graphviz `dot` is not installed: no .{args.format} drawn (install it with `apt install graphviz`, "
                   f"then `dot -T{args.format} {gv} -o {prefix.name}.{args.format}`)")
        return 0
    out = prefix.with_name(f"{prefix.name}.{args.format}")
    done = subprocess.run([dot, f"-T{args.format}", str(gv), "-o", str(out)], capture_output=True, text=True,
                          timeout=60)
    if done.returncode != 0:
        raise Failed(f"dot failed on {gv}: {done.stderr.strip().splitlines()[-1] if done.stderr.strip() else done.returncode}")
    write_line(f"Created file {out}")
    return 0
