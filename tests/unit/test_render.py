"""The CPU ray-casting library (nodes/render): cameras, depth, lasers and lidars against geometry whose answer is
known (a wall, a pillar), the visual/collision split, determinism, and the caps on what a scene may hold."""

from __future__ import annotations

import math

import numpy as np
import pytest

from nodes.render.camera import BACKGROUND, intrinsics, render_camera
from nodes.render.geometry import (
    MAX_MESH_TRIANGLES,
    MAX_SCENE_TRIANGLES,
    RenderError,
    Shape,
    mesh_from_bytes,
    rotate,
    triangle_count,
    triangulate,
)
from nodes.render.lidar import render_ray
from nodes.render.raycast import RayScene
from nodes.urdf.rendered_sensors import CameraSpec, RayAxis, RaySpec
from nodes.urdf.sensors import Noise

WALL_RGBA = (0.9, 0.6, 0.3, 1.0)
THICKNESS = 0.1
SKY = tuple(int(c * 255 + 0.5) for c in BACKGROUND)   # rounded half up, as the camera quantises


def pose(x: float = 0.0, y: float = 0.0, z: float = 0.0, yaw: float = 0.0, pitch: float = 0.0) -> np.ndarray:
    """Translation and Rz(yaw) Ry(pitch), as a 4x4."""
    cy, sy, cp, sp = math.cos(yaw), math.sin(yaw), math.cos(pitch), math.sin(pitch)
    out = np.eye(4)
    out[:3, :3] = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]]) @ np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    out[:3, 3] = (x, y, z)
    return out


def wall_scene(x: float = 2.0, *, visual: bool = True, collision: bool = True, static: bool = False,
               threads: int = 1) -> RayScene:
    """A 4 m x 4 m wall whose near face is at x - THICKNESS / 2, facing a sensor at the origin."""
    wall = Shape("box", (THICKNESS, 4.0, 4.0), np.eye(4), WALL_RGBA, visual=visual, collision=collision, name="wall")
    scene = RayScene(["wall"], [(0, wall)], {0} if static else set(), threads=threads)
    scene.update(pose(x)[None])
    return scene


def centre(spec: CameraSpec) -> tuple[int, int]:
    """The pixel (row, column) nearest the principal point."""
    _, cx, cy = intrinsics(spec)
    return int(round(cy)), int(round(cx))


# ------------------------------------------------------------------------------------------------ camera
def test_a_wall_ahead_has_its_depth_and_its_hue() -> None:
    spec = CameraSpec(width=64, height=48, depth=True)
    picture = render_camera(wall_scene(), spec, np.eye(4))
    v, u = centre(spec)
    assert picture.depth[v, u] == pytest.approx(2.0 - THICKNESS / 2, abs=0.01)
    r, g, b = picture.color[v, u].astype(float)
    assert g / r == pytest.approx(WALL_RGBA[1] / WALL_RGBA[0], rel=0.03)
    assert b / r == pytest.approx(WALL_RGBA[2] / WALL_RGBA[0], rel=0.03)
    assert 0.6 * 255 * WALL_RGBA[0] - 1 <= r <= 255 * WALL_RGBA[0] + 1   # lit between 0.6x and 1.0x
    assert picture.color.shape == (48, 64, 3) and picture.color.dtype == np.uint8
    assert picture.depth.dtype == np.float32 and picture.points.dtype == np.float32
    assert np.isfinite(picture.depth).all()   # the wall fills the view


def test_moving_the_wall_one_metre_moves_the_depth_one_metre() -> None:
    spec = CameraSpec(width=32, height=24, depth=True)
    scene = wall_scene()
    v, u = centre(spec)
    before = render_camera(scene, spec, np.eye(4)).depth[v, u]
    scene.update(pose(3.0)[None])
    after = render_camera(scene, spec, np.eye(4)).depth[v, u]
    assert after - before == pytest.approx(1.0, abs=0.02)


