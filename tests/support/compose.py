"""Replays a docker-compose topology without Docker, from the compose files themselves.

Each service's command, environment, restart policy and secrets are read from the compose file(s) (an
override file merges into the base as docker-compose merges it, for the keys used here) and run on a
"host": a network namespace the test creates, joined to the others by veth links to a bridge (Docker's
compose network). Every process gets, in its own mount namespace, an ``/etc/hosts`` that resolves the
service names to their hosts' addresses (Docker's DNS) and its secrets at ``/run/secrets/<name>``. The
image's working directory (/app, the checkout) is the repository root, and ``python`` is this
interpreter. The official ``eclipse/zenoh`` router image is replaced by ``zenroid router``, which takes
zenohd's options; everything else in the command line is run unchanged.
"""

from __future__ import annotations

import os
import shlex
import shutil
import subprocess
import sys
import threading
import time
import uuid
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from bench.common import stop_all

ROOT = Path(__file__).resolve().parents[2]
ZENOH_IMAGE = "eclipse/zenoh"


@dataclass
class Service:
    name: str
    image: str
    command: list[str]
    environment: dict[str, str]
    restart: str = "no"
    secrets: dict[str, str] = field(default_factory=dict)  # file name in /run/secrets -> secret
    ports: list[str] = field(default_factory=list)
    depends_on: list[str] = field(default_factory=list)


@dataclass
class Compose:
    services: dict[str, Service]
    secrets: dict[str, Path]  # secret name -> file on this machine


def _as_list(value: Any) -> list[str]:
    if value is None:
        return []
    if isinstance(value, str):
        return shlex.split(value)
    if isinstance(value, dict):  # depends_on in its long form
        return [str(k) for k in value]
    return [str(v) for v in value]


def _as_env(value: Any) -> dict[str, str]:
    if value is None:
        return {}
    if isinstance(value, list):  # ["NAME=value", ...]
        return dict(str(item).partition("=")[::2] for item in value)
    return {str(k): "" if v is None else str(v) for k, v in value.items()}


def _secret_mounts(value: Any) -> dict[str, str]:
    """``/run/secrets/<target>`` -> secret name, from the short (name) or long (source, target) syntax."""
    mounts = {}
    for item in value or []:
        source = item if isinstance(item, str) else str(item["source"])
        target = source if isinstance(item, str) else str(item.get("target", source))
        mounts[target] = source
    return mounts


def load(*files: Path) -> Compose:
    """The services of ``files`` merged in order: later files replace ``command``/``image``/``restart`` and
    add to ``environment`` (by name), ``secrets``, ``ports`` and ``depends_on`` (docker-compose's rules)."""
    raw: dict[str, dict[str, Any]] = {}
    secrets: dict[str, Path] = {}
    base_dir = files[0].parent  # relative paths are relative to the project directory (the first file's)
    for path in files:
        document = yaml.safe_load(path.read_text(encoding="utf-8")) or {}
        for name, spec in (document.get("services") or {}).items():
            merged = raw.setdefault(name, {"environment": {}, "secrets": {}, "ports": [], "depends_on": []})
            for key in ("image", "command", "restart", "build"):
                if key in spec:
                    merged[key] = spec[key]
            merged["environment"].update(_as_env(spec.get("environment")))
            merged["secrets"].update(_secret_mounts(spec.get("secrets")))
            for key, convert in (("ports", _as_list), ("depends_on", _as_list)):
                merged[key] += [v for v in convert(spec.get(key)) if v not in merged[key]]
        for name, spec in (document.get("secrets") or {}).items():
            secrets[name] = (base_dir / spec["file"]).resolve()
    services = {
        name: Service(name=name, image=str(spec.get("image", "")), command=_as_list(spec.get("command")),
                      environment=spec["environment"], restart=str(spec.get("restart", "no")),
                      secrets=spec["secrets"], ports=spec["ports"], depends_on=spec["depends_on"])
        for name, spec in raw.items()
    }
    return Compose(services, secrets)


