"""Real robots from example-robot-data in the main job (``robot_file:=``), with the real simulator and the real
controllers in empty.world: G1 stands and squats through the JTC, TALOS (frame links merged) stands in its
SRDF half_sitting pose, a robot without <ros2_control> runs on the block and controllers generated for
it, which are the files written, and a lab's own xacro package (examples/lab_biped_description, named by
``package://``) stands, its STL, DAE and OBJ meshes in the viewer's recording and in a camera's image."""

from __future__ import annotations

import math
import os
import time
from importlib.metadata import PackageNotFoundError, distribution
from pathlib import Path

import msgpack
import numpy as np
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
    # sim/model_states is best effort: when lockstep runs flat out on a loaded machine, Zenoh may drop a
    # stretch of it, so the stand is judged once enough samples of that stretch (or after it) have arrived.
    scenario.wait_for(lambda: len(base(scenario, settled_at, ns)) > 10, 120, "10 model_states after settling")
    samples = base(scenario, settled_at, ns)
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


LAB_BIPED = "package://lab_biped_description/urdf/lab_biped.urdf.xacro"
# the colours of the lab biped's meshes: the DAE's material, the URDF's material of the STLs, the OBJ's MTL
ORANGE, BLUE, GREEN = (0.9, 0.45, 0.1), (0.15, 0.25, 0.6), (0.1, 0.6, 0.25)
TRIPOD = """<robot name="tripod"><link name="tripod_link"><inertial><mass value="1"/>
<inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
<gazebo reference="tripod_link"><sensor name="camera" type="camera"><always_on>true</always_on>
<update_rate>5</update_rate><camera><horizontal_fov>1.0</horizontal_fov>
<image><width>160</width><height>120</height><format>R8G8B8</format></image><clip><near>0.05</near><far>20</far></clip>
</camera><plugin name="c" filename="libgazebo_ros_camera.so"><ros><remapping>camera/image_raw:=camera/rgb</remapping>
</ros><camera_name>camera</camera_name></plugin></sensor></gazebo></robot>"""


def share_of(rgb: np.ndarray, colour: tuple[float, float, float]) -> float:
    """The fraction of an image's pixels of ``colour`` (its chromaticity: shading only scales it)."""
    pixels = rgb.reshape(-1, 3).astype(float)
    lit = pixels.sum(axis=1) > 30
    chroma = pixels[lit] / pixels[lit].sum(axis=1, keepdims=True)
    return float((np.abs(chroma - np.array(colour) / sum(colour)).max(axis=1) < 0.04).sum() / len(pixels))


def mesh_of(data: dict, entity: str) -> dict:
    """The Mesh3D components the viewer recorded for ``entity`` (static and temporal rows merged)."""
    rows = data[entity]
    return {**rows.static, **{k: v for row in rows.rows for k, v in row.items() if v is not None}}


def rgba(colour: tuple[float, float, float]) -> int:
    return int("".join(f"{round(c * 255):02x}" for c in colour) + "ff", 16)


