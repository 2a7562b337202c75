"""The visualiser in a short headless launch (real processes, real Zenoh), checked through the saved .rrd.

Processes: the robot state publisher (robot_description + tf from joint_states), the viz feeder (joint_states,
controller_state, joint_trajectory, humanoid_state, sim/clock, sim/model_states, standing in for the simulator
and controllers), and ``python -m nodes.viz --save``. The recording is read back with Rerun's own reader.
"""

from __future__ import annotations

import math
import signal
import time
from pathlib import Path

import pytest

from nodes.viz.readback import load
from nodes.viz.scene import parse_model as parse_urdf
from tests.conftest import wait_until

ROOT = Path(__file__).resolve().parents[2]
HUMANOID = ROOT / "robots" / "humanoid.urdf"
JOINT_STATES = "plots/humanoid/joint_states/position"


def start_stack(processes, rrd: Path, robots: list[str], feeder_params: list[str] = ()) -> tuple:
    for ns in robots:
        processes.start("-m", "nodes.state_publisher", "--ns", ns,
                        "--param", f"robot_description_file:={HUMANOID}", "--param", f"model_name:={ns}",
                        name=f"state_publisher_{ns}")
    viz = processes.start("-m", "nodes.viz", "--save", str(rrd), name="viz")
    wait_until(lambda: "saving the recording" in processes.output(viz), 30, message="the visualiser to start")
    feeder = processes.start("-m", "nodes.viz.feeder", "--param", f"robots:=[{', '.join(robots)}]",
                             *feeder_params, name="feeder")
    return viz, feeder


def stop(processes, proc) -> str:
    proc.send_signal(signal.SIGINT)
    proc.wait(20)
    return processes.output(proc)


def angle_about_y(quat_xyzw: list[float]) -> float:
    x, y, z, w = quat_xyzw
    assert abs(x) < 1e-6 and abs(z) < 1e-6, f"knee rotation not about y: {quat_xyzw}"
    return 2.0 * math.atan2(y, w)


