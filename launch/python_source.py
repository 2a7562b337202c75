"""The Python front end: a ``.launch.py`` is run (it is code, as in ROS) and its
``generate_launch_description()`` gives the ROS launch actions of the inert description."""

from __future__ import annotations

import importlib.util
import itertools
import sys
from pathlib import Path

from launch.code_errors import launch_code_error
from launch.context import LaunchDescription as RosLaunchDescription
from launch.description import LaunchDescription
from launch.yaml_source import LaunchError, Source

_counter = itertools.count()


def load_python(path: Path) -> LaunchDescription:
    """Execute ``path`` as a module and call its ``generate_launch_description()``; what it raises becomes an
    error naming the launch file's line (its traceback kept for the launcher to print)."""
    name = f"launch_file_{next(_counter)}_{''.join(c if c.isalnum() else '_' for c in path.stem)}"
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:
        raise LaunchError(f"cannot load {path} as Python", Source(path, 0))
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
        generate = getattr(module, "generate_launch_description", None)
        if generate is None:
            raise LaunchError("a Python launch file defines generate_launch_description() (this one does not)",
                              Source(path, 1))
        described = generate()
    except LaunchError:
        raise
    except SyntaxError as exc:
        raise LaunchError(f"SyntaxError: {exc.msg}", Source(Path(exc.filename or path), exc.lineno or 0)) from None
    except Exception as exc:
        raise launch_code_error(exc, Source(path, 0), "the launch file raised") from None
    finally:
        sys.modules.pop(name, None)
    if not isinstance(described, RosLaunchDescription):
        raise LaunchError(f"generate_launch_description() returned {type(described).__name__}, not a "
                          "launch.LaunchDescription", Source(path, 0))
    return LaunchDescription(file=path, actions=list(described.entities), format="python")
