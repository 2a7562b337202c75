"""docker-compose.yml: valid for a real compose implementation, the same nodes and parameters as the main
job's launch file, the router image pinned to our Zenoh, nothing but the viewer published; and the topology
itself, run from the file (each service's command and environment as written there) across network
namespaces standing in for containers: the router's, the simulator's, the control host's and a tools host
(viewer, commander), where joint_states arrive and the robot follows the commander. Docker itself cannot
run on these machines."""

from __future__ import annotations

import importlib.metadata
import json
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from bench.common import wait_until
from launch.resolve import LaunchPlan, find_launch_file, resolve
from nodes.core.params import load_params_file, parse_value
from tests.conftest import ROOT
from tests.support import compose as replay

COMPOSE = ROOT / "docker-compose.yml"
SECURE = ROOT / "docker-compose.secure.yml"  # tests/integration/test_acl.py
ENDPOINT = "tcp/zenohd:7447"
# where each service runs in the namespace replay (a new service must be placed here: the test says so)
PLACEMENT = {
    "zenohd": "router",
    "simulator": "sim",
    "renderer": "sim",
    "controller_manager": "control",
    "spawner_joint_state_broadcaster": "control",
    "spawner_joint_trajectory_controller": "control",
    "robot_state_publisher": "control",
    "joint_commander": "tools",
    "viewer": "tools",
}
HOSTS = ["router", "sim", "control", "tools"]


def docker_compose() -> str:
    found = shutil.which("docker-compose")
    if found is None:
        pytest.skip("docker-compose is not installed (Debian: apt-get install --no-install-recommends "
                    "docker-compose; .ci/run does it)")
    return found


