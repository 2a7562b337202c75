"""The ROS packages the zenroid stack serves, and the node or tool each of their executables is.

Their share folders (launch files and such) are ``nodes/share/packages/<pkg>``; this table is what runs.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Served:
    module: str  # run as ``python -m module``
    module_args: tuple[str, ...] = ()
    ros_node: bool = False  # takes our node options (--ros-args are translated to them)
    what: str = ""


TOOLS = "nodes.tools"

SERVED: dict[str, dict[str, Served]] = {
    "controller_manager": {
        "spawner": Served(TOOLS, ("control", "spawner"), what="zenroid control spawner"),
        "ros2_control_node": Served("nodes.ros2_control_node", ros_node=True,
                                    what="our controller manager; hardware: the simulator or GenericSystem"),
        "unspawner": Served(TOOLS, ("control",), what="zenroid control set_controller_state + unload_controller"),
    },
    "robot_state_publisher": {
        "robot_state_publisher": Served("nodes.state_publisher", ros_node=True, what="our state publisher"),
    },
    "gazebo_ros2_control": {
        # what Gazebo's plugin loading does (gzserver.launch.py starts it beside the simulator)
        "gazebo_ros2_control": Served("nodes.gazebo_ros2_control", ros_node=True,
                                      what="a controller manager for each robot whose URDF loads the plugin"),
    },
    "joint_state_publisher": {
        "joint_state_publisher": Served("nodes.joint_state_publisher.node", ros_node=True,
                                        what="joint_states from the robot description"),
    },
    "joint_state_publisher_gui": {
        "joint_state_publisher_gui": Served("nodes.joint_state_publisher.gui", ros_node=True,
                                            what="the joint state publisher with a web page of sliders"),
    },
    "gazebo_ros": {
        "spawn_entity.py": Served(TOOLS, ("spawn",), what="zenroid spawn"),
    },
    "ros_gz_sim": {
        "create": Served(TOOLS, ("spawn",), what="zenroid spawn"),
    },
    "tf2_ros": {
        "static_transform_publisher": Served("nodes.static_transform", ros_node=True,
                                             what="a latched tf_static transform"),
    },
    "xacro": {
        "xacro": Served(TOOLS, ("xacro",), what="zenroid xacro"),
    },
    "rviz2": {
        "rviz2": Served("nodes.viz", ros_node=True, what="our Rerun viewer"),
    },
}


def served() -> list[str]:
    """The packages served, by name."""
    return sorted(SERVED)


def entries(package: str) -> dict[str, Served]:
    """``name -> Served`` for a served package (empty for any other)."""
    return dict(SERVED.get(package, {}))
