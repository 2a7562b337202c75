"""What every bench and scenario test shares: free loopback ports, a plain Zenoh peer, a launch on a Zenoh port
of its own (started, waited for, torn down), and the process groups they start, always ended.

Every process started here (``spawn``, ``Launch``) leads a process group of its own and is remembered until it
is stopped. If the script or test run that started it ends without stopping it (an exception, ``sys.exit``)
or is ended by SIGTERM or SIGINT (``timeout 60 python bench/viz.py``, Ctrl-C), those groups get SIGINT (a
launcher then stops its nodes and its viewer) and, after a grace period, SIGKILL (a launcher's own orphan
guard then ends its nodes). Without it, a bench stopped by ``timeout`` left a launcher, its nodes and a Rerun
server running.
"""

from __future__ import annotations

import atexit
import json
import os
import re
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from types import FrameType
from typing import TYPE_CHECKING, Any, TypeVar

if TYPE_CHECKING:
    import zenoh

ROOT = Path(__file__).resolve().parents[1]
STOP_GRACE_S = 20.0  # a launcher ends its nodes (each gets its own grace) within this on SIGINT
# The controllers humanoid.yaml's spawners make active (config/controllers.yaml)
MAIN_JOB_CONTROLLERS = ("joint_state_broadcaster", "joint_trajectory_controller", "imu_sensor_broadcaster",
                        "left_foot_ft_broadcaster", "right_foot_ft_broadcaster")
T = TypeVar("T")


