"""The distribution works as a wheel (non-editable, outside the checkout): ``pip install .`` into a fresh
venv runs ``python -m launch humanoid.yaml``, robots/, config/ and worlds/ included, and ``zenroid launch`` still
works when a sourced ROS 2 environment shadows the ``launch`` package."""

from __future__ import annotations

import os
import shutil
import site
import subprocess
import sys
import threading
from pathlib import Path

import msgpack
import pytest

from bench.common import Launch
from tests.conftest import ROOT

ACTIVE = "Configured and activated joint_trajectory_controller"


def _copy_checkout(dest: Path) -> None:
    """The files git knows (tracked, or new and not ignored) as they are now, links kept as links; the
    build then runs in the copy and leaves the checkout untouched (no build/ or egg-info in it)."""
    listed = subprocess.run(["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"], cwd=ROOT,
                            capture_output=True, check=True).stdout.decode().split("\0")
    for name in filter(None, listed):
        source = ROOT / name
        if not source.exists() and not source.is_symlink():
            continue  # deleted in the working tree
        target = dest / name
        target.parent.mkdir(parents=True, exist_ok=True)
        if source.is_symlink():
            target.symlink_to(os.readlink(source))
        else:
            shutil.copy2(source, target)


def _run(argv: list[str], **kwargs) -> subprocess.CompletedProcess:
    result = subprocess.run(argv, capture_output=True, text=True, **kwargs)
    assert result.returncode == 0, f"{argv} failed:\n{result.stdout[-3000:]}\n{result.stderr[-3000:]}"
    return result


@pytest.fixture(scope="module")
def venv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A fresh venv holding the wheel built from this checkout; dependencies come from the interpreter
    running the tests, so nothing is downloaded but the build backend."""
    base = tmp_path_factory.mktemp("wheel")
    _copy_checkout(base / "src")
    _run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(base / "dist"), str(base / "src")],
         timeout=600)
    wheels = list((base / "dist").glob("zenroid-*.whl"))
    assert len(wheels) == 1, wheels
    _run([sys.executable, "-m", "venv", str(base / "venv")], timeout=300)
    python = base / "venv" / "bin" / "python"
    # The dependencies: the site-packages of the interpreter running the tests, which is itself usually a
    # venv (whose packages --system-site-packages would not reach). A path line in a .pth file does not run
    # that folder's own .pth files, so an editable zenroid installed there stays out.
    inner = _run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"]).stdout.strip()
    (Path(inner) / "_test_dependencies.pth").write_text("\n".join(site.getsitepackages()) + "\n")
    # --force-reinstall: the interpreter underneath may hold an editable zenroid of the same version.
    _run([str(python), "-m", "pip", "install", "-q", "--no-index", "--no-deps", "--force-reinstall",
          str(wheels[0])], timeout=300)
    return base / "venv"


def _outside_env(**extra: str) -> dict[str, str]:
    """The user's shell, without anything that points at the checkout."""
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "ZENOH_CONNECT", "ZENOH_CONFIG")}
    env.update(extra)
    return env


def _joint_states_flow(command: list[str], cwd: Path, env: dict[str, str], port: int) -> None:
    """Run the main job with ``command`` (``python -m launch`` of the venv, or its ``zenroid launch``) until
    50 ``humanoid/joint_states`` messages of 22 joints arrived and the trajectory controller is active (its
    parameters come from config/controllers.yaml), then Ctrl-C it."""
    received: list[dict] = []
    lock = threading.Lock()

    def on_sample(sample) -> None:  # noqa: ANN001 - a zenoh sample
        with lock:
            received.append(msgpack.unpackb(sample.payload.to_bytes()))

    launch = Launch("humanoid.yaml", log_dir=cwd, port=port, command=command, env=env, cwd=cwd)
    try:
        launch.peer(120).declare_subscriber("humanoid/joint_states", on_sample)
        launch.wait(lambda: len(received) >= 50 and ACTIVE in launch.output(), 120, "joint_states to flow",
                    interval=0.2)
        with lock:
            last = received[-1]
        assert len(last["name"]) == 22 and len(last["position"]) == 22
    finally:
        launch.close(30)


@pytest.mark.slow
def test_wheel_runs_the_main_job_outside_the_checkout(venv: Path, tmp_path: Path, zenoh_port: int) -> None:
    python = venv / "bin" / "python"
    where = _run([str(python), "-c", "import launch, msgs, nodes.share as s; "
                  "print(launch.__file__, msgs.__file__, s.robot_file('humanoid'), s.config_file('controllers'), "
                  "s.world_file('simple_lab'))"],
                 cwd=tmp_path, env=_outside_env(), timeout=60).stdout.split()
    assert all(Path(p).resolve().is_relative_to(venv.resolve()) for p in where), (where, venv)
    _joint_states_flow([str(python), "-m", "launch"], tmp_path, _outside_env(), zenoh_port)


@pytest.mark.slow
def test_zenroid_launch_works_when_ros2_shadows_launch(venv: Path, tmp_path: Path, zenoh_port: int) -> None:
    """A sourced ROS 2 puts its ``launch`` package first on PYTHONPATH, so ``import launch`` (and
    ``python -m launch``) find ROS's (docs/troubleshooting.md says so); ``zenroid launch`` still runs ours."""
    ros = tmp_path / "opt_ros" / "launch"
    ros.mkdir(parents=True)
    (ros / "__init__.py").write_text('"""Stand-in for ROS 2\'s launch package."""\nROS = True\n')
    env = _outside_env(PYTHONPATH=str(ros.parent))
    shadowed = _run([str(venv / "bin" / "python"), "-c", "import launch; print(launch.__file__)"],
                    cwd=tmp_path, env=env, timeout=60).stdout.strip()
    assert Path(shadowed) == ros / "__init__.py"
    _joint_states_flow([str(venv / "bin" / "zenroid"), "launch"], tmp_path, env, zenoh_port)


@pytest.mark.slow
def test_a_fresh_interpreter_imports_interfaces_by_their_ros_names(venv: Path, tmp_path: Path) -> None:
    """zenroid-interfaces.pth ships in the wheel: ``python my_node.py`` with nothing imported before finds
    ``std_msgs.msg`` and the rest, the same classes as ``msgs``, and a workspace's own package in src/."""
    package = tmp_path / "src" / "my_robot_msgs"
    (package / "msg").mkdir(parents=True)
    (package / "package.xml").write_text("<package format='3'><name>my_robot_msgs</name></package>\n")
    (package / "msg" / "Grasp.msg").write_text("string hand\nfloat64 force 1.0\n")
    program = tmp_path / "my_node.py"
    program.write_text(
        "import sys\n"
        "from std_msgs.msg import String\n"
        "from trajectory_msgs.msg import JointTrajectory\n"
        "from example_interfaces.srv import AddTwoInts\n"
        "from control_msgs.action import FollowJointTrajectory\n"
        "from my_robot_msgs.msg import Grasp\n"
        "import msgs\n"
        "assert String is msgs.std_msgs.String and JointTrajectory is msgs.trajectory_msgs.JointTrajectory\n"
        "assert msgs.__file__.startswith(sys.prefix), msgs.__file__\n"
        "print(Grasp().force, AddTwoInts.Request(a=1, b=2).b, FollowJointTrajectory.Goal.__name__)\n")
    done = _run([str(venv / "bin" / "python"), str(program)], cwd=tmp_path, env=_outside_env(), timeout=120)
    assert done.stdout.split() == ["1.0", "2", "FollowJointTrajectory_Goal"], done.stderr
