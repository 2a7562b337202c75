"""Unit tests of the visualiser's pure parts: URDF model, kinematics, rate limits, the Rerun scene, outputs."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import rerun as rr
from hypothesis import given, settings
from hypothesis import strategies as st

from nodes.kinematics import KinematicTree
from nodes.kinematics import matrix_to_quaternion as matrix_to_quat
from nodes.kinematics import quaternion_to_matrix as quat_to_matrix
from nodes.urdf.model import UrdfError
from nodes.urdf.model import rpy_matrix as rpy_to_matrix
from nodes.viz.blueprint import build_blueprint
from nodes.viz.ratelimit import RateLimiter
from nodes.viz.scene import WORLD_FRAME, RobotScene, frame_name, plot_groups
from nodes.viz.scene import parse_model as parse_urdf
from nodes.viz.sink import OutputPlan
from tests.support.rrd import record as record_rrd

ROOT = Path(__file__).resolve().parents[2]
HUMANOID = (ROOT / "robots" / "humanoid.urdf").read_text()

LEG = """<robot name="leg">
  <material name="red"><color rgba="1 0 0 1"/></material>
  <link name="hip"><visual><geometry><box size="0.2 0.2 0.1"/></geometry><material name="red"/></visual></link>
  <link name="thigh">
    <visual><origin xyz="0 0 -0.2" rpy="0 0 0"/><geometry><cylinder radius="0.05" length="0.4"/></geometry>
      <material name="inline"><color rgba="0 0 1 0.5"/></material></visual>
  </link>
  <link name="foot"><visual><geometry><sphere radius="0.05"/></geometry></visual></link>
  <joint name="hip_pitch" type="revolute"><parent link="hip"/><child link="thigh"/>
    <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="ankle" type="fixed"><parent link="thigh"/><child link="foot"/><origin xyz="0 0 -0.4"/></joint>
