"""TLS between hosts (docs/deployment-tls.md), from the shipped files: config/zenoh-tls-router.json5 and
config/zenoh-tls-client.json5 with certificates made by examples/tls_certs.sh, on three hosts made of
network namespaces (tests/support/compose.py's Network). The router listens on tls/ only; the humanoid
runs on a second host and a user on a third reads joint_states, every link through the router encrypted.
Clients without the CA, with another CA or dialling plain tcp are refused, and so is a router whose
certificate does not name the address a client dialled."""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.conftest import ROOT
from tests.integration.test_compose import run_probe
from tests.support import compose as replay

pytestmark = pytest.mark.slow

ROUTER_CONFIG = ROOT / "config" / "zenoh-tls-router.json5"
CLIENT_CONFIG = ROOT / "config" / "zenoh-tls-client.json5"
MAKE_CERTS = ROOT / "examples" / "tls_certs.sh"
CERTS, ROUTER_ADDRESS = "/path/to/certs", "<router-address>"  # the placeholders of the shipped files

# Every frame on the router host's links for a few seconds: joint_states cross them all the time (the robot
# host's nodes talk through the router), so a cleartext key or joint name would show.
SNIFF = r"""
import json, socket, sys, time
raw = socket.socket(socket.AF_PACKET, socket.SOCK_RAW, socket.htons(0x0003))
raw.settimeout(0.2)
frames = size = 0
cleartext = []
end = time.monotonic() + float(sys.argv[1])
while time.monotonic() < end:
    try:
        frame = raw.recv(65535)
    except TimeoutError:
        continue
    frames, size = frames + 1, size + len(frame)
    cleartext += [word for word in ("joint_states", "left_knee") if word.encode() in frame]
print(json.dumps({"frames": frames, "bytes": size, "cleartext": sorted(set(cleartext))}))
"""


def filled(template: Path, out: Path, values: dict[str, str]) -> Path:
    """``template`` with its placeholders replaced, as a user following the docs would."""
    text = template.read_text(encoding="utf-8")
    for placeholder, value in values.items():
        assert placeholder in text, f"{template.name} lost its placeholder {placeholder}"
        text = text.replace(placeholder, value)
    out.write_text(text, encoding="utf-8")
    return out


def make_certs(directory: Path, *addresses: str) -> None:
    done = subprocess.run(["sh", str(MAKE_CERTS), str(directory), *addresses], capture_output=True, text=True,
                          timeout=60)
    assert done.returncode == 0, done.stdout + done.stderr
    assert {"ca.pem", "ca-key.pem", "router.pem", "router-key.pem"} <= {p.name for p in directory.iterdir()}


def test_tls_router_carries_the_robot_across_hosts_and_refuses_whoever_does_not_trust_it(tmp_path: Path) -> None:
    if not replay.netns_available():
        pytest.skip("network namespaces need root, iproute2 (ip netns) and mount")
    network = replay.Network(["router", "robot", "viewer"], tmp_path)
    address = network.addresses["router"]
    certs, other = tmp_path / "certs", tmp_path / "other-ca"
    make_certs(certs, address)
    make_certs(other, address)  # another CA, also for the router's address
    router_config = filled(ROUTER_CONFIG, tmp_path / "router.json5", {CERTS: str(certs)})
    client = filled(CLIENT_CONFIG, tmp_path / "client.json5", {CERTS: str(certs), ROUTER_ADDRESS: address})
    wrong_ca = filled(CLIENT_CONFIG, tmp_path / "wrong-ca.json5", {CERTS: str(other), ROUTER_ADDRESS: address})
    no_ca = tmp_path / "no-ca.json5"  # TLS with the system's root certificates only
    no_ca.write_text(f'{{mode: "client", connect: {{endpoints: ["tls/{address}:7447"]}}}}')
    plain = tmp_path / "plain-tcp.json5"
    plain.write_text(f'{{mode: "client", connect: {{endpoints: ["tcp/{address}:7447"]}}}}')
    env = replay.base_environment()
    procs: list[subprocess.Popen] = []
    router_log, launch_log = tmp_path / "router.log", tmp_path / "launch.log"
    try:
        procs.append(network.popen("router", [sys.executable, "-m", "nodes.tools", "router", "--config",
                                              str(router_config)], env, router_log))
        deadline = time.monotonic() + 30
        while "listening on tls/0.0.0.0:7447" not in router_log.read_text(errors="replace"):
            assert procs[0].poll() is None and time.monotonic() < deadline, router_log.read_text(errors="replace")
            time.sleep(0.1)
        procs.append(network.popen("robot", [sys.executable, "-m", "launch", "humanoid.yaml", "gui:=false",
                                             "mode:=lockstep", "commander:=none", "--log-dir", str(tmp_path / "logs")],
                                   {**env, "ZENOH_CONFIG": str(client)}, launch_log))
        seen = run_probe(network, "viewer", tmp_path, "watch", "watch", "1", env={"ZENOH_CONFIG": str(client)})
        launched = launch_log.read_text(errors="replace")
        assert "error" not in seen, f"{seen}\n{launched[-3000:]}"
        assert seen["joint_states"] > 10 and seen["pelvis_min"] > 0.75, seen
        assert seen["sim_time"][1] > seen["sim_time"][0], seen
        assert "external router" in launched, launched[-3000:]  # the launcher did not host a router of its own
        echo = network.popen("viewer", [sys.executable, "-m", "nodes.tools", "topic", "echo", "humanoid/joint_states",
                                        "--once", "--field", "name", "--timeout", "30"],
                             {**env, "ZENOH_CONFIG": str(client)}, tmp_path / "echo.log")
        assert echo.wait(60) == 0 and "left_knee" in (tmp_path / "echo.log").read_text(errors="replace"), (
            (tmp_path / "echo.log").read_text(errors="replace"))
        sniffer = network.popen("router", [sys.executable, "-c", SNIFF, "3"], env, tmp_path / "sniff.log")
        sniffer.wait(30)
        sniffed = json.loads((tmp_path / "sniff.log").read_text().splitlines()[-1])
        assert sniffed["bytes"] > 50_000 and sniffed["cleartext"] == [], sniffed

        refusals = {name: run_probe(network, "viewer", tmp_path, name, "rogue",
                                    env={"ZENOH_CONFIG": str(config), "RUST_LOG": "warn"})
                    for name, config in (("wrong-ca", wrong_ca), ("no-ca", no_ca), ("plain-tcp", plain))}
        # on the router's own host, by loopback: the right CA, but the certificate names only `address`
        refusals["loopback"] = run_probe(network, "router", tmp_path, "loopback", "rogue",
                                         env={"ZENOH_CONFIG": str(client), "ZENOH_CONNECT": "tls/127.0.0.1:7447",
                                              "RUST_LOG": "warn"})
    finally:
        replay.stop_all(procs)
        network.close()
    for name, result in refusals.items():
        assert not result["connected"], f"{name} got in: {result}"
    logs = {name: (tmp_path / f"{name}.log").read_text(errors="replace") for name in refusals}
    # Zenoh's reasons (rustls'): the other CA bears the same name as ours, so its signature is what fails
    for name, reason in (("wrong-ca", "BadSignature"), ("no-ca", "UnknownIssuer"), ("loopback", "certificate not valid for name")):
        assert f"invalid peer certificate: {reason}" in logs[name], logs[name][-2000:]
