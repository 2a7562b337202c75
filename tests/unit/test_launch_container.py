"""node_container with composable_node entries (launch_ros's YAML spelling): what resolves, how the launcher
starts the container, and the errors that name the field, file and line."""

from __future__ import annotations

import json
import textwrap
from pathlib import Path

import pytest

from launch.resolve import CONTAINER_MODULE, find_launch_file, resolve
from launch.yaml_source import LaunchError

GOOD = """
launch:
  - arg: {name: mode, default: lockstep}
  - node_container:
      pkg: rclcpp_components
      exec: component_container
      name: pair
      namespace: robot
      respawn: true
      respawn_delay: 0.5
      required: true
      composable_node:
        - pkg: nodes.sim
          plugin: nodes.sim.node::SimulatorNode
          name: simulator
          namespace: /
          param:
            - {name: mode, value: $(var mode)}
            - {name: entities, value: [{name: r, file: x.urdf}]}
          remap:
            - {from: a, to: b}
          extra_arg:
            - {name: use_intra_process_comms, value: "true"}
        - plugin: nodes.control.node::ControllerManagerNode
          name: controller_manager
          params: {update_rate: 500}
          remap: ["c:=d"]
  - node: {name: spawner, module: tests.support.dummy_node, wait_for: [controller_manager]}
"""


def write(directory: Path, text: str, name: str = "test.yaml") -> Path:
    path = directory / name
    path.write_text(textwrap.dedent(text).lstrip(), encoding="utf-8")
    return path


def test_a_container_is_one_process_running_its_composable_nodes(tmp_path: Path) -> None:
    plan = resolve(write(tmp_path, GOOD), {})
    container, spawner = plan.nodes
    assert (container.name, container.namespace, container.module) == ("pair", "robot", CONTAINER_MODULE)
    assert container.respawn and container.respawn_delay == 0.5 and container.required
    simulator, manager = container.composed
    assert (simulator.full_name, simulator.plugin) == ("simulator", "nodes.sim.node::SimulatorNode")
    assert simulator.params == {"mode": "lockstep", "entities": [{"name": "r", "file": "x.urdf"}]}
    assert simulator.remaps == [("a", "b")]
    # a composable node without a namespace takes its container's (as launch_ros)
    assert manager.full_name == "robot/controller_manager" and manager.params == {"update_rate": 500}
    assert manager.remaps == [("c", "d")]
    assert spawner.wait_for == ["controller_manager"]   # a composed node's name is a readiness target

    argv = container.command("python", None, {"simulator": Path("/log/simulator.params.yaml"),
                                              "controller_manager": Path("/log/controller_manager.params.yaml")})
    assert argv[:7] == ["python", "-m", CONTAINER_MODULE, "--name", "pair", "--ns", "robot"]
    loaded = [json.loads(argv[i + 1]) for i, word in enumerate(argv) if word == "--composable"]
    assert loaded == [
        {"plugin": "nodes.sim.node::SimulatorNode",
         "argv": ["--name", "simulator", "--params-file", "/log/simulator.params.yaml", "--remap", "a:=b"]},
        {"plugin": "nodes.control.node::ControllerManagerNode",
         "argv": ["--name", "controller_manager", "--ns", "robot", "--params-file",
                  "/log/controller_manager.params.yaml", "--remap", "c:=d"]},
    ]
    described = plan.describe()["nodes"][0]
    assert [n["name"] for n in described["composable_node"]] == ["simulator", "controller_manager"]


def container(body: str) -> str:
    return ("launch:\n  - node_container:\n      name: c\n" + textwrap.indent(textwrap.dedent(body), " " * 6))


ONE = "composable_node:\n  - {plugin: nodes.sim.node::SimulatorNode, name: s}\n"


@pytest.mark.parametrize(
    ("text", "line", "fragment"),
    [
        ("launch:\n  - node_container: {composable_node: [{plugin: a::B, name: x}]}\n", 2,
         "node_container needs a 'name'"),
        (container("namespace: x\n"), 2, "needs 'composable_node': a non-empty list"),
        (container("composable_node: []\n"), 4, "needs 'composable_node': a non-empty list"),
        (container("composable_node:\n  - {name: s}\n"), 5, "composable_node needs a 'plugin'"),
        (container("composable_node:\n  - {plugin: nodes.sim.node::SimulatorNode}\n"), 5,
         "composable_node needs a 'name'"),
        (container("composable_node:\n  - plugin: nodes.sim.node::SimulatorNode\n    name: s\n    plugn: x\n"), 7,
         "unknown key 'plugn' in composable_node"),
        (container("composable_node:\n  - plugin: nodes.sim.node.SimulatorNode\n    name: s\n"), 5,
         "it must be python.module::NodeClass"),
        (container("composable_node:\n  - plugin: nodes.no_such_module::Node\n    name: s\n"), 5,
         "module 'nodes.no_such_module' not found"),
        (container("composable_node:\n  - plugin: nodes.sim.node::SimulatorNode\n    name: s\n    pkg: nodes.control\n"),
         7, "is not in its 'pkg' 'nodes.control'"),
        (container("composable_node:\n  - plugin: nodes.sim.node::SimulatorNode\n    name: s\n    param:\n"
                   "      - {name: mode}\n"), 8, "'param' item must be a mapping {name, value} or {from}"),
        (container("composable_node:\n  - plugin: nodes.sim.node::SimulatorNode\n    name: s\n    param: {mode: x}\n"),
         7, "'param' must be a list of mappings"),
        (container("composable_node:\n  - plugin: nodes.sim.node::SimulatorNode\n    name: s\n    remap:\n"
                   "      - {from: a, into: b}\n"), 8, "'remap' item must be a mapping {from, to}"),
        (container("composable_node:\n  - plugin: nodes.sim.node::SimulatorNode\n    name: s\n    extra_arg:\n"
                   "      - {name: use_intra_process_comms, value: 'false'}\n"), 8,
         "use_intra_process_comms: false is not offered"),
        (container("exec: component_container_mt\n" + ONE), 4, "node_container 'exec' is 'component_container_mt'"),
        (container("pkg: my_pkg\n" + ONE), 4, "node_container 'pkg' is 'my_pkg'"),
        (container("respawn: maybe\n" + ONE), 4, "must be true or false"),
        (container("plugin: x\n" + ONE), 4, "unknown key 'plugin' in node_container"),
        (container(ONE) + "  - node: {name: s, module: tests.support.dummy_node}\n", 6, "duplicate node name 's'"),
        (container(ONE) + "  - on_exit: {node: s}\n", 6, "on_exit watches node 's'"),
        ("launch:\n  - node_containr: {name: c}\n", 2, "unknown action 'node_containr'"),
    ],
)
def test_bad_container_yaml_names_the_field_file_and_line(tmp_path: Path, text: str, line: int,
                                                          fragment: str) -> None:
    path = write(tmp_path, text)
    with pytest.raises(LaunchError) as info:
        resolve(path, {})
    assert fragment in str(info.value), str(info.value)
    assert str(info.value).startswith(f"{path}:{line}: "), str(info.value)


