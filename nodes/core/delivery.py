"""How a subscription's messages reach its callback: two small objects chosen once per subscription, as
zenoh-python's ``declare_subscriber`` takes a callback or a ``RingChannel``.

**Where and when the callback runs** (``delivery=``), one class per way:

- ``Executed(depth=None)``, the default: one at a time with the node's other callbacks, by the node's
  executor (``executor.py``): on the delivering Zenoh thread under the node's lock, or queued for the
  thread that spins (nodes that ask for it, rclpy's nodes). ``depth``: at most that many wait for the
  spinning thread, the newest kept (a ROS KEEP_LAST depth); None: all of them.
- ``Inline()``: on the delivering Zenoh thread, without the node's lock: for short callbacks that are
  thread safe on their own (the clock, the controller manager's hardware frames).
- ``Batched(max_rate, backlog=256)``: a thread wakes at most ``max_rate`` times a second and runs every
  message that arrived meanwhile in one go; Zenoh keeps them (the newest ``backlog``) in its ring buffer. A
  1 kHz ``joint_states`` then costs a consumer that needs 50 updates a second 50 wake-ups, not 1000.
- ``Spun(depth)``: for nodes whose callbacks run on the spinning thread (rclpy's): messages wait in Zenoh's
  ring of ``depth`` until a spinning thread takes them; one that spins this subscription alone receives
  from the ring itself, so a message costs one thread hand-off, not two.
- ``Pulled(backlog=256)``: no thread delivers anything. Messages wait (the newest ``backlog``) until the
  owner's thread takes them with ``take_pending()`` or ``wait(timeout)``, and the callback runs there. For a
  thread that holds the GIL for long stretches (the simulator's physics, in C++): a delivering thread would
  wait for the GIL until the physics ends and then hand it back and forth; pulling costs no hand-off.

**What the callback gets** (``message=``):

- ``Decoded()``, the default: the message as its class, decoded and checked against the limits;
- ``Raw(objects=False)``: the payload bytes (a subscription without a message type takes only these).
  ``objects=True``: in a container, a message another node of the process published as an object comes as
  that object, built by trusted code and neither encoded nor decoded (the hardware frames between a composed
  simulator and controller manager); from Zenoh, bytes still.

Both take ``with_key=True`` (``callback(msg, key)``, for wildcard keys such as ``"*/joint_states"``) and
``with_source=True`` (the sending publisher's 16-byte id, or None, as the last argument: it tells two senders
on one key apart; it identifies, it does not authenticate, which is Zenoh's access control).

A delivery object holds its subscription's queue or thread, so each serves one subscription.
"""

from __future__ import annotations

import functools
import struct
import threading
import time
from collections import deque
from typing import Any, Protocol

import zenoh

import msgs
from msgs import DecodeError
from nodes.core.session import max_payload_bytes

__all__ = ["Batched", "Decoded", "Delivery", "Executed", "Inline", "Pulled", "Raw", "Spun"]

# Elements per array in a message from the network (every list: points, names, positions ...; a
# JointTrajectory controller takes up to 100,000 points). msgpack refuses a longer array before building any
# of it: a 4 MB payload could otherwise hold four million tiny elements, a Python object each.
MAX_ARRAY_LENGTH = 100_000


@functools.cache
def decode_limits(max_bytes: int | None = None) -> msgs.Limits:
    """The limits our endpoints decode with (one instance per size, so compiled decoders are shared)."""
    size = max_payload_bytes() if max_bytes is None else max_bytes
    return msgs.Limits(max_message_bytes=size, max_array_length=MAX_ARRAY_LENGTH, max_string_length=size)


ATTACHMENT = struct.Struct("<Q16s")  # sequence number, source id (loss detection, `topic hz`)


def parse_attachment(sample: Any) -> tuple[int, bytes] | None:
    """(sequence, source id) of a sample from a zenroid publisher, else None."""
    att = sample.attachment
    if att is None:
        return None
    raw = att.to_bytes()
    if len(raw) != ATTACHMENT.size:
        return None
    return ATTACHMENT.unpack(raw)



