#!/usr/bin/env python3
"""An outside ROS 2 client of the simulated humanoid over rmw_zenoh's wire — imports nothing of zenroid.

It uses zenoh-ros2-sdk (``pip install zenoh-ros2-sdk``), a pure-Python rmw_zenoh client, exactly as a
ROS 2 Jazzy node with ``RMW_IMPLEMENTATION=rmw_zenoh_cpp`` would talk to the humanoid:

1. lists the ROS 2 topics (``ros2 topic list -t``),
2. reads ``/humanoid/joint_states`` (CDR),
3. calls ``/humanoid/controller_manager/list_controllers``,
4. publishes a ``trajectory_msgs/JointTrajectory`` that bends the knees,
5. sends a ``control_msgs/FollowJointTrajectory`` goal (send_goal, feedback, get_result) that straightens them.

    python -m launch humanoid.yaml gui:=false commander:=none     # terminal 1
    python examples/ros2_client.py                                 # terminal 2 (--router HOST:PORT)

The standard message definitions and type hashes are spelled out below because the SDK otherwise
downloads them (no ROS install, maybe no internet); they are ROS 2 Jazzy's.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import threading
import time

import numpy as np
from zenoh_ros2_sdk import ROS2Publisher, ROS2ServiceClient, ROS2Subscriber, get_topic_names_and_types

NS = "/humanoid"
JTC = f"{NS}/joint_trajectory_controller"
ACTION = f"{JTC}/follow_joint_trajectory"
KNEES = ["left_knee", "right_knee"]
SEP = "=" * 80

TIME = "int32 sec\nuint32 nanosec\n"
DURATION = "int32 sec\nuint32 nanosec\n"
HEADER = "builtin_interfaces/Time stamp\nstring frame_id\n"
VECTOR3 = "float64 x\nfloat64 y\nfloat64 z\n"
QUATERNION = "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n"
POINT = ("float64[] positions\nfloat64[] velocities\nfloat64[] accelerations\nfloat64[] effort\n"
         "builtin_interfaces/Duration time_from_start\n")
MULTI_DOF_POINT = ("geometry_msgs/Transform[] transforms\ngeometry_msgs/Twist[] velocities\n"
                   "geometry_msgs/Twist[] accelerations\nbuiltin_interfaces/Duration time_from_start\n")


def msgdef(body: str, *deps: tuple[str, str]) -> str:
    """A full definition: the type's fields, then each nested type after a separator (ros2msg text)."""
    return body + "".join(f"{SEP}\nMSG: {name}\n{text}" for name, text in deps)


STAMPED = (("std_msgs/Header", HEADER), ("builtin_interfaces/Time", TIME))
TRAJECTORY_DEPS = (*STAMPED, ("trajectory_msgs/JointTrajectoryPoint", POINT),
                   ("builtin_interfaces/Duration", DURATION))
MULTI_DOF_DEPS = (("trajectory_msgs/MultiDOFJointTrajectoryPoint", MULTI_DOF_POINT),
                  ("geometry_msgs/Transform", "geometry_msgs/Vector3 translation\ngeometry_msgs/Quaternion rotation\n"),
                  ("geometry_msgs/Twist", "geometry_msgs/Vector3 linear\ngeometry_msgs/Vector3 angular\n"),
                  ("geometry_msgs/Vector3", VECTOR3), ("geometry_msgs/Quaternion", QUATERNION))
TOLERANCE = "string name\nfloat64 position\nfloat64 velocity\nfloat64 acceleration\n"
COMPONENT_TOLERANCE = ("string joint_name\nuint16 component\nfloat64 position\nfloat64 velocity\n"
                       "float64 acceleration\n")
GOAL = ("trajectory_msgs/JointTrajectory trajectory\ntrajectory_msgs/MultiDOFJointTrajectory multi_dof_trajectory\n"
        "control_msgs/JointTolerance[] path_tolerance\ncontrol_msgs/JointComponentTolerance[] component_path_tolerance\n"
        "control_msgs/JointTolerance[] goal_tolerance\n"
        "control_msgs/JointComponentTolerance[] component_goal_tolerance\n"
        "builtin_interfaces/Duration goal_time_tolerance\n")
RESULT = "int32 error_code\nstring error_string\n"
FEEDBACK = ("std_msgs/Header header\nstring[] joint_names\ntrajectory_msgs/JointTrajectoryPoint desired\n"
            "trajectory_msgs/JointTrajectoryPoint actual\ntrajectory_msgs/JointTrajectoryPoint error\n"
            "string[] multi_dof_joint_names\ntrajectory_msgs/MultiDOFJointTrajectoryPoint multi_dof_desired\n"
            "trajectory_msgs/MultiDOFJointTrajectoryPoint multi_dof_actual\n"
            "trajectory_msgs/MultiDOFJointTrajectoryPoint multi_dof_error\n")
