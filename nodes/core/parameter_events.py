"""ROS 2's ``/parameter_events``: each node says there which of its parameters were declared (``new``),
set (``changed``) and deleted, as rcl_interfaces/msg/ParameterEvent with the node's fully qualified name and
a stamp on the node's clock (what ``ros2 topic echo /parameter_events`` and rclpy's ParameterEventHandler
read). One event per declaration and per successful set: a set of several parameters at once
(``set_parameters_atomically``) is one event naming them all.

Our key is ``parameter_events``, shared by every node, with its twin on the ROS 2 wire as rclpy announces it
(reliable, volatile, keep-last 1000). Nothing is sent while nobody listens: the event is built and encoded
only when a subscriber matches (``Publisher.has_subscribers``).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Any

import msgs
from nodes.core import parameter_values as pv
from nodes.core.ros2.names import Qos

ParameterEvent = msgs.get_type("rcl_interfaces/msg/ParameterEvent")
Parameter = msgs.get_type("rcl_interfaces/msg/Parameter")
TOPIC = "/parameter_events"
QOS = Qos(reliable=True, transient_local=False, depth=1000)   # rclpy's qos_profile_parameter_events


class ParameterEvents:
    """The node's publisher on ``/parameter_events``; ``publish`` takes lists of rcl_interfaces/msg/Parameter
    (an rclpy node's, built by rclpy/node.py), ``core_listener`` builds them from a ``nodes.core`` node's
    values."""

    def __init__(self, create_publisher: Callable[..., Any], node_name: str, stamp: Callable[[], Any]) -> None:
        self.publisher = create_publisher(ParameterEvent, TOPIC, ros2_qos=QOS)
        self.node_name = node_name
        self._stamp = stamp

    def publish(self, new: Iterable[Any] = (), changed: Iterable[Any] = (), deleted: Iterable[Any] = ()) -> None:
        if not self.publisher.has_subscribers:
            return
        self.publisher.publish(ParameterEvent(stamp=self._stamp(), node=self.node_name, new_parameters=list(new),
                                              changed_parameters=list(changed),
                                              deleted_parameters=list(deleted)))

    def core_listener(self, describe: Callable[[str], Any], get: Callable[[str], Any]
                      ) -> Callable[[str, list[str]], None]:
        """What a ``nodes.core`` node's parameters call (``NodeParameters.listener``): ``kind`` is ``new``
        or ``changed``, each name's value as ROS 2 types it (``parameter_values.value_msg``)."""
        def on_change(kind: str, names: list[str]) -> None:
            if not self.publisher.has_subscribers:
                return
            params = [Parameter(name=n, value=pv.value_msg(describe(n), get(n))) for n in names]
            self.publish(**{kind: params})

        return on_change
