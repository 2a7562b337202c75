"""The launcher supervising real processes (stand-in nodes) over a real embedded Zenoh router."""

from __future__ import annotations

import os
import re
import signal
import sys
import textwrap
from pathlib import Path

import pytest

from bench.common import Launch, alive, child_env, spawn, stop
from tests.conftest import wait_until


class YamlLaunch(Launch):
    """``python -m launch FILE`` of a launch file written by the test, in its own session, output captured."""

    def __init__(self, tmp_path: Path, text: str, port: int, *args: str) -> None:
        self.file = tmp_path / "test.yaml"
        self.file.write_text(textwrap.dedent(text).lstrip(), encoding="utf-8")
        super().__init__(str(self.file), *args, log_dir=tmp_path, port=port, gui=True)


HEADER = """
launch:
  - arg: {name: zenoh_port, default: "7447"}
"""


def test_respawn_after_kill_9_and_sigint_ends_everything(tmp_path: Path, zenoh_port: int) -> None:
    launch = YamlLaunch(tmp_path, HEADER + """
  - node: {name: worker, module: tests.support.dummy_node, namespace: demo, respawn: true, respawn_delay: 0.3,
           params: {rate: 5.0}, args: [--child]}
  - node: {name: steady, module: tests.support.dummy_node, args: [--detached-child]}
""", zenoh_port)
    try:
        launch.wait_output("[worker] ready demo/worker")
        launch.wait_output("[steady] ready steady")
        first = launch.node_pids("worker")[0]
        os.kill(first, signal.SIGKILL)
        launch.wait_output("respawning 'worker' in 0.3 s (1/5)")
        wait_until(lambda: len(launch.node_pids("worker")) == 2, 20, 0.05, "a second worker")
        second = launch.node_pids("worker")[1]
        assert second != first and alive(second)
        wait_until(lambda: launch.output().count("[worker] ready demo/worker") == 2, 30, 0.05, "respawned ready")
        # Parameters reach the node through the generated params file.
        assert "[worker] params {worker: {ros__parameters: {rate: 5.0}}}" in launch.output()
        children = [int(p) for p in re.findall(r"\[(?:worker|steady)\] (?:detached )?child pid (\d+)",
                                               launch.output())]
        assert len(children) == 3, launch.output()
        everyone = [*launch.node_pids("worker"), *launch.node_pids("steady"), *children]
        assert launch.close() == 0
        wait_until(lambda: all(not alive(p) for p in everyone), 10, 0.05, "every node and child process to end")
        assert "[steady] bye steady" in launch.output()  # SIGINT reached it: it closed cleanly
        assert "ended processes the nodes left behind" in launch.output()  # the detached child
        assert (launch.node_logs / "worker.log").read_text().count("ready demo/worker") == 2
    finally:
        launch.close()


def test_a_node_that_stops_answering_is_restarted_and_one_that_never_served_is_left_alone(
        tmp_path: Path, zenoh_port: int) -> None:
    """Health: a respawnable node that served its get_parameters probe and then stopped answering (hung
    loop, lost link) is killed and respawned; a plain program that never served is not touched."""
    launch = YamlLaunch(tmp_path, HEADER + """
  - node: {name: hangs, module: tests.support.dummy_node, respawn: true, respawn_delay: 0.2, respawn_max: 1,
           health_timeout: 2.0, args: [--serve-for, "2.0"]}
  - node: {name: mute, module: tests.support.dummy_node, respawn: true, health_timeout: 1.0}
""", zenoh_port)
    try:
        launch.wait_output("[hangs] ready hangs")
        launch.wait_output("'hangs' stopped answering for", 40)
        launch.wait_output("started 'hangs' [pid", 10)
        wait_until(lambda: len(launch.node_pids("hangs")) == 2, 20, 0.05, "hangs respawned")
        out = launch.output()
        assert "stopped answering for" in out and ": killed" in out and "'hangs' [pid" in out
        assert "killed for not answering" in out
        assert len(launch.node_pids("mute")) == 1 and "'mute' stopped answering" not in out
    finally:
        assert launch.close() == 0


