"""ros_gz_sim's gz_sim.launch.py, served by zenroid: ``gz_args`` carries the world (and gz sim's options:
``-r`` run, ``-s`` server only, ``-v N`` verbosity, others accepted); our simulator runs it, our viewer is the
GUI unless ``-s`` is given."""

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, IncludeLaunchDescription, OpaqueFunction
from launch.launch_description_sources import PythonLaunchDescriptionSource
from launch_ros.substitutions import FindPackageShare


def _gazebo(context):
    words = context.launch_configurations.get('gz_args', '').split()
    world, server_only, verbose, skip = '', False, 'false', False
    for i, word in enumerate(words):
        if skip:
            skip = False
        elif word == '-s':
            server_only = True
        elif word == '-v' or word.startswith('--verbose'):
            verbose, skip = 'true', word == '-v' and i + 1 < len(words) and words[i + 1].isdigit()
        elif word.startswith('-v') and word[2:].isdigit():
            verbose = 'true'
        elif not word.startswith('-'):
            world = word
    gui = 'false' if server_only else context.launch_configurations.get('gui', 'true')
    return [IncludeLaunchDescription(
        PythonLaunchDescriptionSource([FindPackageShare('gazebo_ros'), '/launch/gazebo.launch.py']),
        launch_arguments={'world': world, 'gui': gui, 'verbose': verbose}.items())]


def generate_launch_description():
    return LaunchDescription([
        DeclareLaunchArgument('gz_args', default_value='', description='the world file and gz sim options'),
        DeclareLaunchArgument('gz_version', default_value='8', description='accepted; ignored'),
        DeclareLaunchArgument('on_exit_shutdown', default_value='false', description='accepted'),
        OpaqueFunction(function=_gazebo),
    ])
