"""Parameters with the three set-parameter callbacks (rclpy docs' "Monitoring for parameter changes"): the
pre-set callback adds a derived parameter, the on-set callback validates, the post-set one acts; the node
publishes its gain on 'gain' so an outside client sees what was applied."""
import rclpy
from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.parameter import Parameter
from std_msgs.msg import String


class GainNode(Node):

    def __init__(self):
        super().__init__('gain_node')
        self.declare_parameter('gain', 1.0, ParameterDescriptor(description='controller gain'))
        self.declare_parameter('gain_doubled', 2.0)
        self.declare_parameter('mode', 'idle', ParameterDescriptor(read_only=True))
        self.add_pre_set_parameters_callback(self.pre_set)
        self.add_on_set_parameters_callback(self.on_set)
        self.add_post_set_parameters_callback(self.post_set)
        self.pub = self.create_publisher(String, 'gain', 10)
        self.timer = self.create_timer(0.2, self.report)
        self.get_logger().info(f"gain {self.get_parameter('gain').value} mode {self.get_parameter('mode').value}")

    def pre_set(self, parameters):
        extra = [Parameter('gain_doubled', Parameter.Type.DOUBLE, 2.0 * p.value)
                 for p in parameters if p.name == 'gain' and p.type_ == Parameter.Type.DOUBLE]
        return parameters + extra

    def on_set(self, parameters):
        for p in parameters:
            if p.name == 'gain' and p.value < 0.0:
                return SetParametersResult(successful=False, reason='gain must be >= 0')
        return SetParametersResult(successful=True)

    def post_set(self, parameters):
        for p in parameters:
            self.get_logger().info(f'applied {p.name} = {p.value}')

    def report(self):
        msg = String()
        msg.data = f"gain={self.get_parameter('gain').value} doubled={self.get_parameter('gain_doubled').value}"
        self.pub.publish(msg)


def main():
    try:
        with rclpy.init():
            rclpy.spin(GainNode())
    except (KeyboardInterrupt, ExternalShutdownException):
        pass


if __name__ == '__main__':
    main()