def test_a_wedged_node_and_a_stopped_one_are_killed_and_respawned_saying_why(tmp_path: Path,
                                                                            zenoh_port: int) -> None:
    """A node whose callbacks and main thread block (as after a Zenoh panic) holds its probe's query until the
    router's timeout answers it with an error: that error is no answer. The node is killed (SIGTERM, then
    SIGKILL: it ignores SIGTERM) and respawned, and the log says why. A node stopped with SIGSTOP likewise."""
    launch = YamlLaunch(tmp_path, HEADER + """
  - node: {name: wedges, module: tests.support.dummy_node, respawn: true, respawn_delay: 0.2, respawn_max: 1,
           health_timeout: 3.0, args: [--serve-for, "2.0", --wedge]}
  - node: {name: stops, module: tests.support.dummy_node, respawn: true, respawn_delay: 0.2, respawn_max: 1,
           health_timeout: 3.0, args: [--serve-for, "100000"]}
""", zenoh_port)
    try:
        launch.wait_output("[wedges] wedged wedges", 30)
        launch.wait_output("[stops] ready stops")
        os.kill(launch.node_pids("stops")[0], signal.SIGSTOP)
        launch.wait_match(r"'wedges' stopped answering for \d+\.\d s \(hung, or its Zenoh link is lost\): killed", 40)
        launch.wait_output("'wedges' still running 2 s after SIGTERM: sending SIGKILL", 20)
        wait_until(lambda: len(launch.node_pids("wedges")) == 2, 20, 0.05, "wedges respawned")
        launch.wait_match(r"'stops' stopped answering for \d+\.\d s .*: killed", 40)
        wait_until(lambda: len(launch.node_pids("stops")) == 2, 20, 0.05, "stops respawned")
        out = launch.output()
        assert "exited with signal 9, killed for not answering" in out, out[-3000:]
    finally:
        for pid in launch.node_pids("stops"):
            try:
                os.kill(pid, signal.SIGCONT)
            except ProcessLookupError:
                pass
        launch.close()


def test_respawn_count_is_reset_after_a_long_run(monkeypatch) -> None:
    """respawn_max caps crash loops: a node that ran RESPAWN_RESET_AFTER_S before it died starts afresh."""
    import io

    from launch import supervisor as sup
    from launch.resolve import LaunchPlan, NodeSpec

    spec = NodeSpec(name="n", namespace="", module=None, executable="/bin/true", args=[], params={},
                    param_files=[], remaps=[], env={}, respawn=True, respawn_delay=0.0, respawn_max=2,
                    required=False, output="screen", wait_for=[], wait_timeout=1.0, source="test")
    supervisor = sup.Supervisor(LaunchPlan(Path("x.yaml"), {}, [spec]), Path("."), {}, None, out=io.StringIO())
    managed = supervisor.nodes[0]
    now = [1000.0]
    monkeypatch.setattr(sup.time, "monotonic", lambda: now[0])
    for expected in (1, 2):  # quick crashes count up ...
        managed.started_at, managed.exit_code = now[0] - 1.0, 1
        supervisor._on_exit(managed)
        assert managed.restarts == expected and managed.state == "respawn_pending"
    managed.started_at = now[0] - 1.0
    supervisor._on_exit(managed)  # ... to the cap
    assert "reached its restart limit (2)" in supervisor.out.getvalue()
    managed.restarts, managed.state = 2, "running"
    managed.started_at = now[0] - sup.RESPAWN_RESET_AFTER_S - 1.0  # ran long: a fresh count
    supervisor._on_exit(managed)
    assert managed.restarts == 1 and managed.state == "respawn_pending"


