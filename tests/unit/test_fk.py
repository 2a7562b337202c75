"""Our vectorised FK against DART's world transforms, the Module 2 lab's analytic FK, and mimic/prismatic."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nodes.kinematics import KinematicTree, matrix_to_quaternion, pose_matrix, quaternion_to_matrix
from nodes.urdf import load_robot_description, parse_urdf

ROBOTS = Path(__file__).resolve().parents[2] / "robots"
ROBOT_NAMES = ["humanoid", "humanoid_simplified", "simple_2dof_arm", "lab_robot", "atlas", "simple_robot"]


def load_tree(xml: str) -> KinematicTree:
    return KinematicTree(parse_urdf(xml))


def robot_xml(name: str) -> str:
    path = ROBOTS / (f"{name}.urdf.xacro" if name == "simple_robot" else f"{name}.urdf")
    return load_robot_description(path)


def dart_skeleton(xml: str, tmp_path: Path):
    import dartpy as dart

    path = tmp_path / "robot.urdf"
    path.write_text(xml)
    loader = dart.utils.DartLoader()
    options = dart.utils.DartLoaderOptions()
    options.mDefaultRootJointType = dart.utils.DartLoaderRootJointType.FIXED  # root at the world origin
    loader.setOptions(options)
    skeleton = loader.parseSkeleton(str(path))
    assert skeleton is not None
    return skeleton


@pytest.mark.parametrize("name", ROBOT_NAMES)
def test_fk_matches_dart_world_transforms_for_100_random_configurations(name: str, tmp_path: Path) -> None:
    xml = robot_xml(name)
    tree = load_tree(xml)
    skeleton = dart_skeleton(xml, tmp_path)
    rng = np.random.default_rng(1234)
    configs = rng.uniform(-math.pi, math.pi, size=(100, tree.num_dofs))
    batch = tree.link_transforms(configs)  # one batched call for all 100
    dart_joints = [skeleton.getJoint(n) for n in tree.dof_names]  # DART's DOF order differs: map by name
    bodies = [skeleton.getBodyNode(n) for n in tree.link_names]
    worst_position = worst_rotation = 0.0
    for k, q in enumerate(configs):
        for joint, value in zip(dart_joints, q, strict=True):
            joint.setPosition(0, value)
        single = tree.link_transforms(q)
        assert np.array_equal(single, batch[k])
        for i, body in enumerate(bodies):
            expected = body.getWorldTransform().matrix()
            worst_position = max(worst_position, float(np.abs(expected[:3, 3] - single[i, :3, 3]).max()))
            relative = expected[:3, :3].T @ single[i, :3, :3]
            # atan2 form of the rotation angle: exact for tiny angles (acos loses half the digits there).
            skew = relative - relative.T
            sine = math.sqrt(skew[2, 1] ** 2 + skew[0, 2] ** 2 + skew[1, 0] ** 2) / 2.0
            angle = math.atan2(sine, (np.trace(relative) - 1.0) / 2.0)
            worst_rotation = max(worst_rotation, angle)
    assert worst_position < 1e-9
    assert worst_rotation < 1e-9


def test_module2_lab_left_hand_matches_the_tutorial_planar_fk() -> None:
    tree = load_tree(robot_xml("humanoid_simplified"))

    def tutorial_fk(shoulder: float, elbow: float) -> tuple[float, float, float]:
        # The lab's analytic FK: shoulder at (0.15, 0.1, 0.15), upper arm 0.25, forearm 0.2, planar in x-y.
        ux = 0.15 + 0.25 * math.cos(shoulder)
        uy = 0.1 + 0.25 * math.sin(shoulder)
        return (ux + 0.2 * math.cos(shoulder + elbow), uy + 0.2 * math.sin(shoulder + elbow), 0.15)

    for wrist in (0.0, 0.7):
        q = tree.configuration({"left_shoulder_joint": math.radians(45), "left_elbow_joint": math.radians(90),
                                "left_wrist_joint": wrist})
        hand = tree.link_transform(q, "left_hand")[:3, 3]
        assert np.allclose(hand, tutorial_fk(math.radians(45), math.radians(90)), atol=1e-12)
    # The worked example's numbers: (0.1768 + 0.15 - 0.1414, 0.1 + 0.1768 + 0.1414, 0.15)
    assert np.allclose(hand, (0.18536, 0.41820, 0.15), atol=1e-4)


MIMIC_URDF = """<robot name="gripper">
  <link name="base"/>
  <link name="a"/><link name="b"/><link name="c"/><link name="slider"/>
  <joint name="ja" type="revolute"><parent link="base"/><child link="a"/><origin xyz="0.1 0 0" rpy="0.3 0 0"/>
    <axis xyz="0 1 1"/><limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
  <joint name="jb" type="revolute"><parent link="a"/><child link="b"/><origin xyz="0 0.2 0"/>
    <axis xyz="0 0 1"/><limit lower="-2" upper="2" effort="1" velocity="1"/>{mimic_b}</joint>
  <joint name="jc" type="continuous"><parent link="b"/><child link="c"/><origin xyz="0 0 0.3" rpy="0 0.5 0"/>
    <axis xyz="1 0 0"/>{mimic_c}</joint>
  <joint name="js" type="prismatic"><parent link="base"/><child link="slider"/><origin xyz="0 0 0" rpy="0 0 0.7"/>
    <axis xyz="1 0 0"/><limit lower="0" upper="0.5" effort="1" velocity="1"/></joint>
