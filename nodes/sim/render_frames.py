"""The simulator's side of the rendered sensors (cameras, depth cameras, lidars, lasers): it publishes the
scene (``sim/scene``, latched, again on every spawn or delete) and, whenever one of those sensors is due, the
state it must show (``sim/render/frame``: sim time, step, every link's world transform, the sensors due). The
renderer (``nodes.render``, a process of its own on the spare core) draws them; the physics never waits for a
picture, except in lockstep.

Lockstep: every frame is rendered, in order, from its own state, so two runs give the same images bit for bit.
The simulator lets at most ``max_outstanding`` frames wait for the renderer's ``sim/render/done`` before it
steps on, so the renderer's queue stays bounded and a lockstep run goes as fast as the slower of the two.
Realtime: frames go out on time and the renderer draws the newest it has for each sensor (a slow renderer
drops frames, never the physics).

A frame goes out only for the sensors somebody watches: the renderer's answers (and its unprompted ones when
that changes) name the sensors with a subscriber, as gazebo_ros' camera plugins render only while subscribed.
A picture nobody reads costs neither the renderer nor the physics (a frame's link poses cost ~0.3 ms).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import msgs
from nodes.core import Node
from nodes.core.delivery import Pulled
from nodes.sim.outputs import next_due
from nodes.sim.scene import SceneLinks, build_scene
from nodes.sim.simulation import Simulation

Scene = msgs.get_type("zenroid_msgs/msg/Scene")
RenderFrame = msgs.get_type("zenroid_msgs/msg/RenderFrame")
RenderDone = msgs.get_type("zenroid_msgs/msg/RenderDone")
_pack_frame = msgs.packer("zenroid_msgs/msg/RenderFrame")
NO_RENDERER_WARNING_S = 10.0   # wall s with rendered sensors and no renderer before saying so
DONE_TIMEOUT_S = 5.0           # lockstep: wall s to wait for the renderer before stepping on without it


@dataclass
class _Scheduled:
    key: str                  # "model::sensor"
    period: float             # s of sim time
    next_due: float = 0.0


class RenderFrames:
    def __init__(self, node: Node, sim: Simulation, idle: Callable[[float], None], *, enabled: bool = True,
                 camera_pose=None, max_outstanding: int = 2) -> None:
        """``idle(max_wait)`` serves requests while lockstep waits for the renderer; ``enabled`` False (the
        simulator's ``sensors:=false``) sends no frames."""
        self.node, self.sim, self.idle = node, sim, idle
        self.enabled = enabled
        self.camera_pose = camera_pose
        self.max_outstanding = max_outstanding
        self.scene_pub = node.create_publisher(Scene, "/sim/scene", latched=True)
        self.frame_pub = node.create_publisher(RenderFrame, "/sim/render/frame")
        # the renderer's answers are pulled by the physics thread, the only one that reads or writes these two
        self._last_done = -1
        self._sent: list[int] = []          # steps of frames sent in lockstep and not yet done
        self._wanted: set[str] | None = None   # sensors the renderer draws for someone (None: not told yet)
        # pulled: the physics thread takes the renderer's answers itself when it looks at them; delivered on a
        # Zenoh thread, each of them (150 a second in lockstep) took the GIL from the physics thread
        self._done_sub = node.create_subscription(RenderDone, "/sim/render/done", self._on_done,
                                                  delivery=Pulled())
        self.version = 0
        self._scene_key: tuple = ()
        self.links = SceneLinks([], [])
        self.sensors: list[_Scheduled] = []
        self._since_no_renderer: float | None = None
        self._warned = False
        self._renderer_gone = False

    # -- the scene ----------------------------------------------------------------------------------------
    def refresh_scene(self) -> None:
        """Publish the scene again when the set of models changed (spawn, delete, a world loaded); raises
        SceneError (a mesh over the renderer's triangle cap) and publishes nothing then."""
        key = tuple((name, id(model)) for name, model in self.sim.entities.items()) + (
            self.sim.world.ground is not None,)
        if key == self._scene_key:
            return
        scene, links = build_scene(self.sim.world, self.sim.entities, self.version + 1, self.camera_pose)
        self._scene_key, self.version, self.links = key, self.version + 1, links
        self.scene_pub.publish(msgs.from_dict(Scene, scene))
        self._schedule()

    def _schedule(self) -> None:
        previous = {s.key: s for s in self.sensors}
        self.sensors = []
        if not self.enabled:
            return
        for name, model in self.sim.entities.items():
            info = getattr(model, "info", None)
            for spec in getattr(info, "rendered_sensors", []):
                if not spec.always_on:
                    continue
                key = f"{name}::{spec.name}"
                kept = previous.get(key)
                self.sensors.append(_Scheduled(key, 1.0 / spec.update_rate,
                                               kept.next_due if kept else self.sim.world.time))

    def restart_schedule(self) -> None:
        """After a reset of sim time: every sensor is due now."""
        for sensor in self.sensors:
            sensor.next_due = self.sim.world.time

    # -- frames -------------------------------------------------------------------------------------------
    def publish_due(self, step: int, t: float, lockstep: bool) -> None:
        """A frame for the sensors due at ``t`` (the state the hardware frames of this period carry)."""
        if not self.sensors:
            return
        due = [s for s in self.sensors if t + 1e-9 >= s.next_due]
        if not due:
            return
        for sensor in due:
            sensor.next_due = next_due(sensor.next_due, t, sensor.period)
        if not self.frame_pub.has_subscribers:
            self._no_renderer()
            return
        self._since_no_renderer = None
        self._done_sub.take_pending()
        wanted = self._wanted
        if wanted is not None:
            due = [s for s in due if s.key in wanted]
            if not due:
                return   # nobody subscribes to these pictures: no frame
        wait = lockstep and not self._renderer_gone
        if wait:
            self._wait_for_renderer()
        frame = _pack_frame(stamp=msgs.time_map(t), step=step, scene_version=self.version,
                            poses=self.links.poses(), sensors=[s.key for s in due], lockstep=wait)
        if wait:
            self._sent.append(step)
        self.frame_pub.publish_raw(frame)

    def _on_done(self, msg) -> None:   # the physics thread (pulled)
        self._last_done = max(self._last_done, int(msg.step))
        self._wanted = set(msg.wanted)
        self._sent = [s for s in self._sent if s > self._last_done]
        self._renderer_gone = False   # a renderer answers (again): lockstep waits for it

    def _wait_for_renderer(self) -> None:
        deadline = time.monotonic() + DONE_TIMEOUT_S
        while True:
            if len(self._sent) < self.max_outstanding:
                return
            if time.monotonic() > deadline:
                self.node.logger.warn(f"sim/render/done: the renderer answered no frame for {DONE_TIMEOUT_S:g} s; "
                                      "lockstep steps on without waiting for it")
                self._renderer_gone = True
                self._sent.clear()
                return
            # block (without the GIL) until the renderer answers, then serve what queued meanwhile
            self._done_sub.wait(0.002)
            self.idle(0.0)

    def _no_renderer(self) -> None:
        self._wanted = None   # the next renderer says what it draws
        now = time.monotonic()
        if self._since_no_renderer is None:
            self._since_no_renderer = now
        elif not self._warned and now - self._since_no_renderer > NO_RENDERER_WARNING_S:
            self._warned = True
            names = ", ".join(s.key for s in self.sensors)
            self.node.logger.warn(f"cameras and range sensors ({names}) but no renderer has subscribed to "
                                  "sim/render/frame for 10 s: start `python -m nodes.render` (launch files do unless "
                                  "sensors:=false)")
