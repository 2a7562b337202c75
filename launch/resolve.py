"""Resolve an inert launch description into a plan: arguments bound, substitutions done, includes
expanded, conditions applied, every value checked. Nothing is started here."""

from __future__ import annotations

import os
import shlex
import shutil
import sys
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from launch._yaml_substitutions import SubstitutionContext, has_substitution, substitute
from launch.context import Condition, LaunchContext
from launch.description import (
    Action,
    ArgDecl,
    ComposableDecl,
    ContainerDecl,
    IncludeDecl,
    LaunchDescription,
    NodeDecl,
    OnExitDecl,
)
from launch.plan import (
    CONTAINER_EXECUTABLES,
    CONTAINER_MODULE,
    CONTAINER_PACKAGES,
    DEFAULT_HEALTH_TIMEOUT,
    DEFAULT_RESPAWN_MAX,
    DEFAULT_WAIT_TIMEOUT,
    LAUNCH_DIR,
    NAME_RE,
    ComposedNodeSpec,
    ExitHandler,
    LaunchPlan,
    NodeSpec,
    check_module,
    check_namespace,
    evaluate_condition,
    join_namespace,
    parse_bool,
    typed_value,
)
from launch.ros_resolve import RosResolution
from launch.yaml_source import LaunchError, LocatedDict, LocatedList, Source


def find_launch_file(name: str, base: Path | None = None) -> Path:
    """A path as given (absolute or relative to ``base``/cwd), else a bare name in ``launch/``."""
    candidate = Path(name).expanduser()
    if not candidate.is_absolute() and base is not None:
        candidate = base / candidate
    if candidate.is_file():
        return candidate
    if not Path(name).is_absolute() and (LAUNCH_DIR / name).is_file():
        return LAUNCH_DIR / name
    raise FileNotFoundError(name)


@dataclass
class _Scope:
    variables: dict[str, str]
    namespace: str
    file: Path
    # what ROS launch actions set for the actions after them in the same scope (GroupAction scopes them)
    env: dict[str, str | None] = field(default_factory=dict)
    params: dict[str, Any] = field(default_factory=dict)
    param_files: list[str] = field(default_factory=list)
    remaps: list[tuple[str, str]] = field(default_factory=list)

    def ctx(self) -> SubstitutionContext:
        return SubstitutionContext(variables=self.variables, current_file=self.file)

    def child(self, variables: dict[str, str] | None = None, file: Path | None = None) -> _Scope:
        return _Scope(dict(self.variables) if variables is None else variables, self.namespace, file or self.file,
                      dict(self.env), dict(self.params), list(self.param_files), list(self.remaps))

    def environment(self) -> dict[str, str]:
        env = dict(os.environ)
        for key, value in self.env.items():
            if value is None:
                env.pop(key, None)
            else:
                env[key] = value
        return env

    def context(self) -> LaunchContext:
        """The ROS launch context of this scope (its launch configurations are this scope's, shared)."""
        context = LaunchContext(current_file=self.file, environment=self.environment())
        context.launch_configurations = self.variables
        return context


