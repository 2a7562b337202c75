"""Every robot in robots/ loads in yourdfpy and DART, validates cleanly, and has its tutorial's names."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import numpy as np
import pytest

from nodes.kinematics import KinematicTree
from nodes.urdf import load_robot_description, parse_urdf, parse_xacro_args, validate

ROBOTS = Path(__file__).resolve().parents[2] / "robots"
ALL = ["humanoid", "humanoid_simplified", "simple_2dof_arm", "lab_robot", "atlas", "simple_robot", "humanoid_20dof"]
XACRO = {"simple_robot", "humanoid_20dof"}
FIXED_BASE = {"humanoid_simplified", "simple_2dof_arm", "lab_robot", "simple_robot"}
LEG_JOINTS = [
    f"{side}_{j}"
    for side in ("left", "right")
    for j in ("hip_yaw", "hip_roll", "hip_pitch", "knee", "ankle_pitch", "ankle_roll")
]
ATLAS_JOINTS = ["back_lbz", "back_mby", "back_ubx", "neck_ay"] + [
    f"{p}_leg_{j}" for p in "lr" for j in ("uhz", "mhx", "lhy", "kny", "uay", "lax")
] + [f"{p}_arm_{j}" for p in "lr" for j in ("elx", "ely", "mwx", "shx", "usy", "uwy")]


def robot_file(name: str) -> Path:
    return ROBOTS / (f"{name}.urdf.xacro" if name in XACRO else f"{name}.urdf")


def urdf_on_disk(name: str, tmp_path: Path) -> Path:
    """DART and yourdfpy need plain URDF files: expand the xacro one first."""
    path = robot_file(name)
    if path.suffix == ".xacro":
        out = tmp_path / f"{name}.urdf"
        out.write_text(load_robot_description(path))
        return out
    return path


def model(name: str):
    return parse_urdf(load_robot_description(robot_file(name)))


@pytest.mark.parametrize("name", ALL)
def test_robot_validates_without_errors_or_warnings(name: str) -> None:
    m = model(name)
    assert [str(i) for i in validate(m)] == []
    # every body has mass and a collision shape, but for the sensors' frames (a token mass, no shape)
    frames = {"camera_link", "camera_optical_frame", "lidar_link", "laser_link"}
    assert all(link.inertial and (link.has_collision or link.name in frames) for link in m.links.values())
    assert all(m.links[name].inertial.mass <= 0.01 and not m.links[name].visuals for name in frames & set(m.links))


@pytest.mark.parametrize("name", ALL)
def test_robot_loads_in_yourdfpy_and_dart_with_same_joints(name: str, tmp_path: Path) -> None:
    import dartpy as dart
    import yourdfpy

    path = urdf_on_disk(name, tmp_path)
    urdf = yourdfpy.URDF.load(str(path), build_scene_graph=True, load_meshes=False)
    m = model(name)
    assert sorted(urdf.actuated_joint_names) == sorted(j.name for j in m.movable_joints())
    loader = dart.utils.DartLoader()
    if name in FIXED_BASE:
        options = dart.utils.DartLoaderOptions()
        options.mDefaultRootJointType = dart.utils.DartLoaderRootJointType.FIXED
        loader.setOptions(options)
    skeleton = loader.parseSkeleton(str(path.resolve()))
    assert skeleton is not None, f"DART could not load {path}"
    free_dofs = 0 if name in FIXED_BASE else 6
    assert skeleton.getNumDofs() == len(m.movable_joints()) + free_dofs
    assert skeleton.getNumBodyNodes() == len(m.links)
    assert skeleton.getMass() == pytest.approx(m.total_mass())


@pytest.mark.parametrize("name", ALL)
def test_ros2_control_block_lists_every_movable_joint(name: str) -> None:
    m = model(name)
    control = {c.name: c for c in m.ros2_control}
    assert set(control) == {j.name for j in m.movable_joints()}
    for entry in control.values():
        assert "position" in entry.command_interfaces
        assert entry.state_interfaces == ["position", "velocity"]


def test_humanoid_has_tutorial_leg_joints_limits_and_mass() -> None:
    m = model("humanoid")
    revolute = [j for j in m.joints.values() if j.type == "revolute"]
    assert 22 <= len(revolute) <= 30
    assert set(LEG_JOINTS) <= {j.name for j in revolute}
    for part in ("waist", "neck", "shoulder_pitch", "shoulder_roll", "shoulder_yaw", "elbow"):
        assert any(part in j.name for j in revolute), part
    assert m.root == "pelvis"
    assert 30.0 <= m.total_mass() <= 70.0
    for j in revolute:
        assert j.lower < j.upper and j.effort > 0 and j.velocity > 0, j.name
    for side in ("left", "right"):
        for j in ("hip_pitch", "hip_roll", "knee"):
            assert m.joints[f"{side}_{j}"].effort >= 150
        for j in ("hip_pitch", "knee", "ankle_pitch"):
            assert np.allclose(m.joints[f"{side}_{j}"].axis, [0, 1, 0])


def _sole_corners(tree: KinematicTree, q: np.ndarray, foot: str) -> np.ndarray:
    """World (pelvis-frame) corners of the foot's collision box bottom face."""
    xml = robot_file("humanoid").read_text()
    size = [float(v) for v in re.search(rf'<link name="{foot}">.*?<box size="([^"]+)"', xml, re.S).group(1).split()]
    centre = [float(v) for v in re.search(rf'<link name="{foot}">.*?<collision>\s*<origin xyz="([^"]+)"', xml,
                                          re.S).group(1).split()]
    corners = np.array([[centre[0] + sx * size[0] / 2, centre[1] + sy * size[1] / 2, centre[2] - size[2] / 2, 1.0]
                        for sx in (-1, 1) for sy in (-1, 1)])
    return (tree.link_transform(q, foot) @ corners.T).T[:, :3], size