def test_humanoid_composed_puts_the_simulator_and_controller_manager_in_one_container() -> None:
    path = find_launch_file("humanoid.yaml")
    separate = resolve(path, {"gui": "false", "mode": "lockstep"})
    composed = resolve(path, {"gui": "false", "mode": "lockstep", "composed": "true"})
    separate_names = [n.name for n in separate.nodes]
    assert "simulator" in separate_names and "controller_manager" in separate_names
    assert not any(n.composed for n in separate.nodes)   # the default: one process each

    (simulation,) = [n for n in composed.nodes if n.composed]
    assert [c.full_name for c in simulation.composed] == ["simulator", "humanoid/controller_manager"]
    assert simulation.respawn and simulation.required and simulation.exclusive_cpu
    assert "simulator" not in [n.name for n in composed.nodes]
    # the same node parameters either way
    by_name = {n.name: n for n in separate.nodes}
    assert simulation.composed[0].params == by_name["simulator"].params
    assert simulation.composed[1].param_files == by_name["controller_manager"].param_files


def test_the_example_in_docs_launch_md_resolves(tmp_path: Path) -> None:
    text = (Path(__file__).resolve().parents[2] / "docs" / "launch.md").read_text()
    section = text.split("## Composable nodes", 1)[1]
    example = section.split("```yaml\n", 1)[1].split("```", 1)[0]
    plan = resolve(write(tmp_path, example), {})
    (container,) = plan.nodes
    assert [c.full_name for c in container.composed] == ["simulator", "humanoid/controller_manager"]
    assert container.composed[0].params["mode"] == "lockstep"
    assert container.composed[1].param_files and container.composed[1].param_files[0].endswith("controllers.yaml")


@pytest.mark.parametrize("name", ["humanoid.yaml", "humanoid_20dof.yaml", "controller_lab.yaml", "lab_2_3.yaml",
                                  "joint_animation.yaml"])
def test_every_launch_file_with_a_simulator_takes_composed(name: str) -> None:
    path = find_launch_file(name)
    separate = resolve(path, {"gui": "false"})
    composed = resolve(path, {"gui": "false", "composed": "true"})
    (container,) = [n for n in composed.nodes if n.composed]
    assert [c.name for c in container.composed] == ["simulator", "controller_manager"]
    by_name = {n.name: n for n in separate.nodes}
    # the same nodes with the same parameters, in one process instead of two
    assert container.composed[0].params == by_name["simulator"].params
    assert container.composed[1].full_name == by_name["controller_manager"].full_name
    assert container.composed[1].param_files == by_name["controller_manager"].param_files
    assert container.exclusive_cpu == by_name["simulator"].exclusive_cpu
    assert {n.name for n in composed.nodes} | {"simulator", "controller_manager"} == \
        {n.name for n in separate.nodes} | {container.name}


def test_the_container_loads_plugins_by_module_and_class_and_names_what_is_wrong() -> None:
    from nodes.core.container import CompositionError, load_plugin, parse_composable
    from nodes.core.lifecycle import LifecycleNode

    assert load_plugin("nodes.core.lifecycle::LifecycleNode") is LifecycleNode
    for plugin, fragment in (("nodes.core.lifecycle.LifecycleNode", "must look like python.module::NodeClass"),
                             ("nodes.no_such_module::Node", "cannot import 'nodes.no_such_module'"),
                             ("json::JSONDecoder", "has no Node subclass 'JSONDecoder'"),
                             ("json::loads", "has no Node subclass 'loads'")):
        with pytest.raises(CompositionError, match=fragment):
            load_plugin(plugin)
    loaded = parse_composable(json.dumps({"plugin": "nodes.core.lifecycle::LifecycleNode",
                                          "argv": ["--name", "x", "--ns", "robot", "--remap", "a:=b"]}))
    assert loaded.factory is LifecycleNode and (loaded.args.name, loaded.args.namespace) == ("x", "robot")
    for text, fragment in (("{not json", "not JSON"), ('{"argv": []}', "must be {"),
                           ('{"plugin": "nodes.core.lifecycle::LifecycleNode", "argv": ["--bogus"]}',
                            "bad node arguments")):
        with pytest.raises(CompositionError, match=fragment):
            parse_composable(text)
