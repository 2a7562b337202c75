"""``python -m nodes.packages.serve PKG EXEC [args]``: one executable of a package zenroid serves, started the
way ROS starts it (``ros2 run``, launch_ros' ``Node``), with its ROS argument spellings turned into ours.

Every served executable runs through here: the ``--ros-args`` sections become our node options (nodes) or are
dropped (tools, which have no parameters), then the executable's own arguments are mapped
(``spawn_entity.py -database``, ``create -name``, ``spawner --stopped`` ...) and our module runs in this process.
"""

from __future__ import annotations

import runpy
import sys
import tempfile
from collections.abc import Callable

from nodes.packages import stack
from nodes.packages.index import UriError, resolve_uri
from nodes.packages.ros_args import RosArgs, RosArgsError, split


class ServeError(ValueError):
    """Arguments a served executable cannot take (names the executable and the argument)."""


def _take(args: list[str], flags: tuple[str, ...], valued: bool = True) -> list[str | None]:
    """Remove every ``flag [value]`` of ``flags`` from ``args`` and return the values (None for a flag alone)."""
    found: list[str | None] = []
    i = 0
    while i < len(args):
        if args[i] in flags:
            if valued:
                if i + 1 >= len(args):
                    raise ServeError(f"'{args[i]}' needs a value")
                found.append(args[i + 1])
                del args[i:i + 2]
            else:
                found.append(None)
                del args[i]
        elif valued and any(args[i].startswith(f"{f}=") for f in flags if f.startswith("--")):
            found.append(args[i].split("=", 1)[1])
            del args[i]
        else:
            i += 1
    return found


def _namespace(ros: RosArgs) -> str:
    return (ros.namespace or "").strip("/")


def spawner(args: list[str], ros: RosArgs) -> list[str]:
    """controller_manager's spawner: ``NAME... [-c CM] [-p FILE] [-t TYPE] [--inactive|--stopped|--load-only]
    [-n NS]``; the manager
    is ``/controller_manager`` (or in the node's namespace), as in ROS, not zenroid's default namespace."""
    args = list(args)
    if _take(args, ("--stopped",), valued=False):
        args.append("--inactive")
    namespaces = _take(args, ("-n", "--namespace", "--ns"))
    for flag in ("-u", "--unload-on-kill", "--activate-as-group"):
        _take(args, (flag,), valued=False)
    _take(args, ("--switch-timeout", "--service-call-timeout"))
    managers = _take(args, ("-c", "--controller-manager"))
    manager = managers[-1] if managers else "controller_manager"
    namespace = namespaces[-1] if namespaces else _namespace(ros)
    if manager and manager.startswith("/"):
        namespace = ""
    return ["control", "spawner", *args, "-c", (manager or "").strip("/"), "--ns", (namespace or "").strip("/")]


def unspawner(args: list[str], ros: RosArgs) -> list[list[str]]:
    """controller_manager's unspawner: deactivate, then unload, each controller named."""
    args = list(args)
    managers = _take(args, ("-c", "--controller-manager"))
    _take(args, ("--switch-timeout",))
    manager = managers[-1] if managers else "controller_manager"
    namespace = "" if manager.startswith("/") else _namespace(ros)
    where = ["-c", manager.strip("/"), "--ns", namespace]
    names = [a for a in args if not a.startswith("-")]
    if not names:
        raise ServeError("unspawner: name at least one controller")
    return [step for name in names for step in (["control", "set_controller_state", name, "inactive", *where],
                                                 ["control", "unload_controller", name, *where])]


def spawn_entity(args: list[str], ros: RosArgs) -> list[str]:
    """gazebo_ros' spawn_entity.py: ``-database NAME`` is a model of Gazebo's model path; the service options
    of Gazebo (``-gazebo_namespace``, ``-spawn_service_timeout``, ``-package_to_model``, ``-b``) map or go."""
    args = list(args)
    for name in _take(args, ("-database",)):
        try:
            path = resolve_uri(f"model://{name}/model.sdf")
        except UriError as exc:
            raise ServeError(f"-database {name}: {exc}") from None
        args += ["-file", str(path)]
    for timeout in _take(args, ("-spawn_service_timeout",)):
        args += ["-timeout", timeout or "30"]
    _take(args, ("-gazebo_namespace",))
    for flag in ("-package_to_model", "-b", "-bond", "-sdf", "-urdf"):
        _take(args, (flag,), valued=False)
    if _take(args, ("-stdin",), valued=False):
        raise ServeError("-stdin is not served: use -file or -topic")
    if "-robot_namespace" not in args:
        args += ["-robot_namespace", _namespace(ros) or "/"]  # gazebo_ros2_control's: the node's, else the root
    topics = _take(args, ("-topic",))
    for topic in topics:
        args += ["-topic", topic if (topic or "").startswith("/") or not _namespace(ros)
                 else f"{_namespace(ros)}/{topic}"]
    return ["spawn", *args]


