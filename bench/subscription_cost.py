"""CPU instructions per message of a subscription's delivery paths, counted by callgrind: the same figure
whatever the machine's load (wall-clock benches here swing 2x between runs; FACTS.md).

One process, one Zenoh session: a ``nodes.core`` publisher sends a 30-joint JointState and waits until the
subscription's callback has run before sending the next (ping-pong, so a bounded queue never drops one).
Each mode runs for two message counts under ``valgrind --tool=callgrind``; the difference in instructions
divided by the difference in messages is the cost of one message, start-up cancelled out. It covers the
publish, Zenoh's local delivery, the decode, the hand-off to the thread that runs the callback and the
callback (an append); the publisher side is the same code in every mode.

- core: a ``nodes.core`` subscription, default delivery (on Zenoh's thread under the node's lock);
- inline: ``Inline()`` (on Zenoh's thread, no lock);
- spin: a node whose callbacks wait for its spinning thread (``callbacks_on_spin_thread``), spun by a thread;
- rclpy: an rclpy subscription (depth 10) spun by ``rclpy``'s executor on a thread;
- rclpy_qos: the same with a deadline (and its callback) and a lifespan: each message stamped on arrival;
- manager: the controller manager's ``hardware/state`` (``Inline()``, ``Raw(objects=True, with_source=True)``);
- pulled: the simulator's ``hardware/command`` (``Pulled()``, the same ``Raw``), taken by the sending thread.

``--root DIR`` measures another checkout of the project (a tree before a change), in the same run.

    python bench/subscription_cost.py [--modes core,inline,spin,rclpy,manager,pulled] [--messages 200,1200]
                                      [--root DIR ...]
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import threading
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TOPIC = "bench/subscription_cost"
DIRECT = False


def child(mode: str, count: int) -> None:
    """Send ``count`` messages to one subscription of ``mode``, one at a time."""
    sys.path.insert(0, os.environ.get("BENCH_ROOT", str(ROOT)))
    import msgs
    from nodes.core import Node
    from nodes.core.session import open_peer

    JointState = msgs.get_type("sensor_msgs/msg/JointState")
    rclpy_mode = mode in ("rclpy", "rclpy_qos")
    session = open_peer([]) if not rclpy_mode else None
    got = threading.Event()
    received = []

    def on_msg(msg) -> None:
        received.append(msg)
        got.set()

    closers = []
    if rclpy_mode:
        import rclpy
        from bench.common import free_port
        from nodes.core.session import loopback_endpoint, open_router
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor

        port = free_port()
        router = open_router(port)   # rclpy's context connects to a router; publisher and subscription share it
        os.environ["ZENOH_CONNECT"] = loopback_endpoint(port)
        context = Context()
        rclpy.init(args=["bench", "--ros-args", "--log-level", "warn"], context=context)
        session = context.session
        rnode = rclpy.create_node("bench_sub", context=context)
        qos = 10
        events = None
        if mode == "rclpy_qos":
            from rclpy.duration import Duration
            from rclpy.qos import QoSProfile
            from rclpy.qos_event import SubscriptionEventCallbacks

            qos = QoSProfile(depth=10, deadline=Duration(seconds=60), lifespan=Duration(seconds=60))
            events = SubscriptionEventCallbacks(deadline=lambda info: None)
        sub = rnode.create_subscription(JointState, "/" + TOPIC, on_msg, qos, event_callbacks=events)._core
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(rnode)
        if not os.environ.get("BENCH_DIRECT"):
            threading.Thread(target=executor.spin, daemon=True).start()
        closers.append(lambda: (executor.shutdown(), rnode.destroy_node(), context.try_shutdown()))
    else:
        class Spun(Node):
            callbacks_on_spin_thread = mode == "spin"

        sub_node = Spun("bench_sub", session=session, log_level="warn")
        try:
            from nodes.core.delivery import Inline, Pulled, Raw
            options = {"inline": {"delivery": Inline()},
                       "manager": {"delivery": Inline(), "message": Raw(objects=True, with_source=True)},
                       "pulled": {"delivery": Pulled(), "message": Raw(objects=True, with_source=True)}}
        except ImportError:   # a tree from before the delivery objects: its flags
            options = {"inline": {"inline": True},
                       "manager": {"inline": True, "raw": True, "with_source": True, "objects": True},
                       "pulled": {"pulled": True, "raw": True, "with_source": True, "objects": True}}
        if mode in ("manager", "pulled"):
            def on_msg(payload, source) -> None:   # noqa: F811 - the raw callbacks' signature
                received.append(payload)
                got.set()
        sub = sub_node.create_subscription(JointState, "/" + TOPIC, on_msg, **options.get(mode, {}))
        if mode == "spin" and not os.environ.get("BENCH_DIRECT"):
            threading.Thread(target=sub_node.spin, daemon=True).start()
        closers.append(sub_node.destroy)
    pub_node = Node("bench_pub", session=session, log_level="warn")
    pub = pub_node.create_publisher(JointState, "/" + TOPIC)
    names = [f"joint_{i}" for i in range(30)]
    positions = [0.1 * i for i in range(30)]
    while not pub.has_subscribers:
        threading.Event().wait(0.01)
    threading.Event().wait(0.5)   # routes settle
    if os.environ.get("BENCH_DIRECT"):
        direct(mode, count, JointState(name=names, position=positions, velocity=positions, effort=positions),
               sub, received, executor if rclpy_mode else sub_node)
        count = 0
    for seq in range(count):
        got.clear()
        msg = JointState(name=names, position=positions, velocity=positions, effort=positions)
        msg.header.frame_id = str(seq)
        pub.publish(msg)
        if mode == "pulled":   # the owner's thread takes it, as the simulator's physics thread does
            while not got.is_set():
                sub.wait(30)
        if not got.wait(30):
            raise SystemExit(f"message {seq} never arrived ({mode})")
    pub_node.destroy()
    for close in closers:
        close()
    if rclpy_mode:
        router.close()
    else:
        session.close()
    print(json.dumps({"received": len(received)}))


class _Payload:
    def __init__(self, data: bytes) -> None:
        self._data = data

    def __len__(self) -> int:
        return len(self._data)

    def to_bytes(self) -> bytes:
        return self._data


class _Sample:
    """What a subscription reads of a Zenoh sample."""

    def __init__(self, key: str, payload: bytes, attachment: bytes) -> None:
        self.key_expr, self.payload, self.attachment = key, _Payload(payload), _Payload(attachment)


def direct(mode: str, count: int, msg, sub, received, spinner) -> None:
    """``--direct``: the subscription's own code only: samples handed to it on this thread, no Zenoh."""
    import msgs

    sample = _Sample(sub.key, msgs.encode(msg), b"\x01" * 8 + b"\x02" * 16)
    for _ in range(count):
        sub.handle_sample(sample)
        if mode == "spin":
            spinner.spin_once(0)
        elif mode in ("rclpy", "rclpy_qos"):
            spinner.spin_once(timeout_sec=0)
    for _ in range(10):   # a spin that ran a due timer (rclpy_qos's deadline check) took no message: catch up
        if len(received) >= count or mode not in ("rclpy", "rclpy_qos"):
            break
        spinner.spin_once(timeout_sec=0)
    if len(received) != count:
        raise SystemExit(f"{mode}: {len(received)} of {count} delivered")


