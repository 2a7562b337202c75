"""A node on sim time (use_sim_time:=true): its clock and a 0.5 s timer follow /clock."""
import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from std_msgs.msg import String


class SimTimeNode(Node):

    def __init__(self):
        super().__init__('sim_time_node')
        self.pub = self.create_publisher(String, 'sim_now', 10)
        self.timer = self.create_timer(0.5, self.tick)

    def tick(self):
        now = self.get_clock().now()
        msg = String()
        msg.data = f'sim now {now.nanoseconds / 1e9:.3f} use_sim_time={self.get_parameter("use_sim_time").value}'
        self.pub.publish(msg)
        self.get_logger().info(msg.data)


def main():
    try:
        with rclpy.init():
            rclpy.spin(SimTimeNode())
    except (KeyboardInterrupt, ExternalShutdownException):
        pass


if __name__ == '__main__':
    main()
