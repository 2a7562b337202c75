"""The controller manager process: ros2_control's controller_manager over the simulator's hardware frames.

It asks ``<ns>/hardware/info`` for the joints (retrying until the simulator answers), then offers the
``<ns>/controller_manager/*`` services and answers every ``<ns>/hardware/state`` with exactly one
``<ns>/hardware/command`` (same ``step``), after running every active controller's ``update`` on the
state's sim time. The hot path (state in, command out) uses raw msgpack on Zenoh's thread.
"""

from __future__ import annotations

import collections
import gc
import json
import os
import sys
import threading
import time
from typing import Any

import msgs
from msgs.classes import maker
from msgs.controller_manager_msgs import (
    ConfigureController,
    ControllerState,
    ListControllers,
    ListHardwareInterfaces,
    LoadController,
    SwitchController,
    UnloadController,
)
from msgs.controller_manager_msgs import HardwareInterface as HardwareInterfaceMsg
from msgs.std_srvs import Trigger
from msgs.zenroid_msgs import (
    GetHardwareInfo,
    HardwareCommand,
    HardwareHeartbeat,
    HardwareState,
    SetParameters,
)
from nodes.control import restore
from nodes.control.config import (
    ConfigError,
    ControllerConfig,
    ManagerConfig,
    load_config_file,
    parse_controller_yaml,
)
from nodes.control.controller import ACTIVE
from nodes.control.interfaces import COMMAND_KINDS, HardwareInterfaces, JointInfo, SensorInfo
from nodes.control.manager import BEST_EFFORT, STRICT, ControllerManager, ManagerError
from nodes.core import Node, ServiceError, realtime
from nodes.core.delivery import Inline, Raw
from nodes.core.endpoints import SingleSender, source_label
from nodes.core.log import truncate

# A request names at most this many controllers, each at most MAX_NAME_CHARS long (a controller manager
# has a handful); the limits are checked before anything is looked up or logged per name.
MAX_SWITCH_CONTROLLERS = 256
MAX_NAME_CHARS = 256
MAX_REPLY_CHARS = 2000   # a status message quoted back to a caller
MAX_PARAMS_CHARS = 64 * 1024   # one controller's parameters as YAML
# A forward jump of sim time between two hardware states larger than this (the simulator's default
# command_timeout: it has started holding position) restarts the controllers (see _resync).
RESYNC_GAP_S = 0.5
# A control cycle running this long is stuck (the watchdog ends the process; the launcher respawns it).
STUCK_CYCLE_S = 5.0
# After an outage in realtime, frames that make sim time run this far ahead of the wall clock were buffered
# in the link (stale) and also restart the controllers; watched for this long after the hardware returns.
CATCH_UP_WATCH_S = 3.0
_pack_command = msgs.packer("zenroid_msgs/msg/HardwareCommand")
_make_command = maker(HardwareCommand)   # composed: our own values, stored without the setters' checks


class CyclePublisher:
    """A controller's publisher. What a controller publishes during a control cycle is sent after the cycle's
    hardware command, so the simulator never waits behind joint_states or controller state. Messages given
    as fields (``publish_fields``) are also packed only then, as ros2_controllers' RealtimePublisher leaves
    serialising to a non-realtime thread: packing joint_states cost the cycle ~18 µs before the command,
    the trajectory controller's state ~110 µs (measured in situ).

    Against realtime hardware a message is dropped rather than wait for a stalled subscriber, as
    ros2_controllers' RealtimePublisher skips one it cannot hand over at once; in lockstep every message is
    delivered (the simulation waits for the controllers anyway, and recordings must be complete)."""

    def __init__(self, publisher: Any, node: ControllerManagerNode) -> None:
        self._publisher = publisher
        self._node = node
        self.msg_type, self.key = publisher.msg_type, publisher.key

    def publish(self, msg: Any) -> None:
        self.publish_raw(msgs.encode(msg))

    def publish_raw(self, payload: bytes) -> None:
        self._send_or_hold(payload)

    def publish_fields(self, **fields: Any) -> None:
        """A message of this publisher's type from its fields (schema names; ROS defaults for the rest).

        In a control cycle the fields are packed after the hardware command is sent: pass values the
        controller will not change afterwards (fresh lists, as ``read_values`` and ``tolist`` return)."""
        self._send_or_hold(fields)

    def _send_or_hold(self, item: bytes | dict[str, Any]) -> None:
        deferred = self._node.deferred_publications
        if deferred is not None and threading.get_ident() == self._node.cycle_thread:
            deferred.append((self, item))
        else:
            self.send_deferred(item)

    def send_deferred(self, item: bytes | dict[str, Any]) -> None:
        """Send what ``publish_raw`` or ``publish_fields`` held back during a cycle."""
        payload = item if isinstance(item, bytes) else msgs.packer(self.msg_type._type)(**item)   # cached per type
        self._publisher.publish_raw(payload, droppable=self._node.realtime_hardware)

    @property
    def has_subscribers(self) -> bool:
        return self._publisher.has_subscribers


