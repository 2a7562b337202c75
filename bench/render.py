"""CPU rendering (nodes/render): the humanoid's camera, lidar and laser in the simple_lab world, the robot moving.

The scene is what the renderer gets from the simulator: simple_lab's models read with nodes.sim.sdf (no DART;
the ground plane as a 100 m x 100 m slab; static models in the static Embree scenes, the free boxes and the
ball in the dynamic ones) and the humanoid's 25 primitive links posed by our FK, a squat and an arm swing,
new every frame (so every frame rebuilds the dynamic scene of the layer it casts against). The sensors are
the humanoid URDF's own: the head RGB-D camera (320x240, also at 640x480), the 16x900 gpu_ray lidar (visual
shapes) and the 720-ray laser (ray: collision shapes).

Per sensor and thread count (1 and 2 interleaved, so that the machine's noise hits both alike), medians
over repeats of: ms a frame (update + rebuild + cast + image/scan making) wall and CPU, rays/s; the rebuild
alone; the cast alone (same poses: no rebuild). Two threads only help while the other core is idle: with
another job on it, wall time equals CPU time whatever the thread count. Then the payloads
(dicts + msgpack, as the renderer node publishes them), the cost of one core for the issue's defaults, how
fast a 640x480 rgb8 Image encodes (msgpack, CDR) against its size, and ways to make LaserScan's float lists.

    python bench/render.py [--frames 12] [--repeats 5]

Prints a table, then one JSON line (last). The machine is shared (2 cores here, other jobs running): the
table ends with the load average; CPU-time figures are what load skews least.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import msgs  # noqa: E402 - after the path set-up
from bench.common import print_table  # noqa: E402
from msgs import cdr  # noqa: E402
from nodes.kinematics import KinematicTree  # noqa: E402
from nodes.render import payloads  # noqa: E402
from nodes.render.camera import render_camera  # noqa: E402
from nodes.render.geometry import Shape  # noqa: E402
from nodes.render.lidar import render_ray  # noqa: E402
from nodes.render.raycast import RayScene  # noqa: E402
from nodes.sim.sdf import load_world  # noqa: E402
from nodes.urdf import load_robot_description, parse_urdf  # noqa: E402
from nodes.urdf.rendered_sensors import RenderedSensorSpec, parse_rendered_sensors  # noqa: E402
from nodes.urdf.xml_safety import parse_xml  # noqa: E402

GREY = (0.7, 0.7, 0.7, 1.0)        # a collision shape's colour (as sim/scene sends it)
SPAWN = (0.0, 0.0, 0.93)           # the humanoid's pelvis, standing
STAMP = {"sec": 1, "nanosec": 0}


def _primitive(kind: str, size: tuple[float, ...], pose: np.ndarray, rgba: tuple[float, ...], visual: bool,
               name: str) -> Shape | None:
    if kind not in ("box", "cylinder", "sphere"):
        return None
    return Shape(kind, tuple(size), pose, tuple(rgba), visual=visual, collision=not visual, name=name)


def world_scene() -> tuple[list[str], list[tuple[int, Shape]], set[int], list[np.ndarray]]:
    """simple_lab: link names, (link, shape) pairs, static link indices, the links' (fixed) world poses."""
    world = load_world("simple_lab.world")
    links, shapes, static, poses = [], [], set(), []
    if world.ground is not None:
        ground = np.eye(4)
        ground[2, 3] = -0.05
        static.add(len(links))
        links.append("ground_plane::link")
        poses.append(world.ground)
        for visual in (True, False):
            shapes.append((0, Shape("box", (100.0, 100.0, 0.1), ground, (0.8, 0.8, 0.8, 1.0), visual=visual,
                                    collision=not visual, name="ground_plane")))
    for model in world.models:
        for link in model.links:
            index = len(links)
            links.append(f"{model.name}::{link.name}")
            poses.append(model.pose @ link.pose)
            if model.static:
                static.add(index)
            for visual, specs in ((True, link.visuals), (False, link.collisions)):
                for spec in specs:
                    shape = _primitive(spec.kind, spec.size, spec.pose, spec.colour or GREY, visual, links[-1])
                    if shape is not None:
                        shapes.append((index, shape))
    return links, shapes, static, poses