# --- the file, checked by docker-compose itself ------------------------------------------------------
@pytest.mark.parametrize("files", [[COMPOSE], [COMPOSE, SECURE]], ids=["base", "secure"])
def test_docker_compose_accepts_the_file(files: list[Path]) -> None:
    argv = [docker_compose()]
    for path in files:
        argv += ["-f", str(path)]
    checked = subprocess.run([*argv, "config", "-q"], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert checked.returncode == 0, checked.stderr
    services = subprocess.run([*argv, "config", "--services"], capture_output=True, text=True, cwd=ROOT,
                              timeout=120)
    assert sorted(services.stdout.split()) == sorted(PLACEMENT), services.stdout + services.stderr


def test_router_image_is_the_zenoh_we_run() -> None:
    image = replay.load(COMPOSE).services["zenohd"].image
    assert image == f"eclipse/zenoh:{importlib.metadata.version('eclipse-zenoh')}", (
        f"{image}: pin the router image to the installed eclipse-zenoh (same protocol version)")


def test_only_the_viewer_is_published_and_every_node_names_the_router() -> None:
    services = replay.load(COMPOSE).services
    published = {name: s.ports for name, s in services.items() if s.ports}
    assert set(published) == {"viewer"}, published
    for name, service in services.items():
        if name != "zenohd":
            assert service.environment.get("ZENOH_CONNECT") == ENDPOINT, (name, service.environment)
    assert (ROOT / "Dockerfile").is_file()


def _normalise(value: Any) -> Any:
    """File paths as absolute paths (the compose file uses paths relative to the image's /app)."""
    if isinstance(value, dict):
        return {k: _normalise(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_normalise(v) for v in value]
    if isinstance(value, str) and "/" in value and (ROOT / value).exists():
        return str((ROOT / value).resolve())
    return value


def _node_of_command(argv: list[str]) -> dict[str, Any]:
    """What a node command line amounts to: program, name, namespace, parameters (params files loaded)."""
    assert argv[:2] == ["python", "-m"], argv
    module, rest = argv[2], argv[3:]
    out: dict[str, Any] = {"module": module, "name": None, "namespace": "", "params": {}, "args": []}
    files: list[str] = []
    items = iter(rest)
    for item in items:
        if item == "--name":
            out["name"] = next(items)
        elif item == "--ns":
            out["namespace"] = next(items)
        elif item == "--params-file":
            files.append(next(items))
        elif item in ("--param", "-p"):
            key, _, value = next(items).partition(":=")
            out["params"][key] = parse_value(value)
        else:
            out["args"].append(item)
    for path in files:
        out["params"] = {**load_params_file(ROOT / path, out["name"], out["namespace"]), **out["params"]}
    out["params"] = _normalise(out["params"])
    return out


def _main_job(viewer_args: list[str]) -> LaunchPlan:
    return resolve(find_launch_file("humanoid.yaml"), {"gui": "true", "viewer_args": " ".join(viewer_args)})


def test_services_run_the_main_jobs_nodes_with_its_parameters() -> None:
    services = replay.load(COMPOSE).services
    viewer_args = _node_of_command(services["viewer"].command)["args"]
    plan = _main_job(viewer_args)
    assert sorted(n.name for n in plan.nodes) == sorted(set(services) - {"zenohd"})
    for spec in plan.nodes:
        command = services[spec.name].command
        if spec.executable is not None:  # a program (the spawners): the same argv
            assert Path(spec.executable).name.startswith("python") and command[0] == "python", command
            assert command[1:] == spec.args, (spec.name, command)
            continue
        node = _node_of_command(command)
        params = dict(spec.params)
        for path in spec.param_files:
            params = {**load_params_file(path, spec.name, spec.namespace), **params}
        assert (node["module"], node["name"], node["namespace"]) == (spec.module, spec.name, spec.namespace)
        assert node["params"] == _normalise(params), spec.name
        assert node["args"] == spec.args, spec.name
        # respawning nodes are restarted by docker; one-shot ones only until they succeed
        assert services[spec.name].restart == ("unless-stopped" if spec.respawn else "on-failure"), spec.name


# --- the topology, run from the file across network namespaces ---------------------------------------
def start_probe(network: replay.Network, host: str, log_dir: Path, name: str, *argv: str,
                env: dict[str, str] | None = None, secrets: dict[str, Path] | None = None) -> subprocess.Popen:
    """``tests/support/deploy_probe.py ARGV`` on ``host``, with ``env`` over the image's environment."""
    environment = replay.base_environment()
    environment.update(env or {})
    proc = network.popen(host, [sys.executable, "-m", "tests.support.deploy_probe", *argv], environment,
                         log_dir / f"{name}.log", secrets)
    proc.log_path = log_dir / f"{name}.log"  # type: ignore[attr-defined]
    return proc


def wait_for_probe_line(proc: subprocess.Popen, line: str, what: str, timeout: float = 120) -> None:
    """Until a started probe printed ``line`` (or ended: ``probe_result`` then says why)."""
    wait_until(lambda: line in proc.log_path.read_text(errors="replace") or proc.poll() is not None,  # type: ignore[attr-defined]
               timeout, what)


def probe_result(proc: subprocess.Popen, timeout: float = 240) -> dict:
    """The JSON line a probe printed (fails the test with its output when it printed none)."""
    try:
        proc.wait(timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
    log = proc.log_path  # type: ignore[attr-defined]
    lines = [line for line in log.read_text(errors="replace").splitlines() if line.startswith("{")]
    assert proc.returncode == 0 and lines, f"{log.stem} failed:\n{log.read_text(errors='replace')[-3000:]}"
    return json.loads(lines[-1])


def run_probe(network: replay.Network, host: str, log_dir: Path, name: str, *argv: str,
              env: dict[str, str] | None = None, secrets: dict[str, Path] | None = None) -> dict:
    return probe_result(start_probe(network, host, log_dir, name, *argv, env=env, secrets=secrets))


@pytest.mark.slow
def test_compose_topology_runs_across_hosts(tmp_path: Path) -> None:
    if not replay.netns_available():
        pytest.skip("network namespaces need root, iproute2 (ip netns) and mount")
    compose = replay.load(COMPOSE)
    network = replay.Network(HOSTS, tmp_path)
    run = replay.Replay(compose, network, PLACEMENT, tmp_path)
    try:
        run.start()
        # a user on the tools host, as the viewer and the commander there: same environment as theirs
        seen = run_probe(network, "tools", tmp_path, "watch", "watch", "6",
                         env=compose.services["viewer"].environment)
        assert "error" not in seen, f"{seen}\n{run.outputs()}"
        assert seen["joint_states"] > 100, seen
        assert seen["knee_max"] - seen["knee_min"] > 0.25, f"the knee does not follow the commander: {seen}"
        assert seen["pelvis_min"] > 0.75, f"the robot fell: {seen}"
        assert seen["sim_time"][1] > seen["sim_time"][0], seen
        # the viewer serves its page on the tools host (the port the compose file publishes)
        page = network.popen("tools", [sys.executable, "-c", WEB_CHECK], replay.base_environment(),
                             tmp_path / "web.log")
        page.wait(60)
        assert page.returncode == 0, (tmp_path / "web.log").read_text() + run.output("viewer")[-3000:]
        # Docker publishes a port by forwarding to the container's own address, not to its loopback.
        published = _reachable_from(network, "router", network.addresses["tools"], 9090)
        # every node runs where the file puts it, once: nothing crashed and restarted
        for name in ("simulator", "controller_manager", "robot_state_publisher", "joint_commander", "viewer"):
            assert run.running[name].starts == 1 and not run.running[name].exits, run.outputs()
        nodes = subprocess.run(
            ["ip", "netns", "exec", network.namespaces["tools"], sys.executable, "-m", "nodes.tools", "node",
             "list"], capture_output=True, text=True, timeout=60, cwd=ROOT,
            env={**replay.base_environment(), "ZENOH_CONNECT": f"tcp/{network.addresses['router']}:7447"})
        listed = nodes.stdout.split()
        for node in ("/simulator", "/humanoid/controller_manager", "/humanoid/robot_state_publisher",
                     "/humanoid/joint_commander", "/viewer"):
            assert node in listed, nodes.stdout + nodes.stderr
        assert published, "the viewer's page is not reachable on the address a published port forwards to"
    finally:
        run.stop()
        network.close()


def _reachable_from(network: replay.Network, host: str, address: str, port: int) -> bool:
    probe = network.popen(host, [sys.executable, "-c", f"import socket; socket.create_connection(({address!r}, {port}), 5)"],
                          replay.base_environment(), network.work_dir / "reach.log")
    return probe.wait(30) == 0


WEB_CHECK = r"""
import sys, time, urllib.request
deadline = time.monotonic() + 50
while True:
    try:
        with urllib.request.urlopen("http://127.0.0.1:9090/", timeout=5) as page:
            sys.exit(0 if page.status == 200 else 1)
    except OSError:
        if time.monotonic() > deadline:
            raise
        time.sleep(0.5)
"""
