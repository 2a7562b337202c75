"""Trajectory visualizer: the Module 2 tutorial's marker example ("Markers: Visualizing Computed Results").

Like the tutorial's ``TrajectoryVisualizer`` node, ``trajectory_visualizer`` publishes a
``visualization_msgs/Marker`` on ``/visualization/trajectory``: frame ``map``, type LINE_STRIP, action ADD,
``scale.x`` 0.05 (the line width), opaque red, one point per waypoint. The tutorial calls
``visualize_trajectory(waypoints)`` once; markers are not latched (RViz and our viewer only see messages
published after they subscribe), so this node republishes every ``period`` seconds.

    python -m launch humanoid.yaml commander:=trajectory_visualizer
    python -m nodes.commanders.trajectory_visualizer --param "waypoints:=[0, 0, 0, 1, 0, 0, 1, 1, 0]"
"""

from __future__ import annotations

import sys
from collections.abc import Sequence

from msgs.geometry_msgs import Point
from msgs.visualization_msgs import Marker
from nodes.core import Node, run_node

# A path the humanoid could walk on the ground in front of it (x forward, y left, z up; m), 2 cm up so it is
# not hidden in the ground plane.
DEFAULT_WAYPOINTS = [0.0, 0.0, 0.02, 0.5, 0.0, 0.02, 1.0, 0.25, 0.02, 1.5, 0.25, 0.02, 1.8, -0.2, 0.02]


def as_waypoints(flat: Sequence[float]) -> list[tuple[float, float, float]]:
    """``[x0, y0, z0, x1, ...]`` as points; raises ValueError naming the problem."""
    if len(flat) < 6 or len(flat) % 3:
        raise ValueError(f"waypoints: {len(flat)} numbers; give x, y, z for at least 2 waypoints")
    return [(float(flat[i]), float(flat[i + 1]), float(flat[i + 2])) for i in range(0, len(flat), 3)]


class TrajectoryVisualizer(Node):
    default_name = "trajectory_visualizer"

    def __init__(self, **kwargs) -> None:
        super().__init__("trajectory_visualizer", **kwargs)
        self.marker_pub = self.create_publisher(Marker, "/visualization/trajectory")
        self.waypoints = as_waypoints(self.declare_parameter(
            "waypoints", DEFAULT_WAYPOINTS, description="x, y, z of each waypoint in frame_id (m), flattened"))
        self.frame_id = self.declare_parameter("frame_id", "map", description="frame of the waypoints")
        period = self.declare_parameter("period", 1.0, min_value=0.05, description="s between republishes")
        self.timer = self.create_timer(period, lambda: self.visualize_trajectory(self.waypoints))
        self.add_on_set_parameter_callback(self.on_parameter)
        self.visualize_trajectory(self.waypoints)
        self.logger.info(f"publishing a {len(self.waypoints)}-waypoint trajectory on visualization/trajectory "
                         f"(frame '{self.frame_id}') every {period:g} s")

    def on_parameter(self, name: str, value) -> str | None:
        """Every parameter applies at once; bad waypoints are refused with the reason."""
        if name == "waypoints":
            try:
                self.waypoints = as_waypoints(value)
            except ValueError as exc:
                return str(exc)
        elif name == "frame_id":
            self.frame_id = value
        elif name == "period":
            self.timer.cancel()
            self.timer = self.create_timer(value, lambda: self.visualize_trajectory(self.waypoints))
        self.visualize_trajectory(self.waypoints)
        return None

    def visualize_trajectory(self, waypoints: Sequence[tuple[float, float, float]]) -> None:
        marker = Marker()
        marker.header.frame_id = self.frame_id
        marker.header.stamp = self.now_msg()
        marker.type = Marker.LINE_STRIP
        marker.action = Marker.ADD
        marker.scale.x = 0.05  # line width
        marker.color.a = 1.0
        marker.color.r = 1.0
        marker.color.g = 0.0
        marker.color.b = 0.0
        for waypoint in waypoints:
            point = Point()
            point.x, point.y, point.z = waypoint
            marker.points.append(point)
        self.marker_pub.publish(marker)


def main(argv: list[str] | None = None) -> int:
    return run_node(TrajectoryVisualizer, argv)


if __name__ == "__main__":
    sys.exit(main())
