"""URDF handling shared by the state publisher and the URDF tools: safe XML, model, validation, loading."""

from nodes.urdf.description import load_robot_description, parse_xacro_args
from nodes.urdf.model import Inertial, Joint, Link, RobotModel, UrdfError, parse_urdf
from nodes.urdf.validate import Issue, validate

__all__ = [
    "Inertial",
    "Issue",
    "Joint",
    "Link",
    "RobotModel",
    "UrdfError",
    "load_robot_description",
    "parse_urdf",
    "parse_xacro_args",
    "validate",
]
