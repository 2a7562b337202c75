"""How an rclpy subscription's messages reach the thread that spins (``nodes.core.delivery.Spun``), in this
process over a real Zenoh router: a thread that spins one subscription alone receives from Zenoh's ring
itself; anything else it must wait for (a timer, a second spinning thread) brings in a pump thread, and
taking the timer away hands the ring back. No message is lost across the switches, every callback runs on
a spinning thread, and KEEP_LAST keeps exactly its depth while nobody spins."""

from __future__ import annotations

import threading
import time

from tests.conftest import wait_until


def _publisher(session, key: str):
    """A ``nodes.core`` talker on ``key``, once the listener's subscription has matched it."""
    import msgs
    from nodes.core import Node

    node = Node("spin_test_talker", session=session, log_level="warn")
    pub = node.create_publisher(msgs.get_type("std_msgs/msg/Int32"), key)
    try:
        wait_until(lambda: pub.has_subscribers, timeout=15, message="the listener matched")
    except BaseException:
        node.destroy()
        raise
    time.sleep(0.3)   # its routes settle
    return node, pub


def _spinning(executor, name: str) -> threading.Thread:
    spinner = threading.Thread(target=executor.spin, name=name, daemon=True)
    spinner.start()
    return spinner


def _publish(pub, numbers) -> None:
    import msgs

    Int32 = msgs.get_type("std_msgs/msg/Int32")
    for i in numbers:
        pub.publish(Int32(data=i))
        time.sleep(0.002)


def test_a_lone_subscription_is_received_by_the_spinning_thread(context, session) -> None:
    import msgs
    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    Int32 = msgs.get_type("std_msgs/msg/Int32")
    node = rclpy.create_node("lone_listener", context=context)
    got: list[tuple[int, int]] = []
    # a depth that a loaded machine's stalls never fill: this test is about the switches, not KEEP_LAST
    subscription = node.create_subscription(Int32, "/numbers", lambda m: got.append((m.data, threading.get_ident())),
                                            1000)
    delivery = subscription._core.delivery
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    spinner = _spinning(executor, "spinner")
    talker, pub = _publisher(session, "/numbers")
    try:
        _publish(pub, range(0, 50))
        wait_until(lambda: len(got) == 50, timeout=15, message=f"50 messages, got {len(got)}")
        assert not delivery.pumping, "a lone subscription is received by the spinning thread itself"

        # a timer added from another thread wakes the receive; the spinner now waits for two things
        ticks: list[int] = []
        timer = node.create_timer(0.05, lambda: ticks.append(threading.get_ident()))
        wait_until(lambda: len(ticks) >= 2, timeout=10, message="the new timer ticking")
        _publish(pub, range(50, 100))
        wait_until(lambda: len(got) == 100, timeout=15, message=f"100 messages, got {len(got)}")
        assert delivery.pumping, "with a timer to wait for too, a pump thread hands messages over"

        # without the timer the spinning thread takes the ring back, losing nothing
        node.destroy_timer(timer)
        executor.wake()
        _publish(pub, range(100, 150))
        wait_until(lambda: len(got) == 150, timeout=15, message=f"150 messages, got {len(got)}")
        wait_until(lambda: not delivery.pumping, timeout=5, message="the ring handed back")
        _publish(pub, range(150, 200))
        wait_until(lambda: len(got) == 200, timeout=15, message=f"200 messages, got {len(got)}")

        assert sorted(n for n, _ in got) == list(range(200))
        assert {ident for _, ident in got} | set(ticks) == {spinner.ident}, "every callback on the spinning thread"

        # destroying the subscription while the spinner receives on it leaves the spin running
        node.destroy_subscription(subscription)
        done = []
        node.create_timer(0.05, lambda: done.append(1))
        wait_until(lambda: done, timeout=10, message="the spin going on after the subscription went")
    finally:
        talker.destroy()
        executor.shutdown()
        spinner.join(timeout=10)
    assert not spinner.is_alive(), "shutdown ends a spin waiting in a receive"


def test_keep_last_keeps_exactly_its_depth_while_nobody_spins(context, session) -> None:
    import msgs
    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    Int32 = msgs.get_type("std_msgs/msg/Int32")
    node = rclpy.create_node("idle_listener", context=context)
    got: list[int] = []
    node.create_subscription(Int32, "/idle_numbers", lambda m: got.append(m.data), 3)
    talker, pub = _publisher(session, "/idle_numbers")
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    try:
        _publish(pub, range(10))
        time.sleep(0.5)   # all ten have arrived; nobody spins
        for _ in range(6):
            executor.spin_once(timeout_sec=0.1)
    finally:
        talker.destroy()
        executor.shutdown()
    assert got == [7, 8, 9]


def test_several_spinning_threads_share_one_subscription(context, session) -> None:
    import msgs
    import rclpy
    from rclpy.callback_groups import ReentrantCallbackGroup
    from rclpy.executors import MultiThreadedExecutor

    Int32 = msgs.get_type("std_msgs/msg/Int32")
    node = rclpy.create_node("shared_listener", context=context)
    got: list[tuple[int, str]] = []
    node.create_subscription(Int32, "/shared_numbers", lambda m: got.append((m.data, threading.current_thread().name)),
                             100, callback_group=ReentrantCallbackGroup())
    executor = MultiThreadedExecutor(num_threads=3, context=context)
    executor.add_node(node)
    spinner = _spinning(executor, "main-spinner")
    talker, pub = _publisher(session, "/shared_numbers")
    try:
        _publish(pub, range(100))
        wait_until(lambda: len(got) == 100, timeout=15, message=f"100 messages, got {len(got)}")
    finally:
        talker.destroy()
        executor.shutdown()
        spinner.join(timeout=10)
    assert sorted(n for n, _ in got) == list(range(100))
    assert {name for _, name in got} <= {"main-spinner"} | {f"rclpy-mt_{i}" for i in range(3)}


def test_wake_ups_while_receiving_itself_do_not_pile_up(context, session) -> None:
    """Work queued while the callback runs (here: a wake-up per message) is looked for once; the tokens a
    wait on the queue would take are not left behind while the spinning thread receives from the ring."""
    import msgs
    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    Int32 = msgs.get_type("std_msgs/msg/Int32")
    node = rclpy.create_node("waking_listener", context=context)
    executor = SingleThreadedExecutor(context=context)
    got: list[int] = []

    def on_number(msg) -> None:
        got.append(msg.data)
        executor.wake()

    subscription = node.create_subscription(Int32, "/waking_numbers", on_number, 1000)
    executor.add_node(node)
    spinner = _spinning(executor, "spinner")
    talker, pub = _publisher(session, "/waking_numbers")
    try:
        _publish(pub, range(100))
        wait_until(lambda: len(got) == 100, timeout=15, message=f"100 messages, got {len(got)}")
        assert not subscription._core.delivery.pumping
        assert executor._spinner._tokens.qsize() <= 1
    finally:
        talker.destroy()
        executor.shutdown()
        spinner.join(timeout=10)
