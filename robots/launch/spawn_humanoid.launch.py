"""Seed 000's spawn_humanoid.launch.py for zenroid's humanoid: gazebo_ros's gazebo.launch.py with a world,
robot_state_publisher with the URDF, and spawn_entity.py from /robot_description at x, y, z. Everything at
the root namespace, as the tutorial's files put it (/joint_states, /robot_description).

    ros2 launch zenroid_description spawn_humanoid.launch.py world:=simple_lab.world z:=1.5
"""

import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, IncludeLaunchDescription
from launch.launch_description_sources import PythonLaunchDescriptionSource
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node


def generate_launch_description():
    pkg_gazebo_ros = get_package_share_directory('gazebo_ros')
    urdf = os.path.join(get_package_share_directory('zenroid_description'), 'urdf', 'humanoid.urdf')
    with open(urdf) as file:
        robot_description = file.read()
    gazebo = IncludeLaunchDescription(
        PythonLaunchDescriptionSource(os.path.join(pkg_gazebo_ros, 'launch', 'gazebo.launch.py')),
        launch_arguments={'world': LaunchConfiguration('world')}.items())
    robot_state_publisher = Node(
        package='robot_state_publisher', executable='robot_state_publisher', name='robot_state_publisher',
        output='screen', parameters=[{'robot_description': robot_description}])
    spawn_entity = Node(
        package='gazebo_ros', executable='spawn_entity.py', output='screen',
        arguments=['-entity', 'humanoid', '-topic', '/robot_description',
                   '-x', LaunchConfiguration('x'), '-y', LaunchConfiguration('y'), '-z', LaunchConfiguration('z')])
    return LaunchDescription([
        DeclareLaunchArgument('world', default_value='simple_lab.world', description='World file to load'),
        DeclareLaunchArgument('x', default_value='0.0'),
        DeclareLaunchArgument('y', default_value='0.0'),
        DeclareLaunchArgument('z', default_value='1.0'),
        gazebo,
        robot_state_publisher,
        spawn_entity,
    ])
