"""``tf2_ros.TransformBroadcaster``: transforms on ``/tf`` (a TFMessage per call)."""

from __future__ import annotations

from typing import Any

from tf2_msgs.msg import TFMessage

from rclpy.qos import QoSProfile


class TransformBroadcaster:
    def __init__(self, node: Any, qos: QoSProfile | int = 100) -> None:
        self.pub_tf = node.create_publisher(TFMessage, "/tf", qos)

    def sendTransform(self, transform: Any) -> None:  # noqa: N802 - tf2_ros's name
        transforms = list(transform) if isinstance(transform, (list, tuple)) else [transform]
        self.pub_tf.publish(TFMessage(transforms=transforms))
