"""tf2_ros for programs written against ROS 2 (Jazzy's Python API), on zenroid's rclpy and messages:
``TransformBroadcaster``, ``StaticTransformBroadcaster``, ``Buffer``, ``TransformListener`` and the tf2
exceptions. Transforms travel on ``/tf`` and ``/tf_static`` as tf2_msgs/TFMessage, which our robot state
publisher and simulator publish too (docs/messages.md)."""

from tf2_ros.buffer import (
    Buffer,
    ConnectivityException,
    ExtrapolationException,
    InvalidArgumentException,
    LookupException,
    TimeoutException,
    TransformException,
)
from tf2_ros.static_transform_broadcaster import StaticTransformBroadcaster
from tf2_ros.transform_broadcaster import TransformBroadcaster
from tf2_ros.transform_listener import TransformListener

__all__ = ["Buffer", "ConnectivityException", "ExtrapolationException", "InvalidArgumentException",
           "LookupException", "StaticTransformBroadcaster", "TimeoutException", "TransformBroadcaster",
           "TransformException", "TransformListener"]
