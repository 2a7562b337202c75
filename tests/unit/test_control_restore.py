"""A respawned controller manager restores its controllers (nodes.control.restore), in-process."""

from __future__ import annotations

from pathlib import Path

import pytest

from nodes.control import restore
from tests.unit.test_control_controllers import LAB_YAML, Rig, lab_rig


def test_saved_set_is_restored_in_its_states_and_holds_the_measured_position(tmp_path: Path,
                                                                              monkeypatch) -> None:
    monkeypatch.setenv(restore.STATE_DIR_ENV, str(tmp_path))
    path = restore.state_file("/simple_robot/controller_manager")
    assert path == tmp_path / "simple_robot.controller_manager.controllers.json"
    first = lab_rig()
    first.spawn("pid_controller", activate=False)  # loaded + configured, inactive
    first.manager.set_controller_params("joint_group_position_controller", {"joints": ["joint1"]})
    first.manager.on_change = lambda: restore.save(path, first.manager)
    first.manager.load("joint_group_position_controller")  # loaded, unconfigured: saved by on_change
    saved = {c["name"]: c["state"] for c in restore.load(path)}
    assert saved == {"joint_state_broadcaster": "active", "joint_trajectory_controller": "active",
                     "pid_controller": "inactive", "joint_group_position_controller": "unconfigured"}

    second = Rig(LAB_YAML, ["joint1"], ("position", "velocity"))  # the respawned process
    second.plant.pos["joint1"] = 0.7  # where the simulator held the joint meanwhile
    second.plant.publish_state()
    active, problems = restore.restore(second.manager, restore.load(path))
    assert problems == []
    assert active == ["joint_state_broadcaster", "joint_trajectory_controller"]
    states = {c["name"]: c["state"] for c in second.manager.list_controllers()}
    assert states == saved
    second.step(0.2)
    assert second.sent[-1][2][0] == pytest.approx(0.7, abs=1e-6)  # resumes from the measured state
    assert second.plant.pos["joint1"] == pytest.approx(0.7, abs=1e-3)


def test_no_state_directory_means_no_file_and_a_bad_file_is_refused(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.delenv(restore.STATE_DIR_ENV, raising=False)
    assert restore.state_file("/humanoid/controller_manager") is None
    assert restore.load(tmp_path / "missing.json") == []
    bad = tmp_path / "bad.json"
    bad.write_text('{"version": 1, "controllers": [{"name": 3}]}')
    with pytest.raises(ValueError, match="malformed entry"):
        restore.load(bad)
    bad.write_text("not json")
    with pytest.raises(ValueError, match="bad.json"):
        restore.load(bad)
