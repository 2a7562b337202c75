"""The simulator's own service types (``zenroid_sim_msgs``), registered with ``msgs`` on import."""

from __future__ import annotations

from pathlib import Path

import msgs

msgs.add_search_path(Path(__file__).resolve().parent / "definitions")

# Stepping modes (docs/simulator.md, Modes): lockstep with the controller manager, wall-clock realtime, kinematic playback.
MODES = ("lockstep", "realtime", "kinematic")

SpawnEntity = msgs.get_type("zenroid_sim_msgs/srv/SpawnEntity")
SetPhysicsProperties = msgs.get_type("zenroid_sim_msgs/srv/SetPhysicsProperties")
GetPhysicsProperties = msgs.get_type("zenroid_sim_msgs/srv/GetPhysicsProperties")
DeleteEntity = msgs.get_type("gazebo_msgs/srv/DeleteEntity")
Empty = msgs.get_type("std_srvs/srv/Empty")
StepSimulation = msgs.get_type("zenroid_msgs/srv/StepSimulation")
GetHardwareInfo = msgs.get_type("zenroid_msgs/srv/GetHardwareInfo")
HardwareState = msgs.get_type("zenroid_msgs/msg/HardwareState")
HardwareCommand = msgs.get_type("zenroid_msgs/msg/HardwareCommand")
HardwareHeartbeat = msgs.get_type("zenroid_msgs/msg/HardwareHeartbeat")
HumanoidState = msgs.get_type("humanoid_msgs/msg/HumanoidState")
ModelStates = msgs.get_type("gazebo_msgs/msg/ModelStates")
LinkStates = msgs.get_type("gazebo_msgs/msg/LinkStates")
GetModelList = msgs.get_type("gazebo_msgs/srv/GetModelList")
GetEntityState = msgs.get_type("gazebo_msgs/srv/GetEntityState")
SetEntityState = msgs.get_type("gazebo_msgs/srv/SetEntityState")
ApplyLinkWrench = msgs.get_type("gazebo_msgs/srv/ApplyLinkWrench")
LinkRequest = msgs.get_type("gazebo_msgs/srv/LinkRequest")
ApplyJointEffort = msgs.get_type("gazebo_msgs/srv/ApplyJointEffort")
JointRequest = msgs.get_type("gazebo_msgs/srv/JointRequest")
Clock = msgs.get_type("rosgraph_msgs/msg/Clock")
String = msgs.get_type("std_msgs/msg/String")
