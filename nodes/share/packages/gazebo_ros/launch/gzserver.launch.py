"""gazebo_ros's gzserver.launch.py, served by zenroid: the physics server is our simulator (DART), at the
root namespace (its services and topics where gazebo_ros puts them for the tutorials' launch files).

Arguments as gazebo_ros's: world (a path or a name in worlds/), pause, verbose, extra_gazebo_args (accepted,
reported when given: Gazebo's plug-in and physics options have no meaning here), plus zenroid's mode
(realtime | lockstep) and sensors (the URDF's IMU, force/torque and contact sensors, and the renderer of
cameras, depth, lidar and laser beside the physics; false leaves them all out).
"""

import sys

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, ExecuteProcess, LogInfo
from launch.conditions import IfCondition
from launch.substitutions import LaunchConfiguration, PythonExpression


def generate_launch_description():
    world = LaunchConfiguration('world')
    log_level = PythonExpression(["'debug' if '", LaunchConfiguration('verbose'), "'.lower() == 'true' else 'info'"])
    extra = LaunchConfiguration('extra_gazebo_args')
    return LaunchDescription([
        DeclareLaunchArgument('world', default_value='', description='SDF world: a path or a name in worlds/'),
        DeclareLaunchArgument('pause', default_value='false', description='start with physics paused'),
        DeclareLaunchArgument('verbose', default_value='false', description='debug logging'),
        DeclareLaunchArgument('extra_gazebo_args', default_value='', description='accepted; Gazebo-only options'),
        DeclareLaunchArgument('mode', default_value='realtime', description='realtime | lockstep'),
        DeclareLaunchArgument('sensors', default_value='true',
                              description='simulate the URDF sensors (IMU, force/torque, contact) and render '
                                          'cameras, depth, lidar, laser'),
        DeclareLaunchArgument('physics', default_value='dart', description='accepted (the physics is DART)'),
        LogInfo(msg=['gzserver: extra_gazebo_args "', extra, '" have no meaning here; ignored'],
                condition=IfCondition(PythonExpression(["len('", extra, "'.strip()) > 0"]))),
        ExecuteProcess(
            name='gzserver',
            cmd=[sys.executable, '-m', 'nodes.sim', '--log-level', log_level,
                 '-p', ['world:=', world], '-p', ['mode:=', LaunchConfiguration('mode')],
                 '-p', ['paused:=', LaunchConfiguration('pause')],
                 '-p', ['sensors:=', LaunchConfiguration('sensors')]],
            output='screen'),
        # gazebo_ros2_control's plugin: a controller manager for each robot whose URDF loads it
        ExecuteProcess(name='gazebo_ros2_control', cmd=[sys.executable, '-m', 'nodes.gazebo_ros2_control'],
                       output='screen'),
        ExecuteProcess(name='renderer', cmd=[sys.executable, '-m', 'nodes.render'], output='screen',
                       condition=IfCondition(LaunchConfiguration('sensors'))),
    ])