def start_order(services: dict[str, Service]) -> list[str]:
    """Dependencies first (docker-compose's start order)."""
    order: list[str] = []

    def visit(name: str, path: tuple[str, ...] = ()) -> None:
        assert name not in path, f"depends_on cycle: {' -> '.join(path + (name,))}"
        if name in order:
            return
        for dep in services[name].depends_on:
            visit(dep, path + (name,))
        order.append(name)

    for name in services:
        visit(name)
    return order


def netns_available() -> bool:
    if os.geteuid() != 0 or shutil.which("ip") is None or shutil.which("mount") is None:
        return False
    probe = f"zr_probe_{uuid.uuid4().hex[:6]}"
    ok = subprocess.run(["ip", "netns", "add", probe], capture_output=True).returncode == 0
    if ok:
        subprocess.run(["ip", "netns", "del", probe], capture_output=True)
    return ok


def _ip(*argv: str) -> None:
    result = subprocess.run(["ip", *argv], capture_output=True, text=True)
    if result.returncode != 0:
        raise RuntimeError(f"ip {' '.join(argv)}: {result.stderr.strip()}")


class Network:
    """Hosts (network namespaces) on one private /24 behind a bridge in a namespace of its own."""

    def __init__(self, hosts: list[str], work_dir: Path) -> None:
        self.tag = uuid.uuid4().hex[:6]
        self.subnet = f"10.233.{100 + int(self.tag[:2], 16) % 100}"
        self.switch = f"zr_sw_{self.tag}"
        self.namespaces = {host: f"zr_{host}_{self.tag}" for host in hosts}
        self.addresses = {host: f"{self.subnet}.{i + 1}" for i, host in enumerate(hosts)}
        self.links = {host: (f"zh{i}{self.tag}", f"zs{i}{self.tag}") for i, host in enumerate(hosts)}
        self.work_dir = work_dir
        self.names: dict[str, str] = {}  # host name (service) -> address, for /etc/hosts
        try:
            _ip("netns", "add", self.switch)
            _ip("-n", self.switch, "link", "add", "br0", "type", "bridge")
            _ip("-n", self.switch, "link", "set", "br0", "up")
            for host, ns in self.namespaces.items():
                inside, outside = self.links[host]
                _ip("netns", "add", ns)
                _ip("link", "add", inside, "type", "veth", "peer", "name", outside)
                _ip("link", "set", inside, "netns", ns)
                _ip("link", "set", outside, "netns", self.switch)
                _ip("-n", self.switch, "link", "set", outside, "master", "br0")
                _ip("-n", self.switch, "link", "set", outside, "up")
                _ip("-n", ns, "addr", "add", f"{self.addresses[host]}/24", "dev", inside)
                _ip("-n", ns, "link", "set", inside, "up")
                _ip("-n", ns, "link", "set", "lo", "up")
        except Exception:
            self.close()
            raise

    def set_link(self, host: str, up: bool) -> None:
        """Unplug (or plug back) a host's cable."""
        _ip("-n", self.switch, "link", "set", self.links[host][1], "up" if up else "down")

    def hosts_file(self) -> Path:
        path = self.work_dir / "hosts"
        lines = ["127.0.0.1 localhost"] + [f"{address} {name}" for name, address in self.names.items()]
        path.write_text("\n".join(lines) + "\n", encoding="utf-8")
        return path

    def popen(self, host: str, argv: list[str], env: dict[str, str], log: Path,
              secrets: dict[str, Path] | None = None) -> subprocess.Popen:
        """Run ``argv`` on ``host`` with the network's /etc/hosts and ``secrets`` at /run/secrets/<name>."""
        script = ["set -e", f"mount --bind {shlex.quote(str(self.hosts_file()))} /etc/hosts"]
        if secrets:
            # a private /run (this mount namespace only) to hold /run/secrets, as in a container
            script += ["mount -t tmpfs zenroid-run /run", "mkdir -p /run/secrets"]
            for name, source in secrets.items():
                target = shlex.quote(f"/run/secrets/{name}")
                script += [f"touch {target}", f"mount --bind -o ro {shlex.quote(str(source))} {target}"]
        script += [f"cd {shlex.quote(str(ROOT))}", 'exec "$@"']
        out = open(log, "ab")
        try:
            return subprocess.Popen(["ip", "netns", "exec", self.namespaces[host], "sh", "-c", "\n".join(script),
                                     "sh", *argv], env=env, stdout=out, stderr=subprocess.STDOUT,
                                    stdin=subprocess.DEVNULL, start_new_session=True)
        finally:
            out.close()

    def close(self) -> None:
        for ns in [*self.namespaces.values(), self.switch]:
            subprocess.run(["ip", "netns", "del", ns], capture_output=True)


