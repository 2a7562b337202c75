"""Real robots from example-robot-data in the main job (``robot_file:=``), with the real simulator and the real
controllers in empty.world: G1 stands and squats through the JTC, TALOS (frame links merged) stands in its
SRDF half_sitting pose, and a robot without <ros2_control> runs on the block and controllers generated for
it, which are the files written."""

from __future__ import annotations

import math
import time
from importlib.metadata import PackageNotFoundError, distribution
from pathlib import Path

import msgpack
import pytest
import yaml

from tests.integration.test_launch_scenarios import Scenario
from tests.integration.test_lockstep_main_job import call

try:
    distribution("example-robot-data")
    from nodes.urdf.paths import package_root

    ROBOTS = package_root("example-robot-data")[0] / "robots"
except (PackageNotFoundError, Exception):   # noqa: BLE001 - the robots extra not installed
    ROBOTS = None

needs_robots = pytest.mark.skipif(ROBOTS is None, reason="example-robot-data (the robots extra) not installed")
G1_LEGS = [f"{side}_{j}_joint" for side in ("left", "right") for j in ("hip_pitch", "knee", "ankle_pitch")]
SQUAT = [-0.5, 1.0, -0.5, -0.5, 1.0, -0.5]


def stamp(msg: dict) -> float:
    return msg["header"]["stamp"]["sec"] + msg["header"]["stamp"]["nanosec"] * 1e-9


def base(scenario: Scenario, since: float = 0.0, ns: str = "humanoid") -> list[tuple[float, float]]:
    """(height, tilt in degrees) of the robot's base in sim/model_states received after ``since``."""
    out = []
    for m in scenario.snapshot("sim/model_states"):
        if ns in m["name"] and m["_received"] >= since:
            pose = m["pose"][m["name"].index(ns)]
            q = pose["orientation"]
            up_z = 1 - 2 * (q["x"] ** 2 + q["y"] ** 2)    # the base's z axis, seen from the world's
            out.append((pose["position"]["z"], math.degrees(math.acos(max(-1.0, min(1.0, up_z))))))
    return out


def sim_time(scenario: Scenario, ns: str = "humanoid") -> float:
    states = scenario.snapshot(f"{ns}/joint_states")
    return stamp(states[-1]) if states else 0.0


def active(scenario: Scenario, ns: str = "humanoid") -> dict[str, str]:
    listed = call(scenario.session, f"{ns}/controller_manager/list_controllers", {}, timeout=2.0)
    return {c["name"]: c["state"] for c in (listed or {}).get("controller", [])}


def stands(scenario: Scenario, seconds: float, ns: str = "humanoid") -> tuple[float, list[tuple[float, float]]]:
    """Waits ``seconds`` of sim time after the controllers are active; returns the settled height and the
    (height, tilt) samples of that stretch."""
    scenario.wait_for(lambda: active(scenario, ns).get("joint_trajectory_controller") == "active", 300,
                      "the trajectory controller active")
    start = sim_time(scenario, ns)
    scenario.wait_for(lambda: sim_time(scenario, ns) >= start + 1.0, 120, "1 s of sim time")
    settled_at = time.monotonic()
    scenario.wait_for(lambda: sim_time(scenario, ns) >= start + 1.0 + seconds, 600, f"{seconds} s of sim time")
    samples = base(scenario, settled_at, ns)
    assert len(samples) > 10
    return samples[0][0], samples


@pytest.fixture(autouse=True)
def own_cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Generated robot files go to this test's folder (the launch's children inherit the environment)."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))


def launch(tmp_path: Path, port: int, *args: str) -> Scenario:
    return Scenario(tmp_path, port, "humanoid.yaml", "mode:=lockstep", "commander:=none", "sensors:=false",
                    "world:=empty.world", *args)