class Subscription(Protocol):
    """What a delivery and a message form see of ``endpoints.Subscription``."""

    node: Any
    msg_type: Any
    key: str
    callback: Any
    group: Any

    def handle_sample(self, sample: zenoh.Sample) -> None: ...


# ------------------------------------------------------------------ what the callback gets

class Decoded:
    """The callback gets the message as ``msg_type``, decoded and checked (a refused one is dropped and
    logged)."""

    raw = False

    def __init__(self, *, with_key: bool = False, with_source: bool = False) -> None:
        self.with_key = with_key
        self.with_source = with_source
        if not (with_key or with_source):   # the common case, one call less per message
            self.sample_arguments = self._value_only   # type: ignore[method-assign]

    def __repr__(self) -> str:
        return f"{type(self).__name__}(with_key={self.with_key}, with_source={self.with_source})"

    def _value_only(self, sub: Subscription, sample: zenoh.Sample) -> tuple[Any, ...] | None:
        try:
            return (msgs.decode(sub.msg_type, sample.payload.to_bytes(), decode_limits()),)
        except DecodeError as exc:
            sub.node.logger.warn_throttle(1.0, f"dropped a message on '{sample.key_expr}': {exc}",
                                          key=f"decode:{sub.key}")
            return None

    def value(self, sub: Subscription, payload: bytes, key: Any) -> Any | None:
        """What the callback gets for ``payload`` (None: refused, and logged)."""
        try:
            return msgs.decode(sub.msg_type, payload, decode_limits())
        except DecodeError as exc:
            sub.node.logger.warn_throttle(1.0, f"dropped a message on '{key}': {exc}",
                                          key=f"decode:{sub.key}")
            return None

    def object_value(self, sub: Subscription, message: Any, payload: bytes | None, key: str) -> Any | None:
        """What the callback gets for a message handed over in-process (the object itself when the types
        agree: zero copy; else decoded from the publisher's bytes, checked as any payload is)."""
        if message is not None and message._type == sub.msg_type._type:
            return message
        return self.value(sub, payload, key)

    def wants_payload(self, sub: Subscription, published_type: Any) -> bool:
        """Does an in-process message of ``published_type`` reach this callback as bytes or need decoding?"""
        return sub.msg_type._type != published_type._type

    def sample_arguments(self, sub: Subscription, sample: zenoh.Sample) -> tuple[Any, ...] | None:
        value = self.value(sub, sample.payload.to_bytes(), sample.key_expr)
        if value is None:
            return None
        if self.with_key:
            args: tuple[Any, ...] = (value, str(sample.key_expr))
            if not self.with_source:
                return args
        elif not self.with_source:
            return (value,)
        else:
            args = (value,)
        attachment = parse_attachment(sample)
        return (*args, attachment[1] if attachment is not None else None)

    def object_arguments(self, sub: Subscription, message: Any, payload: bytes | None, key: str,
                         source: bytes) -> tuple[Any, ...] | None:
        value = self.object_value(sub, message, payload, key)
        if value is None:
            return None
        args: tuple[Any, ...] = (value, key) if self.with_key else (value,)
        return (*args, source) if self.with_source else args


class Raw(Decoded):
    """The callback gets the payload bytes; ``objects=True``: in a container, the publisher's object as is."""

    raw = True

    def __init__(self, *, objects: bool = False, with_key: bool = False, with_source: bool = False) -> None:
        super().__init__(with_key=with_key, with_source=with_source)
        self.objects = objects

    def __repr__(self) -> str:
        return (f"Raw(objects={self.objects}, with_key={self.with_key}, with_source={self.with_source})")

    def value(self, sub: Subscription, payload: bytes, key: Any) -> Any | None:
        return payload

    def _value_only(self, sub: Subscription, sample: zenoh.Sample) -> tuple[Any, ...] | None:
        return (sample.payload.to_bytes(),)

    def sample_arguments(self, sub: Subscription, sample: zenoh.Sample) -> tuple[Any, ...] | None:
        # the hardware frames' path (with_source): no call per message beyond this one
        payload = sample.payload.to_bytes()
        args: tuple[Any, ...] = (payload, str(sample.key_expr)) if self.with_key else (payload,)
        if not self.with_source:
            return args
        att = sample.attachment
        raw = att.to_bytes() if att is not None else b""
        return (*args, ATTACHMENT.unpack(raw)[1] if len(raw) == ATTACHMENT.size else None)

    def _takes_object(self, sub: Subscription, published_type: str) -> bool:
        return self.objects and sub.msg_type is not None and published_type == sub.msg_type._type

    def object_value(self, sub: Subscription, message: Any, payload: bytes | None, key: str) -> Any | None:
        if message is not None and self._takes_object(sub, message._type):
            return message
        return payload

    def wants_payload(self, sub: Subscription, published_type: Any) -> bool:
        return not self._takes_object(sub, published_type._type)