def test_a_static_link_that_moves_is_rebuilt() -> None:
    spec = CameraSpec(width=16, height=12, depth=True)
    scene = wall_scene(static=True)
    v, u = centre(spec)
    before = render_camera(scene, spec, np.eye(4)).depth[v, u]
    scene.update(pose(2.5)[None])
    assert render_camera(scene, spec, np.eye(4)).depth[v, u] - before == pytest.approx(0.5, abs=0.01)


def test_nothing_in_view_is_inf_depth_and_the_background() -> None:
    spec = CameraSpec(width=32, height=24, depth=True)
    picture = render_camera(wall_scene(), spec, pose(yaw=math.pi))   # looking away from the wall
    assert np.all(picture.depth == np.inf)
    assert np.all(picture.color == SKY)
    assert np.isnan(picture.points).all()


def test_too_near_is_minus_inf_and_beyond_far_is_plus_inf() -> None:
    spec = CameraSpec(width=16, height=12, depth=True, near=0.5, far=10.0)
    near = render_camera(wall_scene(0.3), spec, np.eye(4))
    assert np.all(near.depth == -np.inf) and np.all(near.color == SKY) and np.isnan(near.points).all()
    far = render_camera(wall_scene(12.0), spec, np.eye(4))
    assert np.all(far.depth == np.inf) and np.all(far.color == SKY)


def test_camera_info_intrinsics_back_project_the_depth_to_the_wall() -> None:
    spec = CameraSpec(horizontal_fov=1.2, width=80, height=60, depth=True)
    f, cx, cy = intrinsics(spec)
    assert f == pytest.approx(80 / (2 * math.tan(0.6)))
    assert (cx, cy) == (40.5, 30.5)
    picture = render_camera(wall_scene(), spec, np.eye(4))
    for v, u in [(30, 40), (5, 7), (55, 70)]:
        z = picture.depth[v, u]
        point = np.array([(u - cx) / f * z, (v - cy) / f * z, z])
        np.testing.assert_allclose(picture.points[v, u], point, atol=1e-4)
        # optical (x right, y down, z forward) -> the wall's face at sensor x = 1.95
        assert z == pytest.approx(2.0 - THICKNESS / 2, abs=1e-3)


def test_mono8_and_bgr8_orders() -> None:
    scene = wall_scene()
    rgb = render_camera(scene, CameraSpec(width=16, height=12), np.eye(4))
    bgr = render_camera(scene, CameraSpec(width=16, height=12, encoding="bgr8"), np.eye(4))
    mono = render_camera(scene, CameraSpec(width=16, height=12, encoding="mono8"), np.eye(4))
    assert np.array_equal(bgr.color, rgb.color[..., ::-1])
    assert np.array_equal(bgr.rgb, rgb.color)
    assert mono.color.shape == (12, 16) and mono.color.dtype == np.uint8
    luminance = rgb.color.astype(float) @ [0.299, 0.587, 0.114]
    assert np.abs(mono.color - luminance).max() <= 1.0
    assert mono.rgb.shape == (12, 16, 3)


def test_a_rotated_camera_sees_a_pillar_where_geometry_says() -> None:
    pillar = Shape("box", (0.05, 0.05, 0.05), np.eye(4), (0.2, 0.8, 0.2, 1.0), name="pillar")
    scene = RayScene(["pillar"], [(0, pillar)])
    spec = CameraSpec(horizontal_fov=1.0, width=200, height=150, depth=True)
    f, cx, cy = intrinsics(spec)
    yaw = 0.2   # the camera turns left: the pillar straight ahead of the origin appears right of centre
    scene.update(pose(2.0)[None])
    seen = np.argwhere(np.isfinite(render_camera(scene, spec, pose(yaw=yaw)).depth))
    assert len(seen)
    assert seen[:, 1].mean() == pytest.approx(cx + f * math.tan(yaw), abs=1.0)
    assert seen[:, 0].mean() == pytest.approx(cy, abs=1.0)
    scene.update(pose(2.0, z=0.3)[None])   # above the optical axis: a smaller row (y down)
    seen = np.argwhere(np.isfinite(render_camera(scene, spec, np.eye(4)).depth))
    assert seen[:, 0].mean() == pytest.approx(cy - f * 0.3 / 2.0, abs=1.0)
    assert seen[:, 1].mean() == pytest.approx(cx, abs=1.0)