def test_humanoid_stands_flat_at_zero_pose_at_documented_height() -> None:
    tree = KinematicTree(model("humanoid"))
    text = robot_file("humanoid").read_text()
    documented = float(re.search(r"Standing pelvis height at zero pose[^:]*: ([0-9.]+) m", text).group(1))
    q = tree.zero_configuration()
    for foot in ("left_foot", "right_foot"):
        corners, size = _sole_corners(tree, q, foot)
        assert np.allclose(corners[:, 2], -documented, atol=1e-9)  # flat, at the documented depth
        assert size[0] == pytest.approx(0.22, abs=0.03) and size[1] == pytest.approx(0.10, abs=0.03)


def test_humanoid_tutorial_knee_bend_is_a_slight_squat_with_flat_feet() -> None:
    tree = KinematicTree(model("humanoid"))
    bend = {f"{s}_{j}": v for s in ("left", "right") for j, v in
            (("hip_pitch", -0.2), ("knee", 0.4), ("ankle_pitch", -0.2))}
    q = tree.configuration(bend)
    zero = tree.zero_configuration()
    for side in ("left", "right"):
        corners, _ = _sole_corners(tree, q, f"{side}_foot")
        assert np.ptp(corners[:, 2]) < 1e-9  # sole still flat
        standing, _ = _sole_corners(tree, zero, f"{side}_foot")
        assert 0.005 < corners[0, 2] - standing[0, 2] < 0.05  # the pelvis comes down a little
        knee = tree.link_transform(q, f"{side}_shin")[:3, 3]
        assert knee[0] > 0.05  # the knee moves forward: it bends the human way
        ankle = tree.link_transform(q, f"{side}_foot")[:3, 3]
        assert abs(ankle[0]) < 1e-9  # foot straight under the hip


def test_other_robots_have_their_tutorial_joint_names() -> None:
    assert [j.name for j in model("humanoid_simplified").movable_joints()] == [
        f"{s}_{j}_joint" for s in ("left", "right") for j in ("shoulder", "elbow", "wrist")
    ]
    assert model("humanoid_simplified").root == "base_link"
    assert sorted(j.name for j in model("lab_robot").movable_joints()) == sorted(
        ["left_arm_joint", "right_arm_joint", "left_leg_joint", "right_leg_joint"])
    assert [j.name for j in model("simple_2dof_arm").movable_joints()] == ["shoulder_joint", "elbow_joint"]
    atlas = model("atlas")
    assert sorted(j.name for j in atlas.movable_joints()) == sorted(ATLAS_JOINTS)
    assert len(ATLAS_JOINTS) == 28
    # The joint-animation tutorial plays every joint within +-0.5 rad.
    for j in atlas.movable_joints():
        assert j.lower <= -0.5 and j.upper >= 0.5, j.name


def test_simple_robot_xacro_properties_args_and_control_params() -> None:
    text = robot_file("simple_robot").read_text()
    assert 'xacro:property name="length"' in text and 'xacro:property name="mass"' in text
    m = model("simple_robot")
    assert [j.name for j in m.movable_joints()] == ["joint1"]
    (joint1,) = m.ros2_control
    assert joint1.command_interfaces == ["position", "velocity"]
    assert joint1.params["position"] == {"min": "-3.14", "max": "3.14"}
    assert joint1.params["velocity"] == {"min": "-10", "max": "10"}
    assert m.links["link1"].inertial.mass == pytest.approx(0.1)
    longer = parse_urdf(load_robot_description(robot_file("simple_robot"),
                                               xacro_args=parse_xacro_args(["length:=0.4", "mass:=0.5"])))
    assert longer.links["link1"].inertial.mass == pytest.approx(0.5)
    assert longer.links["link1"].inertial.origin[0, 3] == pytest.approx(0.2)


