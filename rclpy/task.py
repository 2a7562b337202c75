"""``Future`` and ``Task`` as rclpy has them: a result set once, done callbacks run by the executor, ``await``."""

from __future__ import annotations

import inspect
import threading
from collections.abc import Callable, Generator
from typing import Any


class Future:
    """The result of something that ends later (a service call, a goal, a task)."""

    def __init__(self, *, executor: Any = None) -> None:
        self._state = "pending"
        self._result: Any = None
        self._exception: BaseException | None = None
        self._exception_fetched = False
        self._callbacks: list[Callable[[Future], None]] = []
        self._lock = threading.Lock()
        self._done_event = threading.Event()
        self._executor = executor

    def __del__(self) -> None:
        if self._exception is not None and not self._exception_fetched:
            print(f"The following exception was never retrieved: {self._exception}")

    def __await__(self) -> Generator[None, None, Any]:
        while not self.done():
            yield self   # the Task running this coroutine resumes once this future is done
        return self.result()

    def cancel(self) -> None:
        with self._lock:
            if self._state != "pending":
                return
            self._state = "cancelled"
        self._finished()

    def cancelled(self) -> bool:
        return self._state == "cancelled"

    def done(self) -> bool:
        return self._state != "pending"

    def result(self) -> Any:
        """The result (None while pending, as rclpy); raises the exception the future was given."""
        if self._exception is not None:
            self._exception_fetched = True
            raise self._exception
        return self._result

    def exception(self) -> BaseException | None:
        self._exception_fetched = True
        return self._exception

    def set_result(self, result: Any) -> None:
        with self._lock:
            self._result = result
            self._state = "finished"
        self._finished()

    def set_exception(self, exception: BaseException) -> None:
        with self._lock:
            self._exception = exception
            self._exception_fetched = False
            self._state = "finished"
        self._finished()

    def _finished(self) -> None:
        self._done_event.set()
        with self._lock:
            callbacks, self._callbacks = self._callbacks, []
        for callback in callbacks:
            self._schedule(callback)
        executor = self._executor
        if executor is not None and not callbacks:
            executor.wake()   # a spin_until_future_complete waiting on this future looks again

    def _schedule(self, callback: Callable[[Future], None]) -> None:
        executor = self._executor
        if executor is not None:
            executor.create_task(callback, self)
        else:
            callback(self)

    def _set_executor(self, executor: Any) -> None:
        self._executor = executor

    def add_done_callback(self, callback: Callable[[Future], None]) -> None:
        with self._lock:
            if not self.done():
                self._callbacks.append(callback)
                return
        self._schedule(callback)

    def remove_done_callback(self, callback: Callable[[Future], None]) -> bool:
        with self._lock:
            if callback in self._callbacks:
                self._callbacks.remove(callback)
                return True
        return False

    def wait(self, timeout: float | None = None) -> bool:
        """Block this thread until done (zenroid: for code that waits without spinning)."""
        return self._done_event.wait(timeout)


class Task(Future):
    """A function or coroutine run by an executor; a coroutine resumes on the executor each time what it
    awaits is done."""

    def __init__(self, handler: Callable[..., Any], args: tuple[Any, ...] = (), kwargs: dict[str, Any] | None = None,
                 executor: Any = None) -> None:
        super().__init__(executor=executor)
        self._handler: Any = handler
        self._args = args
        self._kwargs = kwargs or {}
        self._coroutine: Any = None
        self._running = threading.Lock()
        if inspect.iscoroutine(handler):
            self._coroutine, self._handler = handler, None

    def __call__(self) -> None:
        """Run (or resume) the task on this thread; an exception in it is kept and re-raised."""
        if self.done() or not self._running.acquire(blocking=False):
            return
        try:
            if self._coroutine is None:
                result = self._handler(*self._args, **self._kwargs)
                if inspect.iscoroutine(result):
                    self._coroutine = result
                else:
                    self.set_result(result)
                    return
            try:
                awaited = self._coroutine.send(None)
            except StopIteration as stop:
                self.set_result(stop.value)
                return
            self._wait_for(awaited)
        except Exception as exc:
            self.set_exception(exc)
            self._exception_fetched = True   # raised to whoever spins, as rclpy does
            raise
        finally:
            self._running.release()

    def _wait_for(self, awaited: Any) -> None:
        """Resume when ``awaited`` (a Future, or None from a bare yield) is done."""
        executor = self._executor
        if isinstance(awaited, Future) and not awaited.done():
            awaited.add_done_callback(lambda _f: self._resume())
        elif executor is not None:
            executor._resume_task(self)

    def _resume(self) -> None:
        executor = self._executor
        if executor is not None:
            executor._resume_task(self)
        else:
            self()

    def executing(self) -> bool:
        return self._running.locked()
