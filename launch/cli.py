"""``python -m launch FILE.yaml [name:=value ...]`` and ``zenroid launch``: the ros2 launch of this stack."""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
import time
import warnings
from collections.abc import Iterator
from pathlib import Path

import yaml

from launch import interrupts
from launch._yaml_substitutions import RobotFileError
from launch.code_errors import LaunchCodeError
from launch.description import LaunchDeprecationWarning
from launch.formats import load_description
from launch.resolve import LaunchPlan, find_launch_file, resolve
from launch.yaml_source import LaunchError, Source
from nodes.tools.cli import UsageError


def _usage_error(message: str) -> UsageError:
    """Bad input to the launcher: one line, exit status 2 (as every ``zenroid`` verb)."""
    return UsageError(message)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("file", help="launch file (a path, or a bare name in launch/: humanoid.yaml), or a package "
                        "name followed by a launch file in its share folder (as ros2 launch PKG FILE)")
    # REMAINDER so options may also follow the name:=value pairs (run() picks them out).
    parser.add_argument("arguments", nargs=argparse.REMAINDER, metavar="name:=value", help="launch argument values")
    parser.add_argument("--show-args", action="store_true", help="print the declared arguments and exit")
    parser.add_argument("--print", dest="print_only", action="store_true",
                        help="print the fully resolved description and exit (nothing is started)")
    parser.add_argument("--log-dir", type=Path, default=None,
                        help="where per-node logs go (default: $ZENROID_LOG_DIR or ~/.zenroid/log/<run>)")


def parse_assignments(items: list[str]) -> dict[str, str]:
    values: dict[str, str] = {}
    for item in items:
        name, sep, value = item.partition(":=")
        if not sep or not name.strip():
            raise _usage_error(f"launch arguments look like name:=value, got '{item}'")
        values[name.strip()] = value
    return values


def show_args(path: Path) -> str:
    lines = []
    for arg in load_description(path).declared_args():
        lines.append(f"'{arg.name}':")
        lines.append(f"    {arg.description or 'no description given'}")
        if arg.choices:
            lines.append(f"    Valid choices are: {arg.choices}")
        lines.append(f"    (default: '{arg.default}')" if arg.default is not None else "    (required)")
    return "\n".join(lines) if lines else "(this launch file declares no arguments)"


def zenoh_port_of(plan: LaunchPlan) -> int:
    text = plan.args.get("zenoh_port", "7447")
    try:
        port = int(text)
    except ValueError:
        port = -1
    if not 1 <= port <= 65535:
        raise LaunchError(f"argument 'zenoh_port' must be a TCP port 1..65535, got '{text}'", Source(plan.file, 1))
    return port


def ros2_wire_of(plan: LaunchPlan) -> bool:
    """The ``ros2`` argument (true/false): whether nodes also speak rmw_zenoh (docs/ros2.md)."""
    text = str(plan.args.get("ros2", "true")).strip().lower()
    if text not in ("true", "false", "1", "0"):
        raise LaunchError(f"argument 'ros2' must be true or false, got '{text}'", Source(plan.file, 1))
    return text in ("true", "1")


def default_log_dir(path: Path) -> Path:
    base = Path(os.environ.get("ZENROID_LOG_DIR") or Path.home() / ".zenroid" / "log")
    return base / f"{path.stem}-{time.strftime('%Y%m%d-%H%M%S')}-{os.getpid()}"


def child_environment(endpoint: str | None, ros2: bool = True) -> dict[str, str]:
    """What every node inherits: our environment (the nodes import the packages from where the launcher
    does: the installed distribution, or a checkout on PYTHONPATH), unbuffered output, the router, and
    ``ZENROID_ROS2=0`` when the launch turned the ROS 2 wire off (``ros2:=false``)."""
    env = dict(os.environ)
    if not ros2:
        env["ZENROID_ROS2"] = "0"
    env["PYTHONUNBUFFERED"] = "1"
    if endpoint is not None:  # embedded router: children connect to it and nothing else
        env["ZENOH_CONNECT"] = endpoint
        env.pop("ZENOH_CONFIG", None)
    return env