JOINT_TRAJECTORY = "std_msgs/Header header\nstring[] joint_names\ntrajectory_msgs/JointTrajectoryPoint[] points\n"
MULTI_DOF_TRAJECTORY = ("std_msgs/Header header\nstring[] joint_names\n"
                        "trajectory_msgs/MultiDOFJointTrajectoryPoint[] points\n")

DEFS = {
    "sensor_msgs/msg/JointState": msgdef(
        "std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\nfloat64[] effort\n", *STAMPED),
    "trajectory_msgs/msg/JointTrajectory": msgdef(JOINT_TRAJECTORY, *TRAJECTORY_DEPS),
    "rosgraph_msgs/msg/Clock": msgdef("builtin_interfaces/Time clock\n", ("builtin_interfaces/Time", TIME)),
    "list_controllers_response": msgdef(
        "controller_manager_msgs/ControllerState[] controller\n",
        ("controller_manager_msgs/ControllerState",
         "string name\nstring state\nstring type\nbool is_async\nuint16 update_rate\nstring[] claimed_interfaces\n"
         "string[] required_command_interfaces\nstring[] required_state_interfaces\nbool is_chainable\n"
         "bool is_chained\nstring[] exported_state_interfaces\nstring[] reference_interfaces\n"
         "controller_manager_msgs/ChainConnection[] chain_connections\n"),
        ("controller_manager_msgs/ChainConnection", "string name\nstring[] reference_interfaces\n")),
    "send_goal_request": msgdef(
        "unique_identifier_msgs/UUID goal_id\ncontrol_msgs/FollowJointTrajectoryGoal goal\n",
        ("unique_identifier_msgs/UUID", "uint8[16] uuid\n"), ("control_msgs/FollowJointTrajectoryGoal", GOAL),
        ("trajectory_msgs/JointTrajectory", JOINT_TRAJECTORY),
        ("trajectory_msgs/MultiDOFJointTrajectory", MULTI_DOF_TRAJECTORY),
        ("control_msgs/JointTolerance", TOLERANCE), ("control_msgs/JointComponentTolerance", COMPONENT_TOLERANCE),
        *TRAJECTORY_DEPS, *MULTI_DOF_DEPS),
    "send_goal_response": msgdef("bool accepted\nbuiltin_interfaces/Time stamp\n", ("builtin_interfaces/Time", TIME)),
    "get_result_request": msgdef("unique_identifier_msgs/UUID goal_id\n", ("unique_identifier_msgs/UUID", "uint8[16] uuid\n")),
    "get_result_response": msgdef("int8 status\ncontrol_msgs/FollowJointTrajectoryResult result\n",
                                  ("control_msgs/FollowJointTrajectoryResult", RESULT)),
    "feedback_message": msgdef(
        "unique_identifier_msgs/UUID goal_id\ncontrol_msgs/FollowJointTrajectoryFeedback feedback\n",
        ("unique_identifier_msgs/UUID", "uint8[16] uuid\n"), ("control_msgs/FollowJointTrajectoryFeedback", FEEDBACK),
        *TRAJECTORY_DEPS, *MULTI_DOF_DEPS),
}

# REP-2011 type hashes of the ROS 2 Jazzy interfaces (what `ros2 interface` / rmw_zenoh compute).
HASHES = {
    "sensor_msgs/msg/JointState": "RIHS01_a13ee3a330e346c9d87b5aa18d24e11690752bd33a0350f11c5882bc9179260e",
    "rosgraph_msgs/msg/Clock": "RIHS01_692f7a66e93a3c83e71765d033b60349ba68023a8c689a79e48078bcb5c58564",
    "trajectory_msgs/msg/JointTrajectory": "RIHS01_179b33eba59d676f6d967ac71fe35e7ca2f64b2f3928f4a018cec115e213796e",
    "controller_manager_msgs/srv/ListControllers":
        "RIHS01_4f8e36bb1fa5afdeba45c2d56ae6a2097b1493a253f961dd6290c085033bd189",
    "control_msgs/action/FollowJointTrajectory_SendGoal":
        "RIHS01_b13789dddc325a7a962825c45e28c77d37237ec129dd0c34dc5994562938c57f",
    "control_msgs/action/FollowJointTrajectory_GetResult":
        "RIHS01_e3ceb38e3e1867c8dc0f46014df26e90eb93422f27e9e97f936e07f94be4bc8b",
    "control_msgs/action/FollowJointTrajectory_FeedbackMessage":
        "RIHS01_80398fcb9674a79081a9906e2ccf0c804dd7cb15e22e362e606ee87186beab71",
}
STATUS = {1: "ACCEPTED", 2: "EXECUTING", 3: "CANCELING", 4: "SUCCEEDED", 5: "CANCELED", 6: "ABORTED"}


