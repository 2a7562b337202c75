"""Two hosts in network namespaces made by the test: the humanoid runs on host A behind a standalone
router; host B, which reaches A only over a veth link, reads humanoid/joint_states with zenoh + msgpack
alone and with the zenroid CLI. Skipped where network namespaces cannot be created (not root, no ip)."""

from __future__ import annotations

import subprocess
import sys
import time
import uuid
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

from bench.common import child_env, spawn, stop_all
from tests.support.compose import netns_available

pytestmark = pytest.mark.slow

CLIENT = r"""
import json, sys, msgpack, zenoh
conf = zenoh.Config()
conf.insert_json5("mode", '"client"')  # a third-party tool: everything through the router
conf.insert_json5("connect/endpoints", json.dumps([sys.argv[1]]))
conf.insert_json5("scouting/multicast/enabled", "false")
with zenoh.open(conf) as session:
    sub = session.declare_subscriber("humanoid/joint_states")
    state = msgpack.unpackb(sub.recv().payload.to_bytes())
    print(json.dumps({"joints": len(state["name"]), "knee": state["position"][state["name"].index("left_knee")]}))
"""


@dataclass
class Hosts:
    a: str
    b: str
    address_a: str
    log_dir: Path
    procs: list[subprocess.Popen]

    def run_in(self, ns: str, *argv: str, name: str, env: dict[str, str] | None = None) -> subprocess.Popen:
        log = self.log_dir / f"{name}.log"
        proc = spawn(["ip", "netns", "exec", ns, sys.executable, *argv], log=log, env=child_env(env))
        proc.log_path = str(log)  # type: ignore[attr-defined]
        self.procs.append(proc)
        return proc

    def output(self, proc: subprocess.Popen) -> str:
        return Path(proc.log_path).read_text(errors="replace")  # type: ignore[attr-defined]


def _ip(*argv: str) -> None:
    subprocess.run(["ip", *argv], check=True, capture_output=True)


@pytest.fixture
def hosts(tmp_path: Path) -> Iterator[Hosts]:
    if not netns_available():
        pytest.skip("network namespaces need root and iproute2 (ip netns)")
    tag = uuid.uuid4().hex[:6]
    a, b = f"zr_a_{tag}", f"zr_b_{tag}"
    subnet = 100 + int(tag[:2], 16) % 100  # 10.231.<subnet>.0/24 exists only between these two namespaces
    hosts = Hosts(a, b, f"10.231.{subnet}.1", tmp_path, [])
    try:
        _ip("netns", "add", a)
        _ip("netns", "add", b)
        _ip("link", "add", f"zra{tag}", "type", "veth", "peer", "name", f"zrb{tag}")
        _ip("link", "set", f"zra{tag}", "netns", a)
        _ip("link", "set", f"zrb{tag}", "netns", b)
        _ip("-n", a, "addr", "add", f"10.231.{subnet}.1/24", "dev", f"zra{tag}")
        _ip("-n", b, "addr", "add", f"10.231.{subnet}.2/24", "dev", f"zrb{tag}")
        for ns, dev in ((a, f"zra{tag}"), (b, f"zrb{tag}")):
            _ip("-n", ns, "link", "set", dev, "up")
            _ip("-n", ns, "link", "set", "lo", "up")
        yield hosts
    finally:
        stop_all(hosts.procs, timeout=15)
        subprocess.run(["ip", "netns", "del", a], capture_output=True)
        subprocess.run(["ip", "netns", "del", b], capture_output=True)


def test_humanoid_on_host_a_is_read_from_host_b(hosts: Hosts) -> None:
    endpoint = f"tcp/{hosts.address_a}:7447"
    router = hosts.run_in(hosts.a, "-m", "nodes.tools", "router", "--listen", endpoint, name="router")
    deadline = time.monotonic() + 20
    while "listening on" not in hosts.output(router) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert "listening on" in hosts.output(router), hosts.output(router)
    launch = hosts.run_in(hosts.a, "-m", "launch", "humanoid.yaml", "gui:=false", "mode:=lockstep", name="launch",
                          env={"ZENOH_CONNECT": endpoint})
    # host B: a client with zenoh + msgpack only, then the project's CLI, both over the veth link
    client = hosts.run_in(hosts.b, "-c", CLIENT, endpoint, name="client")
    try:
        client.wait(90)
    except subprocess.TimeoutExpired:
        pytest.fail("host B got no joint_states in 90 s\n" + hosts.output(launch)[-3000:])
    out = hosts.output(client)
    assert client.returncode == 0, out
    assert '"joints": 22' in out, out
    assert "external router" in hosts.output(launch)  # the launcher did not start its own router
    echo = hosts.run_in(hosts.b, "-m", "nodes.tools", "topic", "echo", "humanoid/joint_states", "--once",
                        "--field", "name", "--timeout", "30", name="echo", env={"ZENOH_CONNECT": endpoint})
    echo.wait(60)
    assert echo.returncode == 0 and "left_knee" in hosts.output(echo), hosts.output(echo)
    nodes = hosts.run_in(hosts.b, "-m", "nodes.tools", "node", "list", name="nodes", env={"ZENOH_CONNECT": endpoint})
    nodes.wait(60)
    listed = hosts.output(nodes).split()
    assert "/simulator" in listed and "/humanoid/controller_manager" in listed, listed
