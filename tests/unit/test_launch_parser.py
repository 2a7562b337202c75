"""Launch file parsing and resolution: every error names file:line and nothing is started."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from launch._yaml_substitutions import SubstitutionContext, substitute
from launch.description import LaunchDeprecationWarning
from launch.resolve import find_launch_file, resolve
from launch.yaml_source import LaunchError, Source

ROOT = Path(__file__).resolve().parents[2]


def write(directory: Path, text: str, name: str = "test.yaml") -> Path:
    path = directory / name
    path.write_text(textwrap.dedent(text).lstrip(), encoding="utf-8")
    return path


def error_of(path: Path, args: dict[str, str] | None = None) -> LaunchError:
    with pytest.raises(LaunchError) as info:
        resolve(path, args or {})
    return info.value


GOOD = """
launch:
  - arg: {name: x, default: "0.5", description: "x position"}
  - arg: {name: mode, default: realtime, choices: [realtime, lockstep]}
  - arg: {name: gui, default: "false"}
  - node:
      name: talker
      module: tests.support.dummy_node
      namespace: humanoid
      params: {x: $(var x), mode: $(var mode), gains: [1, "$(var x)"], label: "x=$(var x)"}
      remap: {joint_states: /other/joint_states}
      args: [--exit-after, "1"]
  - arg: {name: commander, default: joint_commander}
  - node: {name: viewer, module: tests.support.dummy_node, if: $(var gui)}
  - node: {name: commander, module: tests.support.dummy_node, unless: "$(var commander) == none"}
  - node: {name: tool, exec: python, args: [-m, tests.support.dummy_node], if: "$(var commander) != joint_commander"}
  - node: {name: headless, module: tests.support.dummy_node, unless: $(var gui)}
  - group:
      namespace: inner
      actions:
        - node: {name: grouped, module: tests.support.dummy_node, namespace: deeper, remap: ["a:=b"]}