def _late_options(args: argparse.Namespace) -> None:
    """Options written after the file or the name:=value pairs (argparse leaves them in the remainder)."""
    rest: list[str] = []
    items = iter(args.arguments)
    for item in items:
        if item == "--show-args":
            args.show_args = True
        elif item == "--print":
            args.print_only = True
        elif item == "--log-dir" or item.startswith("--log-dir="):
            value = item.partition("=")[2] if "=" in item else next(items, None)
            if not value:
                raise _usage_error("--log-dir needs a directory")
            args.log_dir = Path(value)
        elif item.startswith("-"):
            raise _usage_error(f"unknown option '{item}' (options: --show-args, --print, --log-dir DIR)")
        else:
            rest.append(item)
    args.arguments = rest


@contextlib.contextmanager
def _deprecations_logged() -> Iterator[None]:
    """Old spellings in launch files (``param_file``) work and are reported as the launcher's warnings."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", LaunchDeprecationWarning)
        try:
            yield
        finally:
            for warning in caught:
                if issubclass(warning.category, LaunchDeprecationWarning):
                    print(f"[launch] [WARN] {warning.message}", file=sys.stderr, flush=True)
                else:
                    warnings.warn_explicit(warning.message, warning.category, warning.filename, warning.lineno)


def package_launch_file(package: str, name: str) -> Path:
    """``ros2 launch PKG FILE``: FILE in PKG's share folder (its launch/ first, then anywhere below it)."""
    from nodes.packages import PackageNotFoundError, find_share

    try:
        share = find_share(package)
    except PackageNotFoundError as exc:
        raise _usage_error(str(exc).strip('"')) from None
    direct = share / name
    if direct.is_file():
        return direct
    found = sorted(p for p in share.rglob(Path(name).name) if p.is_file())
    preferred = [p for p in found if p.parent.name == "launch"]
    if len(preferred) == 1 or len(found) == 1:
        return (preferred or found)[0]
    if found:
        raise _usage_error(f"package '{package}' has several files named '{name}': "
                           f"{', '.join(str(p.relative_to(share)) for p in found)}")
    raise _usage_error(f"file '{name}' was not found in the share directory of package '{package}' ({share})")


def _launch_file(args: argparse.Namespace) -> Path:
    """FILE, or PKG FILE (the second word not an assignment): the file to launch."""
    try:
        return find_launch_file(args.file)
    except FileNotFoundError:
        names = [i for i, item in enumerate(args.arguments) if ":=" not in item]
        if names:
            package, name = args.file, args.arguments.pop(names[0])
            return package_launch_file(package, name)
        raise _usage_error(f"launch file not found: {args.file} (bare names are looked up in launch/; a package's "
                           "launch file: PKG FILE)") from None


def load_plan(args: argparse.Namespace) -> tuple[Path, LaunchPlan | None]:
    _late_options(args)
    path = _launch_file(args)
    values = parse_assignments(args.arguments)
    try:
        if args.show_args:
            return path, None
        with _deprecations_logged():
            return path, resolve(path, values)
    except (LaunchCodeError, RobotFileError):
        raise
    except LaunchError as exc:
        raise _usage_error(str(exc)) from None


def execute(plan: LaunchPlan, log_dir: Path) -> int:
    """Host the router (unless an external one is configured), supervise the nodes, clean up."""
    from launch.readiness import NodeReadiness
    from launch.reaper import Reaper
    from launch.supervisor import Supervisor
    from nodes.core import memory
    from nodes.core import session as zsession

    port = zenoh_port_of(plan)
    if _interrupted_early():
        return 0
    log_dir.mkdir(parents=True, exist_ok=True)
    exclusive_cpu = reserve_exclusive_cpu(plan)   # before the router's threads exist: they inherit the rest
    reaper = Reaper()
    session = None
    readiness = None
    try:
        if zsession.external_router_configured():
            endpoint = None
            session = zsession.open_peer()
            where = "external router (ZENOH_CONNECT / ZENOH_CONFIG)"
        else:
            endpoint = zsession.loopback_endpoint(port)
            try:
                session = zsession.open_router(port)
            except Exception as exc:  # zenoh raises a plain ZError when the port is taken
                print(f"[launch] [ERROR] cannot host the Zenoh router on {endpoint}: {exc} "
                      f"(is another launch running? pick another with zenoh_port:=N)", flush=True)
                return 1
            where = f"embedded router on {endpoint}"
            # the router relays every payload without Python seeing it: give its buffers back after floods
            memory.trim_periodically()
        print(f"[launch] [INFO] zenoh: {where}", flush=True)
        readiness = NodeReadiness(session)
        environment = child_environment(endpoint, ros2_wire_of(plan))
        supervisor = Supervisor(plan, log_dir, environment, readiness, reaper=reaper,
                                own_process_tree=True, exclusive_cpu=exclusive_cpu)
        interrupts.hand_over(supervisor.handle_signal)  # a signal that came during start-up stops it at once
        try:
            return supervisor.run()
        finally:
            interrupts.release()
    finally:
        if readiness is not None:
            readiness.close()
        if session is not None:
            session.close()
        reaper.close()