@pytest.mark.slow
def test_headless_launch_records_model_frames_plots_and_markers(processes, tmp_path: Path) -> None:
    rrd = tmp_path / "viz.rrd"
    viz, feeder = start_stack(processes, rrd, ["humanoid"])
    wait_until(lambda: "23 visuals" in processes.output(viz), 40, message="the robot model in the visualiser")
    time.sleep(5.0)  # a few knee bends (period 2 s)
    stop(processes, feeder)
    log = stop(processes, viz)
    assert viz.returncode == 0, log
    data = load(rrd)

    # Geometry for every visual link, each in its own named link frame.
    model = parse_urdf(HUMANOID.read_text())
    for link in model.visual_links():
        entity = data.get(f"world/humanoid/links/{link}/visual_0")
        assert entity is not None and entity.rows, f"no geometry for link {link}"
        row = entity.rows[0]
        assert row["CoordinateFrame:frame"] == [f"humanoid/{link}"]
        assert any(k.endswith((":half_sizes", ":radii", ":lengths")) for k in row), row.keys()
    torso = data["world/humanoid/links/torso/visual_0"].rows[0]
    assert torso["Boxes3D:colors"] == [0x3366CCFF], "torso colour comes from the URDF material 'blue'"

    # Link transforms change over time and agree with joint_states at the same sim time.
    knee_frames = data["world/humanoid/frames/left_shin"].column("Transform3D:quaternion")
    knee_angles = {round(t, 6): angle_about_y(q[0]) for t, q in knee_frames}
    assert max(knee_angles.values()) - min(knee_angles.values()) > 0.5, "the knee frame never moved"
    names = data[JOINT_STATES].static["SeriesLines:names"]
    knee_index = names.index("left_knee")
    states = {round(t, 6): v[knee_index] for t, v in data[JOINT_STATES].column("Scalars:scalars")}
    matched = [(t, a) for t, a in knee_angles.items() if t in states]
    assert len(matched) >= 20, f"only {len(matched)} tf rows share a sim time with joint_states"
    worst = max(abs(a - states[t]) for t, a in matched)
    assert worst < 0.05, f"knee frame rotation differs from joint_states by {worst:.3f} rad"
    parent = data["world/humanoid/frames/left_shin"].rows[-1]["Transform3D:parent_frame"]
    assert parent == ["humanoid/left_thigh"]
    pelvis = data["world/humanoid/frames/pelvis"].rows[-1]
    assert pelvis["Transform3D:parent_frame"] == ["tf#/world"], "the floating base is placed in the world"

    # Joint plots: positions, velocities and efforts for every moving joint, at the joint_states rate.
    assert names == [j.name for j in model.movable_joints()]
    for quantity in ("position", "velocity", "effort"):
        rows = data[f"plots/humanoid/joint_states/{quantity}"].column("Scalars:scalars")
        assert len(rows) > 200 and all(len(v) == len(names) for _, v in rows)
    # Commanded vs actual per joint of the trajectory controller; balance plots.
    cmd_actual = data["plots/humanoid/joint_trajectory_controller/left_knee"]
    assert cmd_actual.static["SeriesLines:names"] == ["commanded", "actual"]
    assert len(cmd_actual.column("Scalars:scalars")) > 50
    for entity in ("com", "zmp", "is_balanced"):
        assert data[f"plots/humanoid/balance/{entity}"].rows

    # Markers: paths as line strips that grow, support polygon on the ground, the trajectory target.
    ee_paths = data["world/humanoid/markers/ee_paths"].column("LineStrips3D:strips")
    assert len(ee_paths[-1][1]) == 5, "one path per leaf link (head, hands, feet)"
    assert len(ee_paths[-1][1][0]) > len(ee_paths[0][1][0])
    assert len(data["world/humanoid/markers/com_path"].column("LineStrips3D:strips")[-1][1][0]) > 10
    polygon = data["world/humanoid/markers/support_polygon"].column("LineStrips3D:strips")[-1][1][0]
    assert len(polygon) == 5 and all(0.0 <= p[2] < 0.01 for p in polygon), polygon
    assert data["world/humanoid/markers/target"].column("LineStrips3D:strips")
    assert data["world/humanoid/markers/target/end_effectors"].column("Points3D:positions")


@pytest.mark.slow
def test_robots_appear_and_disappear_under_their_namespaces(processes, tmp_path: Path) -> None:
    rrd = tmp_path / "two.rrd"
    viz, feeder = start_stack(processes, rrd, ["humanoid", "humanoid2"],
                              ["--param", "delete_after:=4.0", "--param", "controller:=legs_controller"])
    wait_until(lambda: "robot 'humanoid2' was deleted" in processes.output(viz), 40,
               message="the second robot's deletion")
    time.sleep(1.0)
    stop(processes, feeder)
    log = stop(processes, viz)
    data = load(rrd)
    assert "robot 'humanoid2': model 'humanoid' with 23 links" in log
    assert data["world/humanoid2/links/torso/visual_0"].rows, "the second robot was drawn"
    clears = data["world/humanoid2"].column("Clear:is_recursive")
    assert clears and clears[0][1] == [True], "the deleted robot's subtree is cleared"
    cleared_at = clears[0][0]
    assert 3.5 <= cleared_at <= 6.0, cleared_at
    # Its pose sits 0.6 m to the side of the first robot, from sim/model_states through tf.
    y = data["world/humanoid2/frames/pelvis"].column("Transform3D:translation")[-1][1][0][1]
    assert abs(y - 0.6) < 1e-6
    # A trajectory controller with another name is found in the node graph and plotted.
    assert data["plots/humanoid/legs_controller/left_knee"].column("Scalars:scalars")
    assert "plots/humanoid/joint_trajectory_controller/left_knee" not in data
    # The first robot keeps going after the deletion.
    last = data["world/humanoid/frames/left_shin"].column("Transform3D:quaternion")[-1][0]
    assert last > cleared_at + 0.3


