"""Bags: rosbag2 bags (metadata.yaml + MCAP or sqlite3 storage) of CDR messages, written and read with rosbags.

rosbags (Ternaris) does the rosbag2 formats; msgs.cdr encodes and decodes the payloads and msgs.type_hash
names the types, the same codec and hashes the ROS 2 wire uses.
"""