def instructions(root: Path, mode: str, count: int) -> int:
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "callgrind.out"
        env = dict(os.environ, BENCH_ROOT=str(root), PYTHONPATH=str(root), BENCH_DIRECT="1" if DIRECT else "")
        proc = subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}",
                               sys.executable, __file__, "--child", mode, str(count)],
                              env=env, capture_output=True, text=True, timeout=1800)
        found = re.search(r"Collected : (\d+)", proc.stderr)
        if proc.returncode != 0 or found is None:
            raise SystemExit(f"{mode} x {count} under callgrind failed:\n{proc.stdout[-2000:]}\n{proc.stderr[-2000:]}")
        return int(found.group(1))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--modes", default="core,inline,spin,rclpy,manager,pulled")
    parser.add_argument("--messages", default="200,1200", help="the two message counts (N1,N2)")
    parser.add_argument("--root", action="append", default=[], help="another checkout to measure too")
    parser.add_argument("--direct", action="store_true",
                        help="only the subscription's code: samples handed to handle_sample on one thread, "
                             "no Zenoh and no thread hand-off (deterministic to a few instructions)")
    args = parser.parse_args()
    global DIRECT
    DIRECT = args.direct
    low, high = (int(n) for n in args.messages.split(","))
    roots = [ROOT, *(Path(r).resolve() for r in args.root)]
    result: dict[str, dict[str, float]] = {}
    for mode in args.modes.split(","):
        for root in roots:   # the trees alternate within each mode: same machine state for both
            per_message = (instructions(root, mode, high) - instructions(root, mode, low)) / (high - low)
            result.setdefault(str(root), {})[mode] = round(per_message)
            print(f"{mode:<8}{str(root):<40}{per_message:>14,.0f} instructions / message", flush=True)
    print(json.dumps({"messages": [low, high], "instructions_per_message": result}))


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        child(sys.argv[2], int(sys.argv[3]))
    else:
        main()
