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

from nodes.viz.scene import parse_model as parse_urdf
from nodes.viz.scene import plot_groups
from tests.conftest import wait_until
from tests.support.rrd import load

ROOT = Path(__file__).resolve().parents[2]
HUMANOID = ROOT / "robots" / "humanoid.urdf"
ROBOT = "world/humanoid/robot"  # the robot's primitives, markers and plotted values, one row per sample
EE_PATH, TARGET = 0xE63CC8FF, 0xFF8C00A0  # marker colours (packed RGBA)


def strips(row: dict, rgba: int, radius: float | None = None) -> list:
    """The line strips of one colour (and radius) in a row of a robot entity."""
    return [strip for strip, color, r in zip(row["LineStrips3D:strips"], row["LineStrips3D:colors"],
                                             row["LineStrips3D:radii"], strict=True)
            if color == rgba and (radius is None or abs(r - radius) < 1e-6)]


def start_stack(processes, rrd: Path, robots: list[str], feeder_params: list[str] = ()) -> tuple:
    for ns in robots:
        processes.start("-m", "nodes.state_publisher", "--ns", ns,
                        "--param", f"robot_description_file:={HUMANOID}", "--param", f"model_name:={ns}",
                        name=f"state_publisher_{ns}")
    viz = processes.start("-m", "nodes.viz", "--save", str(rrd), name="viz")
    wait_until(lambda: "saving the recording" in processes.output(viz), 30, message="the visualiser to start")
    feeder = processes.start("-m", "tests.support.viz_feeder", "--param", f"robots:=[{', '.join(robots)}]",
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
    robot = data[ROBOT]
    assert not [name for name in data if name.startswith("plots")], "plots are columns of the robot entity"
    last = robot.rows[-1]
    counts = {kind: len(last[f"{kind}:centers"]) for kind in ("Boxes3D", "Cylinders3D", "Ellipsoids3D")}
    assert sum(counts.values()) == sum(len(model.links[link].visuals) for link in model.visual_links())
    assert 0x3366CCFF in last["Boxes3D:colors"], "torso colour from the URDF material 'blue'"

    # The robot moves: the shins (cylinders) follow the knee bends of joint_states.
    groups = {g.part: g for g in plot_groups([j.name for j in model.movable_joints()])}
    knee = robot.column("position:left_leg")
    assert max(v[groups["left_leg"].labels.index("knee")] for _, v in knee) > 0.5, "the left knee bends"
    heights = [min(c[2] for c in centers) for _, centers in robot.column("Cylinders3D:centers")]
    assert max(heights) - min(heights) > 0.03, "the lowest cylinder (a shin) never moved with the knees"

    # Plotted values: a column per limb group, every moving joint in exactly one, all three quantities.
    assert sorted(groups) == ["left_arm", "left_leg", "right_arm", "right_leg", "torso_head"]
    assert sum(len(last[f"position:{part}"]) for part in groups) == len(model.movable_joints())
    for part in groups:
        assert len(robot.column(f"position:{part}")) > 20
        for quantity in ("velocity", "effort"):
            assert robot.column(f"{quantity}:{part}")
    # Commanded vs actual per joint of the trajectory controller (the feeder's 6 leg joints: one group), in the
    # rows of the joint_states samples: reference and actual per joint.
    cmd_actual = robot.column("joint_trajectory_controller:joints")
    assert len(cmd_actual) > 10 and len(cmd_actual[-1][1]) == 12
    assert len(robot.column("balance:values")[-1][1]) == 6
    # A row per sample, nothing else in between: the viewer gets one chunk per flush.
    # (Until the first joint_states sample, humanoid_state alone can draw the feet's force arrows: those rows
    # are allowed, however many arrive first on a loaded machine.)
    plotted = [r.get("position:left_leg") is not None for r in robot.rows]
    first = plotted.index(True)
    stray = [r["sim_time"] for r in robot.rows[first:] if r.get("position:left_leg") is None]
    assert not stray, f"rows without plotted values after the first sample: {stray}"

    # Markers: paths as line strips that grow, support polygon on the ground, the trajectory target.
    first_paths = strips(next(r for r in robot.rows if strips(r, EE_PATH)), EE_PATH)
    assert len(strips(last, EE_PATH)) == 5, "one path per leaf link (head, hands, feet)"
    assert len(strips(last, EE_PATH)[0]) > len(first_paths[0])
    balance_colors = (0x3CC85AFF, 0xE63C32FF)
    assert len(next(s for c in balance_colors for s in strips(last, c, 0.004))) > 3, "the CoM path"
    polygon = next(s for c in balance_colors for s in strips(last, c, 0.006))
    assert len(polygon) == 5 and all(0.0 <= p[2] < 0.01 for p in polygon), polygon
    assert strips(last, TARGET), "the target pose's skeleton"


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
    assert "robot 'humanoid2': model 'humanoid' with 27 links, 23 visuals" in log
    assert data["world/humanoid2/robot"].rows, "the second robot was drawn"
    clears = data["world/humanoid2"].column("Clear:is_recursive")
    assert clears and clears[0][1] == [True], "the deleted robot's subtree is cleared"
    cleared_at = clears[0][0]
    assert 3.5 <= cleared_at <= 6.0, cleared_at
    # Its pose sits 0.6 m to the side of the first robot, from sim/model_states through tf.
    torso_y = [c[1] for c in data["world/humanoid2/robot"].column("Boxes3D:centers")[-1][1]]
    assert any(abs(y - 0.6) < 1e-3 for y in torso_y), torso_y
    # A trajectory controller with another name is found in the node graph and plotted.
    assert data[ROBOT].column("legs_controller:joints")
    assert not data[ROBOT].column("joint_trajectory_controller:joints")
    # The first robot keeps going after the deletion.
    last = data[ROBOT].column("Cylinders3D:centers")[-1][0]
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
        # our publisher refuses it (msgs.EncodeError); a foreign one may still send it, as these bytes
        joint_states.publish_raw(msgs.packer(JointState._type)(name=["j1", "j2"], position=[0.1], velocity=[],
                                                               effort=[]))
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
    assert data["world/badbot/robot"].rows, "the valid description was drawn"


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