@pytest.mark.slow
def test_bad_input_is_reported_and_the_visualiser_keeps_running(processes, router: str, tmp_path: Path) -> None:
    import msgs
    from nodes.core import Node

    rrd = tmp_path / "bad.rrd"
    viz = processes.start("-m", "nodes.viz", "--save", str(rrd), "--robots", "badbot", "--param", "ground:=false",
                          name="viz")
    wait_until(lambda: "showing robot 'badbot'" in processes.output(viz), 30, message="the visualiser")
    String = msgs.get_type("std_msgs/msg/String")
    JointState = msgs.get_type("sensor_msgs/msg/JointState")
    with Node("tester", connect=[router]) as node:
        description = node.create_publisher(String, "/badbot/robot_description")
        joint_states = node.create_publisher(JointState, "/badbot/joint_states")
        time.sleep(1.0)  # let the visualiser's subscriptions meet ours through the router
        description.publish(String(data="<robot name='x'><link name='a'/><joint name='j' type='hinge'>"
                                        "<parent link='a'/><child link='b'/></joint></robot>"))
        wait_until(lambda: "unusable robot_description" in processes.output(viz), 15, message="the URDF error")
        joint_states.publish(JointState(name=["j1", "j2"], position=[0.1]))
        # The codec rejects it before our callback, naming the field; the node logs and carries on.
        wait_until(lambda: "position: has 1 entries but name has 2" in processes.output(viz), 15,
                   message="the joint_states length error")
        description.publish(String(data=HUMANOID.read_text()))
        wait_until(lambda: "robot 'badbot': model 'humanoid'" in processes.output(viz), 15,
                   message="a valid description after the bad ones")
    assert viz.poll() is None, "the visualiser died on bad input"
    log = stop(processes, viz)
    assert "joint 'j': unknown type 'hinge'" in log
    data = load(rrd)
    assert data["world/badbot/links/torso/visual_0"].rows, "the valid description was drawn"
    assert "world/ground" not in data, "ground:=false (the joint_animation tutorial has no ground)"


def test_headless_default_serves_the_web_viewer_on_loopback_only(processes) -> None:
    import re
    import urllib.request

    import psutil

    viz = processes.start("-m", "nodes.viz", "--web-port", "0", "--grpc-port", "0", name="viz",
                          env={"DISPLAY": "", "WAYLAND_DISPLAY": ""})
    line = wait_until(lambda: re.search(r"Rerun web viewer: (http://127\.0\.0\.1:(\d+)/\?url=\S+)",
                                        processes.output(viz)), 30, message="the web viewer URL")
    assert "no display: serving the web viewer" in processes.output(viz)
    with urllib.request.urlopen(f"http://127.0.0.1:{line.group(2)}/", timeout=10) as page:
        assert page.status == 200 and b"<html" in page.read(4096).lower()
    listening = [c.laddr for proc in [psutil.Process(viz.pid), *psutil.Process(viz.pid).children(recursive=True)]
                 for c in proc.net_connections(kind="inet") if c.status == psutil.CONN_LISTEN]
    assert listening, "nothing listening"
    assert all(addr.ip == "127.0.0.1" for addr in listening), f"listening beyond loopback: {listening}"
    viz.send_signal(2)
    viz.wait(20)
    assert viz.returncode == 0
    assert not [p for p in psutil.process_iter(["cmdline"]) if "--serve-web" in (p.info["cmdline"] or [])
                and str(line.group(2)) in " ".join(p.info["cmdline"] or [])], "the web server outlived the node"


def test_web_server_dies_with_a_killed_visualiser(processes) -> None:
    import re

    import psutil

    viz = processes.start("-m", "nodes.viz", "--serve", "--web-port", "0", "--grpc-port", "0", name="viz")
    wait_until(lambda: re.search(r"Rerun web viewer: ", processes.output(viz)), 30, message="the web viewer URL")
    server = psutil.Process(viz.pid).children()
    assert len(server) == 1 and "--serve-web" in server[0].cmdline()
    viz.kill()  # SIGKILL: no cleanup code runs
    viz.wait(10)
    psutil.wait_procs(server, timeout=10)
    assert not server[0].is_running(), "the web server outlived a killed visualiser"