# ------------------------------------------------------------------------------------------------ rays
LASER = RaySpec(horizontal=RayAxis(720, 1.0, -math.pi / 2, math.pi / 2), range_min=0.1, range_max=30.0,
                range_resolution=0.01, output="scan")


def test_a_laser_measures_the_wall_ahead() -> None:
    scan = render_ray(wall_scene(), LASER, np.eye(4))
    assert scan.ranges.shape == (1, 720) and scan.ranges.dtype == np.float32
    ahead = int(np.argmin(np.abs(LASER.horizontal.angles())))
    assert scan.ranges[0, ahead] == pytest.approx(2.0 - THICKNESS / 2, abs=LASER.range_resolution)
    assert 0.0 < scan.intensities[0, ahead] <= 1.0
    angles = LASER.horizontal.angles()
    hit = np.isfinite(scan.ranges[0])
    # the wall is 4 m wide: beams beyond atan(2 / 1.95) miss it
    assert np.all(np.abs(angles[hit]) < math.atan2(2.0, 1.95) + 0.01)
    assert np.all(scan.intensities[0, ~hit] == 0.0)
    # counter-clockwise: a beam at +yaw goes to +y
    xyz, _, _ = scan.points()
    assert np.all(np.sign(xyz[:, 1]) == np.sign(angles[hit]))


def test_beyond_range_max_is_inf_and_nearer_than_range_min_minus_inf() -> None:
    short = RaySpec(horizontal=RayAxis(90, 1.0, -0.3, 0.3), range_min=0.1, range_max=1.0)
    assert np.all(render_ray(wall_scene(), short, np.eye(4)).ranges == np.inf)
    assert np.all(render_ray(wall_scene(0.1), short, np.eye(4)).ranges == -np.inf)
    scan = render_ray(wall_scene(0.1), short, np.eye(4))
    assert len(scan.points()[0]) == 0


def test_a_lidar_puts_its_points_on_the_wall_rings_from_the_bottom() -> None:
    spec = RaySpec(horizontal=RayAxis(300, 1.0, -0.6, 0.6), vertical=RayAxis(16, 1.0, -0.26, 0.26),
                   range_max=30.0, range_resolution=0.0)
    scan = render_ray(wall_scene(), spec, np.eye(4))
    assert scan.ranges.shape == (16, 300)
    xyz, intensity, ring = scan.points()
    assert xyz.dtype == np.float32 and ring.dtype == np.uint16 and intensity.shape == ring.shape
    np.testing.assert_allclose(xyz[:, 0], 1.95, atol=0.01)
    assert sorted(set(ring.tolist())) == list(range(16))
    assert np.all(np.diff(ring.astype(int)) >= 0)             # ring-major
    heights = [xyz[ring == r, 2].mean() for r in range(16)]
    assert np.all(np.diff(heights) > 0)                       # ring 0 lowest
    elevation = np.arctan2(xyz[:, 2], np.hypot(xyz[:, 0], xyz[:, 1]))   # each ring at its vertical angle
    np.testing.assert_allclose(elevation, spec.vertical.angles()[ring], atol=1e-4)


def test_ray_noise_then_resolution() -> None:
    spec = RaySpec(horizontal=RayAxis(100, 1.0, -0.2, 0.2), range_resolution=0.05,
                   noise=Noise(type="gaussian", stddev=0.02))
    scan = render_ray(wall_scene(), spec, np.eye(4), np.random.default_rng(1))
    steps = scan.ranges[0] / 0.05
    np.testing.assert_allclose(steps, np.round(steps), atol=1e-3)
    assert len(set(scan.ranges[0].tolist())) > 1


