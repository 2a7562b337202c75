"""gazebo_ros's gazebo.launch.py, served by zenroid: gzserver.launch.py (our simulator) when server is true,
gzclient.launch.py (our viewer) when gui is true; every argument reaches both, as in gazebo_ros."""

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, IncludeLaunchDescription
from launch.conditions import IfCondition
from launch.launch_description_sources import PythonLaunchDescriptionSource
from launch.substitutions import LaunchConfiguration, ThisLaunchFileDir


def generate_launch_description():
    here = ThisLaunchFileDir()
    return LaunchDescription([
        DeclareLaunchArgument('world', default_value='', description='SDF world: a path or a name in worlds/'),
        DeclareLaunchArgument('gui', default_value='true', description='start the viewer (gzclient)'),
        DeclareLaunchArgument('server', default_value='true', description='start the simulator (gzserver)'),
        DeclareLaunchArgument('pause', default_value='false'),
        DeclareLaunchArgument('verbose', default_value='false'),
        DeclareLaunchArgument('extra_gazebo_args', default_value=''),
        IncludeLaunchDescription(PythonLaunchDescriptionSource([here, '/gzserver.launch.py']),
                                 condition=IfCondition(LaunchConfiguration('server'))),
        IncludeLaunchDescription(PythonLaunchDescriptionSource([here, '/gzclient.launch.py']),
                                 condition=IfCondition(LaunchConfiguration('gui'))),
    ])