def reserve_exclusive_cpu(plan: LaunchPlan) -> int | None:
    """The CPU kept for the node with ``exclusive_cpu`` (None: no such node, or none can be kept; says why).

    The launcher's own threads move to the other CPUs first, so the router and every process it starts
    run there; the node's stepping thread claims the kept CPU itself (nodes.core.cpu)."""
    from nodes.core import cpu

    owner = next((spec for spec in plan.nodes if spec.exclusive_cpu), None)
    if owner is None:
        return None
    if not cpu.supported():
        print(f"[launch] [INFO] exclusive_cpu of '{owner.name}': CPU affinity is not available on this system; "
              "not reserved", flush=True)
        return None
    allowed = cpu.allowed_cpus()
    chosen = cpu.choose_exclusive(allowed)
    if chosen is None:
        print(f"[launch] [INFO] exclusive_cpu of '{owner.name}': only one CPU available; not reserved", flush=True)
        return None
    if not cpu.hold_reservation():
        # a second launch on this machine would pick the same CPU: two physics threads on one CPU
        print(f"[launch] [INFO] exclusive_cpu of '{owner.name}': another launch on this machine keeps a CPU for "
              "its physics (or the temporary directory is not writable); not reserved (several worlds side by "
              "side: exclusive_cpu:=false for each)", flush=True)
        return None
    rest = allowed - {chosen}
    cpu.move_threads(rest)
    print(f"[launch] [INFO] CPU {chosen} kept for the stepping thread of '{owner.name}'; every other process "
          f"on CPU {','.join(map(str, sorted(rest)))} (exclusive_cpu)", flush=True)
    return chosen


def _interrupted_early() -> bool:
    """A SIGINT/SIGTERM that arrived before any node started ends the launch here, quietly."""
    name = interrupts.requested()
    if name is not None:
        print(f"[launch] [INFO] received {name} before any node started: nothing to stop", flush=True)
    return name is not None


def run(args: argparse.Namespace) -> int:
    interrupts.install()  # also for `zenroid launch`, which imports us late
    path, plan = load_plan(args)
    if args.show_args:
        try:
            print(show_args(path))
        except LaunchError as exc:
            raise _usage_error(str(exc)) from None
        return 0
    if args.print_only:
        description = plan.describe()
        try:
            port = zenoh_port_of(plan)
        except LaunchError as exc:
            raise _usage_error(str(exc)) from None
        from nodes.core.session import external_router_configured, loopback_endpoint

        description["zenoh"] = ("external (ZENOH_CONNECT / ZENOH_CONFIG)" if external_router_configured()
                                else f"embedded router on {loopback_endpoint(port)}")
        description["commands"] = {
            n.name: n.command(sys.executable, Path("<generated params>") if n.params else None,
                              {c.name: Path("<generated params>") if c.params else None for c in n.composed})
            for n in plan.nodes}
        print(yaml.safe_dump(description, sort_keys=False), end="")
        return 0
    try:
        zenoh_port_of(plan)
        ros2_wire_of(plan)
    except LaunchError as exc:
        raise _usage_error(str(exc)) from None
    return execute(plan, args.log_dir or default_log_dir(path))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m launch", description="run a launch file (our YAML, or ROS's "
                                     "Python, XML or YAML formats)")
    add_arguments(parser)
    args = parser.parse_args(argv)
    try:
        return run(args)
    except UsageError as exc:
        print(f"launch: error: {exc}", file=sys.stderr)
        return 2
    except RobotFileError as exc:
        print(f"launch: error: {exc}", file=sys.stderr)
        return 1
    except LaunchCodeError as exc:   # the launch file's own code raised: its traceback, then file:line
        print(exc.details, end="", file=sys.stderr)
        print(f"launch: error: {exc}", file=sys.stderr)
        return 1
