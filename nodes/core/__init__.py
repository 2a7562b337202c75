"""The node runtime: the only code in zenroid that touches Zenoh."""

from nodes.core.action import ActionClient, ActionServer, ClientGoalHandle, ServerGoalHandle
from nodes.core.delivery import Batched, Decoded, Executed, Inline, Pulled, Raw, Spun
from nodes.core.endpoints import Client, Deferred, Publisher, ServiceError, ServiceServer, Subscription
from nodes.core.executor import CallbackGroup
from nodes.core.lifecycle import LifecycleNode
from nodes.core.log import Logger
from nodes.core.node import Node, Timer
from nodes.core.params import ParameterError
from nodes.core.runner import add_connection_arguments, add_node_arguments, connect_from_args, run_node
from nodes.core.spinner import Spinner

__all__ = [
    "ActionClient", "ActionServer", "Batched", "CallbackGroup", "Client", "ClientGoalHandle", "Decoded",
    "Deferred", "Executed", "Inline", "LifecycleNode", "Logger", "Node", "ParameterError", "Publisher", "Pulled", "Raw",
    "ServerGoalHandle", "ServiceError", "ServiceServer", "Spinner", "Spun", "Subscription", "Timer",
    "add_connection_arguments", "add_node_arguments", "connect_from_args", "run_node",
]