def test_a_ray_sensor_sees_collisions_and_a_gpu_ray_visuals() -> None:
    laser = RaySpec(horizontal=RayAxis(10, 1.0, -0.1, 0.1))
    visual_only = wall_scene(collision=False)
    assert np.all(render_ray(visual_only, laser, np.eye(4)).ranges == np.inf)
    gpu = RaySpec(horizontal=RayAxis(10, 1.0, -0.1, 0.1), visual=True)
    assert np.isfinite(render_ray(visual_only, gpu, np.eye(4)).ranges).all()
    collision_only = wall_scene(visual=False)
    assert np.all(render_camera(collision_only, CameraSpec(width=8, height=6, depth=True), np.eye(4)).depth == np.inf)
    assert np.isfinite(render_ray(collision_only, laser, np.eye(4)).ranges).all()


def test_nearest_of_static_and_dynamic_and_normals_face_the_ray() -> None:
    far_wall = Shape("box", (0.1, 4, 4), pose(4.0), (1, 1, 1, 1), name="far")
    ball = Shape("sphere", (0.25,), np.eye(4), (1, 0, 0, 1), name="ball")
    scene = RayScene(["room", "ball"], [(0, far_wall), (1, ball)], {0})
    scene.update(np.stack([np.eye(4), pose(2.0)]))
    directions = np.array([[1.0, 0, 0], [0.0, 1.0, 0], [math.cos(0.3), math.sin(0.3), 0]])
    hits = scene.cast(np.zeros((3, 3)), directions)
    assert hits.shape.tolist() == [1, -1, 0]
    assert hits.distance[0] == pytest.approx(1.75, abs=0.002)         # the ball, in front of the wall
    assert hits.distance[1] == np.inf
    assert hits.distance[2] == pytest.approx(3.95 / math.cos(0.3), abs=1e-3)
    np.testing.assert_allclose(np.linalg.norm(hits.normal[[0, 2]], axis=1), 1.0, atol=1e-5)
    assert np.all(np.einsum("ij,ij->i", hits.normal, directions) <= 0)
    scene.update(np.stack([np.eye(4), pose(6.0)]))                     # the ball behind the wall
    assert scene.cast(np.zeros((1, 3)), directions[:1]).shape.tolist() == [0]


def test_a_sensor_inside_its_housing_sees_out() -> None:
    """Back faces are culled: a camera at the centre of its box visual, a lidar inside its collision
    cylinder (both common in URDFs) see the wall, not their housing from inside."""
    wall = Shape("box", (THICKNESS, 4.0, 4.0), pose(2.0), WALL_RGBA, name="wall")
    box = Shape("box", (0.05, 0.05, 0.05), np.eye(4), (0.1, 0.1, 0.1, 1.0), name="camera_link::visual")
    can = Shape("cylinder", (0.05, 0.07), np.eye(4), (0.1, 0.1, 0.1, 1.0), name="lidar_link::collision")
    shell = Shape("sphere", (0.5,), np.eye(4), (0.5, 0.5, 0.5, 1.0), name="dome")   # two back faces deep
    scene = RayScene(["room", "sensor"], [(0, wall), (1, box), (1, can), (0, shell)], {0})
    scene.update(np.stack([np.eye(4), np.eye(4)]))
    spec = CameraSpec(width=32, height=24, depth=True, near=0.01)
    picture = render_camera(scene, spec, np.eye(4))
    v, u = centre(spec)
    assert picture.depth[v, u] == pytest.approx(1.95, abs=0.01)
    assert picture.color[v, u, 0] > picture.color[v, u, 2]    # the wall's orange, not the housing's grey
    lidar = RaySpec(horizontal=RayAxis(20, 1.0, -0.2, 0.2), vertical=RayAxis(3, 1.0, -0.1, 0.1), range_min=0.01)
    ranges = render_ray(scene, lidar, np.eye(4)).ranges
    assert np.all(ranges > 1.9) and np.all(np.isfinite(ranges))
    hits = scene.cast(np.zeros((1, 3)), np.array([[1.0, 0, 0]]), cull_back_faces=False)
    assert hits.distance[0] == pytest.approx(0.025, abs=1e-4) and hits.shape[0] == 1   # the box, from inside


