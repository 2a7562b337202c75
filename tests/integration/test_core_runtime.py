"""The node runtime across real processes over a real router: pub/sub of every message family,
services, actions (feedback, result, cancel, preemption), lifecycle, the graph and bad input."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import threading
import time

import msgpack
import pytest

import msgs
from nodes.core import Node, graph
from nodes.core.action import ABORTED, CANCELED, SUCCEEDED, ActionClient
from nodes.core.delivery import Decoded, Executed, Inline, Pulled
from nodes.core.endpoints import ServiceError
from tests.conftest import ROOT, wait_until
from tests.support.samples import sample_message


def _families(per_package: int = 4) -> list[str]:
    """A few message types of every package (all of them would be ~230 endpoints each way)."""
    chosen: dict[str, list[str]] = {}
    for t in msgs.list_types():
        if "/msg/" in t and len(chosen.setdefault(t.split("/")[0], [])) < per_package:
            chosen[t.split("/")[0]].append(t)
    return sorted({*(t for types in chosen.values() for t in types), "sensor_msgs/msg/JointState",
                   "trajectory_msgs/msg/JointTrajectory", "tf2_msgs/msg/TFMessage", "gazebo_msgs/msg/ModelStates"})


MESSAGE_TYPES = _families()
Navigate = msgs.get_type("humanoid_msgs/action/NavigateToGoal")
Trigger = msgs.get_type("std_srvs/srv/Trigger")
SetBool = msgs.get_type("std_srvs/srv/SetBool")
Log = msgs.get_type("rcl_interfaces/msg/Log")


@pytest.fixture
def echo(processes):
    proc = processes.start("-m", "tests.support.echo_node", "--param", f"types:=[{', '.join(MESSAGE_TYPES)}]",
                           name="echo")
    wait_until(lambda: "ready" in processes.output(proc), timeout=30, message="echo node ready")
    return proc


@pytest.fixture
def client(router):
    node = Node("test_client", connect=[router])
    yield node
    node.destroy()


def cli(router: str, *argv: str, timeout: float = 30) -> subprocess.CompletedProcess:
    env = dict(os.environ, ZENOH_CONNECT=router, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "nodes.tools", *argv], capture_output=True, text=True,
                          env=env, timeout=timeout, cwd=ROOT)


def test_every_message_family_round_trips_between_processes(echo, client) -> None:
    received: dict[str, object] = {}
    lock = threading.Lock()
    publishers = {}
    for type_name in MESSAGE_TYPES:
        cls = msgs.get_type(type_name)

        def store(msg, type_name=type_name):
            with lock:
                received[type_name] = msg

        client.create_subscription(cls, f"/echo/out/{type_name}", store, delivery=Inline())
        publishers[type_name] = client.create_publisher(cls, f"/echo/in/{type_name}")
    expected = {t: sample_message(t) for t in MESSAGE_TYPES}

    def all_back() -> bool:
        for type_name, pub in publishers.items():
            if type_name not in received:
                pub.publish(expected[type_name])
        return len(received) == len(MESSAGE_TYPES)

    wait_until(all_back, timeout=20, interval=0.2, message="every type echoed back")
    for type_name in MESSAGE_TYPES:
        assert received[type_name] == expected[type_name], type_name
    families = {t.split("/")[0] for t in MESSAGE_TYPES}
    assert {"sensor_msgs", "trajectory_msgs", "geometry_msgs", "tf2_msgs", "control_msgs", "gazebo_msgs",
            "humanoid_msgs", "std_msgs", "rosgraph_msgs"} <= families


def test_service_call_from_client_and_cli(echo, client, router) -> None:
    trigger = client.create_client(Trigger, "/echo/trigger")
    assert trigger.wait_for_service(5.0)
    assert trigger.call(timeout=5).message == "call 1"
    result = cli(router, "service", "call", "/echo/trigger", "std_srvs/srv/Trigger")
    assert result.returncode == 0, result.stderr
    assert "success: true" in result.stdout and "call 2" in result.stdout
    # a handler that raises answers with an error; the node keeps serving
    with pytest.raises(ServiceError, match="always fails"):
        client.create_client(SetBool, "/echo/fail").call(SetBool.Request(data=True), timeout=5)
    # a request the server cannot decode gets an error naming the field
    with pytest.raises(ServiceError, match="data: expected a bool"):
        from nodes.core.endpoints import call_raw

        call_raw(client.session, "echo/fail", msgpack.packb({"data": "yes"}), 5)
    assert trigger.call(timeout=5).message == "call 3"
    assert echo.poll() is None


def test_action_feedback_result_cancel_and_preemption(echo, client) -> None:
    action = ActionClient(client, Navigate, "echo/navigate")
    assert action.wait_for_server(5.0)
    feedback = []
    handle = action.send_goal(Navigate.Goal(max_velocity=0.4), feedback_callback=feedback.append)
    assert handle.accepted
    status, result = handle.get_result(timeout=10)
    assert status == SUCCEEDED and result.success and result.message == "arrived"
    assert len(feedback) >= 2 and feedback[-1].distance_remaining > 0

    long_goal = action.send_goal(Navigate.Goal(max_velocity=3.0))
    time.sleep(0.3)
    cancel = long_goal.cancel()
    assert cancel.return_code == 0 and len(cancel.goals_canceling) == 1
    status, result = long_goal.get_result(timeout=10)
    assert status == CANCELED and result.message == "canceled"

    first = action.send_goal(Navigate.Goal(max_velocity=3.0))
    time.sleep(0.3)
    second = action.send_goal(Navigate.Goal(max_velocity=0.2))
    assert first.get_result(timeout=10)[0] == ABORTED  # preempted by the new goal
    assert second.get_result(timeout=10)[0] == SUCCEEDED
    assert first.cancel().return_code == 3  # ERROR_GOAL_TERMINATED


def test_bad_payload_is_logged_on_rosout_and_node_keeps_state(echo, client) -> None:
    logs = []
    client.create_subscription(Log, "/rosout", logs.append, delivery=Inline())
    JointState = msgs.get_type("sensor_msgs/msg/JointState")
    back = []
    client.create_subscription(JointState, "/echo/out/sensor_msgs/msg/JointState", back.append,
                               delivery=Inline())
    time.sleep(0.5)
    bad = msgpack.packb({"name": ["a", "b"], "position": [1.0]})
    client.session.put("echo/in/sensor_msgs/msg/JointState", bad)
    client.session.put("echo/in/sensor_msgs/msg/JointState", b"\xc1garbage")
    wait_until(lambda: any("position: has 1 entries but name has 2" in log.msg for log in logs), timeout=10,
               message="a rosout line naming the bad field")
    pub = client.create_publisher(JointState, "/echo/in/sensor_msgs/msg/JointState")
    wait_until(lambda: back or pub.publish(JointState(name=["ok"], position=[1.0])), timeout=10,
               message="valid messages still echoed")
    assert back[0].name == ["ok"] and echo.poll() is None


def test_lifecycle_transitions_over_cli(echo, router) -> None:
    assert "unconfigured" in cli(router, "lifecycle", "get", "/echo").stdout
    assert cli(router, "lifecycle", "set", "/echo", "activate").returncode == 1  # not from unconfigured
    assert cli(router, "lifecycle", "set", "/echo", "configure").returncode == 0
    assert cli(router, "lifecycle", "set", "/echo", "activate").returncode == 0
    assert "active [3]" in cli(router, "lifecycle", "get", "/echo").stdout


def test_graph_sees_node_within_1s_and_loses_it_within_2s_of_kill9(processes, client, router) -> None:
    proc = processes.start("-m", "tests.support.echo_node", "--name", "graph_probe", name="probe")
    seen_ready = wait_until(lambda: "ready" in processes.output(proc) and time.monotonic(), timeout=30,
                            message="probe node ready")
    # the token is declared when the node starts, before "ready": it must be visible right away
    appeared = wait_until(lambda: "/graph_probe" in graph.node_names(client.session, 0.3) and time.monotonic(),
                          timeout=5, interval=0.01, message="graph_probe in the graph")
    assert appeared - seen_ready < 1.0
    listed = cli(router, "node", "list")
    assert "/graph_probe" in listed.stdout.split()
    os.killpg(proc.pid, signal.SIGKILL)
    killed = time.monotonic()
    wait_until(lambda: "/graph_probe" not in graph.node_names(client.session, 0.3), timeout=5, interval=0.05,
               message="graph_probe gone after kill -9")
    assert time.monotonic() - killed < 2.0


def test_cli_topic_pub_echo_and_list(echo, router) -> None:
    env = dict(os.environ, ZENOH_CONNECT=router, PYTHONPATH=str(ROOT))
    echo_proc = subprocess.Popen(
        [sys.executable, "-m", "nodes.tools", "topic", "echo", "/echo/out/sensor_msgs/msg/JointState", "--once",
         "--timeout", "20"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, cwd=ROOT)
    try:
        deadline = time.monotonic() + 20
        while echo_proc.poll() is None and time.monotonic() < deadline:
            pub = cli(router, "topic", "pub", "/echo/in/sensor_msgs/msg/JointState", "sensor_msgs/msg/JointState",
                      "{name: [left_knee], position: [0.4]}", "--once")
            assert pub.returncode == 0, pub.stderr
            try:
                echo_proc.wait(1.0)
            except subprocess.TimeoutExpired:
                pass
        out, err = echo_proc.communicate(timeout=5)
    finally:
        if echo_proc.poll() is None:
            echo_proc.kill()
    assert echo_proc.returncode == 0, err
    assert re.search(r"name: \[left_knee\]", out) and "position: [0.4]" in out
    listed = cli(router, "topic", "list", "-t")
    assert "/echo/out/sensor_msgs/msg/JointState [sensor_msgs/msg/JointState]" in listed.stdout
    bad = cli(router, "topic", "pub", "/x", "sensor_msgs/msg/JointState", "{name: [a], position: [1, 2]}")
    assert bad.returncode == 2 and "position: has 2 entries but name has 1" in bad.stderr


def test_graph_and_doctor_verbs(echo, router) -> None:
    out = cli(router, "graph").stdout
    assert "/echo/in/sensor_msgs/msg/JointState" in out and "subscribers: /echo" in out
    dot = cli(router, "graph", "--dot").stdout
    assert dot.startswith("digraph") and '"/echo" -> "/echo/out/sensor_msgs/msg/JointState"' in dot
    doctor = cli(router, "doctor")
    assert doctor.returncode == 0, doctor.stdout
    assert "router reachable" in doctor.stdout and "/echo" in doctor.stdout


def test_timers_follow_sim_clock(router, client) -> None:
    Clock = msgs.get_type("rosgraph_msgs/msg/Clock")
    node = Node("sim_timer", connect=[router], params={"use_sim_time": True})
    try:
        ticks: list[float] = []
        node.create_timer(0.1, lambda: ticks.append(node.now()))
        clock = client.create_publisher(Clock, "/sim/clock")
        time.sleep(0.3)

        def advance_to(t: float) -> None:
            clock.publish(Clock(clock=msgs.time_from_sec(t)))
            wait_until(lambda: [node.spin_once(0.005)] and abs(node.now() - t) < 1e-9, timeout=5,
                       message=f"clock at {t}")
            while node.spin_once(0.0):
                pass

        for step in range(1, 51):  # 0.5 s of sim time, each step delivered before the next
            advance_to(step * 0.01)
        assert [round(t, 2) for t in ticks] == [0.1, 0.2, 0.3, 0.4, 0.5]
        # a reset (time jumps back) restarts the timers instead of stalling them
        for step in range(0, 16):
            advance_to(step * 0.01)
        assert [round(t, 2) for t in ticks[5:]] == [0.1]
    finally:
        node.destroy()


def test_wildcard_subscription_reports_the_key(router, client) -> None:
    JointState = msgs.get_type("sensor_msgs/msg/JointState")
    seen: list[tuple[str, list[str]]] = []
    client.create_subscription(JointState, "/*/joint_states", lambda m, key: seen.append((key, m.name)),
                               delivery=Inline(), message=Decoded(with_key=True))
    talker = Node("talker", connect=[router])
    try:
        a = talker.create_publisher(JointState, "/robot_a/joint_states")
        b = talker.create_publisher(JointState, "/robot_b/joint_states")
        wait_until(lambda: {k for k, _ in seen} >= {"robot_a/joint_states", "robot_b/joint_states"}
                   or (a.publish(JointState(name=["a"])), b.publish(JointState(name=["b"])))[0],
                   timeout=10, message="both robots' joint_states")
    finally:
        talker.destroy()
    assert ("robot_a/joint_states", ["a"]) in seen and ("robot_b/joint_states", ["b"]) in seen


BAD_NODE = """
from nodes.core import Node, run_node
class Bad(Node):
    def __init__(self, **kw):
        super().__init__("bad", **kw)
        self.declare_parameter("rate", 1.0, min_value=2.0)