# ------------------------------------------------------------------ where and when the callback runs

class Delivery:
    """Base of the ways a callback runs. ``open`` binds it to its subscription and picks ``run``; ``declare``
    then makes the Zenoh subscriber, whose first sample may arrive at once. ``run`` takes the arguments of a
    message from Zenoh (or the ROS 2 wire), ``run_in_process`` those of a message a node of the same process
    published (on the publishing thread)."""

    def __init__(self) -> None:
        self.subscription: Subscription | None = None

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"

    def open(self, sub: Subscription) -> None:
        if self.subscription is not None:
            raise ValueError(f"{self!r} already delivers '{self.subscription.key}': give each subscription "
                             "its own delivery object")
        self.subscription = sub
        self.executor = sub.node.executor
        self.callback = sub.callback
        self.where = f"subscription '{sub.key}'"   # what an error report says (built once, not per message)

    def declare(self, sub: Subscription) -> None:
        """The Zenoh subscriber: a callback by default (Zenoh's thread delivers)."""
        self._sub = sub.node.session.declare_subscriber(sub.key, sub.handle_sample)

    def run(self, *args: Any) -> None:
        raise NotImplementedError

    def run_in_process(self, *args: Any) -> None:
        self.run(*args)

    def take_pending(self) -> int:
        raise TypeError(f"{self.where} is delivered by {self!r}: take_pending() and wait() need "
                        "delivery=Pulled()")

    def wait(self, timeout: float) -> int:
        return self.take_pending()

    def close(self) -> None:
        self._sub.undeclare()


class Executed(Delivery):
    """One at a time with the node's other callbacks, by its executor; ``depth`` bounds those that wait for
    a spinning thread (the newest kept)."""

    def __init__(self, depth: int | None = None) -> None:
        super().__init__()
        if depth is not None and (isinstance(depth, bool) or not isinstance(depth, int) or depth < 1):
            raise ValueError(f"depth must be an int >= 1 or None, got {depth!r}")
        self.depth = depth
        self.dropped = 0   # messages that gave way to newer ones while the spinning thread was busy
        self._waiting: deque[tuple[Any, ...]] = deque(maxlen=depth)
        self._lock = threading.Lock()

    def __repr__(self) -> str:
        return f"Executed(depth={self.depth})"

    def open(self, sub: Subscription) -> None:
        super().open(sub)
        # what Executor.dispatch would do, chosen once instead of per message
        if not self.executor.on_spin_thread:
            self.run = self._run_locked   # type: ignore[method-assign]
        elif self.depth is not None:
            self.run = self._run_bounded   # type: ignore[method-assign]
            self.run_in_process = self._run_bounded   # type: ignore[method-assign]
        else:
            self.run = self._run_queued   # type: ignore[method-assign]

    def run(self, *args: Any) -> None:
        self.executor.dispatch(self.callback, *args, where=self.where, group=self.subscription.group)

    def _run_locked(self, *args: Any) -> None:
        """On the delivering thread, one at a time with the node's other callbacks (its executor's lock)."""
        executor = self.executor
        with executor.lock:
            executor.run_callback(self.callback, *args, where=self.where)

    def _run_queued(self, *args: Any) -> None:
        """Queued for the thread that spins, under the subscription's callback group."""
        self.executor.put((self.callback, args, self.where, self.subscription.group))

    def run_in_process(self, *args: Any) -> None:
        self.executor.dispatch_in_process(self.callback, *args, where=self.where,
                                          group=self.subscription.group)

    def _run_bounded(self, *args: Any) -> None:
        """The message waits in this subscription's own queue of ``depth``; the executor's queue holds one
        turn per waiting message. When the queue is full the oldest gives way and takes no new turn, so the
        turns always match the messages."""
        with self._lock:
            full = len(self._waiting) == self.depth
            self._waiting.append(args)
        if full:
            self.dropped += 1
            return
        self.executor.put((self._take_one, (), self.where, self.subscription.group))

    def _take_one(self) -> None:
        with self._lock:
            if not self._waiting:
                return
            args = self._waiting.popleft()
        self.callback(*args)


