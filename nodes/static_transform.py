"""tf2_ros' ``static_transform_publisher``: one transform, latched on ``tf_static``.

Both of its command lines::

    static_transform_publisher --x 1 --y 0 --z 0.5 --yaw 0 --pitch 0 --roll 0 --frame-id world --child-frame-id cam
    static_transform_publisher 1 0 0.5 0 0 0 world cam            # x y z yaw pitch roll parent child
    static_transform_publisher 1 0 0.5 0 0 0 1 world cam          # x y z qx qy qz qw parent child
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from typing import Any

import msgs
from msgs.tf2_msgs import TFMessage
from nodes.core import Node, run_node


def quaternion_from_rpy(roll: float, pitch: float, yaw: float) -> tuple[float, float, float, float]:
    """(x, y, z, w) of the rotation yaw about z, then pitch about y, then roll about x (fixed axes: tf2's)."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return (sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy,
            cr * cp * cy + sr * sp * sy)


def parse_transform(args: argparse.Namespace) -> dict[str, Any]:
    """The transform of either command line; ValueError names what is wrong."""
    legacy = list(args.legacy)
    if legacy:
        if len(legacy) not in (8, 9):
            raise ValueError(f"expected 'x y z yaw pitch roll frame_id child_frame_id' or 'x y z qx qy qz qw "
                             f"frame_id child_frame_id', got {len(legacy)} arguments")
        try:
            numbers = [float(v) for v in legacy[:-2]]
        except ValueError as exc:
            raise ValueError(f"a number is not one: {exc}") from None
        x, y, z = numbers[:3]
        quat = quaternion_from_rpy(numbers[5], numbers[4], numbers[3]) if len(numbers) == 6 else tuple(numbers[3:])
        parent, child = legacy[-2], legacy[-1]
    else:
        x, y, z = args.x, args.y, args.z
        if args.qx is not None or args.qy is not None or args.qz is not None or args.qw is not None:
            if any(v is not None for v in (args.roll, args.pitch, args.yaw)):
                raise ValueError("give a rotation as a quaternion or as roll/pitch/yaw, not both")
            quat = (args.qx or 0.0, args.qy or 0.0, args.qz or 0.0, 1.0 if args.qw is None else args.qw)
        else:
            quat = quaternion_from_rpy(args.roll or 0.0, args.pitch or 0.0, args.yaw or 0.0)
        parent, child = args.frame_id, args.child_frame_id
        if not parent or not child:
            raise ValueError("--frame-id and --child-frame-id are both needed")
    norm = math.sqrt(sum(q * q for q in quat))
    if not all(math.isfinite(v) for v in (x, y, z, *quat)) or norm < 1e-9:
        raise ValueError("the translation and rotation must be finite, the quaternion not zero")
    if parent == child:
        raise ValueError(f"frame_id and child_frame_id are both '{parent}'")
    qx, qy, qz, qw = (q / norm for q in quat)
    return {"header": {"frame_id": parent}, "child_frame_id": child,
            "transform": {"translation": {"x": x, "y": y, "z": z}, "rotation": {"x": qx, "y": qy, "z": qz, "w": qw}}}


class StaticTransformPublisher(Node):
    default_name = f"static_transform_publisher_{os.getpid()}"

    def __init__(self, cli_args: argparse.Namespace, **kwargs: Any) -> None:
        transform = parse_transform(cli_args)
        super().__init__(self.default_name, **kwargs)
        self.publisher = self.create_publisher(TFMessage, "tf_static", latched=True)
        sec, nanosec = divmod(int(self.now() * 1e9), 1_000_000_000)
        transform["header"]["stamp"] = {"sec": sec, "nanosec": nanosec}
        self.publisher.publish(msgs.from_dict(TFMessage, {"transforms": [transform]}))
        t, r = transform["transform"]["translation"], transform["transform"]["rotation"]
        self.logger.info(f"spinning until stopped - publishing transform from '{transform['header']['frame_id']}' "
                         f"to '{transform['child_frame_id']}': translation ({t['x']:g}, {t['y']:g}, {t['z']:g}), "
                         f"rotation ({r['x']:g}, {r['y']:g}, {r['z']:g}, {r['w']:g})")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="static_transform_publisher", description=__doc__.split("\n")[0])
    parser.add_argument("legacy", nargs="*", help="x y z yaw pitch roll (or qx qy qz qw) frame_id child_frame_id")
    for name in ("x", "y", "z"):
        parser.add_argument(f"--{name}", type=float, default=0.0)
    for name in ("qx", "qy", "qz", "qw", "roll", "pitch", "yaw"):
        parser.add_argument(f"--{name}", type=float, default=None)
    parser.add_argument("--frame-id", "--frame_id", dest="frame_id")
    parser.add_argument("--child-frame-id", "--child_frame_id", dest="child_frame_id")
    return parser


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser()
    try:
        known, _ = parser.parse_known_args(argv)
        parse_transform(known)
    except ValueError as exc:
        print(f"static_transform_publisher: {exc}", file=sys.stderr)
        return 2
    return run_node(StaticTransformPublisher, argv, parser=build_parser())


if __name__ == "__main__":
    sys.exit(main())
