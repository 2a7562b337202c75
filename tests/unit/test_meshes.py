"""nodes.meshes: hostile files refused with the file and the reason (before anything big is read), every format
read with its colours, units and up axis, collision shapes built once and cached by content, paths kept inside
their folders, caps counted per robot, and a URDF's meshes replaced by the converted files."""

from __future__ import annotations

import resource
from pathlib import Path

import numpy as np
import pytest

from nodes.meshes import MeshBudget, MeshError, load_mesh, probe
from nodes.meshes import load as load_module
from nodes.meshes.convert import CollisionPolicy, collision_files, visual_files
from nodes.meshes.paths import MissingMesh, resolve_mesh
from nodes.meshes.urdf import prepare_urdf
from tests.support import meshes as M


@pytest.fixture(autouse=True)
def cache(tmp_path: Path, monkeypatch) -> Path:
    folder = tmp_path / "cache"
    monkeypatch.setenv("ZENROID_MESH_CACHE", str(folder))
    return folder


@pytest.mark.parametrize("case", ["inf_stl", "nan_ascii_stl", "nan_obj", "overflow_obj", "inf_dae", "garbage_obj",
                                  "empty_stl", "flat_stl", "big_stl"])
def test_hostile_meshes_are_refused_naming_the_file_and_the_reason(tmp_path: Path, case: str) -> None:
    path, reason = M.hostile(tmp_path / "meshes")[case]
    with pytest.raises(MeshError) as info:
        collision_files(load_mesh(path), "hull")
    assert str(path) in str(info.value) and reason in str(info.value), str(info.value)


def test_a_huge_binary_stl_is_refused_from_its_header_without_reading_it(tmp_path: Path) -> None:
    path = M.big_stl(tmp_path / "big.stl")
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    with pytest.raises(MeshError, match="1250000 triangles, over the limit of 200000"):
        load_mesh(path)
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before < 20_000   # kB: nothing was loaded
    # a size that does not match the header's count, and no "solid": neither kind of STL
    with open(path, "r+b") as handle:
        handle.truncate(84 + 50 * 10 + 7)
    with pytest.raises(MeshError, match="neither a binary STL"):
        probe(path)


