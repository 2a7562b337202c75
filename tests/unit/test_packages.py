"""The package index (nodes/packages): packages found as ROS finds them, with no build step, and what answers
from it: ament_index_python, xacro's $(find), package:// URIs, interface packages, executables."""

from __future__ import annotations

import os
import site
import sys
from pathlib import Path

import pytest

import ament_index_python
from ament_index_python.packages import (
    PackageNotFoundError,
    get_package_prefix,
    get_package_share_directory,
    get_packages_with_prefixes,
)
from nodes.packages import (
    ExecutableNotFoundError,
    UriError,
    executables,
    find_executable,
    find_share,
    list_packages,
    resolve_uri,
)
from nodes.packages import index as index_module
from tests.conftest import ROOT

PACKAGE_XML = """<?xml version="1.0"?>
<package format="3"><name>{name}</name><version>0.0.1</version><description>d</description>
<maintainer email="a@b.c">a</maintainer><license>MIT</license></package>
"""


def make_package(folder: Path, name: str | None = None) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "package.xml").write_text(PACKAGE_XML.format(name=name or folder.name))
    return folder


@pytest.fixture
def clean_env(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> Path:
    """No ROS variables, an empty working directory, and no Python distributions' prefixes."""
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    monkeypatch.delenv("AMENT_PREFIX_PATH", raising=False)
    work = tmp_path / "ws"
    work.mkdir()
    monkeypatch.chdir(work)
    monkeypatch.setattr(site, "getsitepackages", lambda: [])
    monkeypatch.setattr(site, "getusersitepackages", lambda: str(tmp_path / "no_user_site"))
    monkeypatch.setattr(sys, "prefix", str(tmp_path / "no_prefix"))
    index_module.refresh()
    yield work
    index_module.refresh()


def test_ros_package_path_is_crawled_as_rospack_does(clean_env: Path, tmp_path: Path,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    top = tmp_path / "rpp"
    outer = make_package(top / "a" / "b" / "outer_dir", "outer_pkg")   # <name> wins over the folder's name
    make_package(outer / "nested_pkg")                                   # not descended into a package
    make_package(top / "ignored" / "hidden_pkg")
    (top / "ignored" / "COLCON_IGNORE").write_text("")
    make_package(top / ".git" / "dot_pkg")
    single = make_package(tmp_path / "single")                           # an entry that is itself a package
    monkeypatch.setenv("ROS_PACKAGE_PATH", os.pathsep.join([str(top), str(single)]))
    found = list_packages()
    assert found["outer_pkg"].share == outer and found["outer_pkg"].source == "ROS_PACKAGE_PATH"
    assert found["single"].share == single
    assert not {"nested_pkg", "hidden_pkg", "dot_pkg", "outer_dir"} & set(found)
    # a source package is its own share directory and prefix
    assert get_package_share_directory("outer_pkg") == str(outer) == get_package_prefix("outer_pkg")


def test_relative_package_paths_give_absolute_shares(clean_env: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """``ROS_PACKAGE_PATH=examples``: the share directory (and what ``$(find)`` puts in a URDF) is absolute,
    so it means the same to the processes a launch starts from other folders."""
    make_package(clean_env / "examples" / "rel_pkg")
    monkeypatch.setenv("ROS_PACKAGE_PATH", "examples")
    assert find_share("rel_pkg") == clean_env / "examples" / "rel_pkg"
    assert find_share("rel_pkg").is_absolute()


def test_the_cart_demo_package_expands(clean_env: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """examples/cart_demo: each variant's xacro includes the common one through $(find cart_demo) and names its
    own command interface, initial_value and controllers file."""
    from nodes.urdf import load_robot_description

    monkeypatch.setenv("ROS_PACKAGE_PATH", str(ROOT / "examples"))
    share = find_share("cart_demo")
    for variant, initial in (("position", True), ("velocity", False), ("effort", True)):
        urdf = load_robot_description(share / "urdf" / f"cart_{variant}.urdf.xacro")
        assert f'<command_interface name="{variant}">' in urdf and 'type="prismatic"' in urdf
        assert ('<param name="initial_value">1.0</param>' in urdf) == initial
        assert f"<parameters>{share}/config/cart_controller_{variant}.yaml</parameters>" in urdf
        assert (share / "config" / f"cart_controller_{variant}.yaml").is_file()
        assert (share / "launch" / f"cart_example_{variant}.launch.py").is_file()


def test_ament_prefix_path_markers_and_share_folders(clean_env: Path, tmp_path: Path,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    first, second = tmp_path / "install_a", tmp_path / "install_b"
    markers = first / "share" / "ament_index" / "resource_index" / "packages"
    markers.mkdir(parents=True)
    (markers / "marked_pkg").write_text("")
    (first / "share" / "marked_pkg").mkdir()
    make_package(second / "share" / "unmarked_pkg")
    make_package(second / "share" / "marked_pkg")                      # shadowed by the first prefix
    monkeypatch.setenv("AMENT_PREFIX_PATH", os.pathsep.join([str(first), str(second)]))
    assert get_package_prefix("marked_pkg") == str(first)
    assert get_package_share_directory("marked_pkg") == str(first / "share" / "marked_pkg")
    assert get_package_share_directory("unmarked_pkg") == str(second / "share" / "unmarked_pkg")
    assert get_packages_with_prefixes()["unmarked_pkg"] == str(second)
    assert ament_index_python.get_resources("packages")["marked_pkg"] == str(first)
    assert ament_index_python.has_resource("packages", "marked_pkg") == str(first)
    assert ament_index_python.get_resource("packages", "marked_pkg") == ("", str(first))
    assert ament_index_python.get_search_paths() == [str(first), str(second)]


def test_workspace_src_comes_first(clean_env: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    mine = make_package(clean_env / "src" / "group" / "my_pkg")
    other = make_package(tmp_path / "rpp" / "my_pkg")
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "rpp"))
    assert find_share("my_pkg") == mine != other
    assert list_packages()["my_pkg"].source == "workspace"


def test_python_distributions_with_an_ament_index(clean_env: Path, tmp_path: Path,
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    # laid out as the example-robot-data wheel installs (cmeel): site-packages/cmeel.prefix/share/...
    site_dir = tmp_path / "site-packages"
    prefix = site_dir / "cmeel.prefix"
    (prefix / "share" / "ament_index" / "resource_index" / "packages").mkdir(parents=True)
    (prefix / "share" / "ament_index" / "resource_index" / "packages" / "robot-data").write_text("")
    (prefix / "share" / "robot-data" / "robots").mkdir(parents=True)
    (prefix / "share" / "robot-data" / "robots" / "r.urdf").write_text("<robot name='r'/>")
    monkeypatch.setattr(site, "getsitepackages", lambda: [str(site_dir)])
    index_module.refresh()
    assert list_packages()["robot-data"].source == "python"
    assert resolve_uri("package://robot-data/robots/r.urdf") == prefix / "share" / "robot-data" / "robots" / "r.urdf"


def test_the_stack_packages_and_our_robots(clean_env: Path) -> None:
    found = list_packages()
    for name in ("gazebo_ros", "gazebo_ros2_control", "ros_gz_sim", "controller_manager", "robot_state_publisher", "joint_state_publisher",
                 "joint_state_publisher_gui", "rviz2", "tf2_ros", "xacro", "zenroid_description"):
        assert found[name].source == "zenroid", name
    share = find_share("zenroid_description")
    assert share == (ROOT / "robots").resolve()
    for folder in ("urdf", "config", "worlds", "launch"):
        assert (share / folder).is_dir(), folder
    assert (share / "urdf" / "humanoid.urdf").is_file() and (share / "worlds" / "simple_lab.world").is_file()
    assert (share / "config" / "controllers.yaml").is_file()
    assert (share / "launch" / "spawn_humanoid.launch.py").is_file()


def test_a_missing_package_names_itself_and_every_path_searched(clean_env: Path, tmp_path: Path,
                                                                monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "rpp_here"))
    monkeypatch.setenv("AMENT_PREFIX_PATH", str(tmp_path / "install_here"))
    with pytest.raises(PackageNotFoundError) as caught:
        get_package_share_directory("no_such_pkg")
    message = str(caught.value)
    assert "'no_such_pkg' not found" in message
    for where in (clean_env / "src", tmp_path / "rpp_here", tmp_path / "install_here", "served by zenroid"):
        assert str(where) in message
    assert isinstance(caught.value, KeyError)  # as ament_index_python's
    with pytest.raises(ValueError, match="not a valid package name"):
        get_package_share_directory("a/b")


def test_resolve_uri(clean_env: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    pkg = make_package(tmp_path / "rpp" / "meshy")
    (pkg / "meshes").mkdir()
    (pkg / "meshes" / "m.stl").write_text("solid")
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "rpp"))
    assert resolve_uri("package://meshy/meshes/m.stl") == pkg / "meshes" / "m.stl"
    assert resolve_uri("package://meshy/meshes/../meshes/m.stl") == pkg / "meshes" / "m.stl"
    with pytest.raises(UriError, match="leaves"):
        resolve_uri("package://meshy/../rpp/meshy/meshes/m.stl")
    with pytest.raises(UriError, match="package 'gone' not found"):
        resolve_uri("package://gone/m.stl")
    assert resolve_uri("file:///tmp/x.stl") == Path("/tmp/x.stl")
    assert resolve_uri("meshes/m.stl", base=pkg) == pkg / "meshes" / "m.stl"
    with pytest.raises(UriError, match="unsupported scheme"):
        resolve_uri("http://example.invalid/m.stl")
    models = tmp_path / "models"
    (models / "table").mkdir(parents=True)
    monkeypatch.setenv("GAZEBO_MODEL_PATH", str(models))
    assert resolve_uri("model://table/model.sdf") == models / "table" / "model.sdf"
    assert resolve_uri("model://meshy/meshes/m.stl") == pkg / "meshes" / "m.stl"   # a package of that name
    with pytest.raises(UriError, match="model 'chair' not found"):
        resolve_uri("model://chair/model.sdf")


def test_xacro_find_answers_from_the_index(clean_env: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from nodes.urdf import UrdfError, load_robot_description

    pkg = make_package(tmp_path / "rpp" / "cart_description")
    (pkg / "urdf").mkdir()
    (pkg / "urdf" / "part.xacro").write_text(
        '<robot xmlns:xacro="http://www.ros.org/wiki/xacro"><link name="included"/></robot>')
    (pkg / "urdf" / "cart.urdf.xacro").write_text(
        '<robot name="cart" xmlns:xacro="http://www.ros.org/wiki/xacro">'
        '<xacro:include filename="$(find cart_description)/urdf/part.xacro"/>'
        '<link name="base"><visual><geometry><mesh filename="file://$(find cart_description)/m.stl"/>'
        '</geometry></visual></link></robot>')
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "rpp"))
    urdf = load_robot_description(pkg / "urdf" / "cart.urdf.xacro")
    assert 'name="included"' in urdf and f"file://{pkg}/m.stl" in urdf
    (pkg / "urdf" / "bad.urdf.xacro").write_text(
        '<robot name="b" xmlns:xacro="http://www.ros.org/wiki/xacro">'
        '<xacro:include filename="$(find not_a_pkg)/x.xacro"/></robot>')
    with pytest.raises(UrdfError, match=r"\$\(find not_a_pkg\): package 'not_a_pkg' not found; searched:"):
        load_robot_description(pkg / "urdf" / "bad.urdf.xacro")


def test_interface_packages_found_through_the_index(clean_env: Path, tmp_path: Path,
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    import msgs
    from msgs import registry

    pkg = make_package(tmp_path / "rpp" / "cart_interfaces_dir", "cart_interfaces")
    (pkg / "msg").mkdir()
    (pkg / "msg" / "CartCommand.msg").write_text("float64 position\nstring label\n")
    (pkg / "srv").mkdir()
    (pkg / "srv" / "Home.srv").write_text("bool fast\n---\nbool ok\n")
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "rpp"))
    assert registry.interface_packages()["cart_interfaces"] == pkg
    assert {"cart_interfaces/msg/CartCommand", "cart_interfaces/srv/Home"} <= set(msgs.list_types())
    cls = msgs.get_type("cart_interfaces/msg/CartCommand")
    assert cls(position=1.5, label="x").position == 1.5
    assert msgs.get_type("cart_interfaces/Home")  # kind found on disk


def test_executables_of_a_source_package(clean_env: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    pkg = make_package(tmp_path / "rpp" / "my_package")
    (pkg / "scripts").mkdir()
    (pkg / "scripts" / "joint_commander.py").write_text("print('hi')\n")
    tool = pkg / "scripts" / "tool.sh"
    tool.write_text("#!/bin/sh\necho hi\n")
    tool.chmod(0o755)
    (pkg / "my_package").mkdir()
    (pkg / "my_package" / "__init__.py").write_text("")
    (pkg / "my_package" / "my_node.py").write_text("def main():\n    return 0\n")
    (pkg / "setup.py").write_text(
        "from setuptools import setup\npackage_name = 'my_package'\n"
        "setup(name=package_name, entry_points={'console_scripts': [\n"
        "    'my_node = my_package.my_node:main',\n"
        "    f'other = {package_name}.my_node:main',\n"
        "    'gone = my_package.missing:main',\n]})\n")
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "rpp"))
    found = executables("my_package")
    assert set(found) == {"joint_commander.py", "tool.sh", "my_node", "other"}
    assert found["joint_commander.py"].argv == (sys.executable, str(pkg / "scripts" / "joint_commander.py"))
    assert found["tool.sh"].argv == (str(tool),)
    assert found["my_node"].argv[-2:] == (str(pkg), "my_package.my_node:main")
    with pytest.raises(ExecutableNotFoundError, match=r"no executable 'nope'.*scripts.*it has: joint_commander.py"):
        find_executable("my_package", "nope")
    with pytest.raises(PackageNotFoundError, match=r"(?s)'nobody'.*served by zenroid: .*controller_manager"):
        find_executable("nobody", "x")


