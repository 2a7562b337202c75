"""``ros2``: the ``zenroid`` command line under ros2cli's name, verbs and argument spellings (docs/packages.md).

Each ``ros2 VERB ...`` line is rewritten into the ``zenroid`` verb that does the same (``-1`` -> ``--once``,
``--set-state start`` -> ``--set-state active``, ros2cli's daemon and QoS options dropped ...) and run by the
same implementation. Where ROS 2 is sourced, its own ``ros2`` comes first on PATH; ``ros2 doctor`` says which
one answered.
"""

from __future__ import annotations

import os
import shutil
import sys

from nodes.tools import cli

VERBS = ("action", "bag", "component", "control", "daemon", "doctor", "interface", "launch", "lifecycle", "node",
         "param", "pkg", "run", "service", "topic", "wtf")
# ros2cli options that change nothing here: (flag, takes a value)
_DROPPED_EVERYWHERE = {"--no-daemon": False, "--spin-time": True, "--use-sim-time": False}
_QOS = {"--qos-profile", "--qos-depth", "--qos-history", "--qos-reliability", "--qos-durability",
        "--qos-liveliness", "--qos-liveliness-lease-duration-seconds"}


class Ros2UsageError(ValueError):
    pass


def _drop(args: list[str], flags: dict[str, bool]) -> list[str]:
    out: list[str] = []
    i = 0
    while i < len(args):
        flag = args[i].split("=", 1)[0]
        if flag in flags:
            i += 2 if flags[flag] and "=" not in args[i] else 1
            continue
        out.append(args[i])
        i += 1
    return out


def _rename(args: list[str], names: dict[str, str]) -> list[str]:
    return [names.get(a, a) for a in args]


def _positionals(args: list[str], valued: set[str]) -> list[int]:
    """Indexes of the positional arguments (skipping flags and the values of ``valued`` flags)."""
    found, i = [], 0
    while i < len(args):
        if args[i].startswith("-") and len(args[i]) > 1 and not _is_number(args[i]):
            i += 2 if args[i] in valued else 1
            continue
        found.append(i)
        i += 1
    return found


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def topic(sub: str, args: list[str]) -> list[str]:
    qos = {flag: True for flag in _QOS}
    if sub == "echo":
        args = _drop(args, {**qos, "--no-arr": False, "--no-str": False, "--flow-style": False, "--raw": False,
                            "--lost-messages": False, "--no-lost-messages": False, "--include-message-info": False,
                            "--clear": False})
        if "--csv" in args or "--filter" in args:
            raise Ros2UsageError(f"topic echo: {'--csv' if '--csv' in args else '--filter'} is not served "
                                 "(--field and --json are)")
        args = _rename(args, {"-l": "--truncate-length"})
        positional = _positionals(args, {"--field", "-f", "--truncate-length", "-n", "--timeout", "--wait"})
        if len(positional) >= 2:  # ros2 topic echo TOPIC [TYPE]: the type comes from the graph here
            del args[positional[1]]
    elif sub == "pub":
        args = _drop(args, {**qos, "-w": True, "--wait-matching-subscriptions": True, "-p": True, "--print": True,
                            "-n": True, "--node-name": True, "--keep-alive": True, "--max-wait-time-secs": True})
        args = _rename(args, {"-1": "--once"})
    elif sub in ("hz", "bw"):
        args = _drop(args, {**qos, "--filter": True, "--wall-time": False})
        args = _rename(args, {"-w": "--window"})
    elif sub == "list":
        args = _drop(args, {"-c": False, "--count-topics": False, "--include-hidden-topics": False, "-v": False,
                            "--verbose": False})
    return ["topic", sub, *args]


_STATES = {"configure": "inactive", "configured": "inactive", "stop": "inactive", "stopped": "inactive",
           "start": "active", "started": "active"}


def control(sub: str, args: list[str]) -> list[str]:
    args = _rename(args, {"--set_state": "--set-state", "--start": "--activate", "--stop": "--deactivate",
                          "--start-controllers": "--activate", "--stop-controllers": "--deactivate"})
    args = [_STATES.get(a, a) for a in args]
    args = _drop(args, {"--activate-asap": False, "--switch-timeout": True, "--best-effort": False,
                        "--include-hidden-nodes": False})
    if "--ns" not in args and "--namespace" not in args and not os.environ.get("ZENROID_NS"):
        args += ["--ns", ""]  # ros2 control talks to /controller_manager (or -c's), not zenroid's humanoid/
    return ["control", sub, *args]


def doctor(args: list[str]) -> list[str]:
    where = shutil.which("ros2")
    this = os.path.realpath(sys.argv[0]) if sys.argv and sys.argv[0] else "ros2"
    sourced = os.environ.get("ROS_DISTRO")
    print(f"ros2: zenroid's ros2 ({this}): the zenroid CLI under ros2cli's verbs, no ROS 2 install behind it")
    if sourced:
        print(f"      ROS 2 {sourced} is sourced in this shell; its own ros2 comes first on PATH where its setup "
              "script put it")
    if where and os.path.realpath(where) != this:
        print(f"      the first ros2 on PATH is {where}")
    return ["doctor", *_drop(args, {"-r": False, "--report": False, "-rf": False, "--report-failed": False,
                                    "-iw": False, "--include-warnings": False})]


def translate(argv: list[str]) -> list[str]:
    """``ros2 ...`` arguments -> ``zenroid ...`` arguments."""
    if not argv:
        return argv
    verb, rest = argv[0], list(argv[1:])
    if verb in ("run", "launch"):
        return [verb, *rest]  # the rest belongs to the executable / the launch file
    rest = _drop(rest, _DROPPED_EVERYWHERE) if verb not in ("bag", "pkg", "interface") else rest
    sub = rest[0] if rest else ""
    if verb == "topic" and sub:
        return topic(sub, rest[1:])
    if verb == "control" and sub:
        return control(sub, rest[1:])
    if verb == "doctor" or verb == "wtf":
        return doctor(rest)
    if (verb, sub) in (("service", "call"), ("action", "send_goal")):
        rest = _drop(rest, {"-r": True, "--rate": True})
    if verb == "node" and sub == "list":
        rest = _drop(rest, {"-c": False, "--count-nodes": False})
    if verb == "daemon":
        raise Ros2UsageError("there is no ros2 daemon here: every command asks the Zenoh graph directly")
    if verb == "component":
        raise Ros2UsageError("'ros2 component' is not served: composable nodes are loaded from a launch file's "
                             "node_container")
    return [verb, *rest]


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] in ("-h", "--help"):
        print("usage: ros2 VERB ...  (zenroid's ros2: the zenroid CLI under ros2cli's verbs)\n\nverbs: "
              + ", ".join(v for v in VERBS if v in cli.VERBS or v in ("doctor", "wtf")))
        return 0
    try:
        translated = translate(argv)
    except Ros2UsageError as exc:
        print(f"ros2 {argv[0]}: {exc}", file=sys.stderr)
        return 2
    if translated[0] not in cli.VERBS:
        print(f"ros2: unknown verb '{argv[0]}' (zenroid's ros2 serves {', '.join(VERBS)})", file=sys.stderr)
        return 2
    return cli.main(translated, prog="ros2")


if __name__ == "__main__":
    sys.exit(main())