class Inline(Delivery):
    """On the delivering Zenoh thread (or the publishing thread in-process), without the node's lock."""

    def open(self, sub: Subscription) -> None:
        super().open(sub)
        run = functools.partial(self.executor.run_callback, self.callback, where=self.where)
        self.run = self.run_in_process = run   # type: ignore[method-assign]

    def run(self, *args: Any) -> None:
        self.executor.run_callback(self.callback, *args, where=self.where)


class Batched(Delivery):
    """A thread wakes at most ``max_rate`` times a second and runs what arrived meanwhile, under the node's
    lock; Zenoh keeps the newest ``backlog`` in between."""

    def __init__(self, max_rate: float, backlog: int = 256) -> None:
        super().__init__()
        if not max_rate > 0:
            raise ValueError(f"max_rate must be > 0 Hz, got {max_rate}")
        self.max_rate = max_rate
        self.backlog = _backlog(backlog)

    def __repr__(self) -> str:
        return f"Batched(max_rate={self.max_rate:g}, backlog={self.backlog})"

    def declare(self, sub: Subscription) -> None:
        self._closed = False
        self._sub = sub.node.session.declare_subscriber(sub.key, zenoh.handlers.RingChannel(self.backlog))
        threading.Thread(target=self._drain, args=(sub, 1.0 / self.max_rate), daemon=True,
                         name=f"sub:{sub.key}").start()

    def close(self) -> None:
        # The drain thread blocks in the channel's recv, which holds the channel (undeclaring it meanwhile
        # fails: "Already borrowed"): a wake-up only this session sees ends the wait, then the thread ends.
        self._closed = True
        sub = self.subscription
        sub.node.session.put(sub.key, b"", attachment=WAKE, allowed_destination=zenoh.Locality.SESSION_LOCAL)
        _undeclare_when_free(self._sub)

    def run(self, *args: Any) -> None:
        self.executor.dispatch(self.callback, *args, where=self.where, group=self.subscription.group)

    def run_in_process(self, *args: Any) -> None:
        self.executor.dispatch_in_process(self.callback, *args, where=self.where,
                                          group=self.subscription.group)

    def _drain(self, sub: Subscription, period: float) -> None:
        try:
            while True:
                batch = [self._sub.recv()]          # blocks (without the GIL) until something arrives
                while (sample := self._sub.try_recv()) is not None:
                    batch.append(sample)
                if self._closed:
                    return
                with self.executor.lock:   # the batch in one go: work queued meanwhile sees all of it
                    for sample in batch:
                        sub.handle_sample(sample)
                time.sleep(period)
        except Exception:  # noqa: BLE001 - the subscriber was undeclared: the channel is closed
            return