def test_setup_cfg_console_scripts(tmp_path: Path) -> None:
    from nodes.packages.executables import console_scripts

    (tmp_path / "setup.cfg").write_text("[options.entry_points]\nconsole_scripts =\n    talker = demo.talker:main\n")
    assert console_scripts(tmp_path) == {"talker": "demo.talker:main"}


def test_served_executables_are_our_modules(clean_env: Path) -> None:
    spawner = find_executable("controller_manager", "spawner")
    assert spawner.argv == (sys.executable, "-m", "nodes.packages.serve", "controller_manager", "spawner")
    assert not spawner.ros_node
    assert find_executable("robot_state_publisher", "robot_state_publisher").ros_node


@pytest.mark.skipif(not any((Path(p) / "cmeel.prefix/share/example-robot-data").is_dir()
                            for p in site.getsitepackages()), reason="example-robot-data is not installed")
def test_example_robot_data_as_installed() -> None:
    index_module.refresh()
    share = Path(get_package_share_directory("example-robot-data"))
    assert share.name == "example-robot-data" and share.parent.parent.name == "cmeel.prefix"
    assert resolve_uri("package://example-robot-data/robots/ur_description/urdf/ur5_robot.urdf").is_file()


def test_a_robot_files_own_package_is_added_to_the_package_path(clean_env: Path, tmp_path: Path,
                                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    """A description repository used where it lies (no package path names it): its folder is added to
    ROS_PACKAGE_PATH, once; a package the index knows, or a file in no package, adds nothing."""
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "elsewhere"))
    package = make_package(tmp_path / "downloads" / "lab_bot_description")
    (package / "urdf").mkdir()
    robot = package / "urdf" / "lab_bot.urdf.xacro"
    robot.write_text("<robot name='r'/>")
    line = index_module.add_own_package(robot)
    assert line is not None and "'lab_bot_description'" in line and str(package) in line
    assert os.environ["ROS_PACKAGE_PATH"] == os.pathsep.join([str(tmp_path / "elsewhere"), str(package)])
    assert find_share("lab_bot_description") == package
    assert index_module.add_own_package(robot) is None        # known now
    loose = tmp_path / "loose.urdf"
    loose.write_text("<robot name='r'/>")
    assert index_module.add_own_package(loose) is None


