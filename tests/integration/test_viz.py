"""The visualiser in a short headless launch (real processes, real Zenoh), checked through the saved .rrd.

Processes: the robot state publisher (robot_description + tf from joint_states), the viz feeder (joint_states,
controller_state, joint_trajectory, humanoid_state, sim/clock, sim/model_states, standing in for the simulator
and controllers), and ``python -m nodes.viz --save``. The recording is read back with Rerun's own reader.
"""

from __future__ import annotations

import signal
import time
from pathlib import Path

import pytest

from nodes.viz.readback import load
from nodes.viz.scene import parse_model as parse_urdf
from tests.conftest import wait_until

ROOT = Path(__file__).resolve().parents[2]
HUMANOID = ROOT / "robots" / "humanoid.urdf"
JOINT_STATES = "plots/humanoid/joint_states/position/left_leg"


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

    # Geometry for every visual link: one instance per visual, grouped by primitive kind, URDF colours.
    model = parse_urdf(HUMANOID.read_text())
    shapes = {kind: data[f"world/humanoid/robot/{kind}"] for kind in ("boxes", "cylinders", "spheres")}
    counts = {kind: len(next(v for k, v in e.rows[-1].items() if k.endswith(":centers"))) for kind, e in shapes.items()}
    assert sum(counts.values()) == sum(len(model.links[link].visuals) for link in model.visual_links())
    assert 0x3366CCFF in shapes["boxes"].rows[-1]["Boxes3D:colors"], "torso colour from the URDF material 'blue'"

    # The robot moves: the shins (cylinders) follow the knee bends of joint_states.
    states = data[JOINT_STATES]
    names = states.static["SeriesLines:names"]
    knee = states.column("Scalars:scalars")
    assert max(v[names.index("knee")] for _, v in knee) > 0.5, "the left knee bends (short legend label 'knee')"
    heights = [min(c[2] for c in row["Cylinders3D:centers"]) for row in shapes["cylinders"].rows
               if "Cylinders3D:centers" in row]
    assert max(heights) - min(heights) > 0.03, "the lowest cylinder (a shin) never moved with the knees"

    # Joint plots: one per limb group, every moving joint in exactly one, all three quantities.
    plotted = []
    for group in ("left_leg", "right_leg", "left_arm", "right_arm", "torso_head"):
        entity = data[f"plots/humanoid/joint_states/position/{group}"]
        plotted += entity.static["SeriesLines:names"]
        assert len(entity.column("Scalars:scalars")) > 20
        for quantity in ("velocity", "effort"):
            assert data[f"plots/humanoid/joint_states/{quantity}/{group}"].column("Scalars:scalars")
    assert len(plotted) == len(model.movable_joints())
    # Commanded vs actual per joint of the trajectory controller (the feeder's 6 leg joints: one group).
    cmd_actual = data["plots/humanoid/joint_trajectory_controller/joints"]
    assert cmd_actual.static["SeriesLines:names"][:2] == ["left_knee ref", "left_knee"]
    assert len(cmd_actual.column("Scalars:scalars")) > 10
    assert len(data["plots/humanoid/balance"].column("Scalars:scalars")[-1][1]) == 6

    # Markers: paths as line strips that grow, support polygon on the ground, the trajectory target.
    ee_paths = data["world/humanoid/markers/ee_paths"].column("LineStrips3D:strips")
    assert len(ee_paths[-1][1]) == 5, "one path per leaf link (head, hands, feet)"
    assert len(ee_paths[-1][1][0]) > len(ee_paths[0][1][0])
    assert len(data["world/humanoid/markers/com_path"].column("LineStrips3D:strips")[-1][1][0]) > 3
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
    assert data["world/humanoid2/robot/boxes"].rows, "the second robot was drawn"
    clears = data["world/humanoid2"].column("Clear:is_recursive")
    assert clears and clears[0][1] == [True], "the deleted robot's subtree is cleared"
    cleared_at = clears[0][0]
    assert 3.5 <= cleared_at <= 6.0, cleared_at
    # Its pose sits 0.6 m to the side of the first robot, from sim/model_states through tf.
    torso_y = [c[1] for c in data["world/humanoid2/robot/boxes"].column("Boxes3D:centers")[-1][1]]
    assert any(abs(y - 0.6) < 1e-3 for y in torso_y), torso_y
    # A trajectory controller with another name is found in the node graph and plotted.
    assert data["plots/humanoid/legs_controller/joints"].column("Scalars:scalars")
    assert "plots/humanoid/joint_trajectory_controller/joints" not in data
    # The first robot keeps going after the deletion.
    last = data["world/humanoid/robot/cylinders"].column("Cylinders3D:centers")[-1][0]
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
    assert data["world/badbot/robot/boxes"].rows, "the valid description was drawn"
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
