"""A listener whose callback is slower than its talker: what the QoS depth keeps (``slow_listener.py DEPTH``).
Prints the number of every message it takes; says "ready" once subscribed."""
import sys
import time

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from std_msgs.msg import Int32


class SlowListener(Node):

    def __init__(self, depth):
        super().__init__('slow_listener')
        self.subscription = self.create_subscription(Int32, 'burst', self.listener_callback, depth)
        self.get_logger().info('ready')

    def listener_callback(self, msg):
        print('took %d' % msg.data, flush=True)
        time.sleep(0.05)


def main():
    depth = int(sys.argv[1])
    try:
        with rclpy.init(args=sys.argv[:1]):
            rclpy.spin(SlowListener(depth))
    except (KeyboardInterrupt, ExternalShutdownException):
        pass


if __name__ == '__main__':
    main()
