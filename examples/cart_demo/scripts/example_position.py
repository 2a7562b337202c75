#!/usr/bin/env python3
"""Drive the position cart through /joint_trajectory_controller/follow_joint_trajectory, as
gazebo_ros2_control_demos' example_position does: 0 m at 1 s, -1 m at 2 s, then TARGET (default 0.5 m) at 3 s.

    ros2 run cart_demo example_position.py [TARGET]
"""

import sys

from builtin_interfaces.msg import Duration
from control_msgs.action import FollowJointTrajectory
from trajectory_msgs.msg import JointTrajectoryPoint

import rclpy
from rclpy.action import ActionClient
from rclpy.node import Node


def point(position: float, seconds: int) -> JointTrajectoryPoint:
    return JointTrajectoryPoint(positions=[position], time_from_start=Duration(sec=seconds))


def main() -> int:
    target = float(sys.argv[1]) if len(sys.argv) > 1 else 0.5
    rclpy.init()
    node = Node('trajectory_test_node')
    client = ActionClient(node, FollowJointTrajectory, '/joint_trajectory_controller/follow_joint_trajectory')
    if not client.wait_for_server(timeout_sec=10.0):
        node.get_logger().error('could not get action server')
        return 1
    goal = FollowJointTrajectory.Goal()
    goal.trajectory.joint_names = ['slider_to_cart']
    goal.trajectory.points = [point(0.0, 1), point(-1.0, 2), point(target, 3)]
    goal.goal_time_tolerance = Duration(sec=1)
    sent = client.send_goal_async(
        goal, feedback_callback=lambda fb: print(f'desired {fb.feedback.desired.positions[0]:+.3f}'))
    rclpy.spin_until_future_complete(node, sent)
    handle = sent.result()
    if not handle.accepted:
        node.get_logger().error('goal rejected')
        return 1
    print('goal accepted', flush=True)
    done = handle.get_result_async()
    rclpy.spin_until_future_complete(node, done)
    error_code = done.result().result.error_code
    print(f'result: error_code {error_code}', flush=True)
    node.destroy_node()
    rclpy.shutdown()
    return 0 if error_code == FollowJointTrajectory.Result.SUCCESSFUL else 1


if __name__ == '__main__':
    sys.exit(main())