class Spun(Executed):
    """For a node whose callbacks run on the thread that spins (rclpy's): messages wait in Zenoh's ring of
    ``depth`` (KEEP_LAST, the newest kept) until a spinning thread takes them.

    A thread that spins this subscription alone (one spinning thread, no other subscription of this kind,
    no timer or timeout to wait for: ``rclpy.spin`` of a plain subscriber) blocks in the ring's receive
    itself and runs the callback on waking: one thread hand-off a message, as ``nodes.core``'s default path
    pays, instead of two (Zenoh's thread, then the spinning thread). Otherwise a pump thread hands each
    message to the executor's queue, as ``Executed`` does. Other work for the spinning thread (a service
    request, a timer being added, a shutdown) ends a blocked receive with a wake-up only this session sees."""

    def __init__(self, depth: int) -> None:
        super().__init__(depth)
        self.closed = False
        self.pumping = False
        # whoever receives from Zenoh's ring holds this (the ring refuses a second concurrent receiver)
        self._receiving = threading.Lock()
        self._pump: threading.Thread | None = None
        self._wake_pub: Any = None
        self._receiver: int | None = None   # the thread blocked in wait_held's receive
        self._close_deferred = False

    def __repr__(self) -> str:
        return f"Spun(depth={self.depth})"

    def open(self, sub: Subscription) -> None:
        super().open(sub)
        if not self.executor.on_spin_thread:
            raise ValueError(f"{self.where}: Spun() is for nodes whose callbacks run on the spinning thread")
        self.executor.add_channel(self)

    def declare(self, sub: Subscription) -> None:
        # exactly the depth, as KEEP_LAST keeps: a wake-up that crossed a message in the receive stays in the
        # ring as its oldest entry until the next take, and gives way first
        self._sub = sub.node.session.declare_subscriber(sub.key, zenoh.handlers.RingChannel(self.depth))

    def take_one(self) -> bool | None:
        """Run the callback of one waiting message on this thread: True if it ran, False if its group was
        busy (it waits for the group), None if nothing was waiting (or a pump thread takes them)."""
        if self.pumping or not self._receiving.acquire(blocking=False):
            return None
        try:
            while (sample := self._sub.try_recv()) is not None and is_wake(sample):
                pass
        except zenoh.ZError:
            return None   # undeclared meanwhile: the node is closing
        finally:
            self._receiving.release()
        return None if sample is None else self._run_here(sample)

    def hold(self) -> bool:
        """Take the ring for this thread's ``wait_held`` (a pump thread stops first); False if another
        thread holds it or the subscription is closed."""
        if self.closed:
            return False
        if self.pumping:
            self._stop_pump()
        return self._receiving.acquire(blocking=False)

    def wait_held(self, receiving_on: Any) -> bool | None:
        """After ``hold()``: block in the ring's receive on this thread until a message arrives or
        ``interrupt()``, let the ring go, then run the message's callback as ``take_one`` does.
        ``receiving_on(self)`` is called first (True: a wake-up came before, return at once) and
        ``receiving_on(None)`` once the receive has returned. None: woken without a message."""
        try:
            if receiving_on(self):
                return None
            self._receiver = threading.get_ident()
            sample = self._sub.recv()   # without the GIL; Ctrl-C still raises here (zenoh checks signals)
        except zenoh.ZError:
            return None   # undeclared meanwhile: the node is closing
        finally:
            receiving_on(None)   # wake-ups from now on (the callback's own included) need no interrupt
            self._receiver = None
            self._receiving.release()
            if self._close_deferred:
                self._undeclare()
        if self.closed or is_wake(sample):
            return None
        return self._run_here(sample)

    def interrupt(self) -> None:
        """End a receive in progress with a wake-up that only this session sees."""
        try:
            if self._wake_pub is None:
                self._wake_pub = self.subscription.node.session.declare_publisher(
                    self.subscription.key, allowed_destination=zenoh.Locality.SESSION_LOCAL)
            self._wake_pub.put(b"", attachment=WAKE)
        except zenoh.ZError:
            pass   # the session closed: the receive has ended with it

    def _run_here(self, sample: zenoh.Sample) -> bool:
        sub = self.subscription
        args = sub.arguments_of(sample)
        if args is None:
            return True   # refused (and logged): it was taken all the same
        return self.executor.run_item((self.callback, args, self.where, sub.group))

    def start_pump(self) -> None:
        """From now on a thread of its own hands each message to the executor's queue (several threads spin,
        or the spinning thread also waits for something else)."""
        if self.pumping or self.closed:
            return
        with self._lock:   # several spinning threads may ask at once: one pump
            if self.pumping:
                return
            self.pumping = True
            self._pump = threading.Thread(target=self._pump_messages, daemon=True,
                                          name=f"sub:{self.subscription.key}")
            self._pump.start()

    def _pump_messages(self) -> None:
        handle = self.subscription.handle_sample   # Executed's queue of ``depth``; wake-ups are skipped
        with self._receiving:
            while self.pumping and not self.closed:
                try:
                    sample = self._sub.recv()
                except zenoh.ZError:
                    return
                handle(sample)

    def _stop_pump(self) -> None:
        self.pumping = False
        self.interrupt()
        if self._pump is not None:   # only a spinning thread stops it, never the pump itself
            self._pump.join(timeout=5.0)

    def close(self) -> None:
        self.closed = True
        self.executor.remove_channel(self)
        self.pumping = False
        self.interrupt()   # ends a receive in progress: it holds the ring
        if self._receiver == threading.get_ident():
            # a signal handler (SIGTERM's shutdown) runs inside this thread's own receive, which holds the
            # ring until the handler returns: wait_held lets go of it after that
            self._close_deferred = True
            return
        self._undeclare()

    def _undeclare(self) -> None:
        self._close_deferred = False
        try:
            _undeclare_when_free(self._sub)
            if self._wake_pub is not None:
                self._wake_pub.undeclare()
        except zenoh.ZError:
            pass   # the session closed first: it took them with it