"""


def test_good_file_resolves_with_typed_params_namespaces_and_conditions(tmp_path: Path) -> None:
    plan = resolve(write(tmp_path, GOOD), {"mode": "lockstep"})
    names = [n.name for n in plan.nodes]
    assert names == ["talker", "commander", "headless", "grouped"]
    talker = plan.nodes[0]
    assert talker.params == {"x": 0.5, "mode": "lockstep", "gains": [1, 0.5], "label": "x=0.5"}
    assert talker.remaps == [("joint_states", "/other/joint_states")]
    assert talker.full_name == "humanoid/talker"
    assert plan.nodes[3].namespace == "inner/deeper"
    assert plan.nodes[3].remaps == [("a", "b")]
    assert plan.args == {"x": "0.5", "mode": "lockstep", "gui": "false", "commander": "joint_commander"}
    command = talker.command("python", Path("/tmp/p.yaml"))
    assert command[:5] == ["python", "-m", "tests.support.dummy_node", "--name", "talker"]
    assert "--ns" in command and command[command.index("--ns") + 1] == "humanoid"
    assert command[-2:] == ["--exit-after", "1"]
    gui_plan = resolve(write(tmp_path, GOOD), {"gui": "true", "commander": "none"})
    assert [n.name for n in gui_plan.nodes] == ["talker", "viewer", "tool", "grouped"]
    tool = gui_plan.nodes[2]
    assert tool.command("ignored", None) == [sys.executable, "-m", "tests.support.dummy_node"]


@pytest.mark.parametrize(
    ("text", "line", "fragment"),
    [
        ("launch: []\nextra: 1\n", 2, "unknown key 'extra'"),
        ("launch:\n  - nod: {name: a}\n", 2, "unknown action 'nod'"),
        ("launch:\n  - node:\n      name: a\n      module: tests.support.dummy_node\n      respawnn: true\n", 5,
         "unknown key 'respawnn' in node"),
        ("launch:\n  - arg: {name: x}\n", 2, "missing required argument 'x'"),
        ("launch:\n  - node: {name: a, module: tests.support.dummy_node, args: [\"$(bogus 1)\"]}\n", 2,
         "unknown substitution '$(bogus)'"),
        ("launch:\n  - node: {name: a, module: tests.support.dummy_node, args: [\"$(var x\"]}\n", 2, "unterminated"),
        ("launch:\n  - arg: {name: y, default: '1'}\n  - node:\n      name: a\n      module: tests.support.dummy_node\n"
         "      args: [\"$(var x)\"]\n", 6, "no launch argument 'x' is declared"),
        ("launch:\n  - node: {name: a, module: tests.support.dummy_node, args: [\"$(env ZENROID_SURELY_UNSET_VAR)\"]}\n",
         2, "is not set"),
        ("launch:\n  - include: {file: missing.yaml}\n", 2, "included launch file not found: missing.yaml"),
        ("launch:\n  - node:\n      name: a\n      module: tests.support.dummy_node\n      params_file: nope.yaml\n", 5,
         "parameter file not found: nope.yaml"),
        ("launch:\n  - node:\n      name: a\n      module: tests.support.dummy_node\n      params_file: a.yaml\n"
         "      param_file: b.yaml\n", 6, "both 'params_file' and its old spelling 'param_file'"),
        ("launch:\n  - node: {name: a, module: nodes.no_such_module_here}\n", 2, "module 'nodes.no_such_module_here'"),
        ("launch:\n  - node: {name: a, exec: zenroid-no-such-program}\n", 2, "program 'zenroid-no-such-program'"),
        ("launch:\n  - node: {name: a, module: tests.support.dummy_node, exec: ls}\n", 2, "exactly one of 'module'"),
        ("launch:\n  - node:\n      name: a\n      name: b\n", 4, "duplicate key 'name'"),
        ("launch:\n  - node: {name: a, module: tests.support.dummy_node\n", 3, "invalid YAML"),
        ("launch:\n  - arg: {name: m, default: fast, choices: [realtime, lockstep]}\n", 2, "must be one of"),
        ("launch:\n  - node: {name: a, module: tests.support.dummy_node}\n  - node: {name: a, module: tests.support.dummy_node}\n",
         3, "duplicate node name 'a'"),
        ("launch:\n  - node:\n      name: a\n      module: tests.support.dummy_node\n      respawn: maybe\n", 5,
         "must be true or false"),
        ("launch:\n  - node:\n      name: a\n      module: tests.support.dummy_node\n      respawn_delay: soon\n", 5,
         "respawn_delay' must be a number"),
        ("launch:\n  - node:\n      name: a\n      module: tests.support.dummy_node\n      respawn_delay: -1\n", 5,
         "finite number >= 0"),
        ("launch:\n  - node: {name: a, module: tests.support.dummy_node}\n  - on_exit: {node: b}\n", 3,
         "on_exit watches node 'b'"),
        ("launch:\n  - node: {name: a, module: tests.support.dummy_node, wait_for: [ghost]}\n", 2, "waits for 'ghost'"),
        ("launch:\n  - node: {name: a, module: tests.support.dummy_node, output: loud}\n", 2, "'screen' or 'log'"),
        ("launch:\n  - node: {name: a, module: tests.support.dummy_node, params: [1, 2]}\n", 2, "'params' must be a mapping"),
        ("launch:\n  - node: {name: 'a b', module: tests.support.dummy_node}\n", 2, "node name 'a b'"),
        ("launch:\n  - node: {name: a, module: tests.support.dummy_node, namespace: 'x y'}\n", 2, "namespace 'x y'"),
        ("launch:\n  - node: {name: a, module: tests.support.dummy_node, if: perhaps}\n", 2, "'if' must be true or false"),
        ("launch:\n  - node: !!python/object:os.system {name: a}\n", 2, "invalid YAML"),
        ("launch:\n  - node:\n      module: tests.support.dummy_node\n", 2, "node needs a 'name'"),
        ("launch: {node: a}\n", 1, "'launch' must be a list"),
        ("- node: {name: a}\n", 1, "a launch file is a mapping"),
    ],
)
def test_errors_name_file_line_and_reason(tmp_path: Path, text: str, line: int, fragment: str) -> None:
    path = write(tmp_path, text)
    error = error_of(path)
    assert error.source is not None and error.source.file == path
    assert error.source.line == line, str(error)
    assert fragment in str(error)
    assert str(error).startswith(f"{path}:{line}: ")


def test_unknown_command_line_argument_is_an_error(tmp_path: Path) -> None:
    error = error_of(write(tmp_path, GOOD), {"nope": "1"})
    assert "unknown launch argument(s): nope" in str(error)


def test_include_passes_args_and_inherits_matching_parent_values(tmp_path: Path) -> None:
    write(tmp_path, """
        launch:
          - arg: {name: robot}
          - arg: {name: zenoh_port, default: "1"}
          - node: {name: "$(var robot)_node", module: tests.support.dummy_node, params: {port: $(var zenoh_port)}}
        """, name="child.yaml")
    parent = write(tmp_path, """
        launch:
          - arg: {name: zenoh_port, default: "7000"}
          - include: {file: child.yaml, args: {robot: atlas}}
          - group:
              namespace: g
              actions:
                - include: {file: "$(dirname)/child.yaml", args: {robot: other}}
        """)
    plan = resolve(parent, {"zenoh_port": "7001"})
    assert [(n.name, n.namespace, n.params["port"]) for n in plan.nodes] == [
        ("atlas_node", "", 7001), ("other_node", "g", 7001)]


def test_include_errors_point_into_the_included_file(tmp_path: Path) -> None:
    child = write(tmp_path, "launch:\n  - node: {name: a, module: tests.support.dummy_node, bad_key: 1}\n", name="child.yaml")
    parent = write(tmp_path, "launch:\n  - include: {file: child.yaml}\n")
    error = error_of(parent)
    assert error.source == Source(child, 2)
    write(tmp_path, "launch:\n  - arg: {name: a, default: '1'}\n", name="child.yaml")
    undeclared = write(tmp_path, "launch:\n  - include: {file: child.yaml, args: {zzz: '1'}}\n", name="p2.yaml")
    assert "does not declare" in str(error_of(undeclared))


def test_include_cycle_is_an_error(tmp_path: Path) -> None:
    path = write(tmp_path, "launch:\n  - include: {file: test.yaml}\n")
    assert "include cycle" in str(error_of(path))


def test_substitutions() -> None:
    ctx = SubstitutionContext(variables={"a": "1"}, current_file=Path("/x/y/f.yaml"), environ={"HOME": "/h"},
                              robot_resolver=lambda name: Path(f"/robots/{name}.urdf"))
    src = Source(Path("f.yaml"), 3)
    assert substitute("v=$(var a) h=$(env HOME) d=$(env NOPE dflt)", ctx, src) == "v=1 h=/h d=dflt"
    assert substitute("$(dirname)/z", ctx, src) == "/x/y/z"
    assert substitute("$(robot humanoid)", ctx, src) == "/robots/humanoid.urdf"
    assert substitute("cost $$(var a) plain", ctx, src) == "cost $(var a) plain"
    with pytest.raises(LaunchError, match="takes one argument"):
        substitute("$(var a b)", ctx, src)
    assert substitute("$(robot bot$(var a))", ctx, src) == "/robots/bot1.urdf"
    with pytest.raises(LaunchError, match="no launch argument '1'"):
        substitute("$(var $(var a))", ctx, src)
    with pytest.raises(LaunchError, match="unterminated"):
        substitute("$(robot $(var a)", ctx, src)
    # a substituted value is never re-scanned for substitutions
    ctx.variables = {"a": "$(env HOME)"}
    assert substitute("$(var a)", ctx, src) == "$(env HOME)"
    with pytest.raises(LaunchError, match="empty substitution"):
        substitute("$()", ctx, src)


def test_robot_substitution_uses_robots_dir(tmp_path: Path) -> None:
    path = write(tmp_path, "launch:\n  - node: {name: a, module: tests.support.dummy_node, args: [\"$(robot no_such_bot)\"]}\n")
    error = error_of(path)
    assert error.source.line == 2 and "no_such_bot" in str(error)


def test_bare_names_resolve_in_launch_dir() -> None:
    assert find_launch_file("humanoid.yaml") == ROOT / "launch" / "humanoid.yaml"
    with pytest.raises(FileNotFoundError):
        find_launch_file("no_such_launch.yaml")


def run_cli(*argv: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "launch", *argv], cwd=ROOT, capture_output=True, text=True,
                          timeout=60)


def test_cli_bad_file_exits_2_with_file_line_and_starts_nothing(tmp_path: Path) -> None:
    path = write(tmp_path, "launch:\n  - node: {name: a, module: tests.support.dummy_node, typo: 1}\n")
    result = run_cli(str(path))
    assert result.returncode == 2
    assert f"{path}:2: unknown key 'typo'" in result.stderr
    assert "started" not in result.stdout and "zenoh" not in result.stdout


def test_cli_show_args_and_print(tmp_path: Path) -> None:
    path = write(tmp_path, GOOD)
    shown = run_cli(str(path), "--show-args")
    assert shown.returncode == 0
    assert "'mode':" in shown.stdout and "Valid choices are: ['realtime', 'lockstep']" in shown.stdout
    assert "x position" in shown.stdout and "(default: '0.5')" in shown.stdout
    printed = run_cli(str(path), "x:=2", "--print")
    assert printed.returncode == 0, printed.stderr
    assert "x: 2" in printed.stdout and "embedded router on tcp/127.0.0.1:7447" in printed.stdout
    assert "[launch]" not in printed.stdout  # nothing was started
    bad = run_cli(str(path), "x")
    assert bad.returncode == 2 and "name:=value" in bad.stderr


OLD_SPELLING = """
launch:
  - node:
      name: a
      module: tests.support.dummy_node
      param_file: [params.yaml]