</robot>"""


# -- URDF model -----------------------------------------------------------------------------------------
def test_urdf_visuals_colours_and_tree() -> None:
    model = parse_urdf(LEG)
    assert model.root == "hip"
    assert [v.kind for link in ("hip", "thigh", "foot") for v in model.links[link].visuals] == [
        "box", "cylinder", "sphere"]
    assert model.links["hip"].visuals[0].rgba == (1.0, 0.0, 0.0, 1.0)  # named top-level material
    assert model.links["thigh"].visuals[0].rgba == (0.0, 0.0, 1.0, 0.5)  # inline colour
    assert model.links["foot"].visuals[0].rgba == (0.7, 0.7, 0.7, 1.0)  # default grey
    assert [j.name for j in model.movable_joints()] == ["hip_pitch"]
    assert model.leaf_links() == ["foot"]


def test_humanoid_has_a_visual_on_every_link() -> None:
    model = parse_urdf(HUMANOID)
    frames = ["camera_link", "camera_optical_frame", "lidar_link", "laser_link"]   # sensor frames: no shape
    assert len(model.links) == 27 and model.visual_links() == [link for link in model.links if link not in frames]
    assert model.root == "pelvis" and len(model.movable_joints()) == 22


@pytest.mark.parametrize("xml, reason", [
    ("", "robot_description: empty"),
    ("<robot", "XML syntax error"),
    ("<model/>", "root element is <model>"),
    ('<!DOCTYPE r [<!ENTITY a "aaaa">]><robot name="r"/>', "XML declares entities (<!ENTITY ...>): refused"),
    ('<robot name="r"></robot>', "robot 'r' has no links"),
    ('<robot name="r"><link name="a"><visual><geometry><box size="1 2"/></geometry></visual></link></robot>',
     "link 'a', visual 0: <box size='1 2'> needs 3 number(s), got 2"),
    ('<robot name="r"><link name="a"><visual><geometry><sphere radius="nan"/></geometry></visual></link></robot>',
     "link 'a', visual 0: <sphere radius='nan'> is not finite"),
    ('<robot name="r"><link name="a"><visual><geometry><cone/></geometry></visual></link></robot>',
     "unknown geometry 'cone'"),
    ('<robot name="r"><link name="a"/><joint name="j" type="revolute"><parent link="a"/><child link="b"/>'
     '</joint></robot>', "joint 'j': a revolute joint needs a <limit> element"),
    ('<robot name="r"><link name="a"/><joint name="j" type="continuous"><parent link="a"/><child link="b"/>'
     '</joint></robot>', "joint 'j': child link 'b' does not exist"),
    ('<robot name="r"><link name="a"/><link name="b"/></robot>', "several root links: a, b"),
    ('<robot name="r"><link name="a"/><link name="b"/><joint name="j" type="revolute"><parent link="a"/>'
     '<child link="b"/><axis xyz="0 0 0"/></joint></robot>', "joint 'j': <axis xyz> is the zero vector"),
])
def test_bad_urdf_names_the_element_and_reason(xml: str, reason: str) -> None:
    with pytest.raises(UrdfError, match=None) as info:
        parse_urdf(xml)
    assert reason in str(info.value)


# -- kinematics -----------------------------------------------------------------------------------------
angles = st.floats(min_value=-math.pi, max_value=math.pi, allow_nan=False)


@settings(max_examples=200, deadline=None)
@given(angles, angles, angles)
def test_quaternion_round_trip(roll: float, pitch: float, yaw: float) -> None:
    rotation = rpy_to_matrix(roll, pitch, yaw)
    assert np.allclose(rotation @ rotation.T, np.eye(3), atol=1e-12)
    assert np.allclose(quat_to_matrix(matrix_to_quat(rotation)), rotation, atol=1e-9)


def test_rpy_is_fixed_axis_xyz() -> None:
    # yaw 90 deg maps x to y; roll then pitch then yaw
    assert np.allclose(rpy_to_matrix(0, 0, math.pi / 2) @ [1, 0, 0], [0, 1, 0])
    assert np.allclose(rpy_to_matrix(math.pi / 2, 0, math.pi / 2) @ [0, 1, 0], [0, 0, 1])


def test_forward_kinematics_of_a_pitched_leg() -> None:
    fk = KinematicTree(parse_urdf(LEG))
    foot = fk.link_transform(fk.configuration({"hip_pitch": math.pi / 2}), "foot")
    # Pitching +90 deg about y swings the foot (0.4 m down the thigh) forward to -x... about +y: z -> x
    assert np.allclose(foot[:3, 3], [-0.4, 0.0, 0.0], atol=1e-12)
    tf = dict(zip(fk.child_names, fk.parent_names, strict=True))  # child -> parent, what tf publishes
    assert tf["thigh"] == "hip" and tf["foot"] == "thigh"


def _reference_link_poses(model, values: dict[str, float]) -> dict[str, np.ndarray]:
    """Naive FK, one joint at a time from the root (what the visualiser's own FK used to do)."""
    poses = {model.root: np.eye(4)}
    frontier = [model.root]
    while frontier:
        link = frontier.pop()
        for joint in model.children_of(link):
            motion = np.eye(4)
            q = values.get(joint.name, 0.0)
            if joint.type in ("revolute", "continuous"):
                x, y, z = joint.axis
                c, s, t = math.cos(q), math.sin(q), 1.0 - math.cos(q)
                motion[:3, :3] = [[t * x * x + c, t * x * y - s * z, t * x * z + s * y],
                                  [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
                                  [t * x * z - s * y, t * y * z + s * x, t * z * z + c]]
            elif joint.type == "prismatic":
                motion[:3, 3] = np.asarray(joint.axis) * q
            poses[joint.child] = poses[link] @ joint.origin @ motion
            frontier.append(joint.child)
    return poses


def test_our_fk_matches_the_projects_fk_on_the_humanoid() -> None:
    from nodes.kinematics import KinematicTree
    from nodes.urdf import parse_urdf as project_parse

    model = project_parse(HUMANOID)
    theirs = KinematicTree(model)
    rng = np.random.default_rng(7)
    for _ in range(5):
        values = {name: float(v) for name, v in zip(theirs.dof_names, rng.uniform(-1, 1, len(theirs.dof_names)),
                                                    strict=True)}
        q = theirs.configuration(values)
        ours = _reference_link_poses(model, values)
        for link in ("left_foot", "right_forearm", "head"):
            assert np.allclose(ours[link], theirs.link_transform(q, link), atol=1e-9), link


# -- rate limits ----------------------------------------------------------------------------------------
def test_rate_limiter_keeps_the_average_rate_and_drops_the_rest() -> None:
    now = [0.0]
    limiter = RateLimiter(10.0, clock=lambda: now[0])
    passed = 0
    for _ in range(1000):  # 1 kHz input for 1 s
        passed += limiter.ready()
        now[0] += 0.001
    assert passed == 10
    assert RateLimiter(0.0).ready() and RateLimiter(0.0).ready()  # 0 = unlimited


def test_rate_limiter_resyncs_after_a_gap() -> None:
    now = [0.0]
    limiter = RateLimiter(10.0, clock=lambda: now[0])
    assert limiter.ready()
    now[0] = 5.0
    assert limiter.ready()
    now[0] = 5.01
    assert not limiter.ready(), "no burst of catch-up samples after a pause"


# -- scene (real rerun, saved to a file, read back) -----------------------------------------------------
def test_frame_names() -> None:
    assert frame_name("humanoid", "left_shin") == "humanoid/left_shin"
    assert frame_name("humanoid", "/humanoid/left_shin") == "humanoid/left_shin"
    assert frame_name("humanoid", "world") == WORLD_FRAME
    assert frame_name("humanoid", "odom") == WORLD_FRAME


def record(tmp_path: Path, body) -> dict:
    return record_rrd(tmp_path / "scene.rrd", body, "test_viz")


def _strips(row: dict, rgba: int) -> list:
    """The line strips of one colour (packed RGBA) in a row of the robot entity."""
    return [strip for strip, color in zip(row["LineStrips3D:strips"], row["LineStrips3D:colors"], strict=True)
            if color == rgba]


def test_scene_logs_one_row_per_sample_with_pose_markers_and_plots(tmp_path: Path) -> None:
    def body(recording: rr.RecordingStream) -> None:
        scene = RobotScene(recording, "leg", parse_urdf(LEG))
        assert scene.log_model(0.5) == 3
        scene.log_transforms(1.0, [("hip", "thigh", (0, 0, 0), (0, math.sin(0.15), 0, math.cos(0.15))),
                                   ("world", "hip", (1, 2, 3), (0, 0, 0, 1))])
        scene.log_base_pose(1.0, (9, 9, 9), (0, 0, 0, 1))  # ignored: tf already places the root
        scene.log_joint_states(1.0, ["hip_pitch"], [0.2], [0.1], [])
        scene.update_paths()
        scene.log_joint_states(1.1, ["hip_pitch"], [0.3], [0.1], [])
        scene.update_paths()
        scene.log_transforms(1.15, [("hip", "thigh", (0, 0, 0), (0, math.sin(0.15), 0, math.cos(0.15)))])
        scene.log_target(1.2, "jtc", {"hip_pitch": 1.0})  # both drawn with the next joint_states row
        scene.log_joint_states(1.2, ["hip_pitch"], [0.3], [0.1], [],
                               controllers={"jtc": (["hip_pitch"], [0.4], [0.35])}, balance=[0, 0, 0.5, 0, 0, 1])
        scene.clear(2.0)

    data = record(tmp_path, body)
    assert not [name for name in data if name.startswith("plots")], "no plot entities: plots are robot columns"
    robot = data["world/leg/robot"]
    # One row per call that draws: the model, the first tf, then only the joint_states samples (a tf update
    # or a new target in between waits for the next sample: one kind of row, one chunk per flush).
    assert [r["sim_time"] for r in robot.rows] == [0.5, 1.0, 1.0, 1.1, 1.2]
    # Each primitive an instance of its archetype, placed in the world through the tf tree, URDF colours.
    assert robot.rows[0]["Cylinders3D:colors"] == [0x0000FF80]
    first, moved = (robot.rows[i]["Cylinders3D:centers"][0] for i in (0, 1))
    assert np.allclose(first, [0, 0, -0.2], atol=1e-6), "at the origin until a pose arrives"
    # hip at (1, 2, 3), thigh pitched 0.3 rad: the cylinder's centre 0.2 m down the pitched thigh
    assert np.allclose(moved, [1 - 0.2 * math.sin(0.3), 2, 3 - 0.2 * math.cos(0.3)], atol=1e-5)
    last = robot.rows[-1]
    assert np.allclose(last["Ellipsoids3D:centers"][0], [1 - 0.4 * math.sin(0.3), 2, 3 - 0.4 * math.cos(0.3)],
                       atol=1e-5)
    assert last["Boxes3D:centers"][0] == pytest.approx([1.0, 2.0, 3.0])
    # Plotted values: columns per quantity and joint group (a small robot is one group, "joints").
    assert robot.column("position:joints") == [(1.0, [0.2]), (1.1, [0.3]), (1.2, [0.3])]
    assert robot.column("velocity:joints")[-1] == (1.2, [0.1])
    assert robot.column("effort:joints") == [], "no efforts in the message: no column"
    assert robot.column("jtc:joints") == [(1.2, [0.4, 0.35])], "reference, actual per joint"
    assert robot.column("balance:values") == [(1.2, [0.0, 0.0, 0.5, 0.0, 0.0, 1.0])]
    # Markers in the same row: the foot path from the world pose of the hip (1, 2, 3) + the pitched leg, and
    # the target pose's skeleton with its end effector.
    [path] = _strips(last, 0xE63CC8FF)
    assert len(path) == 2
    assert np.allclose(path[-1], [1 - 0.4 * math.sin(0.3), 2, 3 - 0.4 * math.cos(0.3)], atol=1e-5)
    assert len(_strips(last, 0xFF8C00A0)) == 2, "target skeleton: a segment per joint"
    assert np.allclose(last["Points3D:positions"][-1], [1 - 0.4 * math.sin(1.0), 2, 3 - 0.4 * math.cos(1.0)],
                       atol=1e-5)
    assert data["world/leg"].column("Clear:is_recursive") == [(2.0, [True])]


def test_rows_carry_only_the_plotted_quantities(tmp_path: Path) -> None:
    def body(recording: rr.RecordingStream) -> None:
        scene = RobotScene(recording, "leg", parse_urdf(LEG))
        scene.log_model(0.5)
        scene.log_joint_states(1.0, ["hip_pitch"], [0.2], [0.1], [0.5], ["position"])
        scene.log_transforms(1.05, [("hip", "thigh", (0, 0, 0), (0, 0, 0, 1))])  # waits for the next sample
        scene.log_joint_states(1.1, ["hip_pitch"], [0.3], [0.1], [0.5], [])

    robot = record(tmp_path, body)["world/leg/robot"]
    assert [r["sim_time"] for r in robot.rows] == [0.5, 1.0, 1.1], "no plotted values: still one row per sample"
    assert robot.column("position:joints") == [(1.0, [0.2])]
    assert robot.column("velocity:joints") == [] and robot.column("effort:joints") == []


def test_an_idle_robot_is_drawn_again_at_key_frames(tmp_path: Path) -> None:
    """Without joint_states rows (a paused simulation), a key frame re-logs the robot for late viewers."""
    def body(recording: rr.RecordingStream) -> None:
        scene = RobotScene(recording, "leg", parse_urdf(LEG))
        scene.log_model(0.5)
        scene.refresh(0.6, period=60.0)  # drawn just now: nothing
        scene.refresh(0.7, period=0.0)
        scene.log_joint_states(0.8, ["hip_pitch"], [0.2], [], [])
        scene.refresh(0.9, period=60.0)

    rows = record(tmp_path, body)["world/leg/robot"].rows
    assert [r["sim_time"] for r in rows] == [0.5, 0.7, 0.8]


def test_wall_clock_stamps_go_on_the_wall_time_timeline(tmp_path: Path) -> None:
    """arm_viz has no simulator: its stamps are seconds since 1970, which must not read "+20780d"."""
    def body(recording: rr.RecordingStream) -> None:
        scene = RobotScene(recording, "leg", parse_urdf(LEG))
        scene.log_joint_states(3.0, ["hip_pitch"], [0.1], [], [])
        scene.log_joint_states(1_795_000_000.5, ["hip_pitch"], [0.2], [], [])

    rows = record(tmp_path, body)["world/leg/robot"].rows
    [sim_row] = [r for r in rows if r["position:joints"] == [0.1]]
    [wall_row] = [r for r in rows if r["position:joints"] == [0.2]]
    assert sim_row["sim_time"] == 3.0
    assert "sim_time" not in wall_row and wall_row["wall_time"] == pytest.approx(1_795_000_000.5)


@pytest.mark.parametrize(("robot", "groups"), [
    ("humanoid", {"left leg": 6, "right leg": 6, "left arm": 4, "right arm": 4, "torso & head": 2}),
    ("atlas", {"left leg": 6, "right leg": 6, "left arm": 6, "right arm": 6, "torso & head": 4}),
    ("humanoid_simplified", {"joints": 6}),
])
def test_joint_groups_read_well(robot: str, groups: dict[str, int]) -> None:
    from nodes.share import robot_file
    from nodes.viz.scene import MAX_GROUP, joint_groups, short_labels

    names = [j.name for j in parse_urdf(robot_file(robot).read_text()).movable_joints()]
    found = joint_groups(names)
    assert {g: len(m) for g, m in found.items()} == groups
    assert sorted(j for m in found.values() for j in m) == sorted(names), "every joint in exactly one plot"
    assert all(len(m) <= MAX_GROUP for m in found.values())
    labels = short_labels(found.get("left leg", []))[:2]
    assert labels in ([], ["hip_yaw", "hip_roll"], ["uhz", "mhx"]), "legends without the shared prefix"


def test_joint_groups_split_long_unnamed_lists() -> None:
    from nodes.viz.scene import joint_groups

    groups = joint_groups([f"joint{i}" for i in range(20)])
    assert [len(m) for m in groups.values()] == [8, 8, 4]


def test_scene_rejects_unknown_end_effectors() -> None:
    with pytest.raises(ValueError, match="end_effectors: unknown links \\['hand'\\]"):
        RobotScene(rr.RecordingStream("unused"), "leg", parse_urdf(LEG), end_effectors=["hand"])


def test_balance_markers_sit_on_the_ground(tmp_path: Path) -> None:
    def body(recording: rr.RecordingStream) -> None:
        scene = RobotScene(recording, "leg", parse_urdf(LEG))
        scene.update_balance((0.01, 0.0, 0.8), (0.02, 0.0), False,
                             [(0.1, 0.1, 0.0), (0.1, -0.1, 0.0), (-0.1, -0.1, 0.0)])
        scene.log_joint_states(1.0, ["hip_pitch"], [0.0], [], [], balance=[0.01, 0.0, 0.8, 0.02, 0.0, 0.0])

    row = record(tmp_path, body)["world/leg/robot"].rows[0]
    [ring] = _strips(row, 0xE63C32FF)  # red: not balanced
    assert len(ring) == 4 and ring[0] == ring[-1], "closed polygon"
    assert all(0.0 < p[2] < 0.01 for p in ring), "on the ground"
    assert row["balance:values"][5] == 0.0, "is_balanced is the 6th series"
    assert np.allclose(row["Points3D:positions"][2], [0.02, 0.0, 0.003], atol=1e-6), "the ZMP on the ground"


# -- outputs and layout ---------------------------------------------------------------------------------
def test_output_plan_is_headless_without_a_display(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    plan = OutputPlan.resolve(None, False, False, None, 9090, 9876)
    assert plan.serve and not plan.spawn
    plan = OutputPlan.resolve(None, False, True, None, 9090, 9876)
    assert plan.serve and not plan.spawn and "no display" in plan.notes[0]
    plan = OutputPlan.resolve("x.rrd", False, False, None, 9090, 9876)
    assert plan.save == Path("x.rrd") and not plan.serve and not plan.spawn
    monkeypatch.setenv("DISPLAY", ":0")
    assert OutputPlan.resolve(None, False, False, None, 9090, 9876).spawn
    assert OutputPlan.resolve(None, False, False, True, 9090, 9876).serve  # --headless wins


def _blueprint_side(blueprint: Any) -> Any:
    """The plots beside the 3-D scene (which looks at the world frame)."""
    import rerun.blueprint as rrb

    scene, side = blueprint.root_container.contents
    assert isinstance(scene, rrb.Spatial3DView) and scene.origin == "world"
    return side


def _blueprint_views(item: Any) -> list[Any]:
    """Every view inside a blueprint container (depth first)."""
    children = getattr(item, "contents", None)
    if getattr(item, "kind", None) is None:  # a view: its contents are entity queries, not blueprint items
        return [item]
    return [view for child in children or [] for view in _blueprint_views(child)]


def _mapping(view: Any) -> tuple[str, str, list[str]]:
    """(entity, source column, legend names) of a time series view's one visualizer."""
    [(entity, [visualizer])] = view.visualizer_overrides.items()
    [mapping] = visualizer.mappings
    names = next(b.as_arrow_array().to_pylist() for b in visualizer.overrides
                 if str(b.component_descriptor()).endswith("names"))
    return str(entity), mapping.source_component, names


def test_blueprint_has_a_plot_per_limb_group_and_follows_the_newest_data() -> None:
    import rerun.blueprint as rrb

    from nodes.share import robot_file
    from nodes.viz.blueprint import RobotLayout

    empty = _blueprint_side(build_blueprint())  # nothing seen yet: one plot of everything logged
    assert isinstance(empty, rrb.TimeSeriesView) and empty.origin == "plots"

    names = [j.name for j in parse_urdf(robot_file("humanoid").read_text()).movable_joints()]
    groups = plot_groups(names)
    legs = [g for g in groups if g.part.endswith("leg")]
    one = _blueprint_side(build_blueprint({"humanoid": RobotLayout(
        groups, {"joint_trajectory_controller": legs}, True)}))
    assert one.name == "humanoid" and isinstance(one, rrb.Tabs)
    tabs = {tab.name: _blueprint_views(tab) for tab in one.contents}
    assert list(tabs) == ["positions", "velocities", "efforts", "joint_trajectory_controller", "balance"]
    parts = ["left_leg", "right_leg", "left_arm", "right_arm", "torso_head"]
    # Every plot reads a column of the robot entity and names its series (short labels, <= 8 per plot).
    assert [_mapping(v)[:2] for v in tabs["positions"]] == [("world/humanoid/robot", f"position:{p}") for p in parts]
    assert _mapping(tabs["positions"][0])[2] == ["hip_yaw", "hip_roll", "hip_pitch", "knee", "ankle_pitch",
                                                 "ankle_roll"]
    assert [_mapping(v)[1] for v in tabs["efforts"]] == [f"effort:{p}" for p in parts]
    controller = [_mapping(v) for v in tabs["joint_trajectory_controller"]]
    assert [c[1] for c in controller] == ["joint_trajectory_controller:left_leg", "joint_trajectory_controller:right_leg"]
    assert controller[0][2][:2] == ["hip_yaw ref", "hip_yaw"]
    assert _mapping(tabs["balance"][0])[1:] == ("balance:values", ["CoM x", "CoM y", "CoM z", "ZMP x", "ZMP y",
                                                                   "balanced"])

    two = _blueprint_side(build_blueprint({"a": RobotLayout(), "b": RobotLayout(
        plot_groups(["j"]), {"jtc": plot_groups(["j"])}, True)}))
    assert isinstance(two, rrb.Tabs)
    tabs = {tab.name: _blueprint_views(tab) for tab in two.contents}
    assert set(tabs) == {"a", "b"}
    for ns, views in tabs.items():
        assert views and all(str(v.origin) == f"world/{ns}/robot" for v in views), (ns, [v.origin for v in views])
    a_titles = " | ".join(str(v.name) for v in tabs["a"])
    assert "jtc" not in a_titles and "balance" not in a_titles, a_titles  # only what robot a has


def _blueprint_chunks(blueprint: Any, tmp_path: Path) -> int:
    """How many chunks a viewer takes in for this layout (one per blueprint entity and property)."""
    from rerun.chunk import RrdReader

    path = tmp_path / "layout.rbl"
    blueprint.save("zenroid_viz", str(path))
    reader = RrdReader(str(path))
    return sum(1 for _ in reader.stream(store=reader.blueprints()[0]))


def test_plot_tabs_are_chosen_and_each_costs_the_viewer_chunks(tmp_path: Path) -> None:
    """``plots`` picks the tabs; fewer tabs, fewer chunks for a late viewer to take in before the present."""
    import rerun.blueprint as rrb

    from nodes.share import robot_file
    from nodes.viz.blueprint import PLOT_TABS, RobotLayout

    groups = plot_groups([j.name for j in parse_urdf(robot_file("humanoid").read_text()).movable_joints()])
    layout = {"humanoid": RobotLayout(groups, {"joint_trajectory_controller": groups}, True)}
    side = _blueprint_side(build_blueprint(layout, plots=["positions", "balance"]))
    assert [tab.name for tab in side.contents] == ["positions", "balance"]
    [alone] = build_blueprint(layout, plots=[]).root_container.contents
    assert isinstance(alone, rrb.Spatial3DView), "no plots: the 3-D scene alone"
    counts = {plots: _blueprint_chunks(build_blueprint(layout, plots=list(plots)), tmp_path)
              for plots in (PLOT_TABS, ("positions",), ())}
    assert counts[()] < 15 < counts[("positions",)] < 60 < counts[PLOT_TABS], counts


def test_the_ground_is_the_viewers_grid_in_the_layout() -> None:
    """No ground data for the web server to drop from a short history: the 3-D view draws its own grid."""
    for ground in (True, False):
        scene = build_blueprint(ground=ground).root_container.contents[0]
        grid = scene.properties["LineGrid3D"]
        assert grid.visible.as_arrow_array().to_pylist() == [ground]
        assert grid.spacing.as_arrow_array().to_pylist() == [0.5]


def test_path_buffer_keeps_the_newest_points_in_order() -> None:
    from nodes.viz.scene import PathBuffer

    path = PathBuffer(3)
    assert len(path) == 0 and path.array().shape == (0, 3)
    for i in range(5):
        path.append((i, 0, 0))
    assert len(path) == 3
    assert path.array()[:, 0].tolist() == [2.0, 3.0, 4.0]


@pytest.mark.parametrize("robot", sorted(p.name for p in (ROOT / "robots").glob("*.urdf")))
def test_every_project_robot_is_drawable(robot: str) -> None:
    model = parse_urdf((ROOT / "robots" / robot).read_text())
    assert model.visual_links(), f"{robot}: nothing to draw"
    fk = KinematicTree(model)
    assert set(fk.link_names) == set(model.links), f"{robot}: links unreachable from the root"


def test_model_parse_refuses_a_billion_laughs_description() -> None:
    """The visualiser's model parse goes through the project's XML safety check: entities are never expanded."""
    text = (ROOT / "tests" / "data" / "urdf_broken" / "billion_laughs.urdf").read_text()
    with pytest.raises(UrdfError, match="XML declares entities .*refused"):
        parse_urdf(text)
    with pytest.raises(UrdfError, match="declares entities"):
        parse_urdf(text.replace('<?xml version="1.0"?>', '<?xml version="1.0" encoding="UTF-16"?>'))
