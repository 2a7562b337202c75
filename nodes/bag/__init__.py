"""Bags: recorded messages in MCAP files with ROS 2 (CDR) encoding, readable by ros2 bag and Foxglove."""
