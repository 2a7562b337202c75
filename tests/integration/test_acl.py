"""Access control for multi-host deployments (docker-compose.secure.yml, config/zenoh/secure/), and the
loopback-only default.

With the secure router, every process authenticates with its own user name and password (zenoh's usrpwd)
and zenoh's access control decides what each identity may send: a stranger on another host holding only the
read-only ``guest`` account reads joint_states but cannot move the robot (its hardware commands,
trajectories, wildcard puts, simulator and controller-manager calls never arrive, and its fake simulator
service is never asked), while the stack runs as without it. A client without credentials, or with a wrong
password, is refused at the handshake. Without any of this (a normal launch), nothing listens on a
non-loopback address.
"""

from __future__ import annotations

import ipaddress
import json
import os
import signal
from pathlib import Path

import psutil
import pytest
import zenoh

from tests.conftest import ROOT
from tests.integration.test_compose import (
    COMPOSE,
    HOSTS,
    PLACEMENT,
    SECURE,
    probe_result,
    run_probe,
    start_probe,
    wait_for_probe_line,
)
from tests.integration.test_launch_scenarios import Scenario
from tests.support import compose as replay

SECURE_DIR = ROOT / "config" / "zenoh" / "secure"
IDENTITIES = ["simulator", "renderer", "controller_manager", "robot_state_publisher", "joint_commander", "viewer", "operator",
              "guest"]


# --- the example files ---------------------------------------------------------------------------------
def test_secure_router_config_loads_and_denies_by_default() -> None:
    config = zenoh.Config.from_file(str(SECURE_DIR / "router.json5"))
    acl = json.loads(config.get_json("access_control"))
    assert acl["enabled"] is True and acl["default_permission"] == "deny"
    subjects = {s["id"]: s["usernames"] for s in acl["subjects"]}
    assert sorted(u for users in subjects.values() for u in users) == sorted(IDENTITIES)
    granted: dict[str, set[str]] = {}
    rules = {r["id"]: r for r in acl["rules"]}
    for policy in acl["policies"]:
        for subject in policy["subjects"]:
            granted.setdefault(subject, set()).update(policy["rules"])
    hardware_command = [rid for rid, r in rules.items() if "put" in r["messages"] and "ingress" in r["flows"]
                        and any(_intersects(k, "humanoid/hardware/command") for k in r["key_exprs"])]
    holders = sorted(s for s, rids in granted.items() if set(hardware_command) & rids)
    assert holders == ["controller_manager"], holders
    sim_calls = [rid for rid, r in rules.items() if "query" in r["messages"] and "ingress" in r["flows"]
                 and any(_intersects(k, "sim/pause_physics") for k in r["key_exprs"])]
    assert sorted(s for s, rids in granted.items() if set(sim_calls) & rids) == ["operator"]
    assert "guest" in granted and not {"take part", "serve", "publish", "call"} & granted["guest"]


def _intersects(a: str, b: str) -> bool:
    return zenoh.KeyExpr(a).intersects(zenoh.KeyExpr(b))


def test_every_identity_file_is_a_client_known_to_the_router() -> None:
    dictionary = dict(line.split(":", 1) for line in (SECURE_DIR / "credentials.txt").read_text().split())
    assert sorted(dictionary) == sorted(IDENTITIES)
    for identity in IDENTITIES:
        config = zenoh.Config.from_file(str(SECURE_DIR / f"{identity}.json5"))
        assert json.loads(config.get_json("mode")) == "client", identity  # all traffic through the router
        auth = json.loads(config.get_json("transport/auth/usrpwd"))
        assert (auth["user"], auth["password"]) == (identity, dictionary[identity])
    compose = replay.load(COMPOSE, SECURE)
    for name, service in compose.services.items():
        if name == "zenohd":
            assert service.command == ["--config", "/run/secrets/router.json5"]
            assert compose.secrets[service.secrets["router.json5"]] == SECURE_DIR / "router.json5"
            continue
        assert service.environment["ZENOH_CONFIG"] == "/run/secrets/zenoh.json5", name
        identity = compose.secrets[service.secrets["zenoh.json5"]].stem
        assert identity == (name if name in IDENTITIES else "operator"), (name, identity)  # spawners: operator