raise SystemExit(run_node(Bad))
"""


def test_bad_parameter_exits_2_with_the_reason_and_no_hang(router) -> None:
    env = dict(os.environ, ZENOH_CONNECT=router, PYTHONPATH=str(ROOT))
    result = subprocess.run([sys.executable, "-c", BAD_NODE], capture_output=True, text=True, env=env,
                            timeout=30, cwd=ROOT)
    assert result.returncode == 2
    assert "parameter 'rate': 1.0 is below the minimum 2.0" in result.stderr


SLOW_START_NODE = """
import time
from nodes.core import Node, run_node
class SlowStart(Node):
    def __init__(self, **kw):
        super().__init__("slow_start", **kw)
        print("starting", flush=True)
        time.sleep(60)   # still in the constructor when Ctrl-C comes
raise SystemExit(run_node(SlowStart))
"""


def signal_node_script(router: str, client: Node, script: str, first_line: str, node: str, signum: int,
                       settle: float = 0.0) -> tuple[int, str, str]:
    """Run a node program given as Python source; once it printed ``first_line`` and ``node`` is in the graph
    (and ``settle`` s more), send it ``signum``: (exit status, the rest of its stdout, its stderr)."""
    env = dict(os.environ, ZENOH_CONNECT=router, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, env=env, cwd=ROOT)
    try:
        assert proc.stdout is not None and proc.stdout.readline().strip() == first_line
        wait_until(lambda: node in graph.node_names(client.session, 0.3), timeout=10, message=f"{node} in the graph")
        time.sleep(settle)
        proc.send_signal(signum)
        stdout, stderr = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    return proc.returncode, stdout, stderr


def test_ctrl_c_while_a_node_starts_ends_it_quietly(router, client) -> None:
    """Ctrl-C during a slow start (the docs test's streaming examples on a loaded machine) ends the process
    with a short line and status 130, no traceback, and the half-built node leaves the graph."""
    status, _, stderr = signal_node_script(router, client, SLOW_START_NODE, "starting", "/slow_start", signal.SIGINT)
    assert status == 130, stderr
    assert "Traceback" not in stderr and "interrupted while starting" in stderr, stderr
    wait_until(lambda: "/slow_start" not in graph.node_names(client.session, 0.3), timeout=5,
               message="slow_start gone from the graph")


HOOKED_NODE = """
from nodes.core import Node, run_node
from msgs.std_msgs import String
class Hooked(Node):
    def __init__(self, **kw):
        super().__init__("hooked", **kw)
        self.said = self.create_publisher(String, "/hooked/said")
        print("ready", flush=True)
    def on_process_exit(self):
        self.said.publish(String(data="bye"))   # endpoints still work in the hook
        print(f"hook ran, closed={self.closed}", flush=True)
raise SystemExit(run_node(Hooked))
"""


def test_shutdown_hook_runs_once_before_the_node_closes(router, client) -> None:
    """SIGTERM: ``spin()`` returns, ``run_node`` calls the one shutdown hook (``on_process_exit``) while the
    node's endpoints still work, then destroys the node; the process exits 0."""
    String = msgs.get_type("std_msgs/msg/String")
    said: list[str] = []
    client.create_subscription(String, "/hooked/said", lambda m: said.append(m.data), delivery=Inline())
    # settle: our subscription meets the node's publisher through the router
    status, stdout, stderr = signal_node_script(router, client, HOOKED_NODE, "ready", "/hooked", signal.SIGTERM,
                                                settle=0.5)
    assert status == 0, stderr
    assert stdout.count("hook ran") == 1 and "hook ran, closed=False" in stdout, stdout
    wait_until(lambda: said == ["bye"], timeout=5, message="the hook's message")


def test_deprecated_shutdown_destroys_and_a_subscription_needs_a_callback(router, client) -> None:
    JointState = msgs.get_type("sensor_msgs/msg/JointState")
    with pytest.raises(TypeError, match="needs a callback"):
        client.create_subscription(JointState, "/no/callback", None)
    node = Node("old_spelling", connect=[router])
    with pytest.warns(DeprecationWarning, match=r"Node.shutdown\(\) is deprecated: use Node.destroy\(\)"):
        node.shutdown()
    assert node.closed and not node.ok


def test_publisher_knows_whether_anyone_listens(router, client) -> None:
    JointState = msgs.get_type("sensor_msgs/msg/JointState")
    pub = client.create_publisher(JointState, "/lonely/joint_states")
    assert not pub.has_subscribers
    other = Node("listener2", connect=[router])
    try:
        other.create_subscription(JointState, "/lonely/joint_states", lambda m: None)
        wait_until(lambda: pub.has_subscribers, timeout=5, message="matching subscriber")
    finally:
        other.destroy()
    wait_until(lambda: not pub.has_subscribers, timeout=5, message="subscriber gone")


def test_failing_subclass_constructor_closes_its_session(router, client) -> None:
    class Broken(Node):
        def __init__(self, **kwargs) -> None:
            super().__init__("broken_ctor", **kwargs)
            raise RuntimeError("setup failed")

    with pytest.raises(RuntimeError, match="setup failed"):
        Broken(connect=[router])
    # the half-built node's liveliness token goes away with its closed session
    wait_until(lambda: "/broken_ctor" not in graph.node_names(client.session, 0.3), timeout=5,
               message="broken_ctor gone from the graph")


def test_pulled_subscription_runs_callbacks_on_the_owners_thread_and_times_out(router, client) -> None:
    """``delivery=Pulled()`` (the simulator's hardware/command): messages wait until the owner takes them,
    on its own thread; ``wait`` ends after its timeout with a wake-up no other session ever sees."""
    String = msgs.get_type("std_msgs/msg/String")
    puller = Node("puller", connect=[router])
    try:
        got: list[tuple[str, int]] = []
        sub = puller.create_subscription(String, "pulled/topic", lambda m: got.append((m.data, threading.get_ident())),
                                         delivery=Pulled())
        seen_elsewhere: list[str] = []
        client.create_subscription(String, "pulled/topic", lambda m: seen_elsewhere.append(m.data))
        pub = client.create_publisher(String, "pulled/topic")
        wait_until(lambda: pub.has_subscribers, timeout=10, message="the pulled subscription is matched")
        time.sleep(0.5)   # the client's own subscription is declared too

        pub.publish(String(data="one"))
        assert sub.wait(10.0) >= 1
        assert got == [("one", threading.get_ident())]   # delivered here, not on a Zenoh thread
        for text in ("two", "three"):
            pub.publish(String(data=text))
        wait_until(lambda: len(seen_elsewhere) == 3, timeout=10, message="the other session got all three")
        time.sleep(0.2)
        assert sub.take_pending() == 2
        assert [text for text, _ in got] == ["one", "two", "three"]
        assert sub.take_pending() == 0

        started = time.monotonic()
        assert sub.wait(0.3) == 0                # nothing came: the watchdog ends the wait
        elapsed = time.monotonic() - started
        assert 0.3 <= elapsed < 5.0
        time.sleep(0.5)
        assert seen_elsewhere == ["one", "two", "three"]   # the wake-up stayed inside the puller's session
        assert len(got) == 3

        pub.publish(String(data="four"))         # a wait after a timeout still delivers
        assert sub.wait(10.0) >= 1 and got[-1][0] == "four"

        ended = threading.Event()
        waiter = threading.Thread(target=lambda: (sub.wait(60.0), ended.set()), daemon=True)
        waiter.start()
        time.sleep(0.3)
        puller.destroy_entity(sub)               # undeclared while a thread waits on it: the wait ends
        assert ended.wait(10), "wait() did not return after the subscription was undeclared"
    finally:
        puller.destroy()


def test_delivery_objects_refuse_bad_input_and_executed_depth_keeps_the_newest(router, client) -> None:
    """A subscription's delivery and message form are objects (``nodes/core/delivery.py``): the old flags
    name their replacement, a delivery object serves one subscription, a typeless one takes bytes; and
    ``Executed(depth=N)`` on a node whose callbacks wait for its spinning thread keeps the newest ``N``."""
    String = msgs.get_type("std_msgs/msg/String")
    with pytest.raises(TypeError, match=r"inline= is now delivery=Inline\(\); raw= is now message=Raw\(\)"):
        client.create_subscription(String, "delivery/a", print, inline=True, raw=True)
    shared = Inline()
    client.create_subscription(String, "delivery/a", print, delivery=shared)
    with pytest.raises(ValueError, match="already delivers 'delivery/a'"):
        client.create_subscription(String, "delivery/b", print, delivery=shared)
    with pytest.raises(TypeError, match=r"no message type: its callback takes bytes \(message=Raw\(\)\)"):
        client.create_subscription(None, "delivery/c", print)
    with pytest.raises(ValueError, match="depth must be an int >= 1"):
        Executed(depth=0)

    class Spun(Node):
        callbacks_on_spin_thread = True

    spun = Spun("spun", connect=[router])
    try:
        got: list[str] = []
        keep = Executed(depth=3)
        spun.create_subscription(String, "delivery/burst", lambda m: got.append(m.data), delivery=keep)
        pub = client.create_publisher(String, "delivery/burst")
        wait_until(lambda: pub.has_subscribers, timeout=10, message="the bounded subscription is matched")
        for i in range(20):
            pub.publish(String(data=str(i)))
        wait_until(lambda: keep.dropped == 17, timeout=10, message=f"17 dropped ({keep.dropped} so far)")
        while spun.spin_once(0.2):
            pass
        assert got == ["17", "18", "19"]
    finally:
        spun.destroy()


def test_a_service_answers_later_through_a_deferred(router, client) -> None:
    """A handler that returns a ``Deferred`` frees its node at once; the caller gets the response (or the
    error) given later from another thread, and other requests are served meanwhile."""
    from nodes.core import Deferred

    server = Node("deferring", connect=[router])
    try:
        pending: list[tuple[Deferred, bool]] = []

        def slow(request):
            answer = Deferred()
            pending.append((answer, request.data))
            return answer

        server.create_service(SetBool, "deferred/slow", slow)
        server.create_service(Trigger, "deferred/quick", lambda _r: Trigger.Response(success=True, message="now"))
        results: list = []

        def ask(value: bool) -> None:
            try:
                results.append(client.create_client(SetBool, "deferred/slow").call(SetBool.Request(data=value),
                                                                                   timeout=30))
            except ServiceError as exc:
                results.append(exc)
        callers = [threading.Thread(target=ask, args=(v,)) for v in (True, False)]
        for caller in callers:
            caller.start()
        wait_until(lambda: len(pending) == 2, timeout=20, message="both requests held")
        assert client.create_client(Trigger, "deferred/quick").call(Trigger.Request(), timeout=10).message == "now"
        assert results == []
        for answer, value in pending:
            if value:
                threading.Thread(target=answer.resolve, args=(SetBool.Response(success=True, message="later"),)).start()
            else:
                threading.Thread(target=answer.fail, args=(RuntimeError("no luck"),)).start()
        for caller in callers:
            caller.join(30)
        responses = [r for r in results if not isinstance(r, Exception)]
        errors = [r for r in results if isinstance(r, Exception)]
        assert len(responses) == 1 and responses[0].message == "later"
        assert len(errors) == 1 and "RuntimeError: no luck" in str(errors[0])
    finally:
        server.destroy()
