"""``zenroid urdf_to_graphviz``: the URDF tree as Graphviz, drawn when ``dot`` exists, said so when not."""

from __future__ import annotations

import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from nodes.tools.urdf_graph import to_dot, xyz_rpy
from nodes.urdf import load_robot_description, parse_urdf
from nodes.urdf.model import rpy_matrix
from tests.conftest import ROOT


def _run(tmp_path: Path, *argv: str, path: str | None = None) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    if path is not None:
        env["PATH"] = path
    return subprocess.run([sys.executable, "-m", "nodes.tools", *argv], capture_output=True, text=True, env=env,
                          cwd=tmp_path, timeout=120)


def test_every_link_and_joint_is_drawn_with_the_joint_origin() -> None:
    model = parse_urdf(load_robot_description(str(ROOT / "robots/humanoid.urdf")))
    dot = to_dot(model)
    assert dot.startswith("digraph G {") and dot.rstrip().endswith("}")
    for link in model.links:
        assert f'"{link}" [label="{link}"];' in dot
    for joint in model.joints.values():
        assert f'"{joint.parent}" -> "{joint.name}" [label="xyz: ' in dot
        assert f'"{joint.name}" -> "{joint.child}"' in dot
    assert '"pelvis" -> "waist_yaw" [label="xyz: 0 0 0.06 \\nrpy: 0 0 0"]' in dot


def test_rpy_is_recovered_from_the_origin() -> None:
    for roll, pitch, yaw in [(0.1, -0.4, 2.0), (-1.2, 0.3, -3.0), (0.0, 0.0, 0.0)]:
        transform = np.eye(4)
        transform[:3, :3] = rpy_matrix(roll, pitch, yaw)
        transform[:3, 3] = [1.0, -2.0, 0.5]
        xyz, rpy = xyz_rpy(transform)
        assert xyz == [1.0, -2.0, 0.5]
        assert all(math.isclose(a, b, abs_tol=1e-12) for a, b in zip(rpy, (roll, pitch, yaw)))


def test_without_graphviz_it_writes_the_gv_and_says_so(tmp_path: Path) -> None:
    bare = tmp_path / "bin"
    bare.mkdir()  # a PATH without `dot`
    done = _run(tmp_path, "urdf_to_graphviz", str(ROOT / "robots/simple_robot.urdf.xacro"), "length:=0.3",
                path=str(bare))
    assert done.returncode == 0, done.stderr
    assert "Created file simple_robot.gv" in done.stdout
    assert "Graphviz `dot` is not installed" in done.stdout
    assert (tmp_path / "simple_robot.gv").read_text().startswith("digraph G {")
    assert not (tmp_path / "simple_robot.pdf").exists()


@pytest.mark.skipif(shutil.which("dot") is None, reason="Graphviz not installed (.ci/run installs it)")
def test_with_graphviz_it_draws_a_pdf(tmp_path: Path) -> None:
    done = _run(tmp_path, "urdf_to_graphiz", str(ROOT / "robots/humanoid.urdf"), "-o", "drawn")
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "drawn.pdf").read_bytes().startswith(b"%PDF")
    assert "Created file drawn.pdf" in done.stdout


def test_a_broken_urdf_is_exit_2(tmp_path: Path) -> None:
    broken = tmp_path / "broken.urdf"
    broken.write_text("<robot name='x'><link name='a'/><joint name='j' type='fixed'><parent link='a'/>"
                      "<child link='missing'/></joint>")
    done = _run(tmp_path, "urdf_to_graphviz", str(broken))
    assert done.returncode == 2 and done.stderr.startswith("zenroid urdf_to_graphviz: ")
    assert not list(tmp_path.glob("*.gv"))
