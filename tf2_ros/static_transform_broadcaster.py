"""``tf2_ros.StaticTransformBroadcaster``: every static transform sent so far, latched on ``/tf_static``."""

from __future__ import annotations

from typing import Any

from tf2_msgs.msg import TFMessage

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile


class StaticTransformBroadcaster:
    def __init__(self, node: Any, qos: QoSProfile | int | None = None) -> None:
        if qos is None:
            qos = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL, history=HistoryPolicy.KEEP_LAST)
        self.pub_tf = node.create_publisher(TFMessage, "/tf_static", qos)
        self._net: dict[str, Any] = {}   # child frame -> its latest transform: a new one replaces it, as in tf2_ros

    def sendTransform(self, transform: Any) -> None:  # noqa: N802 - tf2_ros's name
        for t in list(transform) if isinstance(transform, (list, tuple)) else [transform]:
            self._net[t.child_frame_id] = t
        self.pub_tf.publish(TFMessage(transforms=list(self._net.values())))