def test_every_primitive_is_within_its_tolerance() -> None:
    """Balanced facets: vertices just outside the true surface, face planes just inside, both within the
    tolerance (cylinders 1 mm, spheres 2 mm and 1 % of the radius)."""
    for kind, radius in [("sphere", 0.03), ("sphere", 0.1), ("sphere", 0.6), ("cylinder", 0.03),
                         ("cylinder", 0.1), ("cylinder", 0.8)]:
        shape = Shape(kind, (radius,) if kind == "sphere" else (radius, 1.0))
        vertices, triangles = triangulate(shape)
        assert len(triangles) == triangle_count(shape)
        corners = vertices[triangles].astype(np.float64)
        normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
        normals /= np.linalg.norm(normals, axis=1)[:, None]
        if kind == "cylinder":   # the sides only, distances from the axis
            side = np.abs(normals[:, 2]) < 1e-6
            corners, normals = corners[side][..., :2], normals[side][:, :2]
        planes = np.abs(np.einsum("ij,ij->i", normals, corners[:, 0]))
        outermost = np.linalg.norm(corners, axis=-1).max()
        tolerance = 0.001 if kind == "cylinder" else min(0.002, 0.01 * radius) if radius > 0.2 else 0.01 * radius
        assert radius - tolerance <= planes.min() < radius < outermost <= radius + tolerance, (kind, radius)
    vertices, triangles = triangulate(Shape("box", (1, 2, 3)))
    assert len(triangles) == 12 and np.allclose(vertices.max(axis=0), [0.5, 1.0, 1.5])


# ------------------------------------------------------------------------------------------------ determinism
NOISY = CameraSpec(width=48, height=36, depth=True, noise=Noise(type="gaussian", mean=0.0, stddev=0.05))


def test_same_seed_same_bytes_other_seed_other_bytes() -> None:
    scene = wall_scene()
    one = render_camera(scene, NOISY, pose(yaw=0.3), np.random.default_rng(5))
    two = render_camera(scene, NOISY, pose(yaw=0.3), np.random.default_rng(5))
    other = render_camera(scene, NOISY, pose(yaw=0.3), np.random.default_rng(6))
    assert one.color.tobytes() == two.color.tobytes()
    assert one.depth.tobytes() == two.depth.tobytes() and one.points.tobytes() == two.points.tobytes()
    assert one.color.tobytes() != other.color.tobytes()
    ideal = render_camera(scene, NOISY, pose(yaw=0.3), None)
    assert ideal.color.tobytes() != one.color.tobytes()
    spec = RaySpec(horizontal=RayAxis(200, 1.0, -1.0, 1.0), range_resolution=0.0,
                   noise=Noise(type="gaussian", stddev=0.01))
    a, b, c = (render_ray(scene, spec, np.eye(4), np.random.default_rng(s)).ranges for s in (1, 1, 2))
    assert a.tobytes() == b.tobytes() and a.tobytes() != c.tobytes()


def test_threads_give_the_same_bytes_as_one() -> None:
    spec = CameraSpec(width=160, height=120, depth=True)
    objects = [Shape("sphere", (0.3,), pose(2.0, 0.3 * i - 0.6, 0.2 * i - 0.4), (0.2 * i, 0.5, 0.3, 1), name=f"s{i}")
               for i in range(5)]
    pictures = []
    for threads in (1, 2):
        scene = RayScene(["things"], [(0, s) for s in objects], threads=threads)
        scene.update(np.eye(4)[None])
        with scene:
            pictures.append(render_camera(scene, spec, pose(yaw=0.05)))
    assert pictures[0].color.tobytes() == pictures[1].color.tobytes()
    assert pictures[0].depth.tobytes() == pictures[1].depth.tobytes()