@needs_robots
@pytest.mark.slow
@pytest.mark.timeout(900)   # 19 s of lockstep sim time: minutes when the machine is loaded (load 20 seen)
def test_g1_stands_squats_through_the_jtc_and_comes_back(tmp_path: Path, zenoh_port: int) -> None:
    g1 = ROBOTS / "g1_description" / "urdf" / "g1_29dof_rev_1_0.urdf"
    scenario = launch(tmp_path, zenoh_port, f"robot_file:={g1}")
    try:
        scenario.connect("sim/model_states", "humanoid/joint_states")
        height, samples = stands(scenario, 10.0)
        assert all(abs(z - height) <= 0.05 * height for z, _ in samples), (height, min(samples), max(samples))
        assert max(t for _, t in samples) < 5.0

        # down in 2 s, held, back up: the knees reach their targets, hips and ankles keep the trunk over the feet
        down = {"header": {"stamp": {"sec": 0, "nanosec": 0}}, "joint_names": G1_LEGS,
                "points": [{"positions": SQUAT, "time_from_start": {"sec": 2, "nanosec": 0}},
                           {"positions": SQUAT, "time_from_start": {"sec": 4, "nanosec": 0}},
                           {"positions": [0.0] * 6, "time_from_start": {"sec": 6, "nanosec": 0}}]}
        start = sim_time(scenario)
        scenario.session.put("humanoid/joint_trajectory_controller/joint_trajectory", msgpack.packb(down))
        scenario.wait_for(lambda: sim_time(scenario) >= start + 8.0, 600, "the squat and 2 s after it")
        states = [m for m in scenario.snapshot("humanoid/joint_states") if stamp(m) >= start]
        bottom = [m for m in states if start + 3.0 <= stamp(m) <= start + 4.0]
        for name, target in zip(G1_LEGS, SQUAT, strict=True):
            got = [m["position"][m["name"].index(name)] for m in bottom]
            assert all(abs(q - target) <= 0.05 for q in got), (name, target, min(got), max(got))
        heights = [z for z, _ in base(scenario) if z]
        assert min(heights) > 0.5 * height, "G1 fell"
        after = [m for m in states if stamp(m) >= start + 7.0]
        assert all(abs(m["position"][m["name"].index("left_knee_joint")]) <= 0.05 for m in after)
        z, tilt = base(scenario)[-1]
        assert abs(z - height) <= 0.05 * height and tilt < 5.0
    finally:
        scenario.close()


@needs_robots
@pytest.mark.slow
@pytest.mark.timeout(900)
def test_talos_with_its_frames_merged_stands_half_sitting(tmp_path: Path, zenoh_port: int) -> None:
    talos = ROBOTS / "talos_data" / "robots" / "talos_reduced.urdf"
    scenario = launch(tmp_path, zenoh_port, f"robot_file:={talos}", "initial_pose:=half_sitting")
    try:
        scenario.connect("sim/model_states", "humanoid/joint_states", "rosout")
        height, samples = stands(scenario, 10.0)
        assert all(abs(z - height) <= 0.05 * height for z, _ in samples), (height, min(samples), max(samples))
        assert max(t for _, t in samples) < 5.0
        knee = [m["position"][m["name"].index("leg_left_4_joint")] for m in scenario.snapshot("humanoid/joint_states")]
        assert abs(knee[-1] - 0.859395) < 0.05     # held in half_sitting by the JTC
        logged = [m["msg"] for m in scenario.snapshot("rosout")]
        assert any("frames, merged into their parent body" in line and "rgbd_optical_frame" in line
                   for line in logged), logged
    finally:
        scenario.close()


