"""humanoid.yaml written with the ROS launch API: the same processes, the same namespace (``humanoid``).

    python -m launch humanoid.launch.py gui:=false mode:=lockstep

bench/startup.py --launch-file humanoid.launch.py compares its start-up with humanoid.yaml's (docs/performance.md).
"""

import sys

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, ExecuteProcess, Shutdown
from launch.conditions import IfCondition
from launch.substitutions import (
    EqualsSubstitution,
    LaunchConfiguration,
    NotSubstitution,
    PathJoinSubstitution,
)
from launch_ros.actions import Node
from launch_ros.substitutions import FindPackageShare


def python_node(name, module, *options, **kwargs):
    return ExecuteProcess(name=name, cmd=[sys.executable, '-m', module, '--name', name, *options], output='screen',
                          **kwargs)


def generate_launch_description():
    robot = LaunchConfiguration('robot')
    robot_file = PathJoinSubstitution([FindPackageShare('zenroid_description'), 'urdf', [robot, '.urdf']])
    entity = ['entities:=[{name: ', robot, ', file: ', robot_file, ', namespace: ', robot]
    for axis in 'xyzRPY':
        entity += [f', {axis}: ', LaunchConfiguration(axis)]
    entity += ['}]']
    sim_params = ['-p', ['mode:=', LaunchConfiguration('mode')], '-p', ['world:=', LaunchConfiguration('world')],
                  '-p', ['paused:=', LaunchConfiguration('paused')], '-p', ['sensors:=', LaunchConfiguration('sensors')],
                  '-p', entity]
    spawner = dict(package='controller_manager', executable='spawner', namespace=robot, output='screen')
    wait = ['--controller-manager-timeout', '60']   # as humanoid.yaml: a loaded machine starts the manager late
    return LaunchDescription([
        DeclareLaunchArgument('robot', default_value='humanoid'),
        *[DeclareLaunchArgument(axis, default_value='auto' if axis == 'z' else '0.0') for axis in 'xyzRPY'],
        DeclareLaunchArgument('mode', default_value='realtime', choices=['realtime', 'lockstep']),
        DeclareLaunchArgument('paused', default_value='false'),
        DeclareLaunchArgument('gui', default_value='true'),
        DeclareLaunchArgument('sensors', default_value='true'),
        DeclareLaunchArgument('world', default_value='simple_lab.world'),
        DeclareLaunchArgument('commander', default_value='joint_commander'),
        DeclareLaunchArgument('controllers', default_value=PathJoinSubstitution(
            [FindPackageShare('zenroid_description'), 'config', 'controllers.yaml'])),
        python_node('simulator', 'nodes.sim', *sim_params, respawn=True, respawn_delay=1.0, on_exit=Shutdown()),
        python_node('renderer', 'nodes.render', respawn=True, respawn_delay=0.3,
                    condition=IfCondition(LaunchConfiguration('sensors'))),
        Node(package='robot_state_publisher', executable='robot_state_publisher', name='robot_state_publisher',
             namespace=robot, parameters=[{'robot_description_file': robot_file}], respawn=True, respawn_delay=0.3),
        python_node('controller_manager', 'nodes.control', '--ns', robot, '--params-file',
                    LaunchConfiguration('controllers'), respawn=True, respawn_delay=0.1),
        Node(arguments=['joint_state_broadcaster', 'imu_sensor_broadcaster', 'left_foot_ft_broadcaster',
                        'right_foot_ft_broadcaster', *wait], **spawner),
        Node(arguments=['joint_trajectory_controller', *wait], **spawner),
        python_node(LaunchConfiguration('commander'), ['nodes.commanders.', LaunchConfiguration('commander')],
                    '--ns', robot, '-p', 'use_sim_time:=true', respawn=True, respawn_delay=0.3,
                    condition=IfCondition(NotSubstitution(EqualsSubstitution(LaunchConfiguration('commander'),
                                                                             'none')))),
        Node(package='rviz2', executable='rviz2', name='viewer', parameters=[{'robots': [robot]}], respawn=True,
             respawn_delay=0.3, condition=IfCondition(LaunchConfiguration('gui'))),
    ])