def base_environment() -> dict[str, str]:
    """What the image gives every container: the package importable, our interpreter as ``python``."""
    env = {k: v for k, v in os.environ.items() if not k.startswith(("ZENOH_", "ZENROID_"))}
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    env["PYTHONPATH"] = str(ROOT)
    env["PYTHONUNBUFFERED"] = "1"
    return env


@dataclass
class Running:
    service: Service
    host: str
    log: Path
    proc: subprocess.Popen | None = None
    starts: int = 0
    exits: list[int] = field(default_factory=list)


class Replay:
    """Runs every service of a compose topology on its host and applies its restart policy."""

    RESTART_DELAY_S = 1.0

    def __init__(self, compose: Compose, network: Network, placement: dict[str, str], log_dir: Path) -> None:
        missing = sorted(set(compose.services) - set(placement))
        assert not missing, f"services with no host in this test: {missing} (place them)"
        self.compose = compose
        self.network = network
        for name, host in placement.items():
            network.names[name] = network.addresses[host]
        self.running = {name: Running(compose.services[name], placement[name], log_dir / f"{name}.log")
                        for name in compose.services}
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._watcher = threading.Thread(target=self._watch, name="compose-restart", daemon=True)

    def argv(self, service: Service) -> list[str]:
        if service.image.split(":")[0] == ZENOH_IMAGE:  # zenohd's options, taken by our stand-in
            return [sys.executable, "-m", "nodes.tools", "router", *service.command]
        return list(service.command)

    def _start(self, run: Running) -> None:
        env = base_environment()
        env.update(run.service.environment)
        secrets = {target: self.compose.secrets[name] for target, name in run.service.secrets.items()}
        with open(run.log, "ab") as log:
            log.write(f"--- start {run.starts + 1}: {shlex.join(self.argv(run.service))}\n".encode())
        run.proc = self.network.popen(run.host, self.argv(run.service), env, run.log, secrets)
        run.starts += 1

    def start(self) -> None:
        for name in start_order(self.compose.services):
            self._start(self.running[name])
        self._watcher.start()

    def _watch(self) -> None:
        while not self._stop.wait(0.2):
            with self._lock:
                for run in self.running.values():
                    if run.proc is None or run.proc.poll() is None:
                        continue
                    code = run.proc.returncode
                    run.exits.append(code)
                    run.proc = None
                    policy = run.service.restart
                    if policy in ("always", "unless-stopped") or (policy == "on-failure" and code != 0):
                        time.sleep(self.RESTART_DELAY_S)
                        if not self._stop.is_set():
                            self._start(run)

    def output(self, name: str) -> str:
        return self.running[name].log.read_text(errors="replace")

    def outputs(self, tail: int = 2500) -> str:
        return "\n".join(f"===== {name} (starts {run.starts}, exits {run.exits})\n{self.output(name)[-tail:]}"
                         for name, run in self.running.items())

    def stop(self) -> None:
        self._stop.set()
        if self._watcher.is_alive():
            self._watcher.join(5)
        stop_all([run.proc for run in self.running.values() if run.proc is not None], timeout=15)
