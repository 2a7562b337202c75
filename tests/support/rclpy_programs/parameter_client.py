"""Sets and reads another node's parameters with rclpy's AsyncParameterClient."""
import sys

import rclpy
from rclpy.parameter import Parameter
from rclpy.parameter_client import AsyncParameterClient


def main():
    rclpy.init()
    node = rclpy.create_node('gain_tuner')
    client = AsyncParameterClient(node, 'gain_node')
    client.wait_for_services()
    future = client.set_parameters([Parameter('gain', Parameter.Type.DOUBLE, float(sys.argv[1]))])
    rclpy.spin_until_future_complete(node, future)
    for result in future.result().results:
        node.get_logger().info(f'set gain: successful={result.successful} reason={result.reason!r}')
    future = client.get_parameters(['gain', 'gain_doubled'])
    rclpy.spin_until_future_complete(node, future)
    values = [v.double_value for v in future.result().values]
    node.get_logger().info(f'gain values now {values}')
    node.destroy_node()
    rclpy.shutdown()


if __name__ == '__main__':
    main()
