"""rclpy's executors over ``nodes.core``: a ``nodes.core.spinner.Spinner`` spins the nodes' own executors.

Each node's callbacks wait in its ``nodes.core`` executor; an rclpy executor takes them on the thread that
spins (``SingleThreadedExecutor``) or on a pool of threads (``MultiThreadedExecutor``), under their callback
groups. A callback's exception ends ``spin`` with that exception, as in rclpy.
"""

from __future__ import annotations

import os
import threading
import time
import warnings
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import Any

from nodes.core.executor import CallbackGroup as CoreCallbackGroup
from nodes.core.executor import Executor as CoreExecutor
from nodes.core.spinner import Spinner
from rclpy.context import Context, get_default_context
from rclpy.task import Future, Task

__all__ = ["ConditionReachedException", "Executor", "ExternalShutdownException", "MultiThreadedExecutor",
           "ShutdownException", "SingleThreadedExecutor", "TimeoutException"]


class ExternalShutdownException(Exception):
    """The context was shut down (SIGTERM, another thread's ``rclpy.shutdown()``) while spinning."""


class ShutdownException(Exception):
    """The executor was shut down."""


class TimeoutException(Exception):
    pass


class ConditionReachedException(Exception):
    pass


class Executor:
    def __init__(self, *, context: Context | None = None) -> None:
        self._context = context or get_default_context()
        self._context._add_executor(self)
        self._spinner = Spinner(single_thread=isinstance(self, SingleThreadedExecutor))
        self._nodes: list[Any] = []
        self._nodes_lock = threading.RLock()
        self._is_shutdown = False
        # tasks (create_task, done callbacks, coroutine steps): a queue of their own in the same spin
        self._tasks = CoreExecutor(self._report, on_spin_thread=True)
        self._tasks.propagate_errors = True
        # tasks run side by side on a multithreaded executor, as in rclpy (a task that blocks, such as an
        # execute callback that sleeps, leaves the others their threads); each task is one at a time by itself
        self._tasks.default_group = CoreCallbackGroup(exclusive=False)
        self._tasks_spun = False   # the task queue joins the spin with the first task (one queue less to look at)

    @staticmethod
    def _report(text: str) -> None:
        from rclpy.logging import get_logger

        get_logger("rclpy.executors").error(text)

    @property
    def context(self) -> Context:
        return self._context

    def wake(self) -> None:
        self._spinner.wake()

    def create_task(self, callback: Callable[..., Any], *args: Any, **kwargs: Any) -> Task:
        task = Task(callback, args, kwargs, executor=self)
        self._resume_task(task)
        return task

    def _resume_task(self, task: Task) -> None:
        if not self._tasks_spun:
            self._tasks_spun = True
            self._spinner.add(self._tasks)
        self._tasks.put((task, (), "task", None))

    def shutdown(self, timeout_sec: float | None = None) -> bool:
        self._is_shutdown = True
        with self._nodes_lock:
            for node in list(self._nodes):
                self.remove_node(node)
        self.wake()
        return True

    def add_node(self, node: Any) -> bool:
        with self._nodes_lock:
            if node in self._nodes:
                return False
            self._nodes.append(node)
        node.executor = self
        self._spinner.add(node._zr.executor)
        return True

    def remove_node(self, node: Any) -> None:
        with self._nodes_lock:
            if node not in self._nodes:
                return
            self._nodes.remove(node)
        self._spinner.remove(node._zr.executor)

    def get_nodes(self) -> list[Any]:
        with self._nodes_lock:
            return list(self._nodes)

    def spin(self) -> None:
        while self._context.ok() and not self._is_shutdown:
            self.spin_once()

    def spin_until_future_complete(self, future: Future, timeout_sec: float | None = None) -> None:
        future.add_done_callback(lambda _f: self.wake())
        if timeout_sec is None or timeout_sec < 0:
            while self._context.ok() and not future.done() and not self._is_shutdown:
                self.spin_once_until_future_complete(future, None)
            return
        end = time.monotonic() + timeout_sec
        while self._context.ok() and not future.done() and not self._is_shutdown:
            self.spin_once_until_future_complete(future, max(0.0, end - time.monotonic()))
            if time.monotonic() >= end:
                return

    def spin_once(self, timeout_sec: float | None = None) -> None:
        raise NotImplementedError()

    def spin_once_until_future_complete(self, future: Future, timeout_sec: float | None = None) -> None:
        self._spin_once_impl(timeout_sec, future.done)

    def _stop(self, condition: Callable[[], bool] | None = None) -> bool:
        return self._is_shutdown or not self._context.ok() or (condition is not None and condition())

    def _wait_and_run(self, timeout_sec: float | None, condition: Callable[[], bool] | None) -> None:
        if self._is_shutdown:
            return
        if not self._context.ok():
            raise ExternalShutdownException()
        timeout = None if timeout_sec is None or timeout_sec < 0 else timeout_sec
        self._spinner.spin_once(timeout, stop=self._stop if condition is None else lambda: self._stop(condition))
        if not self._is_shutdown and not self._context.ok():
            raise ExternalShutdownException()

    def _spin_once_impl(self, timeout_sec: float | None, condition: Callable[[], bool] | None = None) -> None:
        self._wait_and_run(timeout_sec, condition)

    def __enter__(self) -> Executor:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.shutdown()