def test_required_node_failure_ends_launch_with_nonzero_status(tmp_path: Path, zenoh_port: int) -> None:
    launch = YamlLaunch(tmp_path, HEADER + """
  - node: {name: brittle, module: tests.support.dummy_node, required: true, respawn: true, respawn_delay: 0.1,
           respawn_max: 1, args: [--exit-after, "1", --exit-code, "4"]}
  - node: {name: bystander, module: tests.support.dummy_node, output: log}
  - on_exit: {node: brittle, log: "brittle has gone"}
  - on_shutdown: {log: "launch over"}
""", zenoh_port)
    try:
        assert launch.proc.wait(timeout=40) == 1
        out = launch.output()
        assert "'brittle'" in out and "exited with status 4" in out
        assert len(launch.node_pids("brittle")) == 2  # respawned once, then the restart limit
        assert "reached its restart limit (1)" in out
        assert "required node 'brittle' exited (status 4)" in out
        assert "brittle has gone" in out and out.rstrip().endswith("launch over")
        assert all(not alive(p) for p in launch.node_pids("bystander"))
        # output: log keeps a node off the screen but not out of its log file
        assert "[bystander]" not in out and "ready bystander" in (launch.node_logs / "bystander.log").read_text()
    finally:
        launch.close()


def test_wait_for_starts_nodes_in_readiness_order(tmp_path: Path, zenoh_port: int) -> None:
    launch = YamlLaunch(tmp_path, HEADER + """
  - node: {name: slow_server, module: tests.support.dummy_node, namespace: ns, args: [--start-delay, "1.5"]}
  - node: {name: client, module: tests.support.dummy_node, wait_for: [slow_server]}
  - node: {name: one_shot, module: tests.support.dummy_node, args: [--exit-after, "0.5"]}
  - node: {name: after_one_shot, module: tests.support.dummy_node, wait_for: [one_shot, client]}
""", zenoh_port)
    try:
        launch.wait_output("[after_one_shot] ready after_one_shot", 40)
        out = launch.output()
        assert out.index("[slow_server] ready ns/slow_server") < out.index("started 'client'")
        assert out.index("'one_shot'") < out.index("started 'after_one_shot'")
        assert out.index("[client] ready client") < out.index("started 'after_one_shot'")
    finally:
        assert launch.close() == 0


def test_launcher_killed_with_sigkill_leaves_no_orphans(tmp_path: Path, zenoh_port: int) -> None:
    launch = YamlLaunch(tmp_path, HEADER + """
  - node: {name: a, module: tests.support.dummy_node, args: [--child]}
  - node: {name: b, module: tests.support.dummy_node}
""", zenoh_port)
    try:
        launch.wait_output("[a] ready a")
        launch.wait_output("[b] ready b")
        children = [int(p) for p in re.findall(r"\[a\] child pid (\d+)", launch.output())]
        everyone = [*launch.node_pids("a"), *launch.node_pids("b"), *children]
        os.kill(launch.proc.pid, signal.SIGKILL)  # no chance to clean up: the reaper must
        launch.proc.wait()
        wait_until(lambda: all(not alive(p) for p in everyone), 15, 0.05, "the reaper to end every node")
    finally:
        for pid in locals().get("everyone", []):
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass


@pytest.mark.slow
def test_stubborn_node_gets_sigterm_then_sigkill(tmp_path: Path, zenoh_port: int) -> None:
    launch = YamlLaunch(tmp_path, HEADER + """
  - node: {name: stubborn, module: tests.support.dummy_node, args: [--ignore-sigint]}
""", zenoh_port)
    try:
        launch.wait_output("[stubborn] ready stubborn")
        pid = launch.node_pids("stubborn")[0]
        launch.proc.send_signal(signal.SIGINT)
        assert launch.proc.wait(timeout=30) == 0
        out = launch.output()
        assert "sending SIGTERM" in out and "sending SIGKILL" in out
        assert not alive(pid)
    finally:
        launch.close()