def test_text_formats_are_capped_by_size_and_by_their_declared_triangles(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.setattr(load_module, "MAX_MESH_TRIANGLES", 10)
    with pytest.raises(MeshError, match="12 triangles, over the limit of 10"):
        probe(M.obj(tmp_path / "cube.obj"))
    with pytest.raises(MeshError, match="12 triangles, over the limit of 10"):
        probe(M.dae(tmp_path / "cube.dae"))
    monkeypatch.setattr(load_module, "MAX_TEXT_MESH_BYTES", 100)
    with pytest.raises(MeshError, match="over the limit of 100 bytes for a text mesh"):
        probe(M.ascii_stl(tmp_path / "cube.stl"))
    with pytest.raises(MeshError, match=r"\.ply is not a mesh format read here"):
        probe(tmp_path / "x.ply")


def test_every_format_is_read_with_its_colours_unit_and_up_axis(tmp_path: Path) -> None:
    box = M.CUBE_VERTICES * np.array([1.0, 2.0, 3.0])    # 1 x 2 x 3
    for path in (M.binary_stl(tmp_path / "b.stl", box), M.ascii_stl(tmp_path / "a.stl", box),
                 M.obj(tmp_path / "c.obj", box, rgb=(0.1, 0.6, 0.3))):
        mesh = load_mesh(path)
        vertices, faces = mesh.merged()
        assert mesh.triangles == 12 and np.ptp(vertices, axis=0) == pytest.approx([1, 2, 3]), path
    assert load_mesh(tmp_path / "c.obj").parts[0].rgba == pytest.approx((0.1, 0.6, 0.3, 1.0), abs=0.01)
    # Collada in millimetres with y up: metres, z up (as assimp and Gazebo read it)
    mesh = load_mesh(M.dae(tmp_path / "d.dae", box * 1000, unit=0.001, up="Y_UP", rgb=(0.9, 0.1, 0.1)))
    assert np.ptp(mesh.merged()[0], axis=0) == pytest.approx([1, 3, 2])
    assert mesh.parts[0].rgba == pytest.approx((0.9, 0.1, 0.1, 1.0), abs=0.01)


def test_collision_shapes_are_built_once_and_cached_by_content(tmp_path: Path, cache: Path) -> None:
    # a U: two posts on a bar; one hull fills the gap, a decomposition does not
    posts = [M.CUBE_VERTICES * [0.2, 0.2, 1.0] + [x, 0, 0.6] for x in (-0.4, 0.4)]
    bar = M.CUBE_VERTICES * [1.0, 0.2, 0.2]
    vertices = np.concatenate([bar, *posts])
    faces = np.concatenate([M.CUBE_FACES + 8 * i for i in range(3)])
    path = M.binary_stl(tmp_path / "u.stl", vertices, faces)
    mesh = load_mesh(path)
    hull, hit = collision_files(mesh, "hull")
    assert not hit and len(hull) == 1 and hull[0].is_relative_to(cache)
    hull_mesh = load_mesh(hull[0])
    assert np.ptp(hull_mesh.merged()[0], axis=0) == pytest.approx([1.0, 0.2, 1.2])
    again, hit = collision_files(load_mesh(M.binary_stl(tmp_path / "copy.stl", vertices, faces)), "hull")
    assert hit and again == hull                     # the same bytes elsewhere: the same entry
    parts, _ = collision_files(mesh, "decompose")
    assert len(parts) >= 3, parts                    # the bar and both posts at least
    exact, _ = collision_files(mesh, "exact")
    assert load_mesh(exact[0]).triangles == 36
    files, _ = visual_files(load_mesh(M.obj(tmp_path / "red.obj", rgb=(1, 0, 0))))
    assert [rgba for _, rgba in files] == [(1.0, 0.0, 0.0, 1.0)]


def test_collision_policy_per_launch_and_per_link() -> None:
    policy = CollisionPolicy.parse("decompose, left_hand=exact ,head=hull")
    assert (policy.mode("torso"), policy.mode("left_hand"), policy.mode("head")) == ("decompose", "exact", "hull")
    assert CollisionPolicy.parse("").mode("x") == "hull"
    with pytest.raises(MeshError, match="'convex' is not one of hull, decompose, exact"):
        CollisionPolicy.parse("convex")


def test_paths_stay_inside_their_folders(tmp_path: Path) -> None:
    robot = tmp_path / "my_robot_description" / "urdf" / "robot.urdf"
    mesh = M.binary_stl(tmp_path / "my_robot_description" / "meshes" / "body.stl")
    robot.parent.mkdir(parents=True)
    assert resolve_mesh("package://my_robot_description/meshes/body.stl", robot) == mesh   # an ancestor
    assert resolve_mesh("package:///my_robot_description/meshes/body.stl", robot) == mesh  # TALOS's spelling
    assert resolve_mesh("body.stl", mesh.parent / "r.urdf") == mesh
    with pytest.raises(MissingMesh, match="does not exist"):
        resolve_mesh("package://my_robot_description/meshes/gone.stl", robot)
    with pytest.raises(MeshError, match="outside its package root"):
        resolve_mesh("package://my_robot_description/../../etc/x.stl", robot)
    with pytest.raises(MeshError, match="package 'nowhere_pkg' not found"):
        resolve_mesh("package://nowhere_pkg/x.stl", robot)
    with pytest.raises(MeshError, match="needs the robot's file"):
        resolve_mesh("x.stl", None)


def test_caps_count_files_and_triangles_per_robot(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.setattr(load_module, "MAX_ROBOT_TRIANGLES", 30)
    budget = MeshBudget("robot 'r'")
    first = load_mesh(M.binary_stl(tmp_path / "a.stl"))
    budget.add(first)
    budget.add(first)                                 # the same file twice counts once
    budget.add(load_mesh(M.binary_stl(tmp_path / "b.stl", size=(2, 2, 2))))
    with pytest.raises(MeshError, match=r"robot 'r': its meshes have 36 triangles, over the limit of 30"):
        budget.add(load_mesh(M.binary_stl(tmp_path / "c.stl", size=(3, 3, 3))))


URDF = """<robot name="r">
  <link name="body">
    <inertial><mass value="1"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><geometry><mesh filename="meshes/VISUAL" scale="0.5 0.5 0.5"/></geometry></visual>
    <collision><geometry><mesh filename="meshes/COLLISION"/></geometry></collision>
    <collision><geometry><box size="1 1 1"/></geometry></collision>
  </link>
</robot>"""


def test_a_urdfs_meshes_become_converted_files(tmp_path: Path) -> None:
    M.obj(tmp_path / "meshes" / "paint.obj", rgb=(0.0, 0.0, 1.0))
    M.binary_stl(tmp_path / "meshes" / "body.stl")
    robot = tmp_path / "robot.urdf"
    xml = URDF.replace("VISUAL", "paint.obj").replace("COLLISION", "body.stl")
    prepared = prepare_urdf(xml, robot, "robot 'r'", CollisionPolicy.parse("hull"))
    assert prepared.meshes == 2 and not prepared.warnings
    assert "paint.obj" not in prepared.xml and "body.stl" not in prepared.xml
    assert 'rgba="0 0 1 1"' in prepared.xml and 'scale="0.5 0.5 0.5"' in prepared.xml
    assert '<box size="1 1 1"/>' in prepared.xml                         # primitives stay primitives
    assert prepare_urdf(xml, robot, "robot 'r'").cached == 2             # the second time: from the cache

    # a missing visual mesh is a warning and the visual is left out; a missing collision mesh an error
    prepared = prepare_urdf(xml.replace("paint.obj", "gone.obj"), robot, "robot 'r'")
    assert len(prepared.warnings) == 1 and "gone.obj" in prepared.warnings[0] and "<visual>" not in prepared.xml
    with pytest.raises(MeshError, match=r"robot 'r': link 'body' collision mesh 'meshes/gone.stl': file .*gone.stl does not exist"):
        prepare_urdf(xml.replace("body.stl", "gone.stl"), robot, "robot 'r'")
    M.binary_stl(tmp_path / "meshes" / "inf.stl", M.with_bad_vertex())
    with pytest.raises(MeshError, match=r"link 'body' collision mesh 'meshes/inf.stl': .*inf.stl: vertex 2 is not"):
        prepare_urdf(xml.replace("body.stl", "inf.stl"), robot, "robot 'r'")


def test_the_viewer_draws_a_mesh_visual_in_its_files_colours(tmp_path: Path) -> None:
    from nodes.urdf.model import parse_urdf
    from nodes.viz.scene import mesh_archetype

    M.obj(tmp_path / "meshes" / "paint.obj", M.CUBE_VERTICES * [1, 2, 3], rgb=(0.0, 0.0, 1.0))
    M.dae(tmp_path / "meshes" / "part.dae", M.CUBE_VERTICES * 1000, unit=0.001, rgb=(1.0, 0.0, 0.0))
    xml = URDF.replace("VISUAL", "paint.obj").replace("COLLISION", "body.stl")
    xml = xml.replace("<collision><geometry><mesh", "<visual><geometry><mesh filename='meshes/part.dae'/>"
                      "</geometry></visual><collision><geometry><mesh")
    visuals = parse_urdf(xml).links["body"].visuals
    painted, reason = mesh_archetype(visuals[0], tmp_path)
    assert reason == "" and painted is not None
    positions = np.asarray(painted.vertex_positions.as_arrow_array().to_pylist())
    assert np.ptp(positions, axis=0) == pytest.approx([0.5, 1.0, 1.5])          # scale 0.5 applied
    colours = painted.vertex_colors.as_arrow_array().to_pylist()
    assert set(colours) == {0x0000FFFF}                                           # the MTL's blue, opaque
    part, _ = mesh_archetype(visuals[1], tmp_path)                                # a DAE, in metres
    assert np.ptp(np.asarray(part.vertex_positions.as_arrow_array().to_pylist()), axis=0) == pytest.approx([1, 1, 1])
    gone, reason = mesh_archetype(visuals[0], tmp_path / "elsewhere")
    assert gone is None and "does not exist" in reason


def test_a_world_draws_a_link_without_its_missing_visual_mesh_but_refuses_a_missing_collision_mesh(tmp_path):
    from nodes.sim.sdf import WorldError, parse_world

    def world(part: str) -> str:
        return (f"<sdf version='1.6'><world name='w'><model name='statue'><static>true</static><link name='l'>"
                f"<{part} name='x'><geometry><mesh><uri>meshes/gone.stl</uri></mesh></geometry></{part}>"
                "</link></model></world></sdf>")

    spec = parse_world(world("visual"), tmp_path / "w.world")
    assert spec.models[0].links[0].visuals == [] and "gone.stl" in spec.not_simulated_line()
    with pytest.raises(WorldError, match=r"mesh 'meshes/gone.stl': no file at"):
        parse_world(world("collision"), tmp_path / "w.world")


def test_a_link_named_in_the_policy_is_decomposed(tmp_path: Path) -> None:
    posts = [M.CUBE_VERTICES * [0.2, 0.2, 1.0] + [x, 0, 0.6] for x in (-0.4, 0.4)]
    vertices = np.concatenate([M.CUBE_VERTICES * [1.0, 0.2, 0.2], *posts])
    faces = np.concatenate([M.CUBE_FACES + 8 * i for i in range(3)])
    M.binary_stl(tmp_path / "meshes" / "u.stl", vertices, faces)
    M.binary_stl(tmp_path / "meshes" / "body.stl")
    xml = URDF.replace("VISUAL", "body.stl").replace("COLLISION", "u.stl")
    hulls = prepare_urdf(xml, tmp_path / "r.urdf", "robot 'r'", CollisionPolicy.parse("hull")).xml
    parts = prepare_urdf(xml, tmp_path / "r.urdf", "robot 'r'", CollisionPolicy.parse("hull,body=decompose")).xml
    assert hulls.count("<collision>") == 2 and parts.count("<collision>") >= 4   # 3+ parts and the box


def test_a_scene_over_the_payload_limit_sends_its_biggest_meshes_by_reference(tmp_path, monkeypatch):
    from nodes.meshes.convert import by_reference
    from nodes.sim import scene as scene_module

    shapes = [{"kind": scene_module.MESH, "vertices": bytes(12 * n), "triangles": bytes(12 * n), "size": [],
               "mesh_uri": f"/models/m{n}.stl", "_file": f"/cache/m{n}.stl", "_scale": [1.0, 2.0, 1.0]}
              for n in (10, 1000, 100)]
    monkeypatch.setattr(scene_module, "max_payload_bytes", lambda: scene_module.SCENE_MARGIN_BYTES + 5000)
    scene_module._fit(shapes)
    assert [len(s["vertices"]) for s in shapes] == [120, 0, 1200]                  # the biggest left the message
    assert shapes[1]["mesh_uri"] == "/cache/m1000.stl" and shapes[1]["size"] == [1.0, 2.0, 1.0]
    assert all("_file" not in s and "_scale" not in s for s in shapes)

    files, _ = collision_files(load_mesh(M.binary_stl(tmp_path / "box.stl")), "hull")
    vertices, faces = by_reference(str(files[0]), [1.0, 2.0, 1.0])
    assert np.ptp(vertices, axis=0) == pytest.approx([1, 2, 1]) and vertices.dtype == np.float32
    with pytest.raises(MeshError, match="must be a file of the mesh cache"):
        by_reference(str(tmp_path / "box.stl"), [1, 1, 1])
