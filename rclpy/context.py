"""``Context``: one ``rclpy.init`` — its ROS arguments and the one Zenoh session its nodes share (as rmw_zenoh
opens one session per context)."""

from __future__ import annotations

import atexit
import os
import signal
import sys
import threading
import time
import weakref
from collections.abc import Callable
from typing import Any

from rclpy.arguments import RosArguments, parse

# How long init waits for the router before saying, once, that it is waiting and how to start one.
ROUTER_GRACE_S = 1.0


class Context:
    def __init__(self) -> None:
        self._lock = threading.RLock()
        self._ok = False
        self._args = RosArguments()
        self._session: Any = None
        self._endpoints: list[str] = []
        self._callbacks: list[Callable[[], None]] = []
        self._executors: weakref.WeakSet = weakref.WeakSet()
        self._nodes: weakref.WeakSet = weakref.WeakSet()
        self._shut_by_signal = False
        self.signalled: int | None = None   # the last SIGINT or SIGTERM rclpy's handler took
        self.domain_id = int(os.environ.get("ROS_DOMAIN_ID", "0") or 0)

    # ---------------------------------------------------------------- lifecycle
    def init(self, args: list[str] | None = None, *, domain_id: int | None = None) -> None:
        from rclpy import logging as rclpy_logging

        with self._lock:
            if self._ok:
                raise RuntimeError("Context.init() must only be called once")
            self._args, _ = parse(list(sys.argv if args is None else args))
            if domain_id is not None:
                self.domain_id = domain_id
            default_level = self._args.log_levels.get("")
            if default_level:
                rclpy_logging.set_default_level(default_level)
            for name, level in self._args.log_levels.items():
                if name:
                    rclpy_logging.get_logger(name).set_level(level)
            self._session = self._open_session()
            self._ok = True
        # A program that ends without rclpy.shutdown() (an exception, sys.exit) still closes its session, and
        # before the interpreter waits for its threads: threads Zenoh's callbacks run on end only with it.
        register = getattr(threading, "_register_atexit", atexit.register)
        register(self.try_shutdown)

    def _open_session(self) -> Any:
        from nodes.core.session import ENV_CONFIG, default_endpoints, is_connected, open_peer
        from rclpy.logging import get_logger

        self._endpoints = default_endpoints()
        session = open_peer()
        where = ", ".join(self._endpoints) if not os.environ.get(ENV_CONFIG) else os.environ[ENV_CONFIG]
        logger = get_logger("rclpy")
        deadline = time.monotonic() + ROUTER_GRACE_S
        told = False
        try:
            while not is_connected(session):
                if not told and time.monotonic() > deadline:
                    logger.warn(f"waiting for a Zenoh router on {where}: start one with `zenroid router` or run a "
                                "launch file (`python -m launch humanoid.yaml`); Ctrl-C to give up")
                    told = True
                if self.signalled == signal.SIGTERM:   # as before a real rclpy installs its handlers: the end
                    raise SystemExit(128 + signal.SIGTERM)
                time.sleep(0.05)
        except BaseException:
            session.close()
            raise
        logger.info(f"rclpy (zenroid, no ROS) connected to {where}")
        return session

    @property
    def session(self) -> Any:
        if self._session is None:
            from rclpy.exceptions import NotInitializedException

            raise NotInitializedException()
        return self._session

    @property
    def arguments(self) -> RosArguments:
        return self._args

    def ok(self) -> bool:
        return self._ok

    def shutdown(self) -> None:
        with self._lock:
            if not self._ok:
                raise RuntimeError("Context.shutdown() called on a context that is not initialized or already "
                                   "shut down")
            self._shutdown()

    def try_shutdown(self) -> None:
        with self._lock:
            if self._ok:
                self._shutdown()

    def _shutdown(self) -> None:
        self._ok = False
        for callback in list(self._callbacks):
            try:
                callback()
            except Exception:  # noqa: BLE001 - every callback gets its turn
                pass
        for executor in list(self._executors):
            executor.wake()
        for node in list(self._nodes):
            node._close_core()
        session, self._session = self._session, None
        if session is not None:
            session.close()

    def on_shutdown(self, callback: Callable[[], None]) -> None:
        self._callbacks.append(callback)

    def _add_executor(self, executor: Any) -> None:
        self._executors.add(executor)

    def _add_node(self, node: Any) -> None:
        self._nodes.add(node)

    def get_domain_id(self) -> int:
        return self.domain_id

    def __enter__(self) -> Context:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.try_shutdown()

    def destroy(self) -> None:
        self.try_shutdown()


_default_context = Context()


def get_default_context() -> Context:
    return _default_context