def humanoid() -> tuple[KinematicTree, list[tuple[str, Shape]], list[RenderedSensorSpec]]:
    xml = load_robot_description(ROOT / "robots" / "humanoid.urdf")
    model = parse_urdf(xml)
    tree = KinematicTree(model)
    shapes = []
    for name in tree.link_names:
        link = model.links[name]
        for visual, specs in ((True, link.visuals), (False, link.collisions)):
            for s in specs:
                size = s.size if s.kind == "box" else (s.radius, s.length) if s.kind == "cylinder" else (s.radius,)
                shape = _primitive(s.kind, size, s.origin, getattr(s, "rgba", GREY) if visual else GREY, visual,
                                   f"humanoid::{name}")
                if shape is not None:
                    shapes.append((name, shape))
    sensors = parse_rendered_sensors(parse_xml(xml), "humanoid")
    return tree, shapes, sensors


class Bench:
    """The scene, the frames' poses and the sensors, ready to time."""

    def __init__(self, frames: int) -> None:
        links, shapes, static, world_poses = world_scene()
        self.tree, robot_shapes, sensors = humanoid()
        first = len(links)
        self.robot_links = {name: first + i for i, name in enumerate(self.tree.link_names)}
        links += [f"humanoid::{name}" for name in self.tree.link_names]
        shapes += [(self.robot_links[name], shape) for name, shape in robot_shapes]
        self.links, self.shapes, self.static = links, shapes, static
        base = np.eye(4)
        base[:3, 3] = SPAWN
        names = list(self.tree.dof_index)
        self.poses = []
        for i in range(frames):   # a squat and an arm swing: every link of the robot moves every frame
            q = np.zeros(self.tree.num_dofs)
            phase = 2 * math.pi * i / max(frames, 1)
            for name in names:
                if "knee" in name:
                    q[self.tree.dof_index[name]] = 0.4 + 0.3 * math.sin(phase)
                elif "hip_pitch" in name or "ankle_pitch" in name:
                    q[self.tree.dof_index[name]] = -0.2 - 0.15 * math.sin(phase)
                elif "shoulder_pitch" in name:
                    q[self.tree.dof_index[name]] = 0.5 * math.sin(phase + (0 if "left" in name else math.pi))
            robot = base @ self.tree.link_transforms(q)
            self.poses.append(np.concatenate([np.array(world_poses), robot]))
        self.sensors = {s.name: s for s in sensors}

    def scene(self, threads: int) -> RayScene:
        return RayScene(self.links, self.shapes, self.static, threads=threads)

    def sensor_pose(self, spec: RenderedSensorSpec, frame: int) -> np.ndarray:
        return self.poses[frame][self.robot_links[spec.reference]] @ spec.pose


def one_pass(run: Callable[[int], object], frames: int) -> tuple[float, float]:
    """(wall ms, CPU ms) a call of ``run(frame)``, over one pass of the frames."""
    wall, cpu = time.perf_counter(), time.process_time()
    for frame in range(frames):
        run(frame)
    return (time.perf_counter() - wall) / frames * 1e3, (time.process_time() - cpu) / frames * 1e3


def median_time(run: Callable[[int], object], frames: int, repeats: int) -> tuple[float, float]:
    """(wall ms, CPU ms) a call of ``run(frame)``, median over ``repeats`` passes over the frames."""
    samples = [one_pass(run, frames) for _ in range(repeats)]
    return statistics.median(s[0] for s in samples), statistics.median(s[1] for s in samples)


def draw(scene: RayScene, spec: RenderedSensorSpec, pose: np.ndarray, rng: np.random.Generator):
    if spec.camera is not None:
        return render_camera(scene, spec.camera, pose, rng)
    return render_ray(scene, spec.ray, pose, rng)


def publishable(spec: RenderedSensorSpec, picture) -> list[bytes]:
    """Every message the renderer node publishes for one frame of ``spec``, packed to msgpack."""
    image, info, cloud, scan = (msgs.packer(f"sensor_msgs/msg/{t}") for t in
                                ("Image", "CameraInfo", "PointCloud2", "LaserScan"))
    if spec.camera is not None:
        out = [image(**payloads.image(STAMP, "camera", picture.color, spec.camera.encoding)),
               info(**payloads.camera_info(STAMP, "camera", spec.camera))]
        if spec.camera.depth:
            out += [image(**payloads.image(STAMP, "camera", picture.depth, "32FC1")),
                    info(**payloads.camera_info(STAMP, "camera", spec.camera)),
                    cloud(**payloads.camera_points(STAMP, "camera", picture.points, picture.rgb))]
        return out
    if spec.ray.output == "scan":
        return [scan(**payloads.laser_scan(STAMP, "laser", spec.ray, picture.ranges, picture.intensities, 0.05))]
    return [cloud(**payloads.lidar_points(STAMP, "lidar", *picture.points()))]