def test_port_in_use_is_a_clear_error(tmp_path: Path, zenoh_port: int, router: str) -> None:
    launch = YamlLaunch(tmp_path, HEADER + "  - node: {name: a, module: tests.support.dummy_node}\n", zenoh_port)
    try:
        assert launch.proc.wait(timeout=30) == 1
        assert f"cannot host the Zenoh router on {router}" in launch.output()
        assert "started 'a'" not in launch.output()
    finally:
        launch.close()


def test_external_router_from_environment(tmp_path: Path, zenoh_port: int, router: str, session) -> None:
    """With ZENOH_CONNECT set the launcher hosts nothing: its nodes join the router already there."""
    from nodes.core import graph

    file = tmp_path / "test.yaml"
    file.write_text("launch:\n  - node: {name: guest, module: tests.support.dummy_node, namespace: ext}\n")
    out_path = tmp_path / "launch.out"
    proc = spawn([sys.executable, "-m", "launch", str(file), "--log-dir", str(tmp_path / "logs")], log=out_path,
                 env=child_env({"ZENOH_CONNECT": router}))
    try:
        wait_until(lambda: "/ext/guest" in graph.node_names(session, 0.5), 30, 0.1, "the node on our router")
        assert "zenoh: external router" in out_path.read_text()
    finally:
        assert stop(proc) == 0


def test_supervisor_prefixes_colours_and_logs_output(tmp_path: Path) -> None:
    """In-process: programs (exec, no shell) run to the end; output is prefixed, coloured, and logged."""
    import io

    from launch.resolve import resolve
    from launch.supervisor import Supervisor

    file = tmp_path / "test.yaml"
    file.write_text(textwrap.dedent("""
        launch:
          - node: {name: talker, exec: python, args: [-c, "print('hello'); print('world')"]}
          - node: {name: quiet, exec: python, args: [-c, "print('secret')"], output: log}
          - node: {name: second, exec: python, args: [-c, "print('after')"], wait_for: [talker]}
          - on_shutdown: {log: "done"}
        """))
    plan = resolve(file, {})
    screen = io.StringIO()
    supervisor = Supervisor(plan, tmp_path, dict(os.environ), readiness=None, out=screen, colour=True)
    assert supervisor.run() == 0
    text = screen.getvalue()
    assert "\x1b[32m[talker] \x1b[0mhello\n" in text and "[talker] \x1b[0mworld" in text
    assert "secret" not in text and (tmp_path / "quiet.log").read_text() == "secret\n"
    assert text.index("'talker'") < text.index("started 'second'")  # waited for talker to finish with 0
    assert "[second] \x1b[0mafter" in text
    assert "all processes have ended" in text and text.rstrip().endswith("done")


def test_only_the_exclusive_cpu_node_is_told_the_kept_cpu(tmp_path: Path) -> None:
    # the CPU comes from this launch's reservation only: a value left in the shell reaches no node
    import io

    from launch.resolve import resolve
    from launch.supervisor import Supervisor

    show = "import os; print('cpu=' + os.environ.get('ZENROID_EXCLUSIVE_CPU', 'none'))"
    file = tmp_path / "test.yaml"
    file.write_text(textwrap.dedent(f"""
        launch:
          - node: {{name: stepper, exec: python, args: [-c, "{show}"], exclusive_cpu: true}}
          - node: {{name: other, exec: python, args: [-c, "{show}"]}}
        """))
    plan = resolve(file, {})
    screen = io.StringIO()
    environment = dict(os.environ, ZENROID_EXCLUSIVE_CPU="7")
    assert Supervisor(plan, tmp_path, environment, readiness=None, out=screen, colour=False,
                      exclusive_cpu=1).run() == 0
    text = screen.getvalue()
    assert "[stepper] cpu=1" in text and "[other] cpu=none" in text, text
    screen = io.StringIO()
    assert Supervisor(plan, tmp_path, environment, readiness=None, out=screen, colour=False).run() == 0
    assert "[stepper] cpu=none" in screen.getvalue() and "[other] cpu=none" in screen.getvalue()