class _Resolver(RosResolution):
    def __init__(self, cli_args: Mapping[str, str]) -> None:
        self.cli_args = dict(cli_args)
        self.process_names: set[str] = set()
        self.declared: set[str] = set()
        self.plan: LaunchPlan | None = None
        self.include_stack: list[Path] = []
        self.pending_exit: list[tuple[ExitHandler, Source]] = []
        self.lifecycle_nodes: list[Any] = []   # LifecycleNode actions resolved so far (ChangeState targets)

    # -- values ---------------------------------------------------------------------------------
    def text(self, value: Any, scope: _Scope, source: Source, what: str) -> str:
        if isinstance(value, (LocatedDict, LocatedList, dict, list)):
            raise LaunchError(f"{what} must be a scalar, not a {'list' if isinstance(value, list) else 'mapping'}",
                              source)
        if value is None:
            raise LaunchError(f"{what} must have a value", source)
        if isinstance(value, bool):
            return "true" if value else "false"
        return substitute(str(value), scope.ctx(), source)

    def param_value(self, value: Any, scope: _Scope, source: Source) -> Any:
        if isinstance(value, str):
            return typed_value(substitute(value, scope.ctx(), source)) if has_substitution(value) else value
        if isinstance(value, list):
            return [self.param_value(v, scope, source) for v in value]
        if isinstance(value, dict):
            return {str(k): self.param_value(v, scope, _line(value, k, source)) for k, v in value.items()}
        return value

    def condition(self, action: Action, scope: _Scope) -> bool:
        if isinstance(action.condition_if, Condition):
            context = scope.context()
            return bool(self.call_launch_code(lambda: action.condition_if.evaluate(context), action.source,
                                              "condition"))
        if action.condition_if is not None:
            if not evaluate_condition(self.text(action.condition_if, scope, action.source, "'if'"), "'if'",
                                      action.source):
                return False
        if action.condition_unless is not None:
            if evaluate_condition(self.text(action.condition_unless, scope, action.source, "'unless'"),
                                  "'unless'", action.source):
                return False
        return True

    # -- actions --------------------------------------------------------------------------------
    def run_file(self, description: LaunchDescription, scope: _Scope) -> None:
        self.walk(description.actions, scope)

    def walk(self, actions: list[Action], scope: _Scope) -> None:
        """Each action resolves itself (``launch.description`` for our YAML's, ``launch.actions`` for ROS's)."""
        for action in actions:
            if not isinstance(action, Action):   # a ROS launch action
                self.resolve_ros_action(action, scope)
            elif action.enabled(self, scope):
                action.resolve(self, scope)

    def add_exit_handler(self, action: OnExitDecl, scope: _Scope) -> None:
        handler = ExitHandler(
            node=self.text(action.node, scope, action.source, "on_exit 'node'"),
            log=self.maybe_text(action.log, scope, action.source, "'log'"),
            shutdown=parse_bool(self.text(action.shutdown, scope, action.source, "'shutdown'"),
                                "on_exit 'shutdown'", action.source),
            source=str(action.source),
        )
        self.pending_exit.append((handler, action.source))

    def maybe_text(self, value: Any, scope: _Scope, source: Source, what: str) -> str | None:
        return None if value is None else self.text(value, scope, source, what)

    def declare(self, decl: ArgDecl, scope: _Scope, given: Mapping[str, str] | None = None) -> None:
        if not NAME_RE.match(decl.name):
            raise LaunchError(f"arg name '{decl.name}' must be letters, digits and '_'", decl.source)
        self.declared.add(decl.name)
        if decl.name in scope.variables:  # given by an include, the command line, or the parent
            value = scope.variables[decl.name]
        elif decl.default is not None:
            value = substitute(decl.default, scope.ctx(), decl.source)
        else:
            raise LaunchError(f"missing required argument '{decl.name}' (give it as {decl.name}:=VALUE)",
                              decl.source)
        if decl.choices is not None and value not in decl.choices:
            raise LaunchError(f"argument '{decl.name}' is '{value}', must be one of: {', '.join(decl.choices)}",
                              decl.source)
        scope.variables[decl.name] = value

    def include(self, action: IncludeDecl, scope: _Scope) -> None:
        name = self.text(action.file, scope, action.source, "include 'file'")
        given: dict[str, str] = {}
        for key, value in (action.args or {}).items():
            given[str(key)] = self.text(value, scope, _line(action.args, key, action.source), f"include arg '{key}'")
        try:
            path = find_launch_file(name, scope.file.parent)
        except FileNotFoundError:
            raise LaunchError(f"included launch file not found: {name}", action.source) from None
        self.include_path(str(path), given, scope, action.source)

    def include_ours(self, description: LaunchDescription, path: Path, given: dict[str, str], scope: _Scope,
                     source: Source) -> None:
        """Our YAML format's include: only the arguments the file declares reach it."""
        declared = {a.name for a in description.declared_args()}
        for key in given:
            if key not in declared:
                raise LaunchError(f"include passes argument '{key}' that {path.name} does not declare "
                                  f"(declared: {', '.join(sorted(declared)) or 'none'})", source)
        # Precedence: the include's own args, then the command line, then the including file's values.
        variables = {k: v for k, v in scope.variables.items() if k in declared}
        variables.update({k: v for k, v in self.cli_args.items() if k in declared})
        variables.update(given)
        self.include_stack.append(path.resolve())
        try:
            self.run_file(description, _Scope(variables, scope.namespace, path))
        finally:
            self.include_stack.pop()

    def add_node(self, decl: NodeDecl, scope: _Scope) -> None:
        f = decl.fields
        at = decl.line_source
        name = self.text(f["name"], scope, at("name"), "node 'name'")
        if not NAME_RE.match(name):
            raise LaunchError(f"node name '{name}' must be letters, digits and '_'", at("name"))
        namespace = join_namespace(scope.namespace, self.maybe_text(f.get("namespace"), scope, at("namespace"),
                                                                    "node 'namespace'"))
        check_namespace(namespace, at("namespace"))
        module = executable = None
        if "module" in f:
            module = self.text(f["module"], scope, at("module"), "node 'module'")
            check_module(module, at("module"))
        else:
            program = self.text(f["exec"], scope, at("exec"), "node 'exec'")
            # "python" means the launcher's own interpreter (the one that has this project installed).
            executable = sys.executable if program in ("python", "python3") else shutil.which(program)
            if executable is None:
                raise LaunchError(f"node '{name}': program '{program}' not found", at("exec"))
        args = self.word_list(f.get("args"), scope, decl, "args", split=True)
        params = {}
        if "params" in f:
            params = {str(k): self.param_value(v, scope, _line(f["params"], k, at("params")))
                      for k, v in f["params"].items()}
        param_files = []
        for entry in self.word_list(f.get("params_file"), scope, decl, "params_file"):
            path = Path(entry).expanduser()
            path = path if path.is_absolute() else scope.file.resolve().parent / path
            if not path.is_file():
                raise LaunchError(f"node '{name}': parameter file not found: {entry}", at("params_file"))
            param_files.append(str(path.resolve()))
        remaps = self.remaps(f.get("remap"), scope, decl)
        spec = NodeSpec(name=name, namespace=namespace, module=module, executable=executable, args=args,
                        params=params, param_files=param_files, remaps=remaps, source=str(decl.source),
                        **self.process_options(decl, scope))
        self.add_spec(spec, decl)

    def process_options(self, decl: NodeDecl, scope: _Scope) -> dict[str, Any]:
        """What the launcher does with a process (a node's or a container's): env, respawn, readiness, CPU."""
        f = decl.fields
        at = decl.line_source
        env = {}
        for key, value in (f.get("env") or {}).items():
            env[str(key)] = self.text(value, scope, _line(f["env"], key, at("env")), f"env '{key}'")
        respawn = parse_bool(self.text(f.get("respawn", False), scope, at("respawn"), "respawn"), "node 'respawn'",
                             at("respawn"))
        respawn_delay = self.number(f.get("respawn_delay", 1.0), scope, at("respawn_delay"), "respawn_delay")
        respawn_max = int(self.number(f.get("respawn_max", DEFAULT_RESPAWN_MAX), scope, at("respawn_max"),
                                      "respawn_max", integer=True))
        required = parse_bool(self.text(f.get("required", False), scope, at("required"), "required"),
                              "node 'required'", at("required"))
        output = self.text(f.get("output", "screen"), scope, at("output"), "output")
        if output not in ("screen", "log"):
            raise LaunchError(f"node 'output' must be 'screen' or 'log', got '{output}'", at("output"))
        wait_for = self.word_list(f.get("wait_for"), scope, decl, "wait_for", split=True)
        wait_timeout = self.number(f.get("wait_timeout", DEFAULT_WAIT_TIMEOUT), scope, at("wait_timeout"),
                                   "wait_timeout")
        health_timeout = self.number(f.get("health_timeout", DEFAULT_HEALTH_TIMEOUT), scope, at("health_timeout"),
                                     "health_timeout")
        # true/false, or a comparison such as "$(var mode) == lockstep" (as in 'if')
        exclusive_cpu = evaluate_condition(self.text(f.get("exclusive_cpu", False), scope, at("exclusive_cpu"),
                                                     "exclusive_cpu"), "node 'exclusive_cpu'", at("exclusive_cpu"))
        return dict(env=env, respawn=respawn, respawn_delay=respawn_delay, respawn_max=respawn_max, required=required,
                    output=output, wait_for=wait_for, wait_timeout=wait_timeout, health_timeout=health_timeout,
                    exclusive_cpu=exclusive_cpu)

    def add_spec(self, spec: NodeSpec, decl: NodeDecl) -> None:
        """Add a resolved process; every node name (composed ones too) is unique in a launch."""
        taken = {other.name: other.source for other in self.plan.nodes}
        taken.update({node.name: node.source for other in self.plan.nodes for node in other.composed})
        for name, source in [(spec.name, str(decl.source)), *((n.name, n.source) for n in spec.composed)]:
            if name in taken or name in self.process_names:
                raise LaunchError(f"duplicate node name '{name}' (also at {taken.get(name, 'a ROS launch action')})",
                                  _source_from(source))
            taken[name] = source
        self.process_names.add(spec.name)
        for other in self.plan.nodes:
            if spec.exclusive_cpu and other.exclusive_cpu:
                raise LaunchError(f"node '{spec.name}': only one node of a launch can have exclusive_cpu "
                                  f"('{other.name}' at {other.source} has it)", decl.line_source("exclusive_cpu"))
        self.plan.nodes.append(spec)

    def add_container(self, decl: ContainerDecl, scope: _Scope) -> None:
        """A ``node_container``: one process (our component container) with its composable nodes."""
        f = decl.fields
        at = decl.line_source
        name = self.text(f["name"], scope, at("name"), "node_container 'name'")
        if not NAME_RE.match(name):
            raise LaunchError(f"node_container name '{name}' must be letters, digits and '_'", at("name"))
        for key, allowed in (("pkg", CONTAINER_PACKAGES), ("exec", CONTAINER_EXECUTABLES)):
            if key in f:
                value = self.text(f[key], scope, at(key), f"node_container '{key}'")
                if value not in allowed:
                    raise LaunchError(f"node_container '{key}' is '{value}': this launcher runs its own container "
                                      f"(allowed: {', '.join(allowed)})", at(key))
        namespace = join_namespace(scope.namespace, self.maybe_text(f.get("namespace"), scope, at("namespace"),
                                                                    "node_container 'namespace'"))
        check_namespace(namespace, at("namespace"))
        composed = [self.composable(node, scope, namespace) for node in decl.composables]
        spec = NodeSpec(name=name, namespace=namespace, module=CONTAINER_MODULE, executable=None, args=[], params={},
                        param_files=[], remaps=[], source=str(decl.source), composed=composed,
                        **self.process_options(decl, scope))
        self.add_spec(spec, decl)

    def composable(self, decl: ComposableDecl, scope: _Scope, container_namespace: str) -> ComposedNodeSpec:
        f = decl.fields
        at = decl.line_source
        name = self.text(f["name"], scope, at("name"), "composable_node 'name'")
        if not NAME_RE.match(name):
            raise LaunchError(f"composable_node name '{name}' must be letters, digits and '_'", at("name"))
        # as launch_ros: a composable node's namespace is its own, the container's when it has none
        given = self.maybe_text(f.get("namespace"), scope, at("namespace"), "composable_node 'namespace'")
        namespace = join_namespace(scope.namespace, given) if given is not None else container_namespace
        check_namespace(namespace, at("namespace"))
        plugin = self.text(f["plugin"], scope, at("plugin"), "composable_node 'plugin'")
        module, separator, class_name = plugin.partition("::")
        if not separator or not NAME_RE.match(class_name):
            raise LaunchError(f"composable_node 'plugin' is '{plugin}': it must be python.module::NodeClass "
                              f"(launch_ros's package::Class, with a Python module)", at("plugin"))
        check_module(module, at("plugin"))
        if "pkg" in f:
            pkg = self.text(f["pkg"], scope, at("pkg"), "composable_node 'pkg'")
            if module != pkg and not module.startswith(pkg + "."):
                raise LaunchError(f"composable_node 'plugin' '{plugin}' is not in its 'pkg' '{pkg}'", at("pkg"))
        params: dict[str, Any] = {}
        for i, item in enumerate(f.get("param") or []):   # launch_ros: [{name, value}] or [{from: FILE}]
            where = _line(f["param"], i, at("param"))
            if "from" not in item:
                params[self.text(item["name"], scope, where, "param 'name'")] = self.param_value(item["value"], scope,
                                                                                                   where)
        if "params" in f:
            params.update({str(k): self.param_value(v, scope, _line(f["params"], k, at("params")))
                           for k, v in f["params"].items()})
        files = [item["from"] for item in f.get("param") or [] if "from" in item]
        param_files = []
        for entry in [self.text(v, scope, at("param"), "param 'from'") for v in files] + self.word_list(
                f.get("params_file"), scope, decl, "params_file"):
            path = Path(entry).expanduser()
            path = path if path.is_absolute() else scope.file.resolve().parent / path
            if not path.is_file():
                raise LaunchError(f"composable_node '{name}': parameter file not found: {entry}", at("params_file")
                                  if "params_file" in f else at("param"))
            param_files.append(str(path.resolve()))
        remap = f.get("remap")
        if isinstance(remap, list) and any(isinstance(r, dict) for r in remap):   # launch_ros: [{from, to}]
            remaps = [(self.text(r["from"], scope, _line(remap, i, at("remap")), "remap 'from'"),
                       self.text(r["to"], scope, _line(remap, i, at("remap")), "remap 'to'"))
                      for i, r in enumerate(remap)]
        else:
            remaps = self.remaps(remap, scope, decl)
        for i, item in enumerate(f.get("extra_arg") or []):
            where = _line(f["extra_arg"], i, at("extra_arg"))
            arg_name = self.text(item["name"], scope, where, "extra_arg 'name'")
            if arg_name != "use_intra_process_comms":
                raise LaunchError(f"composable_node 'extra_arg' '{arg_name}' is not known (allowed: "
                                  "use_intra_process_comms)", where)
            if not parse_bool(self.text(item["value"], scope, where, "extra_arg 'value'"),
                              "extra_arg use_intra_process_comms", where):
                raise LaunchError("use_intra_process_comms: false is not offered: the nodes of a container always "
                                  "hand messages over in-process (run the node as a 'node' instead)", where)
        return ComposedNodeSpec(name=name, namespace=namespace, plugin=plugin, params=params, param_files=param_files,
                                remaps=remaps, source=str(decl.source))

    def word_list(self, value: Any, scope: _Scope, decl: NodeDecl | ComposableDecl, key: str, split: bool = False) -> list[str]:
        if value is None:
            return []
        source = decl.line_source(key)
        if isinstance(value, list):
            return [self.text(v, scope, _line(value, i, source), f"'{key}' item") for i, v in enumerate(value)]
        text = self.text(value, scope, source, f"'{key}'")
        if not split:
            return [text]
        try:
            return shlex.split(text)  # tokenising only: nothing ever goes through a shell
        except ValueError as exc:
            raise LaunchError(f"'{key}': {exc}", source) from None

    def remaps(self, value: Any, scope: _Scope, decl: NodeDecl | ComposableDecl) -> list[tuple[str, str]]:
        source = decl.line_source("remap")
        pairs: list[tuple[str, str]] = []
        if value is None:
            return pairs
        if isinstance(value, dict):
            for key, dst in value.items():
                at = _line(value, key, source)
                pairs.append((self.text(key, scope, at, "remap"), self.text(dst, scope, at, "remap target")))
        else:
            for i, item in enumerate(value):
                text = self.text(item, scope, _line(value, i, source), "remap")
                if ":=" not in text:
                    raise LaunchError(f"remap '{text}' must look like from:=to", _line(value, i, source))
                src, dst = text.split(":=", 1)
                pairs.append((src, dst))
        for src, dst in pairs:
            if not src or not dst:
                raise LaunchError(f"remap '{src}:={dst}' needs both names", source)
        return pairs

    def number(self, value: Any, scope: _Scope, source: Source, what: str, integer: bool = False) -> float:
        text = self.text(value, scope, source, what)
        try:
            number = int(text) if integer else float(text)
        except ValueError:
            kind = "an integer" if integer else "a number"
            raise LaunchError(f"node '{what}' must be {kind}, got '{text}'", source) from None
        if number != number or number < 0 or number == float("inf"):
            raise LaunchError(f"node '{what}' must be a finite number >= 0, got '{text}'", source)
        return number