def test_the_example_lab_package_by_uri_through_xacro(clean_env: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """examples/lab_biped_description named as robot_file:= takes it: package:// and file:// URIs, its xacro
    including its leg macro through $(find), no <ros2_control> block."""
    from nodes.share import robot_file
    from nodes.urdf.description import load_robot_description
    from nodes.urdf.model import parse_urdf

    monkeypatch.setenv("ROS_PACKAGE_PATH", str(ROOT / "examples"))
    file = ROOT / "examples" / "lab_biped_description" / "urdf" / "lab_biped.urdf.xacro"
    assert robot_file("package://lab_biped_description/urdf/lab_biped.urdf.xacro") == file
    assert robot_file(file.as_uri()) == file
    with pytest.raises(FileNotFoundError, match="outside its package root"):
        robot_file("package://lab_biped_description/../../pyproject.toml")
    model = parse_urdf(load_robot_description("package://lab_biped_description/urdf/lab_biped.urdf.xacro",
                                              xacro_args={"hip_spacing": "0.25"}))
    assert model.name == "lab_biped" and not model.ros2_control
    assert [j.name for j in model.movable_joints()][:4] == ["left_hip_roll_joint", "left_hip_pitch_joint",
                                                           "left_knee_joint", "left_ankle_pitch_joint"]
    assert model.joints["right_hip_roll_joint"].origin[1, 3] == pytest.approx(-0.125)   # the xacro arg
