"""The rclpy docs' callback-group example: a timer calls a service of the same node and waits for the answer.
With the client in its own group and a MultiThreadedExecutor this works (rclpy "Using callback groups");
a second timer in a mutually exclusive group shows its callbacks never overlap. Results go to 'results'."""
import threading
import time

import rclpy
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup, ReentrantCallbackGroup
from rclpy.executors import ExternalShutdownException, MultiThreadedExecutor
from rclpy.node import Node
from std_msgs.msg import String
from std_srvs.srv import Trigger


class ServiceFromTimer(Node):

    def __init__(self):
        super().__init__('service_from_timer')
        self.srv = self.create_service(Trigger, 'answer', self.answer)
        client_group = MutuallyExclusiveCallbackGroup()
        timer_group = MutuallyExclusiveCallbackGroup()
        self.client = self.create_client(Trigger, 'answer', callback_group=client_group)
        self.timer = self.create_timer(0.2, self.ask, callback_group=timer_group)
        self.slow_group = MutuallyExclusiveCallbackGroup()
        self.active = 0
        self.overlap = 0
        self.lock = threading.Lock()
        for _ in range(2):
            self.create_timer(0.05, self.slow, callback_group=self.slow_group)
        self.reentrant_threads = set()
        self.create_timer(0.05, self.reentrant, callback_group=ReentrantCallbackGroup())
        self.pub = self.create_publisher(String, 'results', 10)
        self.answers = 0

    def answer(self, request, response):
        response.success = True
        response.message = 'answered in %s' % threading.current_thread().name
        return response

    def ask(self):
        future = self.client.call_async(Trigger.Request())
        while not future.done():   # waiting in a callback: another thread must take the response
            time.sleep(0.005)
        self.answers += 1
        msg = String()
        msg.data = f'answers={self.answers} overlap={self.overlap} reentrant_threads={len(self.reentrant_threads)}'
        self.pub.publish(msg)
        self.get_logger().info(msg.data)

    def slow(self):
        with self.lock:
            self.active += 1
            if self.active > 1:
                self.overlap += 1
        time.sleep(0.02)
        with self.lock:
            self.active -= 1

    def reentrant(self):
        self.reentrant_threads.add(threading.current_thread().name)
        time.sleep(0.03)


def main():
    try:
        with rclpy.init():
            node = ServiceFromTimer()
            executor = MultiThreadedExecutor(num_threads=4)
            executor.add_node(node)
            executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass


if __name__ == '__main__':
    main()