def _line(container: Any, key: Any, fallback: Source) -> Source:
    if isinstance(container, (LocatedDict, LocatedList)):
        return Source(fallback.file, container.line_of(key))
    return fallback


# The launcher's own arguments: accepted with every launch file, declared by it or not (docs/launch.md).
LAUNCHER_ARGS = ("zenoh_port", "ros2", "gui", "mode", "sensors", "commander", "world", "composed", "exclusive_cpu")


def resolve(path: Path, cli_args: Mapping[str, str]) -> LaunchPlan:
    """Load ``path`` (any launch format) and resolve it with ``name:=value`` command-line arguments."""
    from launch.formats import load_description

    description = load_description(path)
    resolver = _Resolver(cli_args)
    resolver.plan = LaunchPlan(file=path, args={})
    resolver.include_stack.append(path.resolve())
    if description.format != "zenroid":
        # ROS's semantics: every command-line argument is a launch configuration, declared or not
        scope = _Scope(dict(cli_args), "", path)
        resolver.walk(description.actions, scope)
        resolver.plan.args = dict(scope.variables)
        _check_plan(resolver, path)
        return resolver.plan
    top_declared = {a.name for a in description.declared_args()}
    scope = _Scope({k: v for k, v in cli_args.items() if k in top_declared}, "", path)
    resolver.run_file(description, scope)
    unknown = sorted(set(cli_args) - resolver.declared - set(LAUNCHER_ARGS))
    if unknown:
        raise LaunchError(f"unknown launch argument(s): {', '.join(unknown)} "
                          f"(declared: {', '.join(sorted(resolver.declared)) or 'none'}; see --show-args)",
                          Source(path, 1))
    _check_plan(resolver, path)
    resolver.plan.args = {k: scope.variables[k] for k in top_declared if k in scope.variables}
    resolver.plan.args.update({k: v for k, v in cli_args.items() if k in LAUNCHER_ARGS and k not in top_declared})
    return resolver.plan


def _check_plan(resolver: _Resolver, path: Path) -> None:
    names = {n.name for n in resolver.plan.nodes}
    names |= {c.name for n in resolver.plan.nodes for c in n.composed}   # wait_for may name a composed node
    processes = {n.name for n in resolver.plan.nodes}
    for handler, source in resolver.pending_exit:
        if handler.node not in processes:
            raise LaunchError(f"on_exit watches node '{handler.node}', which this launch does not start", source)
        resolver.plan.on_exit.append(handler)
    for node in resolver.plan.nodes:
        for target in node.wait_for:
            if target not in names:
                raise LaunchError(f"node '{node.name}' waits for '{target}', which this launch does not start",
                                  Source(path, 0) if not node.source else _source_from(node.source))
            if target == node.name:
                raise LaunchError(f"node '{node.name}' waits for itself", _source_from(node.source))


def _source_from(text: str) -> Source:
    file, _, line = text.rpartition(":")
    return Source(Path(file), int(line) if line.isdigit() else 0)
