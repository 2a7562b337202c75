"""ros2/examples' synchronous client (rclpy/services/minimal_client/client.py): call() while another thread
spins."""
import threading

from example_interfaces.srv import AddTwoInts
import rclpy


def main(args=None):
    rclpy.init(args=args)
    node = rclpy.create_node('minimal_client')
    cli = node.create_client(AddTwoInts, 'add_two_ints')

    spin_thread = threading.Thread(target=rclpy.spin, args=(node,), daemon=True)
    spin_thread.start()

    req = AddTwoInts.Request()
    req.a = 41
    req.b = 1
    while not cli.wait_for_service(timeout_sec=1.0):
        node.get_logger().info('service not available, waiting again...')

    response = cli.call(req)
    node.get_logger().info('Result of add_two_ints: for %d + %d = %d' % (req.a, req.b, response.sum))

    node.destroy_node()
    rclpy.try_shutdown()


if __name__ == '__main__':
    main()