# --- a stranger on the network ----------------------------------------------------------------------------
@pytest.mark.slow
@pytest.mark.alone   # seven realtime processes on namespaced hosts: judged on a few seconds of the robot's motion
def test_stranger_reads_joint_states_but_cannot_move_the_robot(tmp_path: Path) -> None:
    if not replay.netns_available():
        pytest.skip("network namespaces need root, iproute2 (ip netns) and mount")
    compose = replay.load(COMPOSE, SECURE)
    network = replay.Network([*HOSTS, "stranger"], tmp_path)
    run = replay.Replay(compose, network, PLACEMENT, tmp_path)
    connect = {"ZENOH_CONNECT": "tcp/zenohd:7447"}
    identity = {**connect, "ZENOH_CONFIG": "/run/secrets/zenoh.json5"}  # as in the compose file
    operator = {"zenoh.json5": compose.secrets["zenoh_operator"]}
    guest = {"zenoh.json5": SECURE_DIR / "guest.json5"}
    try:
        run.start()
        before = run_probe(network, "tools", tmp_path, "call-before", "call", "sim/get_physics_properties",
                           env=identity, secrets=operator)
        assert [r.get("ok", {}).get("success") for r in before["replies"]] == [True], f"{before}\n{run.outputs()}"
        watcher = start_probe(network, "tools", tmp_path, "watch", "watch", "8", "--until-signal", env=identity,
                              secrets=operator)
        wait_for_probe_line(watcher, "watching", "the watcher to see joint_states")
        stranger = start_probe(network, "stranger", tmp_path, "stranger", "rogue", env=identity, secrets=guest)
        wait_for_probe_line(stranger, "spoofing", "the stranger's fake simulator service")
        during = run_probe(network, "tools", tmp_path, "call-during", "call", "sim/get_physics_properties",
                           env=identity, secrets=operator)
        os.killpg(stranger.pid, signal.SIGINT)
        attack = probe_result(stranger)
        # the same stranger without credentials, or guessing a password, is not let in at all
        nobody = tmp_path / "nobody.json5"
        nobody.write_text('{mode: "client"}')
        anonymous = run_probe(network, "stranger", tmp_path, "anonymous", "rogue", env=identity,
                              secrets={"zenoh.json5": nobody})
        wrong = tmp_path / "wrong.json5"
        wrong.write_text('{mode: "client", transport: {auth: {usrpwd: {user: "controller_manager", '
                         'password: "guess"}}}}')
        guessing = run_probe(network, "stranger", tmp_path, "guessing", "rogue", env=identity,
                             secrets={"zenoh.json5": wrong})
        os.killpg(watcher.pid, signal.SIGINT)
        seen = probe_result(watcher)
        after = run_probe(network, "tools", tmp_path, "call-after", "call", "sim/get_physics_properties",
                          env=identity, secrets=operator)
    finally:
        run.stop()
        network.close()
    report = f"stranger: {attack}\nwatch: {seen}\n{run.outputs()}"
    assert attack["connected"] and attack["read_joint_states"] and attack["joints"] == 22, report
    assert attack["puts"] > 100, report
    for key, replies in attack["replies"].items():
        assert "ok" not in replies, f"the stranger's call to {key} was answered: {report}"
    assert seen["rogue_seen"] == [], f"the stranger's commands reached the stack: {report}"
    assert seen["knee_max"] - seen["knee_min"] > 0.25, f"the robot stopped following the commander: {report}"
    assert seen["pelvis_min"] > 0.75, f"the robot fell: {report}"
    assert seen["sim_time"][1] - seen["sim_time"][0] > 5.0, f"physics paused or reset: {report}"
    assert not anonymous["connected"] and not guessing["connected"], (anonymous, guessing)
    # only the real simulator answers its services (the stranger's fake one is never asked), and it kept
    # its physics
    for call in (during, after):
        replies = call["replies"]
        assert len(replies) == 1 and replies[0]["attachment"] == "", replies
        assert replies[0]["ok"]["gravity"]["z"] == pytest.approx(-9.81) and not replies[0]["ok"]["pause"], replies
    for name in ("simulator", "controller_manager", "robot_state_publisher", "joint_commander", "viewer"):
        assert run.running[name].starts == 1, f"'{name}' restarted: {run.outputs()}"


# --- the default: loopback only -------------------------------------------------------------------------
@pytest.mark.slow
def test_a_normal_launch_listens_on_loopback_only(tmp_path: Path, zenoh_port: int) -> None:
    scenario = Scenario(tmp_path, zenoh_port, "humanoid.yaml", "gui:=true",
                        "viewer_args:=--serve --web-port 0 --grpc-port 0")
    try:
        scenario.connect("humanoid/joint_states")
        scenario.wait_for(lambda: len(scenario.snapshot("humanoid/joint_states")) > 50, 90, "joint_states")
        scenario.wait_for(lambda: "Rerun web viewer" in scenario.output(), 60, "the viewer's web server")
        tree = [scenario.proc.pid] + [c.pid for c in psutil.Process(scenario.proc.pid).children(recursive=True)]
        sockets = [c for c in psutil.net_connections(kind="inet") if c.pid in tree]
        listening = [c for c in sockets if c.status == psutil.CONN_LISTEN]
        commands = {pid: _command_of(pid) for pid in {c.pid for c in sockets}}
        exposed = [(commands[c.pid], c.laddr) for c in listening if not ipaddress.ip_address(c.laddr.ip).is_loopback]
        assert not exposed, f"listening beyond loopback: {exposed}"
        # UDP: nothing bound to an address other machines could send to (no multicast scouting)
        udp = [(commands[c.pid], c.laddr) for c in sockets if c.type == 2 and not c.raddr
               and not ipaddress.ip_address(c.laddr.ip).is_loopback]
        assert not udp, f"UDP sockets open beyond loopback: {udp}"
        assert {"launch", "nodes.sim", "nodes.control", "nodes.viz"} <= {
            word for cmd in (commands[c.pid] for c in listening) for word in cmd.split()}, commands
    finally:
        scenario.close()


def _command_of(pid: int) -> str:
    """The start of a process's command line; a short-lived child (the controller spawner) may have ended
    between listing the sockets and asking (psutil then raises ZombieProcess or NoSuchProcess)."""
    try:
        return " ".join(psutil.Process(pid).cmdline()[:4])
    except psutil.Error:
        return f"(pid {pid}, ended)"
