"""Describes, types, sets atomically, deletes and lists another node's parameters with rclpy's
AsyncParameterClient (the calls ``ros2 param describe/list`` make), printing what the node answered."""
import sys

import rclpy
from rclpy.parameter import Parameter
from rclpy.parameter_client import AsyncParameterClient


def main():
    rclpy.init()
    node = rclpy.create_node('parameter_inspector')
    log = node.get_logger().info
    client = AsyncParameterClient(node, sys.argv[1] if len(sys.argv) > 1 else 'gain_node')
    if not client.wait_for_services(timeout_sec=30.0):
        log('no parameter services')
        sys.exit(1)

    def ask(future):
        rclpy.spin_until_future_complete(node, future)
        return future.result()

    described = ask(client.describe_parameters(['gain', 'mode']))
    log(f'describe: {[(d.name, d.type, d.description, d.read_only) for d in described.descriptors]}')
    log(f"types: {list(ask(client.get_parameter_types(['gain', 'mode'])).types)}")
    refused = ask(client.set_parameters_atomically([Parameter('gain', Parameter.Type.DOUBLE, 4.0),
                                                    Parameter('mode', Parameter.Type.STRING, 'run')]))
    log(f'atomically with mode: successful={refused.result.successful} reason={refused.result.reason!r}')
    values = ask(client.get_parameters(['gain'])).values
    log(f'gain after the refused set: {values[0].double_value}')
    done = ask(client.set_parameters_atomically([Parameter('gain', Parameter.Type.DOUBLE, 4.0)]))
    log(f'atomically: successful={done.result.successful}')
    deleted = ask(client.delete_parameters(['gain']))
    log(f'delete: successful={deleted.results[0].successful} reason={deleted.results[0].reason!r}')
    log(f'list: {sorted(ask(client.list_parameters()).result.names)}')
    values = ask(client.get_parameters(['gain', 'gain_doubled'])).values
    log(f'values now {[v.double_value for v in values]}')
    node.destroy_node()
    rclpy.shutdown()


if __name__ == '__main__':
    main()