# A pulled subscription's wake-up: an empty message with this attachment (ours are 24 bytes).
WAKE = b"zenroid-wake"


def is_wake(sample: zenoh.Sample) -> bool:
    att = sample.attachment
    return len(sample.payload) == 0 and att is not None and att.to_bytes() == WAKE


class Pulled(Delivery):
    """Messages wait (the newest ``backlog``) until the owner's thread takes them: ``take_pending()`` or
    ``wait(timeout)``; the callback runs on that thread."""

    def __init__(self, backlog: int = 256) -> None:
        super().__init__()
        self.backlog = _backlog(backlog)
        self.closed = False
        self._wake_pub: Any = None
        self._wake_at: float | None = None   # monotonic deadline of the wait in progress
        self._watchdog: threading.Condition | None = None   # wakes the watchdog thread (_watch)
        self._watchdog_idle = False
        self._watching_until: float | None = None   # the deadline the watchdog thread sleeps until
        # in a container: messages of this session's publishers wait here, as others wait in Zenoh's buffer
        self._in_process: deque[tuple[Any, ...]] = deque()
        self._waiting = False   # the owner's thread is (about to be) blocked in Zenoh's recv

    def __repr__(self) -> str:
        return f"Pulled(backlog={self.backlog})"

    def open(self, sub: Subscription) -> None:
        super().open(sub)
        # the taking thread (the one the owner chose) runs the callback
        run = functools.partial(self.executor.run_callback, self.callback, where=self.where)
        self.run = run   # type: ignore[method-assign]

    def declare(self, sub: Subscription) -> None:
        self._sub = sub.node.session.declare_subscriber(sub.key, zenoh.handlers.RingChannel(self.backlog))

    def run(self, *args: Any) -> None:
        self.executor.run_callback(self.callback, *args, where=self.where)

    def run_in_process(self, *args: Any) -> None:
        self._in_process.append(args)
        if self._waiting:   # the owner is blocked in Zenoh's recv: an empty local message ends it
            self._wake_pub.put(b"", attachment=WAKE)

    def _take_in_process(self) -> int:
        count = 0
        while self._in_process:
            args = self._in_process.popleft()
            self.executor.run_callback(self.callback, *args, where=self.where)
            count += 1
        return count

    def take_pending(self) -> int:
        """Handle every message that has arrived, on this thread; returns how many."""
        count = self._take_in_process() if self._in_process else 0
        handle = self.subscription.handle_sample
        while (sample := self._sub.try_recv()) is not None:
            if not is_wake(sample):
                handle(sample)
                count += 1
        return count

    def wait(self, timeout: float) -> int:
        """Block (without the GIL) until a message arrives or ``timeout`` s pass; handles what arrived and
        returns how many (0: timed out, or the subscription was closed).

        Zenoh's channel has no timed receive, so a watchdog thread ends an overdue wait with an empty
        message that only this session sees (``Locality.SESSION_LOCAL``)."""
        if self.closed:
            return 0
        count = self.take_pending()
        if count:
            return count
        self._arm_watchdog(timeout)
        self._waiting = True
        try:
            if self._in_process:   # handed over in-process after take_pending looked
                self._wake_at = None
                return self.take_pending()
            sample = self._sub.recv()
        except zenoh.ZError:
            return 0   # undeclared while waiting (the node is closing)
        finally:
            self._waiting = False
            self._wake_at = None
        if self.closed:
            return 0
        if not is_wake(sample):
            self.subscription.handle_sample(sample)
            count = 1
        return count + self.take_pending()

    def _arm_watchdog(self, timeout: float) -> None:
        if self._wake_pub is None:
            sub = self.subscription
            self._wake_pub = sub.node.session.declare_publisher(
                sub.key, allowed_destination=zenoh.Locality.SESSION_LOCAL)
            self._watchdog = threading.Condition()
            threading.Thread(target=self._watch, daemon=True, name=f"wait:{sub.key}").start()
        with self._watchdog:
            self._wake_at = deadline = time.monotonic() + timeout
            # asleep without a deadline, or until a later one (an earlier wait's, longer timeout): wake it to
            # take this one; otherwise it looks at the new deadline when its own comes
            watching = self._watching_until
            if self._watchdog_idle or (watching is not None and deadline < watching):
                self._watchdog.notify()

    def _watch(self) -> None:
        """Wake the owner's ``wait`` once its deadline has passed. It sleeps until the deadline it knows and
        then looks again, never polling: a thread that woke every 10 ms took the GIL from the simulator's
        physics thread 100 times a second (and, on a CPU shared with other processes, waited for that CPU
        before giving it back)."""
        condition = self._watchdog
        node = self.subscription.node
        try:
            with condition:
                while not (self.closed or node.closed):
                    deadline = self._wake_at
                    if deadline is None:
                        self._watchdog_idle = True
                        condition.wait()
                        self._watchdog_idle = False
                        continue
                    remaining = deadline - time.monotonic()
                    if remaining > 0:
                        self._watching_until = deadline
                        condition.wait(remaining)
                        self._watching_until = None
                        continue
                    self._wake_at = None
                    self._wake_pub.put(b"", attachment=WAKE)
        except zenoh.ZError:
            return   # the session closed

    def close(self) -> None:
        self.closed = True
        if self._wake_pub is None:
            self._sub.undeclare()
            return
        self._wake_pub.put(b"", attachment=WAKE)   # end a wait in progress: it holds the channel
        with self._watchdog:
            self._watchdog.notify()   # and the watchdog thread's sleep: it sees the subscription closed
        _undeclare_when_free(self._sub)
        self._wake_pub.undeclare()