class Knees:
    """The latest knee angles from /humanoid/joint_states."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.names: list[str] = []
        self.angles: dict[str, float] = {}
        self.count = 0

    def __call__(self, msg) -> None:
        with self.lock:
            self.names = list(msg.name)
            self.angles = {k: float(msg.position[msg.name.index(k)]) for k in KNEES if k in msg.name}
            self.count += 1

    def wait(self, predicate, timeout: float) -> bool:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            with self.lock:
                if self.angles and predicate(self.angles):
                    return True
            time.sleep(0.05)
        return False


def point(store, positions: list[float], seconds: float):
    Point, Duration = store.types["trajectory_msgs/msg/JointTrajectoryPoint"], store.types["builtin_interfaces/msg/Duration"]
    empty = np.array([], dtype=np.float64)
    return Point(positions=np.array(positions, dtype=np.float64), velocities=empty, accelerations=empty, effort=empty,
                 time_from_start=Duration(sec=int(seconds), nanosec=int(seconds % 1 * 1e9)))


def trajectory(store, type_name: str, positions: list[float], seconds: float):
    Header, Time = store.types["std_msgs/msg/Header"], store.types["builtin_interfaces/msg/Time"]
    return store.types[type_name](header=Header(stamp=Time(sec=0, nanosec=0), frame_id=""), joint_names=list(KNEES),
                                  points=[point(store, positions, seconds)])


def run(ip: str, port: int, timeout: float) -> dict:
    report: dict = {}
    # 1. the graph, as `ros2 topic list -t` shows it
    topics = dict(get_topic_names_and_types(router_ip=ip, router_port=port, timeout=2.0))
    report["topics"] = len(topics)
    report["joint_states_type"] = topics.get(f"{NS}/joint_states", ["?"])[0]
    print(f"{len(topics)} topics, e.g. {NS}/joint_states [{report['joint_states_type']}]")

    # the simulator's clock is ROS' /clock (what use_sim_time follows)
    clock: list[float] = []
    clock_sub = ROS2Subscriber("/clock", "rosgraph_msgs/msg/Clock", lambda m: clock.append(m.clock.sec + m.clock.nanosec * 1e-9),
                               router_ip=ip, router_port=port, msg_definition=DEFS["rosgraph_msgs/msg/Clock"],
                               type_hash=HASHES["rosgraph_msgs/msg/Clock"])

    # 2. joint states in CDR
    knees = Knees()
    js = ROS2Subscriber(f"{NS}/joint_states", "sensor_msgs/msg/JointState", knees, router_ip=ip, router_port=port,
                        msg_definition=DEFS["sensor_msgs/msg/JointState"], type_hash=HASHES["sensor_msgs/msg/JointState"])
    store = js.session_mgr.store
    if not knees.wait(lambda a: True, timeout):
        raise RuntimeError(f"no {NS}/joint_states within {timeout} s")
    with knees.lock:
        report["joints"] = len(knees.names)
    print(f"joint_states: {report['joints']} joints, knees {knees.angles}")
    deadline = time.monotonic() + timeout
    while len(clock) < 2 and time.monotonic() < deadline:
        time.sleep(0.05)
    report["clock_advances"] = len(clock) >= 2 and clock[-1] > clock[0]
    print(f"/clock: sim time {clock[-1] if clock else float('nan'):.3f} s ({len(clock)} messages)")

    # 3. a ros2_control service
    lister = ROS2ServiceClient(f"{NS}/controller_manager/list_controllers", "controller_manager_msgs/srv/ListControllers",
                               request_definition="", response_definition=DEFS["list_controllers_response"],
                               type_hash=HASHES["controller_manager_msgs/srv/ListControllers"], router_ip=ip,
                               router_port=port, timeout=timeout)
    response = lister.call()
    if response is None:
        raise RuntimeError("list_controllers: no answer")
    report["controllers"] = {c.name: c.state for c in response.controller}
    print(f"controllers: {report['controllers']}")

    # 4. a JointTrajectory on the controller's topic
    publisher = ROS2Publisher(f"{JTC}/joint_trajectory", "trajectory_msgs/msg/JointTrajectory", router_ip=ip,
                              router_port=port, msg_definition=DEFS["trajectory_msgs/msg/JointTrajectory"],
                              type_hash=HASHES["trajectory_msgs/msg/JointTrajectory"])
    bent = False
    deadline = time.monotonic() + timeout
    while not bent and time.monotonic() < deadline:  # the first message may beat route discovery: repeat
        msg = trajectory(store, "trajectory_msgs/msg/JointTrajectory", [0.5, 0.5], 1.0)
        publisher.publish(header=msg.header, joint_names=msg.joint_names, points=msg.points)
        bent = knees.wait(lambda a: all(abs(v - 0.5) < 0.05 for v in a.values()), 3.0)
    report["topic_command_reached"] = bent
    print(f"JointTrajectory: knees {'reached' if bent else 'did not reach'} 0.5 rad: {knees.angles}")

    # 5. the FollowJointTrajectory action, through its three parts as rmw_zenoh lays them out
    feedback: list = []
    fb = ROS2Subscriber(f"{ACTION}/_action/feedback", "control_msgs/action/FollowJointTrajectory_FeedbackMessage",
                        feedback.append, router_ip=ip, router_port=port, msg_definition=DEFS["feedback_message"],
                        type_hash=HASHES["control_msgs/action/FollowJointTrajectory_FeedbackMessage"])
    send_goal = ROS2ServiceClient(f"{ACTION}/_action/send_goal", "control_msgs/action/FollowJointTrajectory_SendGoal",
                                  request_definition=DEFS["send_goal_request"], response_definition=DEFS["send_goal_response"],
                                  type_hash=HASHES["control_msgs/action/FollowJointTrajectory_SendGoal"],
                                  router_ip=ip, router_port=port, timeout=timeout)
    get_result = ROS2ServiceClient(f"{ACTION}/_action/get_result", "control_msgs/action/FollowJointTrajectory_GetResult",
                                   request_definition=DEFS["get_result_request"],
                                   response_definition=DEFS["get_result_response"],
                                   type_hash=HASHES["control_msgs/action/FollowJointTrajectory_GetResult"],
                                   router_ip=ip, router_port=port, timeout=max(timeout, 30.0))
    time.sleep(0.5)  # let the feedback subscription's route form before the goal runs
    UUID = store.types["unique_identifier_msgs/msg/UUID"]
    Goal = store.types["control_msgs/msg/FollowJointTrajectoryGoal"]
    Duration = store.types["builtin_interfaces/msg/Duration"]
    MultiDOF, Header, Time = (store.types["trajectory_msgs/msg/MultiDOFJointTrajectory"],
                              store.types["std_msgs/msg/Header"], store.types["builtin_interfaces/msg/Time"])
    goal_id = UUID(uuid=np.frombuffer(os.urandom(16), dtype=np.uint8))
    goal = Goal(trajectory=trajectory(store, "trajectory_msgs/msg/JointTrajectory", [0.0, 0.0], 1.5),
                multi_dof_trajectory=MultiDOF(header=Header(stamp=Time(sec=0, nanosec=0), frame_id=""),
                                              joint_names=[], points=[]),
                path_tolerance=[], component_path_tolerance=[], goal_tolerance=[], component_goal_tolerance=[],
                goal_time_tolerance=Duration(sec=0, nanosec=0))
    accepted = send_goal.call(goal_id=goal_id, goal=goal)
    report["goal_accepted"] = bool(accepted and accepted.accepted)
    print(f"send_goal: accepted={report['goal_accepted']}")
    result = get_result.call(goal_id=goal_id) if report["goal_accepted"] else None
    report["goal_status"] = STATUS.get(int(result.status), str(result.status)) if result is not None else "none"
    report["error_code"] = int(result.result.error_code) if result is not None else None
    report["feedback_messages"] = len(feedback)
    report["knees_after_goal"] = dict(knees.angles)
    print(f"get_result: {report['goal_status']} (error_code {report['error_code']}), "
          f"{len(feedback)} feedback messages, knees {knees.angles}")
    for endpoint in (clock_sub, js, fb, publisher, lister, send_goal, get_result):
        endpoint.close()
    return report


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--router", default="127.0.0.1:7447", help="the Zenoh router, HOST:PORT (default: %(default)s)")
    parser.add_argument("--timeout", type=float, default=20.0, help="seconds to wait for each step")
    args = parser.parse_args()
    ip, _, port = args.router.rpartition(":")
    try:
        report = run(ip or "127.0.0.1", int(port), args.timeout)
    except Exception as exc:  # noqa: BLE001 - a one-line reason for the person at the terminal
        print(f"error: {exc}", file=sys.stderr)
        return 1
    ok = (report["joints"] > 0 and report["clock_advances"] and report["topic_command_reached"] and report["goal_status"] == "SUCCEEDED"
          and report["feedback_messages"] > 0)
    print(json.dumps(report))
    sys.stdout.flush()
    os._exit(0 if ok else 1)  # the SDK keeps its Zenoh session (a singleton) open: leave without waiting on it


if __name__ == "__main__":
    sys.exit(main())