@pytest.mark.slow
def test_a_robot_without_ros2_control_runs_on_the_generated_files(tmp_path: Path, zenoh_port: int) -> None:
    """Our humanoid with its <ros2_control> block cut out, as robot 'bare' (no config/ file of its own): the
    launch generates a block and a controllers file, and what runs (the hardware's interfaces, the controllers
    loaded) is what was written."""
    root = Path(__file__).resolve().parents[2]
    text = (root / "robots" / "humanoid.urdf").read_text()
    bare = text[:text.index("<ros2_control")] + text[text.index("</ros2_control>") + len("</ros2_control>"):]
    urdf = tmp_path / "bare_humanoid.urdf"
    urdf.write_text(bare)
    scenario = launch(tmp_path, zenoh_port, "robot:=bare", f"robot_file:={urdf}")
    try:
        scenario.connect("sim/model_states", "bare/joint_states")
        height, samples = stands(scenario, 3.0, "bare")
        assert max(t for _, t in samples) < 5.0
        (written,) = list((tmp_path / "cache" / "zenroid" / "robots").glob("*/*_controllers.yaml"))
        assert f"written to {written.parent}" in scenario.output()
        config = yaml.safe_load(written.read_text())
        manager = config["controller_manager"]["ros__parameters"]
        # the controller manager runs the file written (the sensor broadcasters in it too: the humanoid declares
        # its sensors, which sensors:=false leaves out of the simulation, so those do not activate)
        (line,) = [x for x in scenario.output().splitlines() if "controllers in config:" in x]
        in_config = yaml.safe_load(line.split("controllers in config:")[1].strip())
        assert set(in_config) == {n for n, v in manager.items() if isinstance(v, dict)}
        loaded = active(scenario, "bare")
        assert loaded["joint_state_broadcaster"] == loaded["joint_trajectory_controller"] == "active"
        info = call(scenario.session, "bare/hardware/info", {}, timeout=2.0)
        block = (written.parent / "humanoid.ros2_control.xml").read_text()
        for joint in info["joints"]:
            assert f'<joint name="{joint["name"]}">' in block
            assert joint["command_interfaces"] == ["position"]
            assert joint["state_interfaces"] == ["position", "velocity"]
        jtc = config["joint_trajectory_controller"]["ros__parameters"]["joints"]
        assert jtc == [j["name"] for j in info["joints"]]
    finally:
        scenario.close()


LINK = ('<link name="base"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" '
        'iyz="0"/></inertial>{shape}</link>')


@pytest.mark.parametrize("name, text, reason", [
    ("broken.urdf.xacro",
     '<robot xmlns:xacro="http://www.ros.org/wiki/xacro" name="r"><xacro:undefined_macro/></robot>',
     "xacro failed on {file}"),
    ("nowhere.urdf",
     '<robot name="r">' + LINK.format(shape='<collision><geometry><mesh filename="package://nowhere_pkg/a.stl"/>'
                                            '</geometry></collision>') + "</robot>",
     "package 'nowhere_pkg' not found (searched: "),
    ("escape.urdf",
     '<robot name="r">' + LINK.format(shape='<collision><geometry><mesh filename="../../../../etc/passwd"/>'
                                            '</geometry></collision>') + "</robot>",
     "outside its package root"),
    ("massless.urdf",
     '<robot name="r">' + LINK.format(shape="") + '<link name="arm"/><joint name="j" type="revolute">'
     '<parent link="base"/><child link="arm"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>',
     "link 'arm' is moved by revolute joint 'j' but has no <inertial>"),
])
def test_a_bad_robot_ends_the_launch_at_once_naming_file_and_reason(tmp_path: Path, zenoh_port: int, name: str,
                                                                     text: str, reason: str) -> None:
    import subprocess
    import sys

    robot = tmp_path / "pkg" / "urdf" / name
    robot.parent.mkdir(parents=True)
    robot.write_text(text)
    root = Path(__file__).resolve().parents[2]
    done = subprocess.run([sys.executable, "-m", "launch", "humanoid.yaml", f"robot_file:={robot}", "gui:=false",
                           f"zenoh_port:={zenoh_port}"], cwd=root, capture_output=True, text=True, timeout=120)
    assert done.returncode == 1, done.stdout + done.stderr
    assert str(robot) in done.stderr and reason.format(file=robot) in done.stderr, done.stderr
    assert "started '" not in done.stdout + done.stderr     # no process was started
