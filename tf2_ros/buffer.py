"""``tf2_ros.Buffer``: transforms kept over time, looked up between any two frames of the tree.

As tf2: every transform is a ``geometry_msgs/TransformStamped`` from ``header.frame_id`` (parent) to
``child_frame_id``, kept ``cache_time`` seconds (static ones for ever); ``lookup_transform(target, source, time)``
is the pose of ``source`` in ``target`` at ``time`` (``Time()``: the latest time every link of the chain has),
interpolated between the stamps around it (linear translation, spherical rotation). What cannot be answered
raises the tf2 exception that says why.
"""

from __future__ import annotations

import bisect
import math
import threading
import time as _wall
from typing import Any

from geometry_msgs.msg import TransformStamped

from rclpy.duration import Duration
from rclpy.time import Time


class TransformException(Exception):
    """Any failed transform lookup."""


class LookupException(TransformException):
    """A frame is unknown."""


class ConnectivityException(TransformException):
    """Both frames are known but not in one tree."""


class ExtrapolationException(TransformException):
    """The time asked is outside the times the buffer holds for a link of the chain."""


class InvalidArgumentException(TransformException):
    """A transform or a frame name that cannot be used (empty frame, NaN, not a unit quaternion...)."""


class TimeoutException(TransformException):
    """The transform did not become available within the timeout."""


Pose = tuple[tuple[float, float, float], tuple[float, float, float, float]]   # (x, y, z), (x, y, z, w)


def _mul(a: tuple[float, ...], b: tuple[float, ...]) -> tuple[float, float, float, float]:
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz)


def _rotate(q: tuple[float, ...], v: tuple[float, ...]) -> tuple[float, float, float]:
    x, y, z, _ = _mul(_mul(q, (*v, 0.0)), (-q[0], -q[1], -q[2], q[3]))
    return (x, y, z)


def compose(a: Pose, b: Pose) -> Pose:
    """``a * b``: the pose ``b`` (given in frame of ``a``) in ``a``'s parent."""
    moved = _rotate(a[1], b[0])
    return ((a[0][0] + moved[0], a[0][1] + moved[1], a[0][2] + moved[2]), _mul(a[1], b[1]))


def inverse(a: Pose) -> Pose:
    conj = (-a[1][0], -a[1][1], -a[1][2], a[1][3])
    back = _rotate(conj, a[0])
    return ((-back[0], -back[1], -back[2]), conj)


def _interpolate(a: Pose, b: Pose, s: float) -> Pose:
    translation = tuple(x + (y - x) * s for x, y in zip(a[0], b[0]))
    qa, qb = a[1], b[1]
    dot = sum(x * y for x, y in zip(qa, qb))
    if dot < 0:
        qb, dot = tuple(-x for x in qb), -dot
    if dot > 0.9995:
        q = tuple(x + (y - x) * s for x, y in zip(qa, qb))
    else:
        theta = math.acos(dot)
        wa, wb = math.sin((1 - s) * theta) / math.sin(theta), math.sin(s * theta) / math.sin(theta)
        q = tuple(wa * x + wb * y for x, y in zip(qa, qb))
    norm = math.sqrt(sum(x * x for x in q))
    return translation, tuple(x / norm for x in q)   # type: ignore[return-value]


def _nanoseconds(stamp: Any) -> int:
    if isinstance(stamp, Time):
        return stamp.nanoseconds
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


