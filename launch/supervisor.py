"""Runs a resolved launch plan: starts nodes in readiness order, prefixes and logs their output,
respawns, honours ``required``, restarts respawnable nodes that stop serving (health probes), and shuts
everything down (SIGINT → SIGTERM after 4 s → SIGKILL after 7 s: a Ctrl-C ends the tree within 10 s).

Every node runs in its own process group so signals reach its children too; the reaper guards against
orphans if the launcher itself is killed.
"""

from __future__ import annotations

import os
import queue
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any, Protocol

import yaml

from launch.plan import ComposedNodeSpec, Expansion, LaunchPlan, NodeSpec, Trigger
from launch.reaper import Reaper
from launch.yaml_source import LaunchError
from nodes.core.cpu import EXCLUSIVE_CPU_ENV

SIGTERM_AFTER_S = 4.0
SIGKILL_AFTER_S = 7.0
# The shutdown's stages after the first SIGINT: (seconds after it, signal sent, the one sent before, log level)
_ESCALATION = ((SIGTERM_AFTER_S, signal.SIGTERM, "SIGINT", "WARN"), (SIGKILL_AFTER_S, signal.SIGKILL, "SIGTERM", "ERROR"))
POLL_S = 0.02
HEALTH_KILL_GRACE_S = 2.0  # a node killed for not answering: SIGTERM, then SIGKILL this much later
# A process that ran this long before it exited starts a fresh respawn count: respawn_max caps crash
# loops, not the number of unrelated faults over a long run.
RESPAWN_RESET_AFTER_S = 30.0
STATE_DIR_ENV = "ZENROID_STATE_DIR"  # where nodes keep what they restore after a respawn
CONFIGURATION_ERROR = 2  # a node's exit status for a configuration it refused (nodes.core.run_node)
RESPAWN_ENV = "ZENROID_RESPAWN"  # how many times this node has been respawned (0: first start)
_COLOURS = (32, 36, 33, 35, 34, 91, 92, 93, 94, 95, 96)


def become_subreaper() -> bool:
    """Linux: processes our nodes orphan (e.g. a server started in its own session) become our children
    instead of init's, so the launcher can still find and end them."""
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        return libc.prctl(36, 1, 0, 0, 0) == 0  # PR_SET_CHILD_SUBREAPER
    except (OSError, AttributeError):
        return False


def end_leftovers(keep: set[int], grace_s: float = 2.0) -> list[str]:
    """SIGTERM, then SIGKILL, every descendant not in ``keep``; reap them. Returns what was ended."""
    import psutil

    me = psutil.Process()
    leftovers = [c for c in me.children(recursive=True) if c.pid not in keep]
    described = []
    for proc in leftovers:
        try:
            described.append(f"{proc.pid} ({' '.join(proc.cmdline()[:2]) or proc.name()})")
            proc.terminate()
        except psutil.Error:
            pass
    _, alive = psutil.wait_procs(leftovers, timeout=grace_s)
    for proc in alive:
        try:
            proc.kill()
        except psutil.Error:
            pass
    psutil.wait_procs(alive, timeout=grace_s)  # also reaps the ones that were our (adopted) children
    return described


class Readiness(Protocol):
    def is_alive(self, full_name: str) -> bool: ...


class Health(Protocol):
    """Optional part of a readiness source (``launch.readiness.NodeReadiness``): service probes."""

    def watch(self, full_name: str) -> None: ...
    def unwatch(self, full_name: str) -> None: ...
    def last_answer(self, full_name: str) -> float | None: ...


@dataclass
class Managed:
    """A node and its current process."""

    spec: NodeSpec
    colour: int
    state: str = "waiting"  # waiting | running | respawn_pending | exited | skipped
    proc: subprocess.Popen | None = None
    pgid: int | None = None
    restarts: int = 0
    exit_code: int | None = None
    next_start: float = 0.0
    waiting_since: float = field(default_factory=time.monotonic)
    reader: threading.Thread | None = None
    started_at: float = 0.0
    probed: bool = False  # its health is being probed (it showed up on the graph)
    silent_reported: bool = False
    sigkill_at: float | None = None  # killed for silence: when SIGKILL follows the SIGTERM
    wedged: bool = False  # killed for silence (its exit is a failure whatever its status)
    longest_silence: float = 0.0  # the longest time it went without answering a probe (after its first answer)


