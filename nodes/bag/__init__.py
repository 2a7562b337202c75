"""Bags: rosbag2 directories (metadata.yaml + MCAP) of CDR-encoded messages; reads MCAP and sqlite3 bags from ROS 2."""
