"""Copy the standard interface packages verbatim from their upstream repositories into msgs/definitions.

    python -m tests.support.update_upstream_interfaces MIRRORS

MIRRORS holds bare git clones named ``<owner>+<repo>/repo`` (what ``git clone --mirror`` or the project's
mirror tool makes). Each package's ``msg/``, ``srv/`` and ``action/`` files, its ``package.xml`` and its LICENSE
(the repository's when the package has none) are taken at the branch named in SOURCES, byte for byte; the commit of every source is
written to ``SOURCES.txt``. Our own packages (zenroid_msgs, humanoid_msgs) are not touched.
"""

from __future__ import annotations

import io
import shutil
import subprocess
import sys
import tarfile
from pathlib import Path

HERE = Path(__file__).resolve().parents[2] / "msgs" / "definitions"

# (owner/repo, branch, {package: folder of the package in the repository})
SOURCES: list[tuple[str, str, dict[str, str]]] = [
    ("ros2/common_interfaces", "jazzy", {p: p for p in (
        "actionlib_msgs", "diagnostic_msgs", "geometry_msgs", "nav_msgs", "sensor_msgs", "shape_msgs", "std_msgs",
        "std_srvs", "stereo_msgs", "trajectory_msgs", "visualization_msgs")}),
    ("ros2/example_interfaces", "jazzy", {"example_interfaces": ""}),
    ("ros2/demos", "jazzy", {"action_tutorials_interfaces": "action_tutorials/action_tutorials_interfaces"}),
    ("ros2/rcl_interfaces", "jazzy", {p: p for p in (
        "action_msgs", "builtin_interfaces", "lifecycle_msgs", "rcl_interfaces", "rosgraph_msgs")}),
    ("ros2/geometry2", "jazzy", {"tf2_msgs": "tf2_msgs"}),
    ("ros2/unique_identifier_msgs", "jazzy", {"unique_identifier_msgs": ""}),
    ("ros-controls/control_msgs", "jazzy", {"control_msgs": "control_msgs"}),
    ("ros-controls/ros2_control", "jazzy", {"controller_manager_msgs": "controller_manager_msgs"}),
    ("ros-simulation/gazebo_ros_pkgs", "ros2", {"gazebo_msgs": "gazebo_msgs"}),
]
KINDS = ("msg", "srv", "action")


def _git(repo: Path, *args: str) -> bytes:
    return subprocess.run(["git", "-C", str(repo), *args], check=True, capture_output=True).stdout


def _copy_package(repo: Path, branch: str, folder: str, dest: Path) -> None:
    prefix = f"{folder}/" if folder else ""
    archive = tarfile.open(fileobj=io.BytesIO(_git(repo, "archive", branch, folder or ".")))
    if dest.exists():
        shutil.rmtree(dest)
    for member in archive.getmembers():
        if not member.isfile() or not member.name.startswith(prefix):
            continue
        inside = Path(member.name[len(prefix):])
        wanted = inside.as_posix() in ("package.xml", "LICENSE") or (
            len(inside.parts) == 2 and inside.parts[0] in KINDS and inside.suffix == f".{inside.parts[0]}")
        if wanted:
            (dest / inside).parent.mkdir(parents=True, exist_ok=True)
            (dest / inside).write_bytes(archive.extractfile(member).read())
    for name in ("LICENSE", "LICENSE.txt"):
        if (dest / "LICENSE").exists():
            break   # the package's own
        try:
            (dest / "LICENSE").write_bytes(_git(repo, "show", f"{branch}:{name}"))
            break
        except subprocess.CalledProcessError:
            continue


def main(mirrors: Path) -> None:
    lines = ["# package  repository  branch  commit"]
    for name, branch, packages in SOURCES:
        repo = mirrors / name.replace("/", "+") / "repo"
        commit = _git(repo, "rev-parse", branch).decode().strip()
        for package, folder in packages.items():
            _copy_package(repo, branch, folder, HERE / package)
            lines.append(f"{package}  https://github.com/{name}  {branch}  {commit}")
    (HERE / "SOURCES.txt").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main(Path(sys.argv[1]))
