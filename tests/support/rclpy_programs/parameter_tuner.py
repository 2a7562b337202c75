"""A node whose parameters change: 'gain' and 'mode' from outside (``ros2 param set``), 'tick' counted up by
the node itself twice a second (each change a /parameter_events message)."""
import rclpy
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.parameter import Parameter


class Tuner(Node):

    def __init__(self):
        super().__init__('tuner')
        self.declare_parameter('gain', 1.0, ParameterDescriptor(description='controller gain'))
        self.declare_parameter('mode', 'idle')
        self.declare_parameter('tick', 0)
        self.timer = self.create_timer(0.5, self.count)

    def count(self):
        self.set_parameters([Parameter('tick', value=self.get_parameter('tick').value + 1)])


def main():
    try:
        with rclpy.init():
            rclpy.spin(Tuner())
    except (KeyboardInterrupt, ExternalShutdownException):
        pass


if __name__ == '__main__':
    main()