def encoding_rates(repeats: int) -> dict[str, float]:
    """MB/s of a 640x480 rgb8 Image through msgpack and CDR, encode and decode, and of a plain copy."""
    data = np.random.default_rng(0).integers(0, 255, (480, 640, 3), dtype=np.uint8)
    payload = payloads.image(STAMP, "camera", data, "rgb8")
    size = len(payload["data"]) / 1e6
    packed = msgs.packer("sensor_msgs/msg/Image")(**payload)
    wire = cdr.encode("sensor_msgs/msg/Image", payload)
    image_type = msgs.get_type("sensor_msgs/msg/Image")
    cases = {
        "copy": lambda: bytearray(payload["data"]),
        "tobytes": lambda: data.tobytes(),
        "msgpack_encode": lambda: msgs.packer("sensor_msgs/msg/Image")(**payload),
        "msgpack_decode": lambda: msgs.decode(image_type, packed),
        "cdr_encode": lambda: cdr.encode("sensor_msgs/msg/Image", payload),
        "cdr_decode": lambda: cdr.decode("sensor_msgs/msg/Image", wire),
    }
    out = {}
    for name, fn in cases.items():
        samples = []
        for _ in range(repeats):
            start = time.perf_counter()
            for _ in range(20):
                fn()
            samples.append((time.perf_counter() - start) / 20)
        out[name] = size / statistics.median(samples)
    return out


