"""The humanoid's sensors in the main job (real simulator, controller manager and broadcasters over Zenoh, in
lockstep), read by a client that imports only zenoh and msgpack:

- standing still, the pelvis IMU reads (0, 0, 9.81) ± 0.3 m/s², turns slower than 0.05 rad/s and agrees with
  ``sim/model_states`` within 2°; the two ankle force/torque sensors carry the weight above them within 5 %;
- during a slow squat (3 s down, 1 s held, 3 s up) the sum still holds (50 ms averages) and the measured centre of pressure stays inside the
  support polygon;
- a push (``sim/apply_link_wrench`` on the torso) shows in the IMU's pitch rate and forward acceleration
  and in the ankle torques;
- a sensor declaration with a bad field is refused by ``sim/spawn_entity`` naming sensor and field (the world
  keeps running), and a broadcaster of a sensor the hardware lacks fails to configure while the others run.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import msgpack
import pytest

from nodes.sim.humanoid_state import inside_polygon
from nodes.urdf.model import parse_urdf
from tests.integration.test_launch_scenarios import Scenario
from tests.integration.test_lockstep_main_job import call

ROOT = Path(__file__).resolve().parents[2]
IMU = "humanoid/imu_sensor_broadcaster/imu"
LEFT, RIGHT = "humanoid/left_foot_ft_broadcaster/wrench", "humanoid/right_foot_ft_broadcaster/wrench"
SQUAT = {"hip_pitch": -0.4, "knee": 0.8, "ankle_pitch": -0.4}   # hip + knee + ankle = 0: soles stay flat
LEGS = [f"{side}_{j}" for side in ("left", "right") for j in SQUAT]


def stamp(msg: dict) -> float:
    return msg["header"]["stamp"]["sec"] + msg["header"]["stamp"]["nanosec"] * 1e-9


def weight_above_ankles() -> float:
    model = parse_urdf((ROOT / "robots" / "humanoid.urdf").read_text())
    feet = model.links["left_foot"].inertial.mass + model.links["right_foot"].inertial.mass
    return (model.total_mass() - feet) * 9.81


def force_sums(scenario: Scenario, start: float, end: float) -> dict[float, float]:
    """left + right force.z by stamp, for the stamps both sensors published in [start, end)."""
    left = {stamp(m): m["wrench"]["force"]["z"] for m in scenario.snapshot(LEFT) if start <= stamp(m) < end}
    right = {stamp(m): m["wrench"]["force"]["z"] for m in scenario.snapshot(RIGHT) if start <= stamp(m) < end}
    return {t: left[t] + right[t] for t in sorted(set(left) & set(right))}


def sim_time(scenario: Scenario) -> float:
    imu = scenario.snapshot(IMU)
    return stamp(imu[-1]) if imu else 0.0


def quaternion_angle_deg(a: dict, b: dict) -> float:
    dot = abs(sum(a[k] * b[k] for k in "xyzw"))
    return math.degrees(2 * math.acos(min(1.0, dot)))


@pytest.mark.slow
def test_standing_squatting_and_bad_sensor_input(tmp_path: Path, zenoh_port: int) -> None:
    scenario = Scenario(tmp_path, zenoh_port, "humanoid.yaml", "mode:=lockstep", "commander:=none", "paused:=true")
    try:
        scenario.connect(IMU, LEFT, RIGHT, "sim/model_states", "humanoid/humanoid_state", "rosout")

        def active() -> set[str]:
            listed = call(scenario.session, "humanoid/controller_manager/list_controllers", {}, timeout=1.0)
            return {c["name"] for c in (listed or {}).get("controller", []) if c["state"] == "active"}

        scenario.wait_for(lambda: {"joint_trajectory_controller", "imu_sensor_broadcaster", "left_foot_ft_broadcaster",
                                   "right_foot_ft_broadcaster"} <= active(), 120, "the controllers")
        assert call(scenario.session, "sim/unpause_physics", {}) is not None
        scenario.wait_for(lambda: sim_time(scenario) > 3.0, 240, "3 s of sim time with the IMU broadcasting")

        # --- standing still (landed from the spawn height by 1.5 s) ------------------------------------
        imu = [m for m in scenario.snapshot(IMU) if 2.0 <= stamp(m) < 3.0]
        assert len(imu) > 900 and all(m["header"]["frame_id"] == "pelvis" for m in imu)
        for m in imu:
            a, w = m["linear_acceleration"], m["angular_velocity"]
            assert abs(a["x"]) < 0.3 and abs(a["y"]) < 0.3 and abs(a["z"] - 9.81) < 0.3, a
            assert math.sqrt(w["x"] ** 2 + w["y"] ** 2 + w["z"] ** 2) < 0.05, w
        model = [m for m in scenario.snapshot("sim/model_states") if "humanoid" in m["name"]][-1]
        pelvis = model["pose"][model["name"].index("humanoid")]["orientation"]
        assert quaternion_angle_deg(imu[-1]["orientation"], pelvis) < 2.0, (imu[-1]["orientation"], pelvis)
        weight = weight_above_ankles()
        standing = force_sums(scenario, 2.0, 3.0)
        assert len(standing) > 900
        assert all(abs(total - weight) < 0.05 * weight for total in standing.values()), \
            (weight, min(standing.values()), max(standing.values()))
        assert {m["header"]["frame_id"] for m in scenario.snapshot(LEFT)} == {"left_foot"}

        # --- a squat: down over 3 s, held, up over 3 s (sent while paused: it starts at a known sim time) ---
        assert call(scenario.session, "sim/pause_physics", {}) is not None
        start = sim_time(scenario) + 0.3
        down = [SQUAT[j.split("_", 1)[1]] for j in LEGS]

        def point(t: float, q: list[float]) -> dict:
            return {"positions": q, "velocities": [0.0] * len(q),
                    "time_from_start": {"sec": int(t), "nanosec": int(round(t % 1 * 1e9))}}

        trajectory = {"header": {"stamp": {"sec": int(start), "nanosec": int(round(start % 1 * 1e9))}},
                      "joint_names": LEGS, "points": [point(3.0, down), point(4.0, down), point(7.0, [0.0] * 6)]}
        scenario.session.put("humanoid/joint_trajectory_controller/joint_trajectory", msgpack.packb(trajectory))
        time.sleep(0.5)   # the controller has taken it
        assert call(scenario.session, "sim/unpause_physics", {}) is not None
        scenario.wait_for(lambda: sim_time(scenario) > start + 7.5, 240, "the squat to end")
        sums = force_sums(scenario, start, start + 7.5)
        windows = [list(sums.values())[i:i + 50] for i in range(0, len(sums) - 49, 50)]   # 50 ms averages
        means = [sum(w) / len(w) for w in windows]
        worst = sorted(((abs(m - weight) / weight, round(list(sums)[50 * i], 3)) for i, m in enumerate(means)),
                       reverse=True)[:8]
        assert len(means) > 140 and all(abs(m - weight) < 0.05 * weight for m in means), (weight, start, worst)
        states = [m for m in scenario.snapshot("humanoid/humanoid_state") if start <= stamp(m) < start + 7.5]
        pelvis_z = [m["center_of_mass"]["z"] for m in states]
        assert max(pelvis_z) - min(pelvis_z) > 0.03, "the robot did not squat"
        outside = [(round(stamp(m), 3), m["cop_x"], m["cop_y"]) for m in states if not (
            m["cop_measured"] and inside_polygon((m["cop_x"], m["cop_y"]),
                                                 [(p["x"], p["y"]) for p in m["support_polygon"]]))]
        assert len(states) > 600 and not outside, outside[:5]
        assert all(m["balance_source"] == "cop" and m["is_balanced"] for m in states)

        # --- a push (sim/apply_link_wrench: 120 N forward on the torso for 0.2 s) shows in the IMU and F/T ----
        assert call(scenario.session, "sim/pause_physics", {}) is not None
        push = sim_time(scenario) + 0.5
        quiet = [m for m in scenario.snapshot(IMU) if push - 1.0 <= stamp(m) < push]
        quiet_torque = max(abs(m["wrench"]["torque"]["y"]) for m in scenario.snapshot(LEFT)
                           if push - 1.0 <= stamp(m) < push)
        reply = call(scenario.session, "sim/apply_link_wrench", {
            "link_name": "humanoid::torso", "wrench": {"force": {"x": 120.0, "y": 0.0, "z": 0.0}},
            "start_time": {"sec": int(push), "nanosec": int(round(push % 1 * 1e9))},
            "duration": {"sec": 0, "nanosec": 200_000_000}})
        assert reply and reply["success"], reply
        assert call(scenario.session, "sim/unpause_physics", {}) is not None
        scenario.wait_for(lambda: sim_time(scenario) > push + 1.0, 120, "the push")
        pushed = [m for m in scenario.snapshot(IMU) if push <= stamp(m) < push + 1.0]
        pitch_rate = max(abs(m["angular_velocity"]["y"]) for m in pushed)
        assert max(abs(m["angular_velocity"]["y"]) for m in quiet) < 0.05 < pitch_rate, pitch_rate
        forward = max(abs(m["linear_acceleration"]["x"]) for m in pushed)
        assert forward > 0.5, forward   # standing: the 0.1 m/s^2 bias and noise
        torque = max(abs(m["wrench"]["torque"]["y"]) for m in scenario.snapshot(LEFT) if push <= stamp(m) < push + 1.0)
        assert torque > 3 * quiet_torque + 5.0, (quiet_torque, torque)   # the load moves onto the toes

        # --- bad input: refused with sensor and field named, the world and the controllers keep running ----
        xml = (ROOT / "robots" / "humanoid.urdf").read_text()
        bad = xml.replace('<sensor name="imu_sensor" type="imu">\n      <always_on>true</always_on>\n'
                          "      <update_rate>1000</update_rate>",
                          '<sensor name="imu_sensor" type="imu">\n      <always_on>true</always_on>\n'
                          "      <update_rate>-1</update_rate>")
        assert bad != xml
        reply = call(scenario.session, "sim/spawn_entity", {"name": "second", "xml": bad})
        assert reply and not reply["success"], reply
        assert "sensor 'imu_sensor'" in reply["status_message"] and "<update_rate> -1" in reply["status_message"]
        params = "type: imu_sensor_broadcaster/IMUSensorBroadcaster\nsensor_name: chest_imu\nframe_id: torso\n"
        reply = call(scenario.session, "humanoid/controller_manager/set_controller_parameters",
                     {"names": ["chest_imu_broadcaster"], "values_yaml": [params]})
        assert reply and reply["successful"] == [True], reply
        assert call(scenario.session, "humanoid/controller_manager/load_controller",
                    {"name": "chest_imu_broadcaster"}) == {"ok": True}
        assert call(scenario.session, "humanoid/controller_manager/configure_controller",
                    {"name": "chest_imu_broadcaster"}) == {"ok": False}
        scenario.wait_for(lambda: any("'chest_imu' is not a sensor of the hardware" in m["msg"]
                                      for m in scenario.snapshot("rosout")), 30, "the configure error on rosout")
        listed = call(scenario.session, "humanoid/controller_manager/list_controllers", {})
        states_by_name = {c["name"]: c["state"] for c in listed["controller"]}
        assert states_by_name["chest_imu_broadcaster"] == "unconfigured"
        assert all(states_by_name[name] == "active" for name in (
            "imu_sensor_broadcaster", "left_foot_ft_broadcaster", "right_foot_ft_broadcaster",
            "joint_state_broadcaster", "joint_trajectory_controller"))
        before = sim_time(scenario)
        scenario.wait_for(lambda: sim_time(scenario) > before + 0.5, 60, "the IMU to keep publishing")
    finally:
        scenario.close()
