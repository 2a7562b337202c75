"""``tf2_ros.TransformListener``: ``/tf`` and ``/tf_static`` into a Buffer.

As in tf2_ros, the subscriptions are the node's: their callbacks run while the node is spun (``spin_thread=True``
spins them on a thread of their own, so a program that never spins still fills the buffer).
"""

from __future__ import annotations

import threading
from typing import Any

from tf2_msgs.msg import TFMessage

from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile


class TransformListener:
    def __init__(self, buffer: Any, node: Any, *, spin_thread: bool = False, qos: QoSProfile | int | None = None,
                 static_qos: QoSProfile | int | None = None) -> None:
        self.buffer = buffer
        self.node = node
        qos = qos if qos is not None else QoSProfile(depth=100, durability=DurabilityPolicy.VOLATILE,
                                                     history=HistoryPolicy.KEEP_LAST)
        static_qos = static_qos if static_qos is not None else QoSProfile(
            depth=100, durability=DurabilityPolicy.TRANSIENT_LOCAL, history=HistoryPolicy.KEEP_LAST)
        self.group = MutuallyExclusiveCallbackGroup()
        self.tf_sub = node.create_subscription(TFMessage, "/tf", self.callback, qos, callback_group=self.group)
        self.tf_static_sub = node.create_subscription(TFMessage, "/tf_static", self.static_callback, static_qos,
                                                      callback_group=self.group)
        self.executor = None
        self.dedicated_listener_thread = None
        if spin_thread:
            from rclpy.executors import SingleThreadedExecutor

            self.executor = SingleThreadedExecutor()
            self.executor.add_node(node)
            self.dedicated_listener_thread = threading.Thread(target=self.executor.spin, daemon=True,
                                                              name="tf2_ros listener")
            self.dedicated_listener_thread.start()

    def __del__(self) -> None:
        if self.executor is not None:
            self.executor.shutdown()

    def unregister(self) -> None:
        self.node.destroy_subscription(self.tf_sub)
        self.node.destroy_subscription(self.tf_static_sub)

    def callback(self, data: Any) -> None:
        who = "default_authority"
        for transform in data.transforms:
            self.buffer.set_transform(transform, who)

    def static_callback(self, data: Any) -> None:
        who = "default_authority"
        for transform in data.transforms:
            self.buffer.set_transform_static(transform, who)
