"""The listener of qos_talker.py: deadline and liveliness callbacks (ros2/demos' quality_of_service_demo style,
through ``rclpy.event_handler``, Iron's name of ``rclpy.qos_event``)."""
import rclpy
from rclpy.duration import Duration
from rclpy.event_handler import SubscriptionEventCallbacks
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.qos import LivelinessPolicy, QoSProfile
from std_msgs.msg import String


class QosListener(Node):

    def __init__(self):
        super().__init__('qos_listener')
        automatic = QoSProfile(depth=10, deadline=Duration(seconds=0.3),
                               liveliness=LivelinessPolicy.AUTOMATIC,
                               liveliness_lease_duration=Duration(seconds=1.0))
        manual = QoSProfile(depth=10, liveliness=LivelinessPolicy.MANUAL_BY_TOPIC,
                            liveliness_lease_duration=Duration(seconds=0.6))
        self.create_subscription(
            String, 'heartbeat', self.heard, automatic,
            event_callbacks=SubscriptionEventCallbacks(deadline=self.deadline_missed,
                                                       liveliness=self.liveliness_changed('heartbeat')))
        self.create_subscription(
            String, 'manual_heartbeat', lambda msg: None, manual,
            event_callbacks=SubscriptionEventCallbacks(liveliness=self.liveliness_changed('manual_heartbeat')))

    def heard(self, msg):
        self.get_logger().info('I heard: "%s"' % msg.data)

    def deadline_missed(self, event):
        self.get_logger().info('Requested deadline missed - total %d (delta %d)' % (
            event.total_count, event.total_count_change))

    def liveliness_changed(self, topic):
        def callback(event):
            self.get_logger().info(
                '%s liveliness changed - alive %d (delta %d), not alive %d (delta %d)' % (
                    topic, event.alive_count, event.alive_count_change, event.not_alive_count,
                    event.not_alive_count_change))
        return callback


def main(args=None):
    try:
        with rclpy.init(args=args):
            rclpy.spin(QosListener())
    except (KeyboardInterrupt, ExternalShutdownException):
        pass


if __name__ == '__main__':
    main()
