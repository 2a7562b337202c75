"""``zenroid teleop`` driven in a real terminal: tmux runs it against the main job in lockstep, the test
types keys (send-keys) and reads the screen (capture-pane)."""

from __future__ import annotations

import os
import shlex
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.integration.test_launch_scenarios import Scenario

ROOT = Path(__file__).resolve().parents[2]
pytestmark = pytest.mark.skipif(shutil.which("tmux") is None, reason="tmux is not installed")


class Tmux:
    """One private tmux server (its own socket), so nothing touches anybody else's sessions."""

    def __init__(self, socket: str) -> None:
        self.socket = socket

    def __call__(self, *args: str) -> str:
        return subprocess.run(["tmux", "-L", self.socket, *args], capture_output=True, text=True, check=True,
                              timeout=10).stdout

    def screen(self) -> str:
        return self("capture-pane", "-t", "teleop", "-p")

    def row(self, joint: str) -> list[str]:
        for line in self.screen().splitlines():
            words = line.split()
            if joint in words:
                return words
        return []

    def kill(self) -> None:
        subprocess.run(["tmux", "-L", self.socket, "kill-server"], capture_output=True, timeout=10)


def wait(predicate, timeout: float, what: str, screen) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return
        time.sleep(0.1)
    pytest.fail(f"timed out waiting for {what}; screen:\n{screen()}")


@pytest.mark.slow
def test_teleop_nudges_the_selected_joint_and_quits_cleanly(tmp_path: Path, zenoh_port: int) -> None:
    scenario = Scenario(tmp_path, zenoh_port, "humanoid.yaml", "mode:=lockstep", "commander:=none")
    tmux = Tmux(f"zenroid_test_{zenoh_port}")
    exit_file = tmp_path / "teleop.exit"
    try:
        scenario.connect("humanoid/joint_states", "humanoid/joint_trajectory_controller/joint_trajectory")
        scenario.wait_for(lambda: "Configured and activated joint_trajectory_controller" in scenario.output(),
                          120, "the trajectory controller")
        command = (f"cd {shlex.quote(str(ROOT))} && PYTHONPATH={shlex.quote(str(ROOT))} "
                   f"{shlex.quote(sys.executable)} -m nodes.tools.cli teleop --ns humanoid --zenoh-port {zenoh_port}; "
                   f"echo $? > {shlex.quote(str(exit_file))}; sleep 60")
        env = {k: v for k, v in os.environ.items() if k not in ("TMUX", "ZENOH_CONNECT", "ZENOH_CONFIG")}
        subprocess.run(["tmux", "-L", tmux.socket, "-f", "/dev/null", "new-session", "-d", "-s", "teleop",
                        "-x", "120", "-y", "40", command], check=True, env=env, timeout=10)
        wait(lambda: tmux.row("left_knee")[-4:-3] != [], 60, "the joint list", tmux.screen)
        assert "zenroid teleop  humanoid/joint_trajectory_controller  step 0.050 rad" in tmux.screen()
        assert tmux.row("left_hip_yaw")[0] == ">"                 # the first joint is selected

        tmux("send-keys", "-t", "teleop", "j", "j", "Down")       # j, j and an arrow: the 4th joint
        wait(lambda: tmux.row("left_knee")[:1] == [">"], 10, "left_knee selected", tmux.screen)
        tmux("send-keys", "-t", "teleop", "+")
        wait(lambda: tmux.row("left_knee")[3:4] == ["+0.050"], 10, "the target +0.050", tmux.screen)

        def knee_on_screen() -> float:
            return float(tmux.row("left_knee")[2])
        wait(lambda: abs(knee_on_screen() - 0.05) < 0.01, 60, "the knee at 0.05 rad on screen", tmux.screen)
        last = scenario.snapshot("humanoid/joint_states")[-1]
        assert abs(last["position"][last["name"].index("left_knee")] - 0.05) < 0.01   # the robot really moved
        sent = scenario.snapshot("humanoid/joint_trajectory_controller/joint_trajectory")
        assert len(sent) == 1 and len(sent[0]["joint_names"]) == 22
        point = sent[0]["points"][0]
        assert point["positions"][sent[0]["joint_names"].index("left_knee")] == pytest.approx(0.05, abs=1e-3)
        assert point["time_from_start"] == {"sec": 0, "nanosec": 200_000_000}

        # down past the knee's lower limit (-0.05): stopped there, and the screen says so
        tmux("send-keys", "-t", "teleop", "-", "-", "-", "-")
        wait(lambda: "left_knee is at its lower limit -0.050 rad" in tmux.screen(), 10, "the limit message",
             tmux.screen)
        assert tmux.row("left_knee")[3] == "-0.050"
        tmux("send-keys", "-t", "teleop", "0")
        wait(lambda: tmux.row("left_knee")[3:4] == ["+0.000"], 10, "the zero pose", tmux.screen)

        tmux("send-keys", "-t", "teleop", "q")
        wait(exit_file.exists, 15, "teleop to exit", tmux.screen)
        assert exit_file.read_text().strip() == "0"
    finally:
        tmux.kill()
        scenario.close()
