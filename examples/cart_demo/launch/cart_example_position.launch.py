"""The position cart: Gazebo (gazebo_ros' gazebo.launch.py), the cart spawned from /robot_description, then the
joint state broadcaster and the joint trajectory controller loaded one after the other.

    ros2 launch cart_demo cart_example_position.launch.py
    ros2 run cart_demo example_position.py
"""

import os

import xacro

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import ExecuteProcess, IncludeLaunchDescription, RegisterEventHandler
from launch.event_handlers import OnProcessExit
from launch.launch_description_sources import PythonLaunchDescriptionSource
from launch_ros.actions import Node


def generate_launch_description():
    gazebo = IncludeLaunchDescription(
        PythonLaunchDescriptionSource(
            [os.path.join(get_package_share_directory('gazebo_ros'), 'launch'), '/gazebo.launch.py']),
    )

    # xacro's Python API, as the gazebo_ros2_control demos use it; $(find cart_demo) inside the file
    # resolves through the package index
    xacro_file = os.path.join(get_package_share_directory('cart_demo'), 'urdf', 'cart_position.urdf.xacro')
    doc = xacro.parse(open(xacro_file))
    xacro.process_doc(doc)
    robot_description = {'robot_description': doc.toxml()}

    robot_state_publisher = Node(
        package='robot_state_publisher',
        executable='robot_state_publisher',
        output='screen',
        parameters=[robot_description],
    )

    spawn_entity = Node(
        package='gazebo_ros',
        executable='spawn_entity.py',
        arguments=['-topic', 'robot_description', '-entity', 'cart'],
        output='screen',
    )

    load_joint_state_broadcaster = ExecuteProcess(
        cmd=['ros2', 'control', 'load_controller', '--set-state', 'active', 'joint_state_broadcaster'],
        output='screen',
    )

    load_joint_trajectory_controller = ExecuteProcess(
        cmd=['ros2', 'control', 'load_controller', '--set-state', 'active', 'joint_trajectory_controller'],
        output='screen',
    )

    return LaunchDescription([
        # the plugin's controller manager exists once the cart is in the world
        RegisterEventHandler(OnProcessExit(target_action=spawn_entity,
                                           on_exit=[load_joint_state_broadcaster])),
        RegisterEventHandler(OnProcessExit(target_action=load_joint_state_broadcaster,
                                           on_exit=[load_joint_trajectory_controller])),
        gazebo,
        robot_state_publisher,
        spawn_entity,
    ])