def test_generated_urdfs_are_up_to_date_with_the_generator(tmp_path: Path, monkeypatch) -> None:
    import importlib.util

    spec = importlib.util.spec_from_file_location("build_robots", ROBOTS / "build_robots.py")
    module = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, "build_robots", module)  # dataclasses look their module up
    spec.loader.exec_module(module)
    for name, build in module.BUILDERS.items():
        assert build().xml() == (ROBOTS / f"{name}.urdf").read_text(), f"{name}.urdf is stale: rerun the generator"
    for file, build_text in module.XACRO_BUILDERS.items():
        assert build_text() == (ROBOTS / file).read_text(), f"{file} is stale: rerun the generator"


def _joint_table(m) -> dict:
    return {j.name: (j.type, j.parent, j.child, j.lower, j.upper, j.velocity, j.effort) for j in m.joints.values()}


def test_humanoid_xacro_without_arguments_is_humanoid_urdf() -> None:
    plain, expanded = model("humanoid"), parse_urdf(load_robot_description(ROBOTS / "humanoid.urdf.xacro"))
    assert expanded.name == plain.name == "humanoid"
    assert _joint_table(expanded) == _joint_table(plain)
    assert {n: (link.inertial.mass, link.inertial.inertia.tolist()) for n, link in expanded.links.items()} == \
        {n: (link.inertial.mass, link.inertial.inertia.tolist()) for n, link in plain.links.items()}
    assert [(c.name, c.command_interfaces, c.state_interfaces) for c in expanded.ros2_control] == \
        [(c.name, c.command_interfaces, c.state_interfaces) for c in plain.ros2_control]


def test_humanoid_20dof_variant_locks_waist_and_neck_and_limits_every_joint() -> None:
    """Seed 000's exercise: 20 position-controlled joints, 2 rad/s and 50 Nm in <limit> and <ros2_control>."""
    m = parse_urdf(load_robot_description(ROBOTS / "humanoid_20dof.urdf.xacro"))
    assert m.name == "humanoid_20dof"
    movable = {j.name for j in m.movable_joints()}
    assert movable == set(LEG_JOINTS) | {f"{s}_{j}" for s in ("left", "right")
                                         for j in ("shoulder_pitch", "shoulder_roll", "shoulder_yaw", "elbow")}
    assert m.joints["waist_yaw"].type == m.joints["neck_pitch"].type == "fixed"
    assert all((j.velocity, j.effort) == (2.0, 50.0) for j in m.movable_joints())
    assert {c.name for c in m.ros2_control} == movable
    for c in m.ros2_control:
        assert c.command_interfaces == ["position", "velocity", "effort"]
        assert c.bounds["velocity"] == (-2.0, 2.0) and c.bounds["effort"] == (-50.0, 50.0)
    assert [str(i) for i in validate(m)] == []
    assert m.total_mass() == pytest.approx(model("humanoid").total_mass())
    # the command line still overrides the variant's defaults; a wrong dof is refused by name
    other = parse_urdf(load_robot_description(ROBOTS / "humanoid_20dof.urdf.xacro",
                                              xacro_args=parse_xacro_args(["effort_limit:=80", "dof:=22"])))
    assert len(other.movable_joints()) == 22 and {j.effort for j in other.movable_joints()} == {80.0}
    from nodes.urdf import UrdfError
    with pytest.raises(UrdfError, match="dof must be 22 or 20, got 21"):
        load_robot_description(ROBOTS / "humanoid.urdf.xacro", xacro_args={"dof": "21"})


def test_humanoid_centre_of_mass_is_over_the_feet_standing_and_squatting(tmp_path: Path) -> None:
    """Statically stable in both tutorial poses: the CoM projects inside the feet's support polygon."""
    import dartpy as dart

    loader = dart.utils.DartLoader()
    options = dart.utils.DartLoaderOptions()
    options.mDefaultRootJointType = dart.utils.DartLoaderRootJointType.FIXED
    loader.setOptions(options)
    skeleton = loader.parseSkeleton(str(robot_file("humanoid")))
    tree = KinematicTree(model("humanoid"))
    bend = {f"{s}_{j}": v for s in ("left", "right") for j, v in
            (("hip_pitch", -0.2), ("knee", 0.4), ("ankle_pitch", -0.2))}
    for pose in ({}, bend):
        q = tree.configuration(pose)
        for name, value in zip(tree.dof_names, q, strict=True):
            skeleton.getJoint(name).setPosition(0, value)
        com = skeleton.getCOM()
        corners = np.vstack([_sole_corners(tree, q, f"{side}_foot")[0] for side in ("left", "right")])
        (x_min, y_min), (x_max, y_max) = corners[:, :2].min(axis=0), corners[:, :2].max(axis=0)
        assert x_min + 0.03 < com[0] < x_max - 0.03, (pose, com)  # 3 cm margin front and back
        assert y_min + 0.03 < com[1] < y_max - 0.03, (pose, com)