"""


def test_param_file_still_works_with_a_warning_naming_params_file(tmp_path: Path) -> None:
    """``param_file`` (the old key) reads as ``params_file``; the launcher warns once, with file:line."""
    (tmp_path / "params.yaml").write_text("a:\n  ros__parameters: {rate: 5}\n")
    path = write(tmp_path, OLD_SPELLING)
    with pytest.warns(LaunchDeprecationWarning, match=rf"{path}:5: node key 'param_file' is deprecated: use "
                                                       r"'params_file'"):
        plan = resolve(path, {})
    assert plan.nodes[0].param_files == [str(tmp_path / "params.yaml")]
    assert "--params-file" in plan.nodes[0].command("python", None)
    printed = run_cli(str(path), "--print")
    assert printed.returncode == 0, printed.stderr
    assert printed.stderr.count(f"[launch] [WARN] {path}:5: node key 'param_file' is deprecated: use "
                                "'params_file'") == 1, printed.stderr
    current = write(tmp_path, OLD_SPELLING.replace("param_file", "params_file"), "current.yaml")
    printed = run_cli(str(current), "--print")
    assert printed.returncode == 0 and "WARN" not in printed.stderr, printed.stderr


SHIPPED = {
    "humanoid.yaml": ("humanoid", {"simulator", "renderer", "robot_state_publisher", "controller_manager",
                                   "spawner_joint_state_broadcaster", "spawner_joint_trajectory_controller",
                                   "joint_commander"}),
    "controller_lab.yaml": ("simple_robot", {"simulator", "robot_state_publisher", "controller_manager",
                                             "spawner_active", "spawner_inactive", "trajectory_sender"}),
    "lab_2_3.yaml": ("lab_robot", {"simulator", "robot_state_publisher", "controller_manager", "spawner",
                                   "robot_controller", "robot_monitor"}),
    "joint_animation.yaml": ("atlas", {"simulator", "robot_state_publisher", "controller_manager", "spawner",
                                       "joint_control"}),
    "arm_viz.yaml": ("humanoid_simplified", {"robot_state_publisher", "joint_state_publisher"}),
}
COMMANDERS = {"joint_commander", "trajectory_sender", "robot_controller", "robot_monitor", "joint_control",
              "joint_state_publisher"}


@pytest.mark.parametrize("name", sorted(SHIPPED))
def test_shipped_launch_files_resolve(name: str) -> None:
    robot, nodes = SHIPPED[name]
    path = find_launch_file(name)
    headless = resolve(path, {"gui": "false", "zenoh_port": "7600", "mode": "lockstep"})
    assert {n.name for n in headless.nodes} == nodes
    assert headless.args["zenoh_port"] == "7600"
    for node in headless.nodes:
        assert node.namespace in ("", robot), node.name
    simulators = [n for n in headless.nodes if n.module == "nodes.sim"]
    for sim in simulators:
        entity = sim.params["entities"][0]
        assert entity["name"] == entity["namespace"] == robot and Path(entity["file"]).is_file()
        assert sim.params["mode"] == "lockstep" and sim.required
    with_gui = resolve(path, {"gui": "true", "commander": "none", "viewer_args": "--save /tmp/x.rrd"})
    names = {n.name for n in with_gui.nodes}
    assert names == (nodes - COMMANDERS) | {"viewer"}
    viewer = next(n for n in with_gui.nodes if n.name == "viewer")
    assert viewer.args == ["--save", "/tmp/x.rrd"] and viewer.params == {"robots": [robot]}


def test_humanoid_spawn_pose_arguments() -> None:
    plan = resolve(find_launch_file("humanoid.yaml"), {"x": "1.5", "z": "1.0", "Y": "1.57", "gui": "false"})
    entity = plan.nodes[0].params["entities"][0]
    assert (entity["x"], entity["y"], entity["z"], entity["Y"]) == (1.5, 0.0, 1.0, 1.57)
    assert plan.args["mode"] == "realtime"
    with pytest.raises(LaunchError, match="must be one of: realtime, lockstep"):
        resolve(find_launch_file("humanoid.yaml"), {"mode": "kinematic"})


def test_zenroid_launch_verb_is_the_same_launcher(tmp_path: Path) -> None:
    shown = subprocess.run([sys.executable, "-m", "nodes.tools.cli", "launch", "humanoid.yaml", "--show-args"],
                           cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert shown.returncode == 0, shown.stderr
    assert "'zenoh_port':" in shown.stdout and "'commander':" in shown.stdout
    path = write(tmp_path, "launch:\n  - node: {name: a, module: tests.support.dummy_node, if: maybe}\n")
    bad = subprocess.run([sys.executable, "-m", "nodes.tools.cli", "launch", str(path)], cwd=ROOT,
                         capture_output=True, text=True, timeout=60)
    assert bad.returncode == 2 and f"{path}:2:" in bad.stderr


def test_exclusive_cpu_is_a_condition_for_one_node_only(tmp_path: Path) -> None:
    # the main job keeps a CPU for the physics in lockstep only, and a user can force it either way
    humanoid = find_launch_file("humanoid.yaml")
    by_mode = {mode: {n.name: n.exclusive_cpu for n in resolve(humanoid, {"mode": mode}).nodes}
               for mode in ("lockstep", "realtime")}
    assert by_mode["lockstep"]["simulator"] and not by_mode["realtime"]["simulator"]
    assert [name for name, on in by_mode["lockstep"].items() if on] == ["simulator"]
    assert resolve(humanoid, {"mode": "realtime", "exclusive_cpu": "true"}).nodes[0].exclusive_cpu
    assert not resolve(humanoid, {"mode": "lockstep", "exclusive_cpu": "false"}).nodes[0].exclusive_cpu
    assert resolve(humanoid, {"mode": "lockstep"}).nodes[0].describe()["exclusive_cpu"] is True

    two = write(tmp_path, """
        launch:
          - node: {name: a, module: tests.support.dummy_node, exclusive_cpu: true}
          - node: {name: b, module: tests.support.dummy_node, exclusive_cpu: "yes"}
        """)
    err = error_of(two)
    assert "test.yaml:3" in str(err) and "only one node of a launch can have exclusive_cpu" in str(err)
    assert "'a'" in str(err)
    bad = write(tmp_path, """
        launch:
          - node: {name: a, module: tests.support.dummy_node, exclusive_cpu: sometimes}
        """, "bad.yaml")
    assert "exclusive_cpu" in str(error_of(bad)) and "sometimes" in str(error_of(bad))