# ------------------------------------------------------------------------------------------------ refusals
def test_caps_refuse_before_building() -> None:
    faces = np.zeros((MAX_MESH_TRIANGLES + 1, 3), dtype=np.uint32)
    big = Shape("mesh", vertices=np.zeros((3, 3), np.float32), triangles=faces, name="statue::visual")
    with pytest.raises(RenderError, match=r"statue::visual.*over the cap of 200000 per mesh"):
        RayScene(["statue"], [(0, big)])
    each = np.zeros((MAX_MESH_TRIANGLES, 3), dtype=np.uint32)    # one array shared by every shape
    many = [(0, Shape("mesh", vertices=np.zeros((3, 3), np.float32), triangles=each, name=f"m{i}"))
            for i in range(MAX_SCENE_TRIANGLES // MAX_MESH_TRIANGLES + 1)]
    with pytest.raises(RenderError, match=r"over 2000000 triangles"):
        RayScene(["crowd"], many)


def test_bad_shapes_and_poses_are_refused() -> None:
    with pytest.raises(RenderError, match=r"box shape 'flat'.*positive"):
        RayScene(["a"], [(0, Shape("box", (1.0, 0.0, 1.0), name="flat"))])
    with pytest.raises(RenderError, match=r"cone"):
        RayScene(["a"], [(0, Shape("cone", (1.0,)))])
    with pytest.raises(RenderError, match=r"link index 3"):
        RayScene(["a"], [(3, Shape("sphere", (1.0,)))])
    scene = RayScene(["a"], [(0, Shape("sphere", (1.0,)))])
    with pytest.raises(RenderError, match=r"before the first update"):
        scene.cast(np.zeros((1, 3)), np.array([[1.0, 0, 0]]))
    with pytest.raises(RenderError, match=r"\(1, 4, 4\)"):
        scene.update(np.zeros((2, 4, 4)))
    with pytest.raises(RenderError, match=r"not finite: a"):
        scene.update(np.full((1, 4, 4), np.nan))


def test_mesh_bytes_are_checked() -> None:
    vertices = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], dtype="<f4")
    triangles = np.array([[0, 1, 2]], dtype="<u4")
    v, f = mesh_from_bytes(vertices.tobytes(), triangles.tobytes())
    assert v.shape == (3, 3) and f.tolist() == [[0, 1, 2]]
    with pytest.raises(RenderError, match=r"vertices are 35 bytes, not a whole number"):
        mesh_from_bytes(vertices.tobytes()[:-1], triangles.tobytes())
    with pytest.raises(RenderError, match=r"triangles are 8 bytes"):
        mesh_from_bytes(vertices.tobytes(), triangles.tobytes()[:8])
    with pytest.raises(RenderError, match=r"index \(3\) is out of range of the 3 vertices"):
        mesh_from_bytes(vertices.tobytes(), np.array([[0, 1, 3]], dtype="<u4").tobytes())
    bad = vertices.copy()
    bad[1, 2] = np.nan
    with pytest.raises(RenderError, match=r"not finite"):
        mesh_from_bytes(bad.tobytes(), triangles.tobytes())
    with pytest.raises(RenderError, match=r"200001 triangles, over the cap"):
        mesh_from_bytes(vertices.tobytes(), bytes(12 * (MAX_MESH_TRIANGLES + 1)))
    with pytest.raises(RenderError, match=r"600001 vertices, over the cap"):
        mesh_from_bytes(bytes(12 * (3 * MAX_MESH_TRIANGLES + 1)), triangles.tobytes())
    # a mesh shape renders: the triangle in the plane x = 1 (rotated into it), seen by a laser
    turn = np.eye(4)
    turn[:3, :3] = [[0, 0, 1], [1, 0, 0], [0, 1, 0]]      # local x -> world y, y -> z, z -> x
    turn[:3, 3] = (1.0, -0.2, -0.2)
    facing = Shape("mesh", pose=turn, vertices=v, triangles=f[:, ::-1].copy(), name="tri")   # normal -x
    away = Shape("mesh", pose=turn, vertices=v, triangles=f, name="tri")                       # normal +x
    for shape, seen in ((facing, True), (away, False)):   # a one-sided mesh is seen from its front only
        scene = RayScene(["m"], [(0, shape)])
        scene.update(np.eye(4)[None])
        hits = scene.cast(np.zeros((1, 3)), np.array([[1.0, 0, 0]]))
        assert (hits.distance[0] == pytest.approx(1.0, abs=1e-5) and hits.shape[0] == 0) if seen else \
            (hits.distance[0] == np.inf and hits.shape[0] == -1)


