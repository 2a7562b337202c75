"""A talker with QoS deadline, liveliness and lifespan, in the style of ros2/demos' quality_of_service_demo:
``/heartbeat`` (automatic liveliness) and ``/manual_heartbeat`` (MANUAL_BY_TOPIC: publishing asserts it)
carry COUNT messages at 10 Hz, then fall silent while the node keeps spinning; ``/status`` is published once,
transient local, and lives LIFESPAN seconds."""
import sys

import rclpy
from rclpy.duration import Duration
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, LivelinessPolicy, QoSProfile
from rclpy.qos_event import PublisherEventCallbacks
from std_msgs.msg import String


class QosTalker(Node):

    def __init__(self, count, lifespan):
        super().__init__('qos_talker')
        self.count = count
        self.sent = 0
        automatic = QoSProfile(depth=10, deadline=Duration(seconds=0.3),
                               liveliness=LivelinessPolicy.AUTOMATIC,
                               liveliness_lease_duration=Duration(seconds=1.0))
        manual = QoSProfile(depth=10, deadline=Duration(seconds=0.3),
                            liveliness=LivelinessPolicy.MANUAL_BY_TOPIC,
                            liveliness_lease_duration=Duration(seconds=0.6))
        self.heartbeat = self.create_publisher(
            String, 'heartbeat', automatic,
            event_callbacks=PublisherEventCallbacks(deadline=self.deadline_missed))
        self.manual_heartbeat = self.create_publisher(
            String, 'manual_heartbeat', manual,
            event_callbacks=PublisherEventCallbacks(liveliness=self.liveliness_lost))
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                             lifespan=Duration(seconds=lifespan))
        self.status = self.create_publisher(String, 'status', latched)
        self.status.publish(String(data='ready'))
        self.get_logger().info('Published status')
        self.timer = self.create_timer(0.1, self.tick)

    def tick(self):
        if self.sent >= self.count:
            return
        self.sent += 1
        self.heartbeat.publish(String(data='beat %d' % self.sent))
        self.manual_heartbeat.publish(String(data='beat %d' % self.sent))
        if self.sent == self.count:
            self.get_logger().info('Stopped publishing')

    def deadline_missed(self, event):
        self.get_logger().info('Offered deadline missed - total %d (delta %d)' % (
            event.total_count, event.total_count_change))

    def liveliness_lost(self, event):
        self.get_logger().info('Liveliness lost - total %d (delta %d)' % (
            event.total_count, event.total_count_change))


def main(args=None):
    rclpy.init(args=args)
    count = int(sys.argv[1]) if len(sys.argv) > 1 else 5
    lifespan = float(sys.argv[2]) if len(sys.argv) > 2 else 3.0
    node = QosTalker(count, lifespan)
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass


if __name__ == '__main__':
    main()
