"""ros2_control without ROS: the controller manager process and its controllers (issue 5)."""
