"""Constants rclpy exports."""

S_TO_NS = 1000 * 1000 * 1000
DEFAULT_QOS_DEPTH = 10