class SingleThreadedExecutor(Executor):
    """Runs every callback on the thread that calls ``spin``."""

    def spin_once(self, timeout_sec: float | None = None) -> None:
        self._spin_once_impl(timeout_sec)


class MultiThreadedExecutor(Executor):
    """Runs callbacks on ``num_threads`` threads; callbacks of one mutually exclusive group never overlap."""

    def __init__(self, num_threads: int | None = None, *, context: Context | None = None) -> None:
        super().__init__(context=context)
        if num_threads is None:
            num_threads = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 2)
        if num_threads == 1:
            warnings.warn("MultiThreadedExecutor is used with a single thread.\n"
                          "Use the SingleThreadedExecutor instead.", stacklevel=2)
        self._num_threads = max(1, int(num_threads))
        self._workers: ThreadPoolExecutor | None = None
        self._running: list[Any] = []
        self._errors: list[BaseException] = []
        self._lock = threading.Lock()

    def _worker(self) -> None:
        try:
            while not self._is_shutdown and self._context.ok() and not self._errors:
                self._spinner.spin_once(0.2, stop=self._stop)
        except BaseException as exc:  # noqa: BLE001 - re-raised by the thread that spins
            with self._lock:
                self._errors.append(exc)
            self.wake()

    def _ensure_workers(self) -> None:
        with self._lock:
            self._running = [f for f in self._running if not f.done()]
            if self._workers is None:
                self._workers = ThreadPoolExecutor(self._num_threads, thread_name_prefix="rclpy-mt")
            while len(self._running) < self._num_threads - 1:
                self._running.append(self._workers.submit(self._worker))

    def _raise_errors(self) -> None:
        with self._lock:
            errors, self._errors = self._errors, []
        if errors:
            raise errors[0]

    def _spin_once_impl(self, timeout_sec: float | None, condition: Callable[[], bool] | None = None) -> None:
        # the calling thread is one of the ``num_threads``; the others spin in the pool meanwhile
        self._ensure_workers()
        self._raise_errors()
        self._wait_and_run(timeout_sec, lambda: bool(self._errors) or (condition is not None and condition()))
        self._raise_errors()

    def spin_once(self, timeout_sec: float | None = None) -> None:
        self._spin_once_impl(timeout_sec)

    def shutdown(self, timeout_sec: float | None = None) -> bool:
        super().shutdown(timeout_sec)
        workers, self._workers = self._workers, None
        if workers is not None:
            in_pool = threading.current_thread().name.startswith("rclpy-mt")   # a callback shutting down
            workers.shutdown(wait=not in_pool and (timeout_sec is None or timeout_sec > 0))
        return True


_global_executor: SingleThreadedExecutor | None = None
_global_lock = threading.Lock()


def get_global_executor() -> SingleThreadedExecutor:
    global _global_executor
    with _global_lock:
        if _global_executor is None or _global_executor._context is not get_default_context() \
                or _global_executor._is_shutdown:
            _global_executor = SingleThreadedExecutor()
        return _global_executor