def float_list_us(repeats: int) -> dict[str, float]:
    """us to turn 720 float32 ranges into the list of floats the codecs want."""
    ranges = np.random.default_rng(0).uniform(0.1, 10.0, 720).astype(np.float32)
    ranges[::7] = np.inf
    cases = {
        "tolist": lambda: ranges.tolist(),
        "astype_float64_tolist": lambda: ranges.astype(np.float64).tolist(),
        "list_map_float": lambda: list(map(float, ranges)),
        "comprehension": lambda: [float(x) for x in ranges],
    }
    out = {}
    for name, fn in cases.items():
        samples = []
        for _ in range(repeats):
            start = time.perf_counter()
            for _ in range(500):
                fn()
            samples.append((time.perf_counter() - start) / 500 * 1e6)
        out[name] = statistics.median(samples)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=12, help="distinct robot poses a pass renders")
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    load_before = os.getloadavg()[0]
    bench = Bench(args.frames)
    camera = bench.sensors["camera"]
    cases = {
        "camera 320x240 RGB-D": camera,
        "camera 640x480 RGB-D": dataclasses.replace(
            camera, camera=dataclasses.replace(camera.camera, width=640, height=480)),
        "lidar 16x900": bench.sensors["lidar"],
        "laser 720": bench.sensors["laser"],
    }
    probe = bench.scene(1)
    probe.update(bench.poses[0])
    rows, results = [], {}
    layers = {layer: probe.triangles(layer) for layer in ("visual", "collision")}
    for layer, (static, dynamic) in layers.items():
        rows.append((f"{layer} triangles: static, dynamic", f"{static}, {dynamic}",
                     "the dynamic ones are uploaded again every frame"))
    scenes = {threads: bench.scene(threads) for threads in (1, 2)}
    for label, spec in cases.items():
        rays = (spec.camera.width * spec.camera.height) if spec.camera else spec.ray.rays
        layer = "visual" if spec.camera is not None or spec.ray.visual else "collision"
        rng = np.random.default_rng(0)

        def frame(i: int, scene: RayScene, spec: RenderedSensorSpec = spec, rng=rng) -> None:
            scene.update(bench.poses[i])
            draw(scene, spec, bench.sensor_pose(spec, i), rng)

        def rebuild(i: int, scene: RayScene, layer: str = layer) -> None:
            scene.update(bench.poses[i])
            scene.prepare(layer)

        def cast_only(i: int, scene: RayScene, spec: RenderedSensorSpec = spec, rng=rng) -> None:
            draw(scene, spec, bench.sensor_pose(spec, 0), rng)

        samples: dict[tuple[int, str], list[tuple[float, float]]] = {}
        for scene in scenes.values():
            frame(0, scene)                               # warm: caches of ray directions, the static scenes
        for _ in range(args.repeats):   # 1 and 2 threads interleaved: the machine's noise hits both alike
            for threads, scene in scenes.items():
                for name, run in (("frame", frame), ("rebuild", rebuild)):
                    samples.setdefault((threads, name), []).append(
                        one_pass(lambda i, run=run, scene=scene: run(i, scene), args.frames))
                scene.update(bench.poses[0])
                samples.setdefault((threads, "cast"), []).append(
                    one_pass(lambda i, scene=scene: cast_only(i, scene), args.frames))
        for threads in scenes:
            wall, cpu, rebuild_ms, cast_ms = (statistics.median(s[k] for s in samples[(threads, name)])
                                              for name, k in (("frame", 0), ("frame", 1), ("rebuild", 0),
                                                              ("cast", 0)))
            key = f"{label}, {threads} thread{'s' if threads > 1 else ''}"
            results[key] = {"frame_ms": round(wall, 2), "frame_cpu_ms": round(cpu, 2),
                            "rays_per_s": round(rays / wall * 1e3), "rebuild_ms": round(rebuild_ms, 2),
                            "cast_only_ms": round(cast_ms, 2)}
            rows.append((f"{key}: ms a frame (CPU ms)", f"{wall:.1f} ({cpu:.1f})",
                         f"{rays / wall / 1e3:.2f} M rays/s; rebuild {rebuild_ms:.1f} ms, no-rebuild {cast_ms:.1f} ms"))
    for scene in scenes.values():
        scene.close()

    # the payloads, as the node makes and packs them (thread count does not matter)
    payload_ms = {}
    for label, spec in cases.items():
        probe.update(bench.poses[0])
        picture = draw(probe, spec, bench.sensor_pose(spec, 0), None)
        ms, _ = median_time(lambda _i, spec=spec, picture=picture: publishable(spec, picture), 4, args.repeats)
        size = sum(len(b) for b in publishable(spec, picture))
        payload_ms[label] = round(ms, 2)
        rows.append((f"{label}: payloads + msgpack", f"{ms:.2f} ms", f"{size / 1e6:.2f} MB a frame"))

    rates = {"camera 320x240 RGB-D": 30.0, "lidar 16x900": 10.0, "laser 720": 20.0}
    fraction = {}
    for threads in (1, 2):
        suffix = f", {threads} thread{'s' if threads > 1 else ''}"
        render_cpu = sum(rate * results[label + suffix]["frame_cpu_ms"] for label, rate in rates.items()) / 1e3
        packing = sum(rate * payload_ms[label] for label, rate in rates.items()) / 1e3
        fraction[threads] = {"render": round(render_cpu, 3), "with_payloads": round(render_cpu + packing, 3)}
        rows.append((f"issue defaults, fraction of one core{suffix}", f"{render_cpu + packing:.2f}",
                     f"render {render_cpu:.2f} + payloads {packing:.2f} (CPU time; each frame its own rebuild)"))

    codec = encoding_rates(args.repeats)
    for name, rate in codec.items():
        rows.append((f"640x480 rgb8 Image {name}", f"{rate:,.0f} MB/s", "0.92 MB of pixels"))
    lists = float_list_us(args.repeats)
    for name, us in lists.items():
        rows.append((f"LaserScan 720 floats: {name}", f"{us:.1f} us", ""))

    print(f"{len(bench.links)} links ({len(bench.static)} static), {len(bench.shapes)} shapes, "
          f"{args.frames} frames x {args.repeats} repeats, medians")
    print_table(rows, load_before)
    print(json.dumps({"sensors": results, "payload_ms": payload_ms, "core_fraction": fraction,
                      "image_codec_mb_per_s": {k: round(v) for k, v in codec.items()},
                      "laserscan_list_us": {k: round(v, 1) for k, v in lists.items()},
                      "triangles": layers, "load_average": round(load_before, 2), "cpus": os.cpu_count()}))


if __name__ == "__main__":
    main()