class _Link:
    """One child frame's transforms to its parent: (stamp ns, parent, pose), sorted by stamp."""

    def __init__(self) -> None:
        self.stamps: list[int] = []
        self.entries: list[tuple[str, Pose]] = []
        self.static: tuple[str, Pose] | None = None

    def insert(self, stamp: int, parent: str, pose: Pose, keep_ns: int) -> None:
        i = bisect.bisect_left(self.stamps, stamp)
        if i < len(self.stamps) and self.stamps[i] == stamp:
            self.entries[i] = (parent, pose)
        else:
            self.stamps.insert(i, stamp)
            self.entries.insert(i, (parent, pose))
        cutoff = bisect.bisect_left(self.stamps, self.stamps[-1] - keep_ns)
        del self.stamps[:cutoff], self.entries[:cutoff]

    def parent(self) -> str:
        return self.static[0] if self.static is not None else self.entries[-1][0]

    def latest(self) -> int | None:
        return None if self.static is not None else self.stamps[-1]

    def at(self, stamp: int, child: str) -> Pose:
        if self.static is not None:
            return self.static[1]
        stamps = self.stamps
        if stamp > stamps[-1] or stamp < stamps[0]:
            raise ExtrapolationException(
                f"Lookup would require extrapolation {'into the future' if stamp > stamps[-1] else 'into the past'}."
                f" Requested time {stamp / 1e9:.6f} but the {'latest' if stamp > stamps[-1] else 'earliest'} data "
                f"is at time {(stamps[-1] if stamp > stamps[-1] else stamps[0]) / 1e9:.6f}, when looking up "
                f"transform from frame [{child}] to frame [{self.parent()}]")
        i = bisect.bisect_left(stamps, stamp)
        if stamps[i] == stamp:
            return self.entries[i][1]
        s = (stamp - stamps[i - 1]) / (stamps[i] - stamps[i - 1])
        return _interpolate(self.entries[i - 1][1], self.entries[i][1], s)