class Supervisor:
    def __init__(self, plan: LaunchPlan, log_dir: Path, child_env: dict[str, str],
                 readiness: Readiness | None, out: IO[str] | None = None, colour: bool | None = None,
                 python: str = sys.executable, reaper: Reaper | None = None, own_process_tree: bool = False,
                 exclusive_cpu: int | None = None) -> None:
        self.plan = plan
        self.log_dir = log_dir
        self.child_env = child_env
        self.readiness = readiness
        self.out = out or sys.stdout
        self.colour = self.out.isatty() if colour is None else colour
        self.python = python
        self.reaper = reaper
        # Only a launcher process owns all its descendants; embedded in another program it must not adopt
        # or end processes that are not its nodes'.
        self.own_process_tree = own_process_tree
        self.exclusive_cpu = exclusive_cpu   # told to the node with exclusive_cpu (launch.cli reserves it)
        self.nodes = [Managed(spec, _COLOURS[i % len(_COLOURS)]) for i, spec in enumerate(plan.nodes)]
        self.by_name = {m.spec.name: m for m in self.nodes}
        # a node composed into a container: its process is the container's, its liveliness its own
        self.composed_full_names: dict[str, str] = {}
        for managed in self.nodes:
            for node in managed.spec.composed:
                self.by_name[node.name] = managed
                self.composed_full_names[node.name] = node.full_name
        self.exit_status = 0
        self._print_lock = threading.Lock()
        # ROS launch reactions (launch.resolve.Trigger): events queued (output lines come from reader threads)
        # and run on the main loop; timers due at a monotonic time
        self._events: queue.SimpleQueue = queue.SimpleQueue()
        self._timers: list[tuple[float, Trigger]] = []
        self._io_watched = any(t.kind == "io" for t in plan.triggers)
        self._shutdown_fired = False
        self._stop_reason: str | None = None
        self._signals = 0
        self._shutdown_started: float | None = None
        self._escalation = 0  # 0 SIGINT sent, 1 SIGTERM sent, 2 SIGKILL sent

    # -- output ---------------------------------------------------------------------------------
    def say(self, text: str, level: str = "INFO") -> None:
        line = f"[launch] [{level}] {text}"
        if self.colour and level in ("WARN", "ERROR"):
            line = f"\x1b[{33 if level == 'WARN' else 31}m{line}\x1b[0m"
        with self._print_lock:
            self.out.write(line + "\n")
            self.out.flush()

    def _pump(self, managed: Managed, stream: IO[bytes]) -> None:
        """Copy one process's output to its log file and (output: screen) to our stdout, prefixed."""
        prefix = f"[{managed.spec.name}] "
        if self.colour:
            prefix = f"\x1b[{managed.colour}m{prefix}\x1b[0m"
        with open(self.log_dir / f"{managed.spec.name}.log", "ab") as log:
            for raw in iter(stream.readline, b""):
                log.write(raw)
                log.flush()
                if self._io_watched:
                    self._events.put(("io", managed, raw))
                if managed.spec.output == "screen":
                    text = raw.decode("utf-8", errors="replace").rstrip("\n")
                    with self._print_lock:
                        self.out.write(prefix + text + "\n")
                        self.out.flush()
        stream.close()

    # -- processes ------------------------------------------------------------------------------
    def _params_file(self, spec: NodeSpec | ComposedNodeSpec) -> Path | None:
        if not spec.params:
            return None
        path = self.log_dir / f"{spec.name}.params.yaml"
        # a ROS program's node name may be its own default (launch_ros writes '/**' for the same reason)
        key = spec.name if isinstance(spec, ComposedNodeSpec) or getattr(spec, "module", None) else "/**"
        document = {key: {"ros__parameters": spec.params}}
        path.write_text(yaml.safe_dump(document, sort_keys=False), encoding="utf-8")
        return path

    def _start(self, managed: Managed) -> None:
        spec = managed.spec
        composed_params = {node.name: self._params_file(node) for node in spec.composed}
        generated = self._params_file(spec) if spec.module or spec.style else None
        argv = spec.command(self.python, generated, composed_params)
        env = dict(self.child_env)
        env[STATE_DIR_ENV] = str(self.log_dir / "state")
        env[RESPAWN_ENV] = str(managed.restarts)
        env.update(spec.env)
        env.pop(EXCLUSIVE_CPU_ENV, None)   # only from this launch's reservation, never inherited from a shell
        if spec.exclusive_cpu and self.exclusive_cpu is not None:
            env[EXCLUSIVE_CPU_ENV] = str(self.exclusive_cpu)
        try:
            proc = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                    stderr=subprocess.STDOUT, env=env, start_new_session=True, cwd=spec.cwd)
        except OSError as exc:
            self.say(f"cannot start '{spec.name}': {exc.strerror or exc}", "ERROR")
            managed.state = "exited"
            managed.exit_code = 127
            self._on_exit(managed)
            return
        managed.proc = proc
        managed.pgid = proc.pid  # start_new_session: the child leads its own group
        managed.started_at = time.monotonic()
        managed.probed = managed.silent_reported = False
        managed.sigkill_at = None
        managed.wedged = False
        if self.reaper:
            self.reaper.watch(proc.pid)
        managed.state = "running"
        managed.reader = threading.Thread(target=self._pump, args=(managed, proc.stdout), daemon=True,
                                          name=f"output-{spec.name}")
        managed.reader.start()
        what = spec.module or spec.executable
        if spec.composed:
            what = f"container: {', '.join(node.name for node in spec.composed)}"
        again = f" (restart {managed.restarts}/{spec.respawn_max})" if managed.restarts else ""
        self.say(f"started '{spec.name}' [pid {proc.pid}] ({what}){again}")
        self._event("start", managed)

    def _dependency_state(self, managed: Managed) -> str:
        """'ready' when every wait_for node is live (or finished with status 0), 'failed' if one can never be."""
        for target in managed.spec.wait_for:
            dep = self.by_name[target]
            if dep.state == "exited" and dep.exit_code == 0:
                continue
            if dep.state in ("exited", "skipped"):
                return "failed"
            if dep.state != "running":
                return "waiting"
            composed = self.composed_full_names.get(target)
            # a node in a container: up when it is on the graph itself; a process: under either of its names
            names = (composed,) if composed is not None else (dep.spec.full_name, dep.spec.name)
            live = self.readiness is not None and any(self.readiness.is_alive(name) for name in names)
            if not live:
                return "waiting"
        return "ready"

    def _on_exit(self, managed: Managed) -> None:
        spec, code = managed.spec, managed.exit_code
        if managed.probed and self._health is not None:
            self._health.unwatch(spec.full_name)
            managed.probed = False
        if managed.pgid is not None:
            # Whatever the node left running in its group (its own children) must not outlive it.
            try:
                os.killpg(managed.pgid, signal.SIGKILL)
            except (ProcessLookupError, PermissionError):
                pass
            if self.reaper:
                self.reaper.forget(managed.pgid)
        describe = f"signal {-code}" if code is not None and code < 0 else f"status {code}"
        if self._shutdown_started is not None:
            self.say(f"'{spec.name}' ended ({describe})")
            return
        if managed.wedged:
            describe += ", killed for not answering"
            code = code if code else 1
        level = "INFO" if code == 0 else "ERROR"
        self.say(f"'{spec.name}' [pid {managed.proc.pid if managed.proc else '-'}] exited with {describe}", level)
        self._event("exit", managed)
        for handler in self.plan.on_exit:
            if handler.node == spec.name:
                if handler.log:
                    self.say(handler.log)
                if handler.shutdown:
                    self.request_stop(f"on_exit of '{spec.name}' asked for shutdown")
        if spec.respawn and time.monotonic() - managed.started_at >= RESPAWN_RESET_AFTER_S:
            managed.restarts = 0
        if spec.respawn and code == CONFIGURATION_ERROR:
            # run_node's status for a configuration the node refused (a bad world file, a bad parameter):
            # the same configuration would be refused again, so the launch ends now instead of after retries
            self.say(f"'{spec.name}' refused its configuration (status {code}): not respawned", "ERROR")
        elif spec.respawn and managed.restarts < spec.respawn_max and self._stop_reason is None:
            managed.restarts += 1
            managed.state = "respawn_pending"
            managed.next_start = time.monotonic() + spec.respawn_delay
            self.say(f"respawning '{spec.name}' in {spec.respawn_delay:g} s "
                     f"({managed.restarts}/{spec.respawn_max})", "WARN")
            return
        elif spec.respawn:
            self.say(f"'{spec.name}' reached its restart limit ({spec.respawn_max})", "ERROR")
        if spec.required:
            if code != 0:
                self.exit_status = 1
            self.request_stop(f"required node '{spec.name}' exited ({describe})")

    @property
    def _health(self) -> Health | None:
        readiness = self.readiness
        return readiness if readiness is not None and hasattr(readiness, "last_answer") else None  # type: ignore[return-value]

    def _check_health(self, managed: Managed, now: float) -> None:
        """A running node that stopped answering for ``health_timeout`` is not alive: restart it (respawn)."""
        spec, health = managed.spec, self._health
        if health is None or spec.health_timeout <= 0:
            return
        if managed.sigkill_at is not None:   # killed for silence: it has its grace to end, then SIGKILL
            if now >= managed.sigkill_at:
                managed.sigkill_at = None
                self.say(f"'{spec.name}' still running {HEALTH_KILL_GRACE_S:g} s after SIGTERM: sending SIGKILL",
                         "ERROR")
                self._kill_group(managed, signal.SIGKILL)
            return
        if not managed.probed:
            if self.readiness.is_alive(spec.full_name):  # a node (not a plain program) is on the graph
                health.watch(spec.full_name)
                managed.probed = True
            return
        last = health.last_answer(spec.full_name)
        if last is None:
            return  # not serving yet (start-up): only a node that served once can stop serving
        silent = now - last
        managed.longest_silence = max(managed.longest_silence, silent)
        if silent < spec.health_timeout:
            if managed.silent_reported:
                managed.silent_reported = False
                self.say(f"'{spec.name}' answers again")
            return
        if managed.silent_reported:
            return
        managed.silent_reported = True
        why = f"'{spec.name}' stopped answering for {silent:.1f} s (hung, or its Zenoh link is lost)"
        if spec.respawn or spec.required:
            # a wedged node is a dead node: ended like a crash, then respawned (or the launch ends) as one
            self.say(f"{why}: killed", "ERROR")
            self._kill_group(managed, signal.SIGTERM)
            managed.sigkill_at = now + HEALTH_KILL_GRACE_S
            managed.wedged = True
        else:
            self.say(f"{why}; it neither respawns nor is required, so it is left running", "WARN")

    # -- ROS launch reactions ------------------------------------------------------------------
    def _event(self, kind: str, managed: Managed, data: bytes = b"") -> None:
        if any(t.kind == kind for t in self.plan.triggers):
            self._events.put((kind, managed, data))

    def _process_event(self, kind: str, managed: Managed, data: bytes) -> None:
        from launch import events

        spec, proc = managed.spec, managed.proc
        common = dict(action=spec.action, name=spec.name, cmd=list(proc.args) if proc else None,
                      pid=proc.pid if proc else 0)
        if kind == "exit":
            event: Any = events.ProcessExited(returncode=managed.exit_code or 0, **common)
        elif kind == "start":
            event = events.ProcessStarted(**common)
        else:
            event = events.ProcessIO(text=data, **common)
        for trigger in list(self.plan.triggers):
            if trigger.kind == kind and (trigger.matches is None or trigger.matches(spec)):
                self._fire(trigger, event)

    def _fire(self, trigger: Trigger, event: Any) -> None:
        try:
            expansion = trigger.fire(event)
        except LaunchError as exc:
            self.say(f"event handler at {trigger.source}: {exc}", "ERROR")
            return
        self._absorb(expansion)

    def _absorb(self, expansion: Expansion) -> None:
        # what a fired reaction (or the launch's start) yields: logs, processes, more reactions, a shutdown
        for level, text in expansion.logs:
            self.say(text, level)
        if self._shutdown_started is None:
            for spec in expansion.nodes:
                managed = Managed(spec, _COLOURS[len(self.nodes) % len(_COLOURS)])
                self.nodes.append(managed)
                self.by_name[spec.name] = managed
        for trigger in expansion.triggers:
            if trigger.kind == "timer":
                self._timers.append((time.monotonic() + trigger.after, trigger))
            else:
                self.plan.triggers.append(trigger)
                self._io_watched = self._io_watched or trigger.kind == "io"
        if expansion.shutdown:
            self.request_stop(expansion.shutdown)

    def _run_reactions(self, now: float) -> None:
        while True:
            try:
                kind, managed, data = self._events.get_nowait()
            except queue.Empty:
                break
            self._process_event(kind, managed, data)
        due = [entry for entry in self._timers if entry[0] <= now]
        if due and self._shutdown_started is None:
            self._timers = [entry for entry in self._timers if entry[0] > now]
            for _, trigger in due:
                self._fire(trigger, None)

    def _fire_shutdown(self) -> None:
        from launch import events

        if self._shutdown_fired:
            return
        self._shutdown_fired = True
        for trigger in [t for t in self.plan.triggers if t.kind == "shutdown"]:
            self._fire(trigger, events.Shutdown(reason=self._stop_reason or "the launch ended"))

    def request_stop(self, reason: str) -> None:
        if self._stop_reason is None:
            self._stop_reason = reason

    def handle_signal(self, signum: int, _frame: object = None) -> None:
        """SIGINT/SIGTERM: begin the shutdown; a second signal escalates one stage right away."""
        self._signals += 1
        self.request_stop(f"received {signal.Signals(signum).name}")
        if self._signals > 1 and self._shutdown_started is not None:
            self._shutdown_started -= SIGTERM_AFTER_S if self._escalation == 0 else SIGKILL_AFTER_S

    def _kill_group(self, managed: Managed, sig: int) -> None:
        if managed.proc is None or managed.proc.poll() is not None:
            return
        try:
            os.killpg(managed.pgid, sig)
        except (ProcessLookupError, PermissionError):
            pass

    # -- main loop ------------------------------------------------------------------------------
    def _step_running(self, now: float) -> None:
        for managed in self.nodes:
            if managed.state == "waiting" and self._shutdown_started is None:
                state = self._dependency_state(managed)
                if state == "ready":
                    self._start(managed)
                elif state == "failed":
                    managed.state = "skipped"
                    self.say(f"not starting '{managed.spec.name}': a node it waits for "
                             f"({', '.join(managed.spec.wait_for)}) failed", "ERROR")
                    if managed.spec.required:
                        self.exit_status = 1
                        self.request_stop(f"required node '{managed.spec.name}' could not start")
                elif now - managed.waiting_since > managed.spec.wait_timeout:
                    managed.state = "skipped"
                    self.exit_status = 1
                    self.say(f"'{managed.spec.name}' waited {managed.spec.wait_timeout:g} s for "
                             f"{', '.join(managed.spec.wait_for)} to come up; giving up", "ERROR")
                    self.request_stop("a node's wait_for timed out")
            elif managed.state == "running" and managed.proc.poll() is not None:
                managed.exit_code = managed.proc.returncode
                managed.state = "exited"
                self._on_exit(managed)
            elif managed.state == "running":
                self._check_health(managed, now)
            elif managed.state == "respawn_pending" and now >= managed.next_start and self._stop_reason is None:
                self._start(managed)

    def _step_shutdown(self, now: float) -> bool:
        """Advance the shutdown; True once every process has ended."""
        elapsed = now - self._shutdown_started
        for stage, (after, sig, before, level) in enumerate(_ESCALATION, start=1):
            if self._escalation == stage - 1 and elapsed >= after:
                self._escalation = stage
                for managed in self.nodes:
                    if managed.proc is not None and managed.proc.poll() is None:
                        self.say(f"'{managed.spec.name}' still running after {before}: sending {sig.name}", level)
                        self._kill_group(managed, sig)
        done = True
        for managed in self.nodes:
            if managed.state == "running":
                if managed.proc.poll() is None:
                    done = False
                else:
                    managed.exit_code = managed.proc.returncode
                    managed.state = "exited"
                    self._on_exit(managed)
        return done

    def _begin_shutdown(self) -> None:
        self._shutdown_started = time.monotonic()
        self.say(f"shutting down: {self._stop_reason}")
        self._fire_shutdown()
        for managed in self.nodes:
            if managed.state in ("waiting", "respawn_pending"):
                managed.state = "skipped"
            self._kill_group(managed, signal.SIGINT)

    def run(self) -> int:
        """Supervise until every process ended (or a stop was requested and carried out)."""
        self.say(f"log directory: {self.log_dir}")
        if self.own_process_tree:
            become_subreaper()
        self._absorb(Expansion(logs=list(self.plan.logs), shutdown=self.plan.shutdown,
                               triggers=[t for t in self.plan.triggers if t.kind == "timer"]))
        self.plan.triggers = [t for t in self.plan.triggers if t.kind != "timer"]
        while True:
            now = time.monotonic()
            self._run_reactions(now)
            if self._stop_reason is not None and self._shutdown_started is None:
                self._begin_shutdown()
            if self._shutdown_started is not None:
                if self._step_shutdown(now):
                    break
            else:
                self._step_running(now)
                if all(m.state in ("exited", "skipped") for m in self.nodes) and not self._timers \
                        and self._events.empty():
                    self.say("all processes have ended")
                    self._fire_shutdown()
                    break
            time.sleep(POLL_S)
        for managed in self.nodes:
            if managed.reader is not None:
                managed.reader.join(timeout=2.0)
        if self.own_process_tree:
            leftovers = end_leftovers({self.reaper.pid} if self.reaper else set())
            if leftovers:
                self.say(f"ended processes the nodes left behind: {', '.join(leftovers)}", "WARN")
        silences = [f"{m.spec.name} {m.longest_silence:.1f} s" for m in self.nodes if m.longest_silence > 0]
        if silences:   # how close the watchdog came to a kill: the figure health_timeout is chosen against
            self.say(f"health: longest time without an answer: {', '.join(silences)}")
        for message in self.plan.on_shutdown:
            self.say(message)
        return self.exit_status
