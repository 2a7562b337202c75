"""nodes.core.session: which endpoints, listeners and identity a node's Zenoh configuration carries."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from nodes.core import session


def _get(config, key: str):
    return json.loads(config.get_json(key))


def test_default_peer_listens_on_loopback_only(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("ZENOH_CONNECT", raising=False)
    monkeypatch.delenv("ZENOH_CONFIG", raising=False)
    config = session.peer_config()
    assert _get(config, "mode") == "peer"
    assert _get(config, "connect/endpoints") == ["tcp/127.0.0.1:7447"]
    assert _get(config, "listen/endpoints") == ["tcp/127.0.0.1:0"]
    assert _get(config, "scouting/multicast/enabled") is False


def test_a_config_file_gives_the_identity_and_zenoh_connect_the_router(tmp_path: Path,
                                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "node.json5"
    path.write_text('{mode: "client", connect: {endpoints: ["tcp/elsewhere:7447"]},'
                    ' transport: {auth: {usrpwd: {user: "controller_manager", password: "secret"}}}}')
    monkeypatch.setenv("ZENOH_CONFIG", str(path))
    monkeypatch.delenv("ZENOH_CONNECT", raising=False)
    config = session.peer_config()
    assert _get(config, "mode") == "client"  # the file decides: a client goes through the router only
    assert _get(config, "connect/endpoints") == ["tcp/elsewhere:7447"]
    assert _get(config, "transport/auth/usrpwd/user") == "controller_manager"
    assert _get(config, "scouting/multicast/enabled") is False
    monkeypatch.setenv("ZENOH_CONNECT", "tcp/zenohd:7447")
    config = session.peer_config()
    assert _get(config, "connect/endpoints") == ["tcp/zenohd:7447"]
    assert _get(config, "transport/auth/usrpwd/password") == "secret"


def test_router_from_a_zenohd_file_keeps_its_listeners(tmp_path: Path) -> None:
    path = tmp_path / "router.json5"
    path.write_text('{listen: {endpoints: ["tcp/0.0.0.0:7999"]}, access_control: {enabled: true,'
                    ' default_permission: "deny", rules: [], subjects: [], policies: []}}')
    config = session.router_config(file=str(path))
    assert _get(config, "mode") == "router"
    assert session.listen_endpoints(config) == ["tcp/0.0.0.0:7999"]
    assert _get(config, "access_control/enabled") is True
    assert session.listen_endpoints(session.router_config(7500)) == ["tcp/127.0.0.1:7500"]
    path.write_text("{}")  # no listeners of its own: loopback, never zenoh's every-interface default
    assert session.listen_endpoints(session.router_config(7501, file=str(path))) == ["tcp/127.0.0.1:7501"]