def gz_create(args: list[str], ros: RosArgs) -> list[str]:
    """ros_gz_sim's create: ``-name`` (``-entity_name``), ``-file``, ``-topic``, ``-string``, pose."""
    args = list(args)
    out = ["spawn"]
    for name in _take(args, ("-name", "-entity_name", "--name")):
        out += ["-entity", name or ""]
    for xml in _take(args, ("-string",)):
        with tempfile.NamedTemporaryFile("w", suffix=".urdf" if "<robot" in (xml or "") else ".sdf", delete=False,
                                         encoding="utf-8") as tmp:
            tmp.write(xml or "")
        out += ["-file", tmp.name]
    _take(args, ("-world", "--world"))
    _take(args, ("-allow_renaming", "--allow_renaming"))
    if _take(args, ("-param", "--param")):
        raise ServeError("-param is not served: use -topic robot_description")
    for topic in _take(args, ("-topic", "--topic")):
        out += ["-topic", topic or ""]
    return [*out, *args, "-robot_namespace", _namespace(ros) or "/"]


def rviz2(args: list[str], ros: RosArgs) -> list[str]:
    """rviz2: ``-d FILE.rviz`` read for what maps onto our viewer (printed once, with what does not);
    ``-f FRAME`` is the fixed frame; the splash screen and Ogre options go."""
    args = list(args)
    configs = _take(args, ("-d", "--display-config"))
    frames = _take(args, ("-f", "--fixed-frame"))
    _take(args, ("-s", "--splash-screen", "-l", "--ogre-log", "--opengl"))
    for flag in ("--fullscreen", "--disable-anti-aliasing", "--no-stereo"):
        _take(args, (flag,), valued=False)
    from nodes.viz.rviz_config import RvizConfigError, read_rviz  # the viewer package loads Rerun: rviz2 only

    out: list[str] = []
    mapping = None
    if configs:
        try:
            mapping = read_rviz(configs[-1] or "")
        except RvizConfigError as exc:
            print(f"rviz2: {exc}; opening the default view", file=sys.stderr, flush=True)
    if mapping is not None:
        if frames:
            mapping.fixed_frame = frames[-1]
        print(f"rviz2: {configs[-1]} shown: {', '.join(mapping.mapped) or 'nothing'}", flush=True)
        if mapping.not_mapped:
            print(f"rviz2: not shown by our viewer: {', '.join(mapping.not_mapped)}", flush=True)
        for param in mapping.viewer_params():
            out += ["--param", param]
    elif frames:
        others = ", ".join(f for f in ("world", "map", "odom") if f != frames[-1])
        out += ["--param", f"world_frames:=[{frames[-1]}, {others}]"]
    return [*out, *args]


def xacro(args: list[str], ros: RosArgs) -> list[str]:
    args = [a for a in args if a not in ("--inorder", "-i", "--legacy")]
    return ["xacro", *args]


Translator = Callable[[list[str], RosArgs], list[str]]
TRANSLATORS: dict[tuple[str, str], Translator] = {
    ("controller_manager", "spawner"): spawner,
    ("gazebo_ros", "spawn_entity.py"): spawn_entity,
    ("ros_gz_sim", "create"): gz_create,
    ("xacro", "xacro"): xacro,
    ("rviz2", "rviz2"): rviz2,
}


def command(package: str, executable: str, argv: list[str]) -> tuple[str, list[list[str]]]:
    """(module, argument lists to run it with, in order) for ``package executable argv``."""
    entry = stack.entries(package).get(executable)
    if entry is None:
        raise ServeError(f"zenroid does not serve '{package} {executable}'")
    rest, ros = split(argv)
    if (package, executable) == ("controller_manager", "unspawner"):
        return entry.module, unspawner(rest, ros)
    translate = TRANSLATORS.get((package, executable))
    args = translate(rest, ros) if translate else [*entry.module_args, *rest]
    return entry.module, [[*args, *ros.node_options()] if entry.ros_node else args]


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if len(argv) < 2:
        print("usage: python -m nodes.packages.serve PACKAGE EXECUTABLE [args ...]", file=sys.stderr)
        return 2
    package, executable, rest = argv[0], argv[1], argv[2:]
    try:
        module, runs = command(package, executable, rest)
    except (ServeError, RosArgsError) as exc:
        print(f"{package} {executable}: {exc}", file=sys.stderr)
        return 2
    status = 0
    for args in runs:
        sys.argv = [executable, *args]
        try:
            runpy.run_module(module, run_name="__main__", alter_sys=True)
        except SystemExit as exc:
            status = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
            if status:
                return status
    return status


if __name__ == "__main__":
    sys.exit(main())
