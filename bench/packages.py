"""What the package index costs: one scan of a workspace of N packages (every command that names a package
pays it once per process), and the start of a command under each name (``zenroid pkg list``,
``ros2 pkg list``: the ros2 spellings' cost) and of a served executable (``serve xacro xacro --help``
against ``zenroid xacro --help``: the --ros-args and mapping layer).

    python bench/packages.py [--packages 400] [--runs 7]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.common import child_env, print_table  # noqa: E402 - after the path is set

PACKAGE_XML = "<package format='3'><name>{name}</name><version>0.0.1</version><description>d</description>" \
              "<maintainer email='a@b.c'>a</maintainer><license>MIT</license></package>"


def workspace(root: Path, count: int) -> Path:
    """``count`` packages in groups of 20, each with launch/, urdf/ and a few files (a crawl must not enter them)."""
    for i in range(count):
        folder = root / f"group_{i // 20}" / f"pkg_{i}"
        for sub in ("launch", "urdf", "config", "meshes"):
            (folder / sub).mkdir(parents=True)
            (folder / sub / "x.txt").write_text("x")
        (folder / "package.xml").write_text(PACKAGE_XML.format(name=f"pkg_{i}"))
    return root


def scan_ms(path: Path, runs: int) -> list[float]:
    code = ("import time, sys; from nodes.packages.index import Index; t = time.perf_counter(); i = Index(); "
            "print((time.perf_counter() - t) * 1000, len(i.packages))")
    env = child_env({"ROS_PACKAGE_PATH": str(path)})
    times = []
    for _ in range(runs):
        out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True,
                             cwd=tempfile.gettempdir())
        times.append(float(out.stdout.split()[0]))
    return times


def commands_ms(commands: dict[str, list[str]], runs: int) -> dict[str, float]:
    """Median wall ms of each command, the commands interleaved run by run (a shared machine's load then
    weighs on all of them alike)."""
    times: dict[str, list[float]] = {name: [] for name in commands}
    for _ in range(runs):
        for name, argv in commands.items():
            start = time.perf_counter()
            subprocess.run([sys.executable, *argv], env=child_env(), capture_output=True, check=True, cwd=ROOT)
            times[name].append((time.perf_counter() - start) * 1000)
    return {name: statistics.median(values) for name, values in times.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--packages", type=int, default=400)
    parser.add_argument("--runs", type=int, default=7)
    args = parser.parse_args()
    load_before = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as tmp:
        tree = workspace(Path(tmp), args.packages)
        scan = scan_ms(tree, args.runs)
    figures = {"packages": args.packages, "scan_ms": statistics.median(scan), **commands_ms({
        "zenroid_pkg_list_ms": ["-m", "nodes.tools", "pkg", "list"],
        "ros2_pkg_list_ms": ["-m", "nodes.tools.ros2", "pkg", "list"],
        "zenroid_xacro_help_ms": ["-m", "nodes.tools", "xacro", "--help"],
        "served_xacro_help_ms": ["-m", "nodes.packages.serve", "xacro", "xacro", "--help"]}, args.runs)}
    print(json.dumps(figures))
    print_table([
        (f"index scan, {args.packages} packages on ROS_PACKAGE_PATH", f"{figures['scan_ms']:.1f} ms",
         f"median of {args.runs} processes (the index itself, imports excluded)"),
        ("zenroid pkg list", f"{figures['zenroid_pkg_list_ms']:.0f} ms", "whole process, wall"),
        ("ros2 pkg list", f"{figures['ros2_pkg_list_ms']:.0f} ms", "the same through the ros2 spellings"),
        ("zenroid xacro --help", f"{figures['zenroid_xacro_help_ms']:.0f} ms", "whole process, wall"),
        ("serve xacro xacro --help", f"{figures['served_xacro_help_ms']:.0f} ms",
         "the same as `ros2 run xacro xacro` / Node(package='xacro') start it"),
    ], load_before)


if __name__ == "__main__":
    main()