def _undeclare_when_free(subscriber: Any) -> None:
    for _ in range(500):
        try:
            subscriber.undeclare()
            break
        except RuntimeError:   # "Already borrowed": the waiting thread has not let go yet
            time.sleep(0.01)


def _backlog(backlog: Any) -> int:
    if isinstance(backlog, bool) or not isinstance(backlog, int) or backlog < 1:
        raise ValueError(f"backlog must be an int >= 1, got {backlog!r}")
    return backlog



_LEGACY = {"inline": "delivery=Inline()", "pulled": "delivery=Pulled(backlog)",
           "backlog": "Pulled(backlog=...)", "max_rate": "delivery=Batched(max_rate)", "raw": "message=Raw()",
           "objects": "message=Raw(objects=True)",
           "with_key": "message=Decoded(with_key=True) or Raw(with_key=True)",
           "with_source": "message=Decoded(with_source=True) or Raw(with_source=True)"}


def legacy_subscription_options(options: dict[str, Any]) -> str:
    """The error for options a subscription no longer takes as flags: what to write instead."""
    parts = [f"{name}= is now {_LEGACY[name]}" if name in _LEGACY else f"{name}= is not an option"
             for name in options]
    return "; ".join(parts) + " (nodes.core.delivery; docs/nodes.md, Subscriptions)"
