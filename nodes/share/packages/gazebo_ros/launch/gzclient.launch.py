"""gazebo_ros's gzclient.launch.py, served by zenroid: the GUI is our Rerun viewer (its URL printed when
headless). Arguments as gazebo_ros's (verbose, gdb, valgrind accepted)."""

import sys

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, ExecuteProcess


def generate_launch_description():
    return LaunchDescription([
        DeclareLaunchArgument('verbose', default_value='false'),
        DeclareLaunchArgument('gdb', default_value='false', description='accepted; ignored'),
        DeclareLaunchArgument('valgrind', default_value='false', description='accepted; ignored'),
        ExecuteProcess(name='gzclient', cmd=[sys.executable, '-m', 'nodes.viz'], output='screen'),
    ])