</robot>"""


def test_mimic_chain_equals_setting_the_joints_directly() -> None:
    mimic = load_tree(MIMIC_URDF.format(mimic_b='<mimic joint="ja" multiplier="2" offset="0.1"/>',
                                        mimic_c='<mimic joint="jb" multiplier="-0.5" offset="0.2"/>'))
    plain = load_tree(MIMIC_URDF.format(mimic_b="", mimic_c=""))
    assert mimic.dof_names == ["ja", "js"]
    qa, qs = 0.4, 0.3
    qb = 2 * qa + 0.1
    qc = -0.5 * qb + 0.2
    expected = plain.link_transforms(plain.configuration({"ja": qa, "jb": qb, "jc": qc, "js": qs}))
    got = mimic.link_transforms(mimic.configuration({"ja": qa, "js": qs}))
    assert np.allclose(got, expected, atol=1e-12)


def test_prismatic_and_continuous_joints_match_dart(tmp_path: Path) -> None:
    xml = MIMIC_URDF.format(mimic_b="", mimic_c="")
    tree = load_tree(xml)
    skeleton = dart_skeleton(xml, tmp_path)
    q = tree.configuration({"ja": 0.3, "jb": -1.1, "jc": 2.5, "js": 0.25})
    for name, value in zip(tree.dof_names, q, strict=True):
        skeleton.getJoint(name).setPosition(0, value)
    world = tree.link_transforms(q)
    for i, link in enumerate(tree.link_names):
        assert np.allclose(world[i], skeleton.getBodyNode(link).getWorldTransform().matrix(), atol=1e-12)
    slider = world[tree.link_index["slider"], :3, 3]
    assert np.allclose(slider, [0.25 * math.cos(0.7), 0.25 * math.sin(0.7), 0.0])


def test_wrong_number_of_joint_values_is_rejected_and_unknown_names_are_ignored() -> None:
    tree = load_tree(robot_xml("simple_2dof_arm"))
    with pytest.raises(ValueError, match="2 degrees of freedom"):
        tree.link_transforms(np.zeros(3))
    assert np.array_equal(tree.configuration({"shoulder_joint": 1.0, "nope": 5.0}), [1.0, 0.0])


@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(-1.0, 1.0), min_size=4, max_size=4).filter(lambda v: np.linalg.norm(v) > 1e-3))
def test_quaternion_round_trip(values: list[float]) -> None:
    quat = np.array(values) / np.linalg.norm(values)
    rotation = quaternion_to_matrix(quat)
    back = matrix_to_quaternion(rotation)
    assert back[3] >= 0
    assert np.allclose(quaternion_to_matrix(back), rotation, atol=1e-12)
    assert np.allclose(np.abs(back @ quat), 1.0, atol=1e-12)


def test_quaternion_of_half_turns_is_exact() -> None:
    for axis in np.eye(3):
        rotation = 2 * np.outer(axis, axis) - np.eye(3)  # 180 degrees about the axis
        assert np.allclose(np.abs(matrix_to_quaternion(rotation)), [*axis, 0.0], atol=1e-15)
    pose = pose_matrix([1, 2, 3], [0, 0, math.sin(0.25), math.cos(0.25)])
    assert np.allclose(pose[:3, 3], [1, 2, 3]) and np.isclose(pose[1, 0], math.sin(0.5))


def test_state_publisher_transforms_compose_to_fk_and_include_mimic_joints() -> None:
    from nodes.state_publisher import TransformTree

    xml = MIMIC_URDF.format(mimic_b='<mimic joint="ja" multiplier="2" offset="0.1"/>', mimic_c="")
    tree = TransformTree(xml, frame_prefix="r/")
    unknown = tree.update(["jc", "ja", "ghost", "js"], [0.3, -0.4, 9.0, 0.2])
    assert unknown == ["ghost"]
    stamp = {"sec": 1, "nanosec": 0}
    transforms = tree.movable_transforms(stamp) + tree.static_transforms(stamp)
    assert {t["child_frame_id"] for t in transforms} == {"r/a", "r/b", "r/c", "r/slider"}  # jb (mimic) too
    assert tree.static_transforms(stamp) == []
    # Walk the published tree from the root: it must reproduce the FK of every link.
    by_child = {t["child_frame_id"]: t for t in transforms}
    fk = tree.kinematics.link_transforms(tree.positions)
    for link in ("a", "b", "c", "slider"):
        pose, frame = np.eye(4), "r/" + link
        while frame != tree.root_frame:
            t = by_child[frame]
            tr, rot = t["transform"]["translation"], t["transform"]["rotation"]
            pose = pose_matrix([tr["x"], tr["y"], tr["z"]], [rot[k] for k in "xyzw"]) @ pose
            frame = t["header"]["frame_id"]
        assert np.allclose(pose, fk[tree.kinematics.link_index[link]], atol=1e-12), link
    # Missing joints keep their last value.
    tree.update(["js"], [0.4])
    assert tree.positions[tree.kinematics.dof_index["ja"]] == -0.4


def test_state_publisher_refuses_an_invalid_description() -> None:
    from nodes.state_publisher import TransformTree
    from nodes.urdf import UrdfError

    with pytest.raises(UrdfError, match="lower limit"):
        TransformTree((ROBOTS.parent / "tests/data/urdf_broken/limits_inverted.urdf").read_text())


@pytest.mark.parametrize("name", ["humanoid", "atlas"])
def test_matrix_free_local_poses_equal_local_transforms(name: str) -> None:
    tree = load_tree(robot_xml(name))
    configs = np.random.default_rng(7).uniform(-math.pi, math.pi, size=(50, tree.num_dofs))
    translation, quaternion = tree.local_poses(configs)
    local = tree.local_transforms(configs)
    assert np.allclose(np.linalg.norm(quaternion, axis=-1), 1.0, atol=1e-12)
    assert np.allclose(quaternion_to_matrix(quaternion), local[..., :3, :3], atol=1e-12)
    assert np.allclose(translation, local[..., :3, 3], atol=1e-12)