# ------------------------------------------------------------------------------------------------ culling
def test_moving_links_out_of_view_are_left_out_and_the_pictures_do_not_change() -> None:
    """A camera, a lidar and a laser among 40 moving boxes around them: each cast leaves out the boxes its
    field of view cannot reach, and every image, depth and range is bit-identical to an uncut cast's."""
    rng = np.random.default_rng(7)
    boxes = [Shape("box", tuple(rng.uniform(0.1, 0.6, 3)), np.eye(4), tuple(rng.uniform(0.2, 1.0, 3)) + (1.0,),
                   name=f"box{i}") for i in range(40)]
    poses = np.array([pose(*rng.uniform(-4, 4, 3), yaw=rng.uniform(-3, 3)) for _ in boxes])
    camera = CameraSpec(horizontal_fov=1.2, width=80, height=60, near=0.05, far=20.0, depth=True)
    lidar = RaySpec(horizontal=RayAxis(180, 1.0, -math.pi, math.pi), vertical=RayAxis(8, 1.0, -0.26, 0.26),
                    range_min=0.1, range_max=30.0, visual=True)
    laser = RaySpec(horizontal=RayAxis(90, 1.0, -1.5, 1.5), range_min=0.1, range_max=5.0)
    for trial in range(5):
        sensor = pose(*rng.uniform(-1, 1, 3), yaw=rng.uniform(-3, 3), pitch=rng.uniform(-0.5, 0.5))
        cut = RayScene([b.name for b in boxes], list(enumerate(boxes)), threads=1)
        whole = RayScene([b.name for b in boxes], list(enumerate(boxes)), threads=1)
        cut.update(poses)
        whole.update(poses)
        picture = render_camera(cut, camera, sensor)
        kept = cut.dynamic_triangles_cast("visual")

        def uncut(*args, view=None, _cast=whole.cast, **kwargs):   # the same casts with every box in
            return _cast(*args, **kwargs)

        whole.cast = uncut
        reference = render_camera(whole, camera, sensor)
        assert np.array_equal(picture.color, reference.color) and np.array_equal(picture.depth, reference.depth)
        assert kept < whole.triangles("visual")[1], (trial, kept)   # some of the 40 were behind or beside it
        for spec in (lidar, laser):
            assert np.array_equal(render_ray(cut, spec, sensor).ranges, render_ray(whole, spec, sensor).ranges)


@pytest.mark.parametrize(("rows_type", "rotation_type", "translation_type"), [
    (np.float32, np.float32, None), (np.float32, np.float64, np.float64), (np.float64, np.float32, np.float64),
    (np.float32, np.float32, np.float64), (np.float32, np.float32, np.float32)])
def test_rotate_is_the_plain_sum_bit_for_bit(rows_type, rotation_type, translation_type) -> None:
    # pictures stay byte-identical across versions: rotate's column loop adds the same terms in the same order
    rng = np.random.default_rng(7)
    rows = rng.normal(size=(5000, 3)).astype(rows_type)
    rotation = rng.normal(size=(3, 3)).astype(rotation_type)
    plain = rows[:, 0:1] * rotation[:, 0] + rows[:, 1:2] * rotation[:, 1] + rows[:, 2:3] * rotation[:, 2]
    if translation_type is None:
        got = rotate(rows, rotation)
    else:
        translation = rng.normal(size=3).astype(translation_type)
        plain = plain + translation
        got = rotate(rows, rotation, translation)
    assert got.dtype == plain.dtype and np.array_equal(got, plain)
