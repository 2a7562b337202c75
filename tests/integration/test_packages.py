"""The package index from the outside, as real processes: ``zenroid pkg``, xacro's ``$(find)`` through
``zenroid xacro``, ``ament_index_python`` imported by a user's script, and a source package's console_scripts
entry run as ``ros2 run`` would."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from bench.common import child_env
from tests.conftest import ROOT

PACKAGE_XML = ('<?xml version="1.0"?><package format="3"><name>{name}</name><version>0.0.1</version>'
               '<description>d</description><maintainer email="a@b.c">a</maintainer><license>MIT</license></package>')


def workspace(tmp_path: Path) -> Path:
    """A colcon-style workspace, never built: src/cart_description (xacro with $(find)) and src/cart_nodes
    (an ament_python package with a console_scripts entry)."""
    ws = tmp_path / "ws"
    desc = ws / "src" / "cart_description"
    (desc / "urdf").mkdir(parents=True)
    (desc / "package.xml").write_text(PACKAGE_XML.format(name="cart_description"))
    (desc / "urdf" / "wheel.xacro").write_text(
        '<robot xmlns:xacro="http://www.ros.org/wiki/xacro"><link name="wheel"/></robot>')
    (desc / "urdf" / "cart.urdf.xacro").write_text(
        '<robot name="cart" xmlns:xacro="http://www.ros.org/wiki/xacro">'
        '<xacro:include filename="$(find cart_description)/urdf/wheel.xacro"/><link name="base"/>'
        '<joint name="j" type="fixed"><parent link="base"/><child link="wheel"/></joint></robot>')
    nodes = ws / "src" / "cart_nodes"
    (nodes / "cart_nodes").mkdir(parents=True)
    (nodes / "package.xml").write_text(PACKAGE_XML.format(name="cart_nodes"))
    (nodes / "cart_nodes" / "__init__.py").write_text("")
    (nodes / "cart_nodes" / "hello.py").write_text(
        "import sys\n\ndef main():\n    from ament_index_python.packages import get_package_share_directory\n"
        "    print('hello', sys.argv[1:], get_package_share_directory('cart_description'))\n    return 3\n")
    (nodes / "setup.py").write_text(
        "from setuptools import setup\npackage_name = 'cart_nodes'\nsetup(name=package_name, entry_points={\n"
        "    'console_scripts': [package_name + '_hello = cart_nodes.hello:main']})\n")
    return ws


def zenroid(args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "nodes.tools", *args], cwd=cwd, env=child_env(),
                          capture_output=True, text=True, timeout=120)


def test_pkg_verbs_find_the_workspace_and_the_stack(tmp_path: Path) -> None:
    ws = workspace(tmp_path)
    listed = zenroid(["pkg", "list"], ws)
    assert listed.returncode == 0, listed.stderr
    names = listed.stdout.split()
    assert {"cart_description", "cart_nodes", "controller_manager", "gazebo_ros", "zenroid_description"} <= set(names)
    prefix = zenroid(["pkg", "prefix", "cart_description"], ws)
    assert prefix.stdout.strip() == str(ws / "src" / "cart_description")
    assert zenroid(["pkg", "prefix", "--share", "zenroid_description"], ws).stdout.strip() == \
        str((ROOT / "robots").resolve())
    exes = zenroid(["pkg", "executables", "cart_nodes"], ws)
    assert exes.stdout.split("\n")[0] == "cart_nodes cart_nodes_hello"
    missing = zenroid(["pkg", "prefix", "cart_wheels"], ws)
    assert missing.returncode == 1
    assert "package 'cart_wheels' not found" in missing.stderr and str(ws / "src") in missing.stderr
    assert "served by zenroid: " in missing.stderr


def test_xacro_find_in_a_workspace(tmp_path: Path) -> None:
    ws = workspace(tmp_path)
    out = zenroid(["xacro", "src/cart_description/urdf/cart.urdf.xacro"], ws)
    assert out.returncode == 0, out.stderr
    assert '<link name="wheel"/>' in out.stdout
    (ws / "src" / "cart_description" / "urdf" / "bad.xacro").write_text(
        '<robot name="b" xmlns:xacro="http://www.ros.org/wiki/xacro">'
        '<xacro:include filename="$(find cart_wheels)/w.xacro"/></robot>')
    bad = zenroid(["xacro", "src/cart_description/urdf/bad.xacro"], ws)
    assert bad.returncode == 2
    assert "$(find cart_wheels): package 'cart_wheels' not found; searched:" in bad.stderr


def test_a_console_script_runs_from_the_unbuilt_source(tmp_path: Path) -> None:
    ws = workspace(tmp_path)
    probe = ("import sys, json\nfrom nodes.packages import find_executable\n"
             "print(json.dumps(find_executable('cart_nodes', 'cart_nodes_hello').command(['a', 'b'])))\n")
    found = subprocess.run([sys.executable, "-c", probe], cwd=ws, env=child_env(), capture_output=True, text=True,
                           timeout=60)
    assert found.returncode == 0, found.stderr
    import json

    command = json.loads(found.stdout)
    ran = subprocess.run(command, cwd=ws, env=child_env(), capture_output=True, text=True, timeout=60)
    assert ran.returncode == 3, ran.stderr   # the entry point's return value is the exit status
    assert ran.stdout.strip() == f"hello ['a', 'b'] {ws / 'src' / 'cart_description'}"