def send_held_back(held_back: Any, logger: Any) -> None:
    """Send a cycle's held-back publications (``CyclePublisher``), in order, once its command is out.
    Fields that do not pack lose that one message (logged), not the ones after it."""
    for publisher, item in held_back:
        try:
            publisher.send_deferred(item)
        except (TypeError, ValueError, OverflowError) as exc:
            logger.warn_throttle(1.0, f"{publisher.key}: dropped a controller's message that does not pack: {exc}",
                                 key=f"pack {publisher.key}")


class NodeControllerContext:
    """The handle a controller gets: endpoints on the manager's node, named after the controller."""

    def __init__(self, node: ControllerManagerNode, controller_name: str) -> None:
        self.node = node
        self.controller_name = controller_name
        self.logger = node.logger
        self._entities: list[Any] = []

    def _resolve(self, name: str) -> str:
        return f"{self.controller_name}/{name[2:]}" if name.startswith("~/") else name

    def _keep(self, entity: Any) -> Any:
        self._entities.append(entity)
        return entity

    def now(self) -> float:
        return self.node.control_time

    def create_publisher(self, msg_type: Any, topic: str) -> Any:
        publisher = self._keep(self.node.create_publisher(msg_type, self._resolve(topic)))
        return CyclePublisher(publisher, self.node)

    def create_subscription(self, msg_type: Any, topic: str, callback: Any) -> Any:
        # Inline: commands reach the controller without waiting for the executor (lowest latency);
        # controllers hand them to update() through an atomic assignment or a deque.
        return self._keep(self.node.create_subscription(msg_type, self._resolve(topic), callback,
                                                        delivery=Inline()))

    def create_service(self, srv_type: Any, name: str, handler: Any) -> Any:
        return self._keep(self.node.create_service(srv_type, self._resolve(name), handler))

    def create_action_server(self, action_type: Any, name: str, **callbacks: Any) -> Any:
        return self._keep(self.node.create_action_server(action_type, self._resolve(name), **callbacks))

    def destroy_all(self) -> None:
        for entity in reversed(self._entities):
            try:
                self.node.destroy_entity(entity)
            except Exception as exc:  # noqa: BLE001 - best effort; never stop the manager
                self.logger.warn(f"{self.controller_name}: could not close an endpoint: {exc}")
        self._entities.clear()