@pytest.mark.slow
@pytest.mark.timeout(600)
def test_a_lab_xacro_package_stands_and_its_meshes_are_drawn_and_seen(tmp_path: Path, zenoh_port: int,
                                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    """examples/lab_biped_description, as a user runs it: found through ROS_PACKAGE_PATH, its xacro (an
    included leg macro, $(find), args) expanded, no <ros2_control> (generated), frames merged, its SRDF's
    knees-bent "stand" as the initial pose, spawned at z:=auto. It stands 10 s; the viewer's recording has its DAE (millimetres, Y up), STL (binary and ASCII)
    and OBJ (MTL colour) meshes as Mesh3D in metres and in their colours; a camera on a tripod sees them."""
    from tests.support.rrd import load

    root = Path(__file__).resolve().parents[2]
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(root / "examples"))
    rrd = tmp_path / "lab_biped.rrd"
    scenario = launch(tmp_path, zenoh_port, "robot:=lab_biped", f"robot_file:={LAB_BIPED}", "initial_pose:=stand",
                      "sensors:=true", "gui:=true", f"viewer_args:=--save {rrd}")
    try:
        scenario.connect("sim/model_states", "lab_biped/joint_states", "tripod/camera/rgb")
        height, samples = stands(scenario, 10.0, "lab_biped")
        assert all(abs(z - height) <= 0.05 * height for z, _ in samples), (height, min(samples), max(samples))
        assert max(t for _, t in samples) < 5.0
        # knees bent (the SRDF's "stand", held by the JTC on the generated gains), the soles on the ground (z:=auto)
        assert 0.60 < height < 0.72, height
        knees = [m["position"][m["name"].index("left_knee_joint")] for m in scenario.snapshot("lab_biped/joint_states")]
        assert abs(knees[-1] - 0.7) < 0.05, knees[-1]
        print(f"lab biped standing: pelvis {height:.4f} m, {min(z for z, _ in samples):.4f}.."
              f"{max(z for z, _ in samples):.4f} m, tilt at most {max(t for _, t in samples):.2f} deg")

        # a camera on a tripod 1.5 m ahead of the biped, facing it
        reply = call(scenario.session, "sim/spawn_entity", {
            "name": "tripod", "xml": TRIPOD, "robot_namespace": "tripod", "fixed": True,
            "initial_pose": {"position": {"x": 1.5, "y": 0.0, "z": 0.5}, "orientation": {"z": 1.0, "w": 0.0}}},
            timeout=60)
        assert reply and reply["success"], reply
        scenario.wait_for(lambda: scenario.snapshot("tripod/camera/rgb"), 120, "the tripod's camera image")
        image = scenario.snapshot("tripod/camera/rgb")[-1]
        rgb = np.frombuffer(image["data"], np.uint8).reshape(image["height"], image["width"], 3)
        (tmp_path / "tripod.ppm").write_bytes(f"P6 {rgb.shape[1]} {rgb.shape[0]} 255\n".encode() + rgb.tobytes())
        shares = {name: share_of(rgb, colour) for name, colour in
                  (("torso (DAE)", ORANGE), ("legs (STL)", BLUE), ("feet (OBJ)", GREEN))}
        assert all(share > 0.002 for share in shares.values()), shares
        z, tilt = base(scenario, ns="lab_biped")[-1]
        assert abs(z - height) <= 0.05 * height and tilt < 5.0
    finally:
        scenario.close()
    data = load(rrd)
    links = "world/lab_biped/links"
    torso = mesh_of(data, f"{links}/base_link/visual_0")
    # millimetres and Y up in the file: metres and Z up here (0.24 deep, 0.30 wide, 0.36 tall)
    assert np.ptp(np.asarray(torso["Mesh3D:vertex_positions"]), axis=0) == pytest.approx([0.24, 0.30, 0.36],
                                                                                           abs=1e-4)
    assert set(torso["Mesh3D:vertex_colors"]) == {rgba(ORANGE)}
    for side in ("left", "right"):
        thigh = mesh_of(data, f"{links}/{side}_thigh_link/visual_0")   # binary STL, the URDF's material
        shin = mesh_of(data, f"{links}/{side}_shin_link/visual_0")     # ASCII STL
        foot = mesh_of(data, f"{links}/{side}_foot_link/visual_0")     # OBJ and its MTL
        assert np.ptp(np.asarray(thigh["Mesh3D:vertex_positions"]), axis=0)[2] == pytest.approx(0.25, abs=1e-4)
        assert set(thigh["Mesh3D:vertex_colors"]) == set(shin["Mesh3D:vertex_colors"]) == {rgba(BLUE)}
        assert np.ptp(np.asarray(foot["Mesh3D:vertex_positions"]), axis=0) == pytest.approx([0.22, 0.12, 0.04],
                                                                                              abs=1e-4)
        assert set(foot["Mesh3D:vertex_colors"]) == {rgba(GREEN)}


def test_a_lab_package_named_by_its_path_is_added_to_the_package_path(tmp_path: Path, zenoh_port: int,
                                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    """The lab biped's xacro named by a plain path, with no package path set (a repository cloned anywhere):
    the launch resolves (xacro's $(find lab_biped_description) included) and says it added the package."""
    import subprocess
    import sys

    root = Path(__file__).resolve().parents[2]
    package = root / "examples" / "lab_biped_description"
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    monkeypatch.delenv("AMENT_PREFIX_PATH", raising=False)
    done = subprocess.run([sys.executable, "-m", "launch", "humanoid.yaml", "robot:=lab_biped",
                           f"robot_file:={package / 'urdf' / 'lab_biped.urdf.xacro'}", f"zenoh_port:={zenoh_port}",
                           "--print"], cwd=tmp_path, capture_output=True, text=True, timeout=120,
                          env={**os.environ, "PYTHONPATH": str(root)})
    assert done.returncode == 0, done.stdout + done.stderr
    assert f"package 'lab_biped_description' of {package}" in done.stderr
    assert f"added {package} to ROS_PACKAGE_PATH" in done.stderr
    assert "generated a <ros2_control> block (8 joints" in done.stderr
