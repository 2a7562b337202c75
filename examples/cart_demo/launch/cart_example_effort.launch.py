"""The effort cart: as the position cart, with a JointGroupEffortController taking newtons on
/effort_controller/commands. The controllers are loaded by controller_manager's spawner, chained the same way.

    ros2 launch cart_demo cart_example_effort.launch.py
    ros2 topic pub --once /effort_controller/commands std_msgs/msg/Float64MultiArray "{data: [5.0]}"
"""

import os

import xacro

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import IncludeLaunchDescription, RegisterEventHandler
from launch.event_handlers import OnProcessExit
from launch.launch_description_sources import PythonLaunchDescriptionSource
from launch_ros.actions import Node


def generate_launch_description():
    share = get_package_share_directory('cart_demo')
    gazebo = IncludeLaunchDescription(
        PythonLaunchDescriptionSource(
            [os.path.join(get_package_share_directory('gazebo_ros'), 'launch'), '/gazebo.launch.py']),
    )

    robot_description = {'robot_description': xacro.process_file(
        os.path.join(share, 'urdf', 'cart_effort.urdf.xacro')).toxml()}

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

    joint_state_broadcaster_spawner = Node(
        package='controller_manager',
        executable='spawner',
        arguments=['joint_state_broadcaster', '--controller-manager', '/controller_manager'],
    )

    effort_controller_spawner = Node(
        package='controller_manager',
        executable='spawner',
        arguments=['effort_controller', '-c', '/controller_manager',
                   '--param-file', os.path.join(share, 'config', 'cart_controller_effort.yaml')],
    )

    return LaunchDescription([
        RegisterEventHandler(OnProcessExit(target_action=spawn_entity,
                                           on_exit=[joint_state_broadcaster_spawner])),
        RegisterEventHandler(OnProcessExit(target_action=joint_state_broadcaster_spawner,
                                           on_exit=[effort_controller_spawner])),
        gazebo,
        robot_state_publisher,
        spawn_entity,
    ])
