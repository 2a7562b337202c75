"""The DART simulator process (``python -m nodes.sim``): Gazebo + gazebo_ros + gazebo_ros2_control in one.

One idea per module:

- ``urdf_info``    URDF checks with line numbers, joint limits, the ``<ros2_control>`` interfaces
- ``world``        the DART world: time step, gravity, collision detector, ground plane
- ``entity``       a URDF spawned as a skeleton at a pose; reset to it
- ``hardware``     per-robot hardware interface: commands, limits, the implicit-spring joint servo
- ``simulation``   entities + hardware + stepping/reset, no networking
- ``humanoid_state`` CoM, support polygon, ZMP, is_balanced
- ``stepping``     wall-clock pacing and the lockstep command inbox
- ``robot_link``   one robot's Zenoh endpoints (hardware frames, humanoid_state, hardware/info)
- ``node``         the simulator node: parameters, sim/* services, outputs, the stepping loop
- ``config`` / ``robot_files`` / ``geometry`` / ``interfaces``  settings, URDF sources, quaternions, types

Only this package imports dartpy.
"""
