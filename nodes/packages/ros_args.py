"""ROS's command-line arguments (``--ros-args -p a:=b -r x:=y --params-file F --log-level debug ...``) taken
out of an argv and spelled as our nodes' options (``--param``, ``--remap``, ``--ns``, ``--name``,
``--params-file``, ``--log-level``), so a served executable started the ROS way gets them."""

from __future__ import annotations

from dataclasses import dataclass, field

LOG_LEVELS = {"debug": "debug", "info": "info", "warn": "warn", "warning": "warn", "error": "error",
              "fatal": "error", "unset": "info"}
# flags of rcl that take no value and change nothing here
_FLAGS = {"--enable-rosout-logs", "--disable-rosout-logs", "--enable-stdout-logs", "--disable-stdout-logs",
          "--enable-external-lib-logs", "--disable-external-lib-logs"}
_VALUED = {"-e", "--enclave", "--log-config-file", "--log-file-name"}


class RosArgsError(ValueError):
    """A ``--ros-args`` section we cannot read (names the argument)."""


@dataclass
class RosArgs:
    params: list[str] = field(default_factory=list)       # NAME:=VALUE
    remaps: list[str] = field(default_factory=list)       # FROM:=TO
    params_files: list[str] = field(default_factory=list)
    namespace: str | None = None
    name: str | None = None
    log_level: str | None = None
    ignored: list[str] = field(default_factory=list)

    def node_options(self) -> list[str]:
        argv: list[str] = []
        if self.name is not None:
            argv += ["--name", self.name]
        if self.namespace is not None:
            argv += ["--ns", self.namespace.strip("/")]
        for path in self.params_files:
            argv += ["--params-file", path]
        for item in self.params:
            argv += ["--param", item]
        for item in self.remaps:
            argv += ["--remap", item]
        if self.log_level is not None:
            argv += ["--log-level", self.log_level]
        return argv

    def __bool__(self) -> bool:
        return bool(self.params or self.remaps or self.params_files or self.namespace is not None
                    or self.name is not None or self.log_level is not None)


def split(argv: list[str]) -> tuple[list[str], RosArgs]:
    """(the arguments outside every ``--ros-args`` section, what the sections say)."""
    rest: list[str] = []
    ros = RosArgs()
    i = 0
    while i < len(argv):
        if argv[i] != "--ros-args":
            rest.append(argv[i])
            i += 1
            continue
        i += 1
        while i < len(argv) and argv[i] not in ("--", "--ros-args"):
            flag = argv[i]
            value = argv[i + 1] if i + 1 < len(argv) else None
            if flag in _FLAGS:
                ros.ignored.append(flag)
                i += 1
                continue
            if value is None:
                raise RosArgsError(f"--ros-args: '{flag}' needs a value")
            if flag in ("-p", "--param"):
                if ":=" not in value:
                    raise RosArgsError(f"--ros-args: parameter '{value}' is not NAME:=VALUE")
                ros.params.append(value)
            elif flag in ("-r", "--remap"):
                if ":=" not in value:
                    raise RosArgsError(f"--ros-args: remapping '{value}' is not FROM:=TO")
                source, _, target = value.partition(":=")
                source = source.rpartition(":")[2] if ":" in source else source  # node-specific: node:from
                if source == "__ns":
                    ros.namespace = target
                elif source in ("__node", "__name"):
                    ros.name = target
                else:
                    ros.remaps.append(f"{source}:={target}")
            elif flag == "--params-file":
                ros.params_files.append(value)
            elif flag == "--log-level":
                level = value.rpartition(":=")[2].lower()  # a logger's own level (name:=level) sets ours
                if level not in LOG_LEVELS:
                    raise RosArgsError(f"--ros-args: log level '{value}' (choose from {', '.join(LOG_LEVELS)})")
                ros.log_level = LOG_LEVELS[level]
            elif flag in _VALUED:
                ros.ignored += [flag, value]
            else:
                raise RosArgsError(f"--ros-args: unknown argument '{flag}'")
            i += 2
        if i < len(argv) and argv[i] == "--":
            i += 1
    return rest, ros