class ControllerManagerNode(Node):
    """ros2_control controller manager: controllers from YAML, run against the simulator's hardware."""

    default_name = "controller_manager"

    def __init__(self, *, cli_args: Any = None, **kwargs: Any) -> None:
        super().__init__("controller_manager", **kwargs)
        self._setup(cli_args)

    def _setup(self, cli_args: Any) -> None:
        self.update_rate = int(self.declare_parameter(
            "update_rate", 100.0, type=float, min_value=1.0, max_value=100_000.0,
            description="controller update rate (Hz); the simulator steps physics_rate/update_rate per command"))
        self.hardware_timeout = self.declare_parameter(
            "hardware_timeout", 1.0, type=float, min_value=0.01,
            description="wall s without hardware/state before the hardware is reported lost")
        self.autostart = self.declare_parameter(
            "activate", [], type=list, description="controllers to load, configure and activate on start")
        extra = self.declare_parameter("controllers_file", "", type=str, description="extra ros2_control YAML")
        self.thread_priority = int(self.declare_parameter(
            "thread_priority", 50, type=int, min_value=0, max_value=realtime.MAX_PRIORITY,
            read_only="applied to the process's threads when the hardware is found",
            description="SCHED_FIFO priority of the manager's threads against realtime hardware (the control "
                        "loop runs on Zenoh's), as ros2_control's thread_priority; 0: normal priority"))
        try:
            self.config = self._load_config(cli_args)
            if extra:
                self.config.merge(load_config_file(extra, self.name))
        except ConfigError as exc:
            raise ValueError(str(exc)) from None
        self.control_time = 0.0
        self.deferred_publications: list[tuple[Any, bytes | dict[str, Any]]] | None = None   # during a cycle
        self.realtime_hardware = True
        self.cycle_thread = 0
        self.manager: ControllerManager | None = None
        self.hardware: HardwareInterfaces | None = None
        self._last_time: float | None = None
        self._last_state_wall = 0.0
        self._lost = False
        self._paused_heartbeat = -1e9   # monotonic time of the last "paused" heartbeat
        self._paused = False            # reported: the simulator is paused (frames stopped, heartbeats come)
        self._catch_up: tuple[float, float] | None = None  # (wall, sim time) of the first frame after an outage
        self._cycles = 0
        self._cycle_us: collections.deque[float] = collections.deque(maxlen=20_000)
        self._bad_frames = 0
        self._cycle_since: float | None = None
        threading.Thread(target=self._discover, daemon=True, name="hardware-discovery").start()

    def _raise_priority(self, priority: int, mode: str) -> None:
        if priority <= 0:
            return
        if mode != "realtime":
            # Lockstep has no deadline to meet, and the manager is busy for as long as the physics runs: at
            # FIFO it would starve the processes that share its CPU (the launcher keeps one CPU for physics).
            self.logger.info(f"{mode} hardware: threads at normal priority (thread_priority is for realtime)")
            return
        problem = realtime.raise_process(priority)
        if problem is None:
            self.logger.info(f"threads at SCHED_FIFO priority {priority} (thread_priority)")
        else:   # as ros2_control: the loop still runs, with more jitter
            self.logger.warn(f"could not enable SCHED_FIFO priority {priority} (thread_priority): {problem}; "
                             "the control loop runs at normal priority (docs/controllers.md: Real-time priority)")

    def _load_config(self, cli_args: Any) -> ManagerConfig:
        config = ManagerConfig()
        for path in getattr(cli_args, "params_file", None) or []:
            try:
                config.merge(load_config_file(path, self.name))
            except ConfigError as exc:
                raise ValueError(str(exc)) from None
        if config.update_rate is not None and not self.has_parameter_override("update_rate"):
            self.update_rate = config.update_rate
        # Controller types given as node parameters (``--param jtc.type:=...``) count too.
        for key, value in self.parameter_overrides().items():
            if key.endswith(".type") and isinstance(value, str):
                config.controllers.setdefault(key[:-5], ControllerConfig(key[:-5])).type = value
        return config

    # --- start-up -----------------------------------------------------------------------------------
    def _discover(self) -> None:
        """Ask the simulator for the robot's joints until it answers (it may start after us)."""
        client = self.create_client(GetHardwareInfo, "hardware/info")
        attempt = 0
        while self.ok:
            try:
                info = client.call(timeout=1.0)
            except ServiceError as exc:
                if attempt % 10 == 0:
                    self.logger.info(f"waiting for the hardware at '{client.key}' ({exc})")
                attempt += 1
                time.sleep(0.3)
                continue
            self.call_soon(lambda found=info: self._start(found), where="hardware start")
            return

    def _start(self, info: Any) -> None:
        joints = []
        for j in info.joints:
            kinds = [k for k in j.command_interfaces if k in COMMAND_KINDS]
            joints.append(JointInfo(j.name, kinds, list(j.state_interfaces), j.min_position, j.max_position,
                                    j.max_velocity, j.max_effort))
        sensors = [SensorInfo(s.name, s.type, s.frame_id, list(s.state_interfaces)) for s in info.sensors]
        self.hardware = HardwareInterfaces(joints, sensors)
        self.realtime_hardware = info.mode == "realtime"
        self._raise_priority(self.thread_priority, info.mode)
        self.manager = ControllerManager(self.hardware, self.config, self.update_rate, self._make_context,
                                         self.logger)
        self.logger.info(f"hardware '{info.robot_name}' ({info.mode}, {len(joints)} joints, sensors "
                         f"{[s.name for s in sensors]}); "
                         f"update rate {self.update_rate} Hz; controllers in config: "
                         f"{sorted(self.config.controllers)}")
        # Reliable so that in lockstep a congested link delays a command instead of losing it (the
        # simulator would hold position and the run would no longer be repeatable); in realtime each
        # command is dropped rather than waited for, as the next one supersedes it.
        self._cmd_pub = self.create_publisher(HardwareCommand, "hardware/command", express=True)
        # frames from one simulator only: a second publisher on the key (a forged or replayed frame) is ignored
        self._state_sender = SingleSender(takeover_after=self.hardware_timeout)
        # the simulator says it is paused (no frames, but there): not a lost link
        self.create_subscription(HardwareHeartbeat, "hardware/heartbeat", self._on_heartbeat,
                                 delivery=Inline())
        self.create_subscription(HardwareState, "hardware/state", self._on_state,
                                 delivery=Inline(), message=Raw(objects=True, with_source=True))
        self.create_service(ListControllers, "~/list_controllers", self._srv_list)
        self.create_service(LoadController, "~/load_controller", self._srv_load)
        self.create_service(ConfigureController, "~/configure_controller", self._srv_configure)
        self.create_service(SwitchController, "~/switch_controller", self._srv_switch)
        self.create_service(UnloadController, "~/unload_controller", self._srv_unload)
        self.create_service(ListHardwareInterfaces, "~/list_hardware_interfaces", self._srv_interfaces)
        self.create_service(SetParameters, "~/set_controller_parameters", self._srv_set_controller_params)
        self.create_service(Trigger, "~/statistics", self._srv_statistics)
        self.create_timer(0.25, self._watchdog, sim_time=False)
        self._restore_controllers()
        for name in self.autostart:
            if name in self.manager.controllers:
                continue  # restored after a respawn
            try:
                self.manager.load(name)
                self.manager.configure(name)
                ok, message = self.manager.switch([name], [], STRICT)
                if not ok:
                    raise ManagerError(message)
            except ManagerError as exc:
                self.logger.error(f"could not start controller '{name}': {exc}")
        self._last_state_wall = time.monotonic()
        # Everything allocated so far lives as long as the process: keep it out of the garbage collector's
        # scans so a collection during a control cycle stays short.
        gc.collect()
        gc.freeze()
        # Zenoh delivers each subscription on its own Python thread; with the default 5 ms GIL switch
        # interval a trajectory could wait behind a busy thread for several control periods.
        sys.setswitchinterval(0.0005)
        self.logger.info("controller manager ready")

    def _restore_controllers(self) -> None:
        """After a respawn: the controllers the previous process had, in their states (nodes.control.restore)."""
        path = restore.state_file(self.fully_qualified_name)
        if path is None:
            return
        try:
            entries = restore.load(path)
        except ValueError as exc:
            self.logger.error(f"not restoring controllers: {exc}")
            entries = []
        if entries:
            active, problems = restore.restore(self.manager, entries)
            for problem in problems:
                self.logger.error(f"restoring controllers: {problem}")
            self.logger.warn(f"respawned: restored {len(entries)} controller(s) from {path.name}; active {active} "
                             "(holding the measured position)")
        self.manager.on_change = lambda: restore.save(path, self.manager)
        self.manager.on_change()

    def _make_context(self, name: str) -> NodeControllerContext:
        return NodeControllerContext(self, name)

    # --- hardware loop (Zenoh thread) -------------------------------------------------------------------
    def _on_state(self, payload: bytes | Any, source: bytes | None = None) -> None:
        started = time.perf_counter()
        if isinstance(payload, bytes):
            try:
                state = msgs.decode(HardwareState, payload)   # validated at the trust boundary
            except msgs.DecodeError as exc:   # a malformed frame is dropped, the loop lives on
                self._bad_frames += 1
                self.logger.warn_throttle(1.0, f"dropped a malformed hardware/state frame: {exc}")
                return
        else:
            state = payload   # a composed simulator's frame, built in this process
        if not self._state_sender.admit(source, time.monotonic()):
            self.logger.warn_throttle(
                1.0, f"hardware/state: ignored {self._state_sender.refused} frame(s) from "
                f"{source_label(source)}: this robot's frames come from {source_label(self._state_sender.owner)} "
                "(two publishers on hardware/state: a second simulator, a replay or a forgery)", key="foreign state")
            return
        step, names, positions = state.step, state.name, state.position
        velocities, efforts, sensor_values = state.velocity, state.effort, state.sensor_values
        t = msgs.time_to_sec(state.stamp)
        manager = self.manager
        self._cycle_since = time.monotonic()   # the watchdog's view of a cycle that never ends
        with manager.lock:
            self.hardware.read_state(names, positions, velocities, efforts, sensor_values)
            wall = time.monotonic()
            if self._paused:
                self._paused = False
                self.logger.info("hardware resumed (the simulator unpaused)")
            if self._lost:
                self._lost = False
                self.logger.info("hardware is back")
                # realtime: frames buffered in a link that was cut arrive late and in a burst; watch for it
                self._catch_up = (wall, t) if self.realtime_hardware else None
            if self._last_time is not None and not 0.0 <= t - self._last_time <= RESYNC_GAP_S:
                self._resync(t)
                self._catch_up = None
            elif self._catch_up is not None:
                wall0, t0 = self._catch_up
                if (t - t0) - (wall - wall0) > RESYNC_GAP_S:
                    # sim time ran ahead of the wall clock: these were stale frames of an outage during which
                    # the simulator held position (it got no commands), so the controllers must restart where
                    # the joints are, exactly as after a gap
                    self._resync(t, stale_s=(t - t0) - (wall - wall0))
                    self._catch_up = None
                elif wall - wall0 > CATCH_UP_WATCH_S:
                    self._catch_up = None  # frames at the wall clock's pace: a pause ended, nothing was missed
            self._last_time = t
            self.control_time = t
            self.cycle_thread = threading.get_ident()
            self.deferred_publications = []
            manager.tick(t)
            cmd_names, cmd_kinds, cmd_values = manager.command()
            self._last_state_wall = time.monotonic()
        self._cycle_since = None
        if self._cmd_pub.local_subscriptions:   # composed: the simulator takes the object itself
            self._cmd_pub.publish(_make_command(step=step, update_rate=self.update_rate, name=cmd_names,
                                                interface=cmd_kinds, value=cmd_values),
                                  droppable=self.realtime_hardware)
        else:
            self._cmd_pub.publish_raw(_pack_command(step=step, update_rate=self.update_rate, name=cmd_names,
                                                    interface=cmd_kinds, value=cmd_values),
                                      droppable=self.realtime_hardware)
        deferred, self.deferred_publications = self.deferred_publications, None
        send_held_back(deferred or (), self.logger)
        self._cycles += 1
        self._cycle_us.append((time.perf_counter() - started) * 1e6)

    def _resync(self, t: float, stale_s: float = 0.0) -> None:
        """Sim time jumped: restart the controllers so they hold the joints where they are measured now.

        Back in time: a reset or a new simulator (its old commands mean nothing). Forward by more than
        RESYNC_GAP_S: states were lost (a network partition, a stalled link) while the simulator held
        position; a trajectory controller would otherwise jump to where its old trajectory has got to, or
        replay points meant for the time it missed. New trajectories resume from the measured position."""
        if stale_s:
            self.logger.warn(f"hardware/state frames arrived {stale_s:.3f} s late after an outage (buffered in the "
                             "link): holding the measured position")
            reason = "hardware states late"
        elif t < self._last_time:
            self.logger.warn(f"sim time went back from {self._last_time:.3f} to {t:.3f} s (reset or a new "
                             "simulator)")
            reason = "hardware reset"
        else:
            self.logger.warn(f"missed {t - self._last_time:.3f} s of sim time (lost hardware/state frames): "
                             "holding the measured position")
            reason = "hardware states missed"
        self.manager.restart_active(reason)
        self.manager.reset_clock()

    def _watchdog(self) -> None:
        since = self._cycle_since
        if since is not None and time.monotonic() - since > STUCK_CYCLE_S:
            # A control cycle (normally well under a millisecond) that never ends - a controller's update
            # stuck, a lock never released - leaves the robot without commands while the node still answers
            # every service: end the process so the launcher respawns it (its controllers are restored).
            self.logger.fatal(f"a control cycle has not ended for {time.monotonic() - since:.1f} s (a controller "
                              "stuck in update?): exiting to be respawned")
            os._exit(1)
        now = time.monotonic()
        silent = now - self._last_state_wall
        if silent <= self.hardware_timeout:
            return
        if now - self._paused_heartbeat <= self.hardware_timeout:
            if not self._paused:
                self._paused = True
                self._lost = False
                self.logger.info("hardware paused: the simulator is paused (its heartbeat comes, no frames); "
                                 "controllers hold and resume with it")
        elif not self._lost:
            self._lost = True
            self._paused = False
            self.logger.error(f"lost the hardware: no hardware/state and no heartbeat for {silent:.1f} s (the "
                              "simulator is gone or the link is cut); controllers keep their state and resume "
                              "when it returns")

    def _on_heartbeat(self, msg: Any) -> None:
        if msg.paused:
            self._paused_heartbeat = time.monotonic()

    @property
    def hardware_status(self) -> str:
        """"ok", "paused" (the simulator says so) or "lost" (neither frames nor heartbeats)."""
        return "lost" if self._lost else "paused" if self._paused else "ok"

    # --- services (executor thread) ---------------------------------------------------------------------
    def _srv_list(self, _request: Any) -> Any:
        rows = self.manager.list_controllers()
        return ListControllers.Response(controller=[ControllerState(
            name=r["name"], state=r["state"], type=r["type"], claimed_interfaces=r["claimed_interfaces"],
            required_command_interfaces=r["required_command_interfaces"],
            required_state_interfaces=r["required_state_interfaces"]) for r in rows])

    def _attempt(self, what: str, name: str, fn: Any) -> bool:
        problem = _name_problem("name", name)
        if problem:
            self.logger.error(f"{what} refused: {problem}")
            return False
        try:
            fn(name)
            return True
        except ManagerError as exc:
            self.logger.error(f"{what}: {exc}")
            return False

    def _srv_load(self, request: Any) -> Any:
        return LoadController.Response(ok=self._attempt("load_controller", request.name, self.manager.load))

    def _srv_configure(self, request: Any) -> Any:
        return ConfigureController.Response(
            ok=self._attempt("configure_controller", request.name, self.manager.configure))

    def _srv_unload(self, request: Any) -> Any:
        return UnloadController.Response(ok=self._attempt("unload_controller", request.name, self.manager.unload))

    def _srv_switch(self, request: Any) -> Any:
        problem = _switch_request_problem(request)
        if problem:
            self.logger.error(f"switch_controller refused: {problem}")
            return SwitchController.Response(ok=False, message=problem)
        strictness = request.strictness
        if strictness == 0:   # unset: ros2_control defaults to BEST_EFFORT with a warning
            self.logger.warn("switch_controller: strictness not set (0): defaulting to BEST_EFFORT (1); "
                             "pass 1 (BEST_EFFORT) or 2 (STRICT)")
            strictness = BEST_EFFORT
        ok, message = self.manager.switch(list(request.activate_controllers), list(request.deactivate_controllers),
                                          strictness)
        message = truncate(message, MAX_REPLY_CHARS)
        if not ok:
            self.logger.error(f"switch_controller refused: {message}")
        return SwitchController.Response(ok=ok, message=message)

    def _srv_interfaces(self, _request: Any) -> Any:
        commands, states = self.manager.list_interfaces()
        return ListHardwareInterfaces.Response(
            command_interfaces=[HardwareInterfaceMsg(**c) for c in commands],
            state_interfaces=[HardwareInterfaceMsg(**s) for s in states])

    def _srv_set_controller_params(self, request: Any) -> Any:
        """names[i] = controller name, values_yaml[i] = its parameters (a YAML map, may include ``type``)."""
        if len(request.names) != len(request.values_yaml):
            raise ValueError(f"{len(request.names)} names but {len(request.values_yaml)} values_yaml")
        if len(request.names) > MAX_SWITCH_CONTROLLERS:
            raise ValueError(f"names: {len(request.names)} controllers, over the limit of {MAX_SWITCH_CONTROLLERS}")
        ok, reasons = [], []
        for i, (name, text) in enumerate(zip(request.names, request.values_yaml, strict=True)):
            problem = _name_problem(f"names[{i}]", name)
            if not problem and len(text) > MAX_PARAMS_CHARS:
                problem = f"values_yaml[{i}]: {len(text)} characters, over the {MAX_PARAMS_CHARS}-character limit"
            if problem:
                ok.append(False)
                reasons.append(problem)
                self.logger.error(f"set_controller_parameters refused: {problem}")
                continue
            try:
                self.manager.set_controller_params(name, parse_controller_yaml(text, f"parameters of '{name}'"))
                ok.append(True)
                reasons.append("")
            except (ConfigError, ManagerError) as exc:
                ok.append(False)
                reasons.append(truncate(str(exc), MAX_REPLY_CHARS))
                self.logger.error(f"set_controller_parameters refused: values_yaml[{i}]: {exc}")
        return SetParameters.Response(successful=ok, reasons=reasons)

    def _srv_statistics(self, _request: Any) -> Any:
        samples = sorted(self._cycle_us)

        def pct(q: float) -> float:
            return samples[min(len(samples) - 1, int(q * len(samples)))] if samples else 0.0

        return Trigger.Response(success=True, message=json.dumps({
            "hardware": self.hardware_status,
            "cycles": self._cycles, "bad_frames": self._bad_frames, "cycle_p50_us": pct(0.5),
            "cycle_p99_us": pct(0.99), "cycle_max_us": samples[-1] if samples else 0.0,
            "active": [r["name"] for r in self.manager.list_controllers() if r["state"] == ACTIVE],
        }))

    def on_process_exit(self) -> None:
        manager = self.manager
        if manager is None:
            return
        manager.on_change = None  # the saved set stays what was running: a respawn restores it
        active = [name for name, e in manager.controllers.items() if e.state == ACTIVE]
        if active:
            manager.switch([], active, BEST_EFFORT)  # ends running goals (aborted) before the session closes


def _name_problem(field: str, name: str) -> str:
    """Why ``name`` (a controller name in a request) is refused, or ""."""
    if len(name) > MAX_NAME_CHARS:
        return f"{field}: {len(name)} characters, over the {MAX_NAME_CHARS}-character limit for a controller name"
    return ""


def _switch_request_problem(request: Any) -> str:
    """Why a switch_controller request is refused before any controller is looked at, or ""."""
    if request.strictness not in (0, BEST_EFFORT, STRICT):
        return (f"strictness: {request.strictness} is not BEST_EFFORT ({BEST_EFFORT}) or STRICT ({STRICT})"
                + (" (AUTO and FORCE_AUTO are not supported)" if request.strictness in (3, 4) else ""))
    for field in ("activate_controllers", "deactivate_controllers"):
        names = getattr(request, field)
        if len(names) > MAX_SWITCH_CONTROLLERS:
            return f"{field}: {len(names)} names, over the limit of {MAX_SWITCH_CONTROLLERS} per request"
        for i, name in enumerate(names):
            problem = _name_problem(f"{field}[{i}]", name)
            if problem:
                return problem
    return ""
