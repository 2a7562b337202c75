"""Watches parameter changes with rclpy's ParameterEventHandler: the tuner's gain (a node name relative to
this node's namespace) and every event of every node."""
import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.parameter import parameter_value_to_python
from rclpy.parameter_event_handler import ParameterEventHandler


class Watcher(Node):

    def __init__(self):
        super().__init__('watcher')
        self.handler = ParameterEventHandler(self)
        self.gain_handle = self.handler.add_parameter_callback(
            parameter_name='gain', node_name='tuner', callback=self.on_gain)
        self.event_handle = self.handler.add_parameter_event_callback(self.on_event)
        self.get_logger().info('watching')

    def on_gain(self, parameter):
        self.get_logger().info(f'gain callback: {parameter_value_to_python(parameter.value)}')

    def on_event(self, event):
        def pairs(parameters):
            return [(p.name, parameter_value_to_python(p.value)) for p in parameters]

        self.get_logger().info(
            f'event {event.node} new={pairs(event.new_parameters)} changed={pairs(event.changed_parameters)} '
            f'deleted={pairs(event.deleted_parameters)}')


def main():
    try:
        with rclpy.init():
            rclpy.spin(Watcher())
    except (KeyboardInterrupt, ExternalShutdownException):
        pass


if __name__ == '__main__':
    main()