def free_port() -> int:
    """A TCP port on loopback nothing listens on now (the kernel's pick)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def loopback(port: int) -> str:
    return f"tcp/127.0.0.1:{port}"


def child_env(extra: dict[str, str] | None = None) -> dict[str, str]:
    """This environment for a process of the checkout: the checkout first on PYTHONPATH, unbuffered output,
    and no ZENOH_CONNECT or ZENOH_CONFIG (a launch would join that network instead of hosting its router)."""
    env = {k: v for k, v in os.environ.items() if k not in ("ZENOH_CONNECT", "ZENOH_CONFIG")}
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(ROOT), env.get("PYTHONPATH", "")) if p)
    env["PYTHONUNBUFFERED"] = "1"
    env.update(extra or {})
    return env


def plain_peer(port: int) -> zenoh.Session:
    """A Zenoh peer of our own (none of the project's code) connected to the router on ``port`` of loopback."""
    import zenoh

    config = zenoh.Config()
    config.insert_json5("mode", json.dumps("peer"))
    config.insert_json5("connect/endpoints", json.dumps([loopback(port)]))
    config.insert_json5("listen/endpoints", json.dumps(["tcp/127.0.0.1:0"]))
    config.insert_json5("scouting/multicast/enabled", "false")
    return zenoh.open(config)


def wait_until(predicate: Callable[[], T], timeout: float, what: str, interval: float = 0.05,
               check: Callable[[], None] | None = None) -> T:
    """Poll ``predicate`` until it returns a truthy value (returned); ``check`` raises if waiting is pointless
    (a process ended). RuntimeError naming ``what`` on timeout."""
    deadline = time.monotonic() + timeout
    while True:
        if check is not None:
            check()
        value = predicate()
        if value:
            return value
        if time.monotonic() > deadline:
            raise RuntimeError(f"timed out after {timeout:g} s waiting for {what}")
        time.sleep(interval)


# ------------------------------------------------------------------------------------------ process groups
_groups: dict[int, subprocess.Popen] = {}   # pid (= its process group) -> process, until stopped
_previous_handlers: dict[int, Any] = {}


def spawn(argv: Sequence[str], log: Path | None = None, env: dict[str, str] | None = None,
          cwd: Path | str = ROOT, **popen: Any) -> subprocess.Popen:
    """Start ``argv`` leading a process group of its own, remembered until ``stop``; its output goes to ``log``
    (appended) or nowhere, unless ``popen`` says otherwise (``stdout=subprocess.PIPE``)."""
    if log is not None:
        log.parent.mkdir(parents=True, exist_ok=True)
        out = open(log, "ab")  # the child holds its own copy; ours is closed below
        popen.setdefault("stdout", out)
        popen.setdefault("stderr", subprocess.STDOUT)
    else:
        popen.setdefault("stdout", subprocess.DEVNULL)
        popen.setdefault("stderr", subprocess.STDOUT)
    try:
        proc = subprocess.Popen(list(argv), cwd=cwd, env=child_env() if env is None else env,
                                start_new_session=True, **popen)
    finally:
        if log is not None:
            out.close()
    _groups[proc.pid] = proc
    _install_cleanup()
    return proc


def _signal_group(proc: subprocess.Popen, sig: int) -> None:
    try:
        os.killpg(proc.pid, sig)
    except (ProcessLookupError, PermissionError):
        pass


def stop(proc: subprocess.Popen, timeout: float = STOP_GRACE_S, sig: int = signal.SIGINT) -> int:
    """``sig`` to the process's group, then SIGKILL to it after ``timeout`` s; its exit status."""
    if proc.poll() is None:
        _signal_group(proc, sig)
    try:
        proc.wait(timeout)
    except subprocess.TimeoutExpired:
        _signal_group(proc, signal.SIGKILL)
        proc.wait()
    _groups.pop(proc.pid, None)
    return proc.returncode


def stop_all(procs: Sequence[subprocess.Popen] | None = None, timeout: float = STOP_GRACE_S) -> None:
    """Stop ``procs`` (default: every process started here and not yet stopped) together: SIGINT to every
    group first, so their graceful shutdowns overlap, then SIGKILL to what is left after ``timeout`` s."""
    procs = list(_groups.values()) if procs is None else list(procs)
    for proc in procs:
        if proc.poll() is None:
            _signal_group(proc, signal.SIGINT)
    deadline = time.monotonic() + timeout
    for proc in procs:
        stop(proc, max(0.1, deadline - time.monotonic()))


def _end_groups(timeout: float) -> None:
    """SIGINT to every remembered group, SIGKILL to those left after ``timeout`` s. Only polls (never a
    blocking wait): a signal handler may have interrupted a ``wait`` on the same process."""
    procs = list(_groups.values())
    for proc in procs:
        if proc.poll() is None:
            _signal_group(proc, signal.SIGINT)
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and any(proc.poll() is None for proc in procs):
        time.sleep(0.05)
    for proc in procs:
        if proc.poll() is None:
            _signal_group(proc, signal.SIGKILL)


def _on_signal(signum: int, frame: FrameType | None) -> None:
    _end_groups(timeout=10.0)
    previous = _previous_handlers.get(signum, signal.SIG_DFL)
    if callable(previous):
        previous(signum, frame)   # Python's own SIGINT handler raises KeyboardInterrupt
        return
    signal.signal(signum, signal.SIG_DFL)
    os.kill(os.getpid(), signum)  # end as the signal would have ended us


def _install_cleanup() -> None:
    """Once, from the main thread: stop the remembered groups at exit and on SIGTERM/SIGINT (chained to the
    handlers there were; a signal someone chose to ignore stays ignored)."""
    if _previous_handlers or threading.current_thread() is not threading.main_thread():
        return
    for signum in (signal.SIGTERM, signal.SIGINT):
        previous = signal.getsignal(signum)
        _previous_handlers[signum] = previous
        if previous is not signal.SIG_IGN:
            signal.signal(signum, _on_signal)
    atexit.register(stop_all)


# ------------------------------------------------------------------------------------------ a launch
class LaunchError(RuntimeError):
    pass


class Launch:
    """``python -m launch FILE gui:=false zenoh_port:=PORT ARGS...`` hosting its router on a free loopback port
    (or ``port``), its output in ``log_dir/launch.out``, its node logs in ``log_dir/logs``. ``command``
    replaces ``python -m launch`` (another interpreter, ``zenroid launch``); ``env`` the whole environment."""

    ROUTER_UP = "zenoh: embedded router"

    def __init__(self, launch_file: str, *args: str, log_dir: Path, port: int | None = None, gui: bool = False,
                 command: Sequence[str] = (sys.executable, "-m", "launch"), env: dict[str, str] | None = None,
                 cwd: Path | str = ROOT) -> None:
        self.port = port or free_port()
        self.log_dir = log_dir
        self.out_path = log_dir / "launch.out"
        self.node_logs = log_dir / "logs"
        self.sessions: list[zenoh.Session] = []
        self.seen_pids: set[int] = set()
        argv = [*command, launch_file, *([] if gui else ["gui:=false"]), f"zenoh_port:={self.port}", *args,
                "--log-dir", str(self.node_logs)]
        self.proc = spawn(argv, log=self.out_path, env=env, cwd=cwd)

    @property
    def endpoint(self) -> str:
        return loopback(self.port)

    def output(self) -> str:
        return self.out_path.read_text(errors="replace") if self.out_path.exists() else ""

    def check(self) -> None:
        """LaunchError (with the end of the output) if the launcher has ended."""
        if self.proc.poll() is not None:
            raise LaunchError(f"the launch ended (status {self.proc.returncode}):\n{self.output()[-4000:]}")

    def wait(self, predicate: Callable[[], T], timeout: float, what: str, interval: float = 0.05) -> T:
        """``predicate``'s first truthy value; LaunchError with the end of the output if the launch ends first or
        ``timeout`` s pass."""
        try:
            return wait_until(predicate, timeout, what, interval, check=self.check)
        except LaunchError as exc:
            raise LaunchError(f"while waiting for {what}: {exc}") from None
        except RuntimeError as exc:
            raise LaunchError(f"{exc}:\n{self.output()[-4000:]}") from None

    def wait_output(self, text: str, timeout: float = 90.0) -> None:
        """Until ``text`` is in the launch's output."""
        self.wait(lambda: text in self.output(), timeout, f"'{text}' in the launch output")

    def wait_match(self, pattern: str, timeout: float = 90.0) -> re.Match[str]:
        """The first match of the regular expression ``pattern`` in the launch's output."""
        return self.wait(lambda: re.search(pattern, self.output()), timeout, f"/{pattern}/ in the launch output")

    def node_pids(self, name: str) -> list[int]:
        """The pids the launcher reported for node ``name``, in start order (respawns after the first)."""
        return [int(p) for p in re.findall(rf"started '{re.escape(name)}' \[pid (\d+)\]", self.output())]

    def peer(self, timeout: float = 60.0) -> zenoh.Session:
        """A plain Zenoh peer on the launch's router, once it is up (closed by ``close``)."""
        self.wait_output(self.ROUTER_UP, timeout)
        session = plain_peer(self.port)
        self.sessions.append(session)
        return session

    def pids(self) -> set[int]:
        """The launcher and every process under it now (also remembered in ``seen_pids``)."""
        import psutil

        try:
            launcher = psutil.Process(self.proc.pid)
            found = {launcher.pid, *(c.pid for c in launcher.children(recursive=True))}
        except psutil.NoSuchProcess:
            found = set()
        self.seen_pids |= found
        return found

    def close(self, timeout: float = STOP_GRACE_S) -> int:
        """Close the peers, stop the launch (SIGINT, then SIGKILL after ``timeout`` s); its exit status."""
        for session in self.sessions:
            try:
                session.close()
            except Exception:  # noqa: BLE001 - closing what may already be closed
                pass
        self.sessions.clear()
        return stop(self.proc, timeout)

    def __enter__(self) -> Launch:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def alive(pid: int) -> bool:
    """A process that exists and has not ended (a zombie has)."""
    import psutil

    try:
        return psutil.Process(pid).status() != psutil.STATUS_ZOMBIE
    except psutil.NoSuchProcess:
        return False


# ------------------------------------------------------------------------------------------ runs
def interleaved_runs(modes: Sequence[str], runs: int, run_once: Callable[[str, str], dict]) -> dict[str, list[dict]]:
    """A Zenoh router in this process on a free loopback port, and ``runs`` rounds of ``run_once(mode,
    endpoint)`` for every mode in turn (interleaved, so the machine's noise hits every mode alike)."""
    from nodes.core.session import open_router

    port = free_port()
    router = open_router(port)
    results: dict[str, list[dict]] = {mode: [] for mode in modes}
    try:
        for _ in range(runs):
            for mode in modes:
                results[mode].append(run_once(mode, loopback(port)))
    finally:
        router.close()
    return results


def print_table(rows: Sequence[tuple[str, str, str]], load_before: float) -> None:
    """A bench's table: measurement, result, note; last, the load average before and after (the machine is
    shared: a figure taken under load says so)."""
    rows = [*rows, ("load average (1 min) before / after", f"{load_before:.1f} / {os.getloadavg()[0]:.1f}",
                    f"{os.cpu_count()} cores shared with other jobs")]
    width = max(len(r[0]) for r in rows)
    print(f"{'measurement':<{width}}  {'result':>16}  note")
    for name, value, note in rows:
        print(f"{name:<{width}}  {value:>16}  {note}")