class Buffer:
    """tf2_ros.Buffer: ``set_transform``, ``lookup_transform``, ``can_transform`` (and their ``_full`` forms)."""

    def __init__(self, cache_time: Duration | None = None, node: Any = None) -> None:
        self.cache_time = cache_time if cache_time is not None else Duration(seconds=10)
        self._links: dict[str, _Link] = {}
        self._changed = threading.Condition()

    # -- filling
    def set_transform(self, transform: Any, authority: str) -> bool:
        return self._set(transform, authority, static=False)

    def set_transform_static(self, transform: Any, authority: str) -> bool:
        return self._set(transform, authority, static=True)

    def _set(self, transform: Any, authority: str, static: bool) -> bool:
        child, parent = transform.child_frame_id.strip("/"), transform.header.frame_id.strip("/")
        t, r = transform.transform.translation, transform.transform.rotation
        pose = ((t.x, t.y, t.z), (r.x, r.y, r.z, r.w))
        if not child or not parent or child == parent:
            raise InvalidArgumentException(f"transform from {authority}: frames '{parent}' -> '{child}' are not "
                                           "two non-empty, different names")
        if not all(math.isfinite(v) for v in (*pose[0], *pose[1])):
            raise InvalidArgumentException(f"transform {parent} -> {child} from {authority} has a non-finite value")
        norm = math.sqrt(sum(v * v for v in pose[1]))
        if abs(norm - 1.0) > 0.01:
            raise InvalidArgumentException(f"transform {parent} -> {child} from {authority}: quaternion "
                                           f"{pose[1]} is not normalized")
        pose = (pose[0], tuple(v / norm for v in pose[1]))   # type: ignore[assignment]
        with self._changed:
            link = self._links.setdefault(child, _Link())
            if static:
                link.static = (parent, pose)
            else:
                link.insert(_nanoseconds(transform.header.stamp), parent, pose, self.cache_time.nanoseconds)
            self._changed.notify_all()
        return True

    def clear(self) -> None:
        with self._changed:
            self._links.clear()

    def all_frames_as_string(self) -> str:
        with self._changed:
            return "".join(f"Frame {child} exists with parent {link.parent()}.\n"
                           for child, link in sorted(self._links.items()))

    # -- looking up
    def _chain(self, frame: str) -> list[str]:
        chain = [frame]
        while chain[-1] in self._links:
            chain.append(self._links[chain[-1]].parent())
            if len(chain) > 1000:
                raise ConnectivityException(f"the tree has a loop through frame {frame}")
        return chain

    def _lookup(self, target: str, source: str, stamp: int) -> tuple[Pose, int]:
        target, source = target.strip("/"), source.strip("/")
        frames = set(self._links) | {link.parent() for link in self._links.values()}
        for frame in (target, source):
            if frame not in frames:
                raise LookupException(f'"{frame}" passed to lookupTransform argument '
                                      f'{"target_frame" if frame == target else "source_frame"} does not exist. ')
        up_source, up_target = self._chain(source), self._chain(target)
        common = next((f for f in up_source if f in set(up_target)), None)
        if common is None:
            raise ConnectivityException(f"Could not find a connection between '{target}' and '{source}' because "
                                        "they are not part of the same tree. Tf has two or more unconnected trees.")
        links = up_source[:up_source.index(common)] + up_target[:up_target.index(common)]
        if stamp == 0:   # the latest time every link of the chain has (static links have them all)
            latest = [t for t in (self._links[f].latest() for f in links) if t is not None]
            stamp = min(latest) if latest else 0
        pose_in_common = {}
        for chain in (up_source, up_target):
            pose: Pose = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
            for frame in chain[:chain.index(common)]:
                pose = compose(self._links[frame].at(stamp, frame), pose)
            pose_in_common[chain[0]] = pose
        return compose(inverse(pose_in_common[target]), pose_in_common[source]), stamp

    def lookup_transform(self, target_frame: str, source_frame: str, time: Any,
                         timeout: Duration | None = None) -> Any:
        """The pose of ``source_frame`` in ``target_frame`` at ``time`` (``Time()``: the latest available)."""
        pose, stamp = self._wait(target_frame, source_frame, _nanoseconds(time), timeout)
        result = TransformStamped()
        result.header.frame_id, result.child_frame_id = target_frame, source_frame
        result.header.stamp.sec, result.header.stamp.nanosec = divmod(stamp, 1_000_000_000)
        t, r = result.transform.translation, result.transform.rotation
        (t.x, t.y, t.z), (r.x, r.y, r.z, r.w) = pose
        return result

    def lookup_transform_full(self, target_frame: str, target_time: Any, source_frame: str, source_time: Any,
                              fixed_frame: str, timeout: Duration | None = None) -> Any:
        """Through ``fixed_frame``: source at ``source_time`` into the fixed frame, then out to the target at
        ``target_time``."""
        source_in_fixed = self.lookup_transform(fixed_frame, source_frame, source_time, timeout)
        fixed_in_target = self.lookup_transform(target_frame, fixed_frame, target_time, timeout)
        pose = compose(_pose_of(fixed_in_target), _pose_of(source_in_fixed))
        result = TransformStamped()
        result.header.frame_id, result.child_frame_id = target_frame, source_frame
        result.header.stamp = fixed_in_target.header.stamp
        t, r = result.transform.translation, result.transform.rotation
        (t.x, t.y, t.z), (r.x, r.y, r.z, r.w) = pose
        return result

    def can_transform(self, target_frame: str, source_frame: str, time: Any, timeout: Duration | None = None,
                      return_debug_tuple: bool = False) -> Any:
        try:
            self._wait(target_frame, source_frame, _nanoseconds(time), timeout)
        except TransformException as error:
            return (False, str(error)) if return_debug_tuple else False
        return (True, "") if return_debug_tuple else True

    def can_transform_full(self, target_frame: str, target_time: Any, source_frame: str, source_time: Any,
                           fixed_frame: str, timeout: Duration | None = None, return_debug_tuple: bool = False) -> Any:
        try:
            self.lookup_transform_full(target_frame, target_time, source_frame, source_time, fixed_frame, timeout)
        except TransformException as error:
            return (False, str(error)) if return_debug_tuple else False
        return (True, "") if return_debug_tuple else True

    def _wait(self, target: str, source: str, stamp: int, timeout: Duration | None) -> tuple[Pose, int]:
        deadline = _wall.monotonic() + (timeout.nanoseconds / 1e9 if timeout is not None else 0.0)
        with self._changed:
            while True:
                try:
                    return self._lookup(target, source, stamp)
                except TransformException as error:
                    left = deadline - _wall.monotonic()
                    if left <= 0:
                        raise error from None
                    self._changed.wait(min(left, 0.05))


def _pose_of(transform: Any) -> Pose:
    t, r = transform.transform.translation, transform.transform.rotation
    return (t.x, t.y, t.z), (r.x, r.y, r.z, r.w)
