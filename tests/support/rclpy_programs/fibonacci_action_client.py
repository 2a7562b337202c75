"""action_tutorials_py's Fibonacci client: feedback, the result; with ``cancel`` as argument it cancels the
goal after two feedback messages (ros2/examples' client_cancel)."""
import sys

from action_msgs.msg import GoalStatus
from action_tutorials_interfaces.action import Fibonacci

import rclpy
from rclpy.action import ActionClient
from rclpy.node import Node


class FibonacciActionClient(Node):

    def __init__(self, cancel):
        super().__init__('fibonacci_action_client')
        self._action_client = ActionClient(self, Fibonacci, 'fibonacci')
        self._cancel = cancel
        self._feedbacks = 0

    def send_goal(self, order):
        goal_msg = Fibonacci.Goal()
        goal_msg.order = order
        self._action_client.wait_for_server()
        self._send_goal_future = self._action_client.send_goal_async(
            goal_msg, feedback_callback=self.feedback_callback)
        self._send_goal_future.add_done_callback(self.goal_response_callback)

    def goal_response_callback(self, future):
        self._goal_handle = future.result()
        if not self._goal_handle.accepted:
            self.get_logger().info('Goal rejected :(')
            rclpy.shutdown()
            return
        self.get_logger().info('Goal accepted :)')
        self._get_result_future = self._goal_handle.get_result_async()
        self._get_result_future.add_done_callback(self.get_result_callback)

    def cancel_done(self, future):
        cancel_response = future.result()
        if len(cancel_response.goals_canceling) > 0:
            self.get_logger().info('Goal successfully canceled')
        else:
            self.get_logger().info('Goal failed to cancel')

    def get_result_callback(self, future):
        result = future.result().result
        status = future.result().status
        if status == GoalStatus.STATUS_SUCCEEDED:
            self.get_logger().info('Result: {0}'.format(result.sequence))
        elif status == GoalStatus.STATUS_CANCELED:
            self.get_logger().info('Goal canceled, status CANCELED')
        else:
            self.get_logger().info('Goal ended with status {0}'.format(status))
        rclpy.shutdown()

    def feedback_callback(self, feedback_msg):
        feedback = feedback_msg.feedback
        self._feedbacks += 1
        self.get_logger().info('Received feedback: {0}'.format(feedback.partial_sequence))
        if self._cancel and self._feedbacks == 2:
            self._goal_handle.cancel_goal_async().add_done_callback(self.cancel_done)


def main(args=None):
    rclpy.init(args=args)
    action_client = FibonacciActionClient(cancel='cancel' in sys.argv[1:])
    action_client.send_goal(10)
    try:
        rclpy.spin(action_client)
    except rclpy.executors.ExternalShutdownException:
        pass


if __name__ == '__main__':
    main()
