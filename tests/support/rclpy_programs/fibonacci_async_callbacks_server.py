"""A Fibonacci server whose goal and cancel callbacks are coroutines, as rclpy allows: each awaits a future
(here a short approval a timer gives) before it answers."""
import time

from action_tutorials_interfaces.action import Fibonacci

import rclpy
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.executors import ExternalShutdownException, MultiThreadedExecutor
from rclpy.node import Node
from rclpy.task import Future


class FibonacciActionServer(Node):

    def __init__(self):
        super().__init__('fibonacci_action_server')
        self._group = ReentrantCallbackGroup()
        self._action_server = ActionServer(
            self,
            Fibonacci,
            'fibonacci',
            execute_callback=self.execute_callback,
            callback_group=self._group,
            goal_callback=self.goal_callback,
            cancel_callback=self.cancel_callback)

    def approval(self, answer):
        future = Future()

        def give():
            timer.cancel()
            future.set_result(answer)

        timer = self.create_timer(0.1, give, callback_group=self._group)
        return future

    async def goal_callback(self, goal_request):
        self.get_logger().info('Received goal request')
        if not await self.approval(goal_request.order <= 100):
            return GoalResponse.REJECT
        self.get_logger().info('Goal approved')
        return GoalResponse.ACCEPT

    async def cancel_callback(self, goal_handle):
        self.get_logger().info('Received cancel request')
        await self.approval(True)
        self.get_logger().info('Cancel approved')
        return CancelResponse.ACCEPT

    async def execute_callback(self, goal_handle):
        self.get_logger().info('Executing goal...')
        feedback_msg = Fibonacci.Feedback()
        feedback_msg.partial_sequence = [0, 1]

        for i in range(1, goal_handle.request.order):
            if goal_handle.is_cancel_requested:
                goal_handle.canceled()
                self.get_logger().info('Goal canceled')
                return Fibonacci.Result()

            feedback_msg.partial_sequence.append(
                feedback_msg.partial_sequence[i] + feedback_msg.partial_sequence[i-1])
            goal_handle.publish_feedback(feedback_msg)
            time.sleep(0.2)

        goal_handle.succeed()
        result = Fibonacci.Result()
        result.sequence = feedback_msg.partial_sequence
        return result


def main(args=None):
    try:
        rclpy.init(args=args)
        fibonacci_action_server = FibonacciActionServer()
        executor = MultiThreadedExecutor()
        rclpy.spin(fibonacci_action_server, executor=executor)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass


if __name__ == '__main__':
    main()
