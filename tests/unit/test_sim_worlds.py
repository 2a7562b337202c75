"""SDF world files (nodes/sim/sdf.py, sdf_model.py): what is read from Gazebo Classic and new Gazebo files,
model:// includes through the model path, and every kind of bad input refused with the file and the reason
before anything is built. The worlds are built as real DART skeletons here; the simulator process reading
them is tested in tests/integration/test_sim_worlds.py."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from nodes.share import WORLDS_DIR
from nodes.sim import sdf
from nodes.sim.config import parse_gains
from nodes.sim.sdf import WorldError, load_world, parse_model, parse_world
from nodes.sim.sdf_model import WorldModel
from nodes.sim.simulation import Simulation
from nodes.sim.world import PhysicsWorld

BOX = ("<link name='link'><inertial><mass>{mass}</mass><inertia><ixx>{i}</ixx><iyy>{i}</iyy><izz>{i}</izz>"
       "</inertia></inertial><collision name='c'><geometry><box><size>{size}</size></box></geometry></collision>"
       "<visual name='v'><geometry><box><size>{size}</size></box></geometry>"
       "<material><diffuse>0.1 0.2 0.3 1</diffuse></material></visual></link>")


def box_model(name: str = "box", pose: str = "0 0 0.5 0 0 0", mass: str = "1", i: str = "0.01",
              size: str = "0.2 0.2 0.2", static: bool = False) -> str:
    return (f"<model name='{name}'><pose>{pose}</pose>" + ("<static>true</static>" if static else "")
            + BOX.format(mass=mass, i=i, size=size) + "</model>")


def world(body: str, version: str = "1.6") -> str:
    return f"<?xml version='1.0'?><sdf version='{version}'><world name='w'>{body}</world></sdf>"


def make_model(folder: Path, name: str, body: str, config_file: str = "model.sdf") -> Path:
    path = folder / name
    path.mkdir(parents=True)
    (path / "model.config").write_text(f"<?xml version='1.0'?><model><name>{name}</name>"
                                       f"<sdf version='1.6'>{config_file}</sdf></model>")
    (path / config_file).write_text(f"<?xml version='1.0'?><sdf version='1.6'>{body}</sdf>")
    return path


# ------------------------------------------------------------------------------------------- what is read
@pytest.mark.parametrize("name", sorted(p.name for p in WORLDS_DIR.glob("*.world")))
def test_each_shipped_world_loads_and_builds(name: str) -> None:
    spec = load_world(name)
    assert spec.ground is not None and spec.gravity == (0.0, 0.0, -9.81)
    sim = Simulation(PhysicsWorld(), parse_gains({}))
    sim.load_world(spec, 50.0, 1.0)
    sim.step(200)
    assert [row[0] for row in sim.model_states()] == ["ground_plane", *(m.name for m in spec.models)]


def test_simple_lab_has_static_and_dynamic_models_none_near_the_spawn_point() -> None:
    spec = load_world("simple_lab")
    static = {m.name for m in spec.models if m.static}
    dynamic = {m.name for m in spec.models if not m.static}
    assert {"walls", "table", "ramp"} <= static and {"box_small", "box_medium", "box_large"} <= dynamic
    assert len(dynamic) >= 5
    sim = Simulation(PhysicsWorld(), parse_gains({}))
    sim.load_world(spec, 50.0, 1.0)
    for model in sim.entities.values():
        for i in range(model.skeleton.getNumBodyNodes()):
            body = model.skeleton.getBodyNode(i)
            for k in range(body.getNumShapeNodes()):
                node = body.getShapeNode(k)
                low, high = np.asarray(node.getShape().getBoundingBox().getMin()), \
                    np.asarray(node.getShape().getBoundingBox().getMax())
                corners = [node.getWorldTransform().multiply(np.array([x, y, z]))
                           for x in (low[0], high[0]) for y in (low[1], high[1]) for z in (low[2], high[2])]
                assert min(np.hypot(c[0], c[1]) for c in corners) > 1.5, f"{model.name} near the origin"


def test_gravity_where_each_version_puts_it_and_physics() -> None:
    physics = ("<physics type='ode'><max_step_size>0.002</max_step_size><real_time_factor>0.5</real_time_factor>"
               "<real_time_update_rate>250</real_time_update_rate>{g}</physics>")
    old = parse_world(world(physics.format(g="<gravity>0 0 -3</gravity>"), "1.4"))
    new = parse_world(world("<gravity>0 0 -1.62</gravity>" + physics.format(g=""), "1.6"))
    newest = parse_world(world("<gravity>0 0 -3.71</gravity>" + physics.format(g=""), "1.9"))
    assert (old.gravity, new.gravity, newest.gravity) == ((0, 0, -3), (0, 0, -1.62), (0, 0, -3.71))
    assert (new.physics.max_step_size, new.physics.real_time_factor, new.physics.real_time_update_rate) == \
        (0.002, 0.5, 250.0)
    assert parse_world(world("")).gravity == (0.0, 0.0, -9.8)     # SDF's default


def test_models_links_shapes_colours_and_joints_are_built() -> None:
    text = world("""
      <include><uri>model://ground_plane</uri></include>
      <model name='door'><pose>1 2 0 0 0 1.5707963</pose>
        <link name='frame'><collision name='c'><geometry><cylinder><radius>0.05</radius><length>2</length>
          </cylinder></geometry></collision></link>
        <link name='leaf'><pose>0.5 0 1 0 0 0</pose>
          <inertial><mass>10</mass><inertia><ixx>1</ixx><iyy>1</iyy><izz>1</izz></inertia></inertial>
          <visual name='v'><geometry><box><size>1 0.05 2</size></box></geometry>
            <material><script><name>Gazebo/Wood</name></script></material></visual>
          <visual name='knob'><geometry><sphere><radius>0.03</radius></sphere></geometry></visual></link>
        <joint name='hinge' type='revolute'><parent>frame</parent><child>leaf</child><pose>-0.5 0 0 0 0 0</pose>
          <axis><xyz>0 0 1</xyz><limit><lower>-1.5</lower><upper>1.5</upper></limit></axis></joint>
        <joint name='anchor' type='fixed'><parent>world</parent><child>frame</child></joint>
      </model>
      <model name='floor_patch'><static>true</static>
        <link name='l'><collision name='c'><geometry><plane><normal>0 0 1</normal><size>2 2</size></plane>
        </geometry></collision></link></model>""")
    spec = parse_world(text)
    door = WorldModel(spec.models[0])
    skeleton = door.skeleton
    assert skeleton.getNumDofs() == 1 and skeleton.getJoint("hinge").getNumDofs() == 1
    assert skeleton.getJoint("hinge").getPositionUpperLimit(0) == 1.5
    leaf = skeleton.getBodyNode("leaf")
    assert leaf.getMass() == 10.0
    # the leaf's world position: the model pose (yaw 90 degrees) applied to its pose in the model
    assert np.allclose(leaf.getWorldTransform().translation(), [1.0, 2.5, 1.0], atol=1e-6)
    colours = [leaf.getShapeNode(k).getVisualAspect().getRGBA() for k in range(leaf.getNumShapeNodes())]
    assert np.allclose(colours[0], sdf.SCRIPT_COLOURS["Gazebo/Wood"])
    assert door.world_pose().position == pytest.approx((1.0, 2.0, 0.0))
    patch = WorldModel(spec.models[1])
    assert patch.static and not patch.skeleton.isMobile()


def test_includes_through_the_model_path_with_name_pose_and_static(tmp_path: Path) -> None:
    make_model(tmp_path / "a", "crate", box_model("crate_model"), "crate.sdf")
    make_model(tmp_path / "b", "shelf", box_model("shelf", static=True))
    text = world("""
      <include><uri>model://sun</uri></include>
      <include><uri>model://crate</uri><name>crate_1</name><pose>1 0 0.1 0 0 0</pose></include>
      <include><uri>model://crate</uri><name>crate_2</name><pose>2 0 0.1 0 0 0</pose><static>true</static></include>
      <include><uri>model://shelf</uri></include>
      <light name='lamp' type='point'/><plugin name='p' filename='libx.so'/><scene/><gui/>
      <model name='m'><link name='l'><sensor name='s' type='imu'/></link><plugin name='q' filename='y'/></model>""")
    env = {"ZENROID_MODEL_PATH": str(tmp_path / "a"), "GAZEBO_MODEL_PATH": f"/nowhere{os.pathsep}{tmp_path / 'b'}"}
    spec = parse_world(text, environ=env)
    by_name = {m.name: m for m in spec.models}
    assert list(by_name) == ["crate_1", "crate_2", "shelf", "m"]
    assert by_name["crate_1"].pose[:3, 3].tolist() == [1.0, 0.0, 0.1] and not by_name["crate_1"].static
    assert by_name["crate_2"].static and by_name["shelf"].static
    line = spec.not_simulated_line()
    for element in ("light (model://sun)", "light", "plugin", "scene", "link/sensor", "model/plugin"):
        assert element in line
    # new Gazebo's variable too
    assert parse_world(text, environ={"GZ_SIM_RESOURCE_PATH": f"{tmp_path / 'a'}:{tmp_path / 'b'}"}).models


def test_an_sdf_model_as_a_spawn_request_carries_it() -> None:
    text = f"<?xml version='1.0'?><sdf version='1.7'>{box_model('crate', pose='0 0 0 0 0 0')}</sdf>"
    assert sdf.is_sdf(text) and not sdf.is_sdf("<?xml version='1.0'?><robot name='r'/>")
    model = parse_model(text)
    assert model.name == "crate" and len(model.links) == 1


# ------------------------------------------------------------------------------------------- bad input
def refused(text: str, match: str, environ: dict[str, str] | None = None) -> None:
    with pytest.raises(WorldError, match=match):
        spec = parse_world(text, Path("/tmp/test.world"), environ or {})
        for model in spec.models:
            WorldModel(model)


def test_entity_expansion_and_external_entities_are_refused() -> None:
    bomb = ("<?xml version='1.0'?><!DOCTYPE sdf [<!ENTITY a 'aaaaaaaaaa'><!ENTITY b '&a;&a;&a;&a;&a;&a;'>]>"
            "<sdf version='1.6'><world name='w'><model name='&b;'/></world></sdf>")
    refused(bomb, r"test\.world: XML declares entities")
    external = ("<?xml version='1.0'?><!DOCTYPE sdf SYSTEM 'file:///etc/passwd'>"
                "<sdf version='1.6'><world name='w'/></sdf>")
    refused(external, "external DTD")


def test_unknown_and_missing_model_uris(tmp_path: Path) -> None:
    refused(world("<include><uri>model://no_such_model</uri></include>"),
            r"line 1: <include>: 'model://no_such_model': no model 'no_such_model' in the model path")
    refused(world("<include><uri>https://fuel.gazebosim.org/x</uri></include>"), "nothing is fetched")
    refused(world("<include><name>x</name></include>"), "missing <uri>")
    (tmp_path / "empty_model").mkdir()
    (tmp_path / "empty_model" / "model.config").write_text("<model><sdf version='1.6'>gone.sdf</sdf></model>")
    refused(world("<include><uri>model://empty_model</uri></include>"), "no model file 'gone.sdf'",
            {"ZENROID_MODEL_PATH": str(tmp_path)})


def test_limits_are_counted_before_parsing(tmp_path: Path) -> None:
    many = world("<model name='m'/>" * (sdf.MAX_MODELS + 1))
    refused(many, f"{sdf.MAX_MODELS + 1} <model>/<include> elements, more than the limit of {sdf.MAX_MODELS}")
    huge = tmp_path / "huge.world"
    with open(huge, "wb") as handle:
        handle.truncate(2 * 1024**3)                      # sparse: 2 GB to stat, nothing to read
    with pytest.raises(WorldError, match=r"huge\.world: world file is 2147483648 bytes, more than the limit"):
        load_world(str(huge))
    model = tmp_path / "models" / "statue"
    (model / "meshes").mkdir(parents=True)
    with open(model / "meshes" / "statue.stl", "wb") as handle:
        handle.truncate(1024**3)                          # a 1 GB mesh
    (model / "model.sdf").write_text("<sdf version='1.6'><model name='statue'><static>true</static><link name='l'>"
                                     "<visual name='v'><geometry><mesh><uri>meshes/statue.stl</uri></mesh></geometry>"
                                     "</visual></link></model></sdf>")
    refused(world("<include><uri>model://statue</uri></include>"),
            r"mesh 'meshes/statue.stl' is 1073741824 bytes, more than the limit",
            {"ZENROID_MODEL_PATH": str(tmp_path / "models")})


@pytest.mark.parametrize(("body", "match"), [
    (box_model(pose="nan 0 0 0 0 0"), r"<pose>: must be finite"),
    (box_model(pose="0 0 inf 0 0 0"), r"<pose>: must be finite"),
    (box_model(pose="1e9 0 0 0 0 0"), r"<pose>: position \[1000000000.0, 0.0, 0.0\] is farther than 10000 m"),
    (box_model(pose="0 0 0"), r"<pose>: expected 6 number\(s\)"),
    (box_model(mass="1e12"), r"<mass>: 1e\+12 is outside \[0, 1e\+06\]"),
    (box_model(mass="-1"), r"<mass>: -1 is outside"),
    (box_model(mass="0"), r"mass 0 kg of a dynamic link must be at least"),
    (box_model(i="0"), r"link box::link: inertia is not positive definite"),
    (box_model(i="-0.5"), r"inertia is not positive definite"),
    (box_model(i="1e30"), r"<ixx>: 1e\+30 is outside"),
    (box_model(size="-1 1 1"), r"<size>: \[-1.0, 1.0, 1.0\] m: each side must be in \(0, 10000\]"),
    (box_model(size="1e9 1 1"), r"each side must be in"),
    (box_model(size="NaN 1 1"), r"must be finite"),
    ("<model name='s'><link name='l'><collision name='c'><geometry><sphere><radius>0</radius></sphere>"
     "</geometry></collision></link></model>", r"<radius>: 0 m is outside \(0, 10000\]"),
    ("<gravity>0 0 -1e6</gravity>", r"<gravity>: \[0.0, 0.0, -1000000.0\] m/s\^2"),
    ("<physics type='ode'><max_step_size>0</max_step_size></physics>", r"<max_step_size>: 0 is outside"),
    ("<model name='a b'><link name='l'/></model>", r"model name 'a b': has ' '"),
    ("<model name='e'/>", r"model 'e' has no <link>"),
    (box_model("twin") + box_model("twin"), r"two models are named 'twin'"),
    ("<model name='j'><link name='a'/><link name='b'/><joint name='x' type='screw'><parent>a</parent>"
     "<child>b</child></joint></model>", r"joint 'x': type 'screw' is not supported"),
    ("<model name='j'><link name='a'/><link name='b'/><joint name='x' type='fixed'><parent>a</parent>"
     "<child>c</child></joint></model>", r"joint 'x': child link 'c' does not exist"),
    ("<model name='j'><link name='a'/><link name='b'/><joint name='x' type='fixed'><parent>a</parent>"
     "<child>b</child></joint><joint name='y' type='fixed'><parent>b</parent><child>a</child></joint></model>",
     r"form a loop"),
])
def test_absurd_values_are_refused_naming_the_element(body: str, match: str) -> None:
    refused(world(body), match)


def test_zero_inertia_is_fine_on_a_static_link() -> None:
    spec = parse_world(world(box_model(mass="0", i="0", static=True)))
    assert WorldModel(spec.models[0]).static


def test_cyclic_includes_are_refused(tmp_path: Path) -> None:
    make_model(tmp_path, "ouroboros", "<model name='o'><link name='l'/><include><uri>model://ouroboros</uri>"
                                      "</include></model>")
    make_model(tmp_path, "ping", "<model name='p'><link name='l'/><include><uri>model://pong</uri></include></model>")
    make_model(tmp_path, "pong", "<model name='q'><link name='l'/><include><uri>model://ping</uri></include></model>")
    env = {"ZENROID_MODEL_PATH": str(tmp_path)}
    refused(world("<include><uri>model://ouroboros</uri></include>"), r"cyclic include: .*ouroboros -> .*ouroboros",
            env)
    refused(world("<include><uri>model://ping</uri></include>"), r"cyclic include: .*ping -> .*pong -> .*ping", env)


def test_mesh_paths_that_leave_the_model_folder_are_refused(tmp_path: Path) -> None:
    (tmp_path / "secret.stl").write_text("solid x\nendsolid x\n")
    for uri in ("../secret.stl", f"file://{tmp_path / 'secret.stl'}", "/etc/passwd", "meshes/../../secret.stl"):
        body = (f"<model name='m'><static>true</static><link name='l'><visual name='v'><geometry><mesh>"
                f"<uri>{uri}</uri></mesh></geometry></visual></link></model>")
        make_model(tmp_path / "models" / str(abs(hash(uri))), "m", body)
        with pytest.raises(WorldError, match=r"leaves the model folder"):
            parse_world(world("<include><uri>model://m</uri></include>"),
                        environ={"ZENROID_MODEL_PATH": str(tmp_path / "models" / str(abs(hash(uri))))})
    (tmp_path / "models2" / "m" / "meshes").mkdir(parents=True)
    os.symlink(tmp_path / "secret.stl", tmp_path / "models2" / "m" / "meshes" / "link.stl")
    (tmp_path / "models2" / "m" / "model.sdf").write_text(
        "<sdf version='1.6'><model name='m'><static>true</static><link name='l'><visual name='v'><geometry><mesh>"
        "<uri>meshes/link.stl</uri></mesh></geometry></visual></link></model></sdf>")
    with pytest.raises(WorldError, match=r"leaves the model folder"):
        parse_world(world("<include><uri>model://m</uri></include>"),
                    environ={"ZENROID_MODEL_PATH": str(tmp_path / "models2")})
    # a spawn request has no folder: a relative mesh path is refused, not read from the simulator's cwd
    with pytest.raises(WorldError, match=r"a mesh in a spawn request must be a model:// URI"):
        parse_model("<sdf version='1.6'><model name='m'><link name='l'><visual name='v'><geometry><mesh>"
                    "<uri>x.stl</uri></mesh></geometry></visual></link></model></sdf>")


def test_a_mesh_inside_its_model_folder_is_loaded(tmp_path: Path) -> None:
    folder = make_model(tmp_path, "wedge", "<model name='wedge'><static>true</static><link name='l'><collision "
                        "name='c'><geometry><mesh><uri>model://wedge/meshes/wedge.stl</uri><scale>2 2 2</scale>"
                        "</mesh></geometry></collision></link></model>")
    (folder / "meshes").mkdir()
    corners = ["0 0 0", "1 0 0", "0 1 0", "0 0 1"]   # a tetrahedron: a hull with a volume
    facets = ""
    for face in ((0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)):
        facets += "facet normal 0 0 0\nouter loop\n" + "".join(f"vertex {corners[i]}\n" for i in face)
        facets += "endloop\nendfacet\n"
    (folder / "meshes" / "wedge.stl").write_text(f"solid w\n{facets}endsolid w\n")
    spec = parse_world(world("<include><uri>model://wedge</uri></include>"),
                       environ={"ZENROID_MODEL_PATH": str(tmp_path)})
    shape = WorldModel(spec.models[0]).skeleton.getBodyNode(0).getShapeNode(0).getShape()
    assert shape.getType() == "MeshShape" and np.allclose(shape.getScale(), [2, 2, 2])


def test_unknown_world_names_list_the_shipped_ones() -> None:
    with pytest.raises(WorldError, match=r"world 'no_such_world' not found .*shipped: empty.world, simple_lab.world"):
        load_world("no_such_world")
    assert load_world("simple_lab").name == load_world("simple_lab.world").name == "simple_lab"


def test_links_and_models_reached_through_includes_are_counted_while_expanding(tmp_path: Path) -> None:
    """Each cap is met at the first element over it: the fan-outs below are 10^7 links expanded in full."""
    leaf = ("<link name='l'><collision name='c'><geometry><box><size>0.1 0.1 0.1</size></box></geometry>"
            "</collision></link>")
    for i in range(1, 9):
        body = leaf if i == 8 else "".join(f"<include><uri>model://fan{i + 1}</uri><name>m{k}</name></include>"
                                           for k in range(10))
        make_model(tmp_path, f"fan{i}", f"<model name='fan{i}'>{body}</model>")
    links = "".join(leaf.replace("name='l'", f"name='l{i}'") for i in range(100))
    make_model(tmp_path, "block", f"<model name='block'>{links}</model>")
    make_model(tmp_path, "one", f"<model name='one'>{leaf}</model>")
    make_model(tmp_path, "ten", "<model name='ten'>" + "".join(
        f"<include><uri>model://one</uri><name>o{k}</name></include>" for k in range(10)) + "</model>")
    env = {"ZENROID_MODEL_PATH": str(tmp_path)}
    refused(world("<include><uri>model://fan1</uri></include>"),
            rf"a model has more than {sdf.MAX_MODEL_LINKS} links .*fan8/model.sdf", env)
    with pytest.raises(WorldError, match=rf"a model has more than {sdf.MAX_MODEL_LINKS} links"):
        sdf.parse_model("<sdf version='1.7'><model name='x'><include><uri>model://fan1</uri></include></model></sdf>",
                        "spawn", env)
    blocks = "".join(f"<include><uri>model://block</uri><name>b{k}</name></include>"
                     for k in range(sdf.MAX_LINKS // 100 + 1))
    refused(world(blocks), rf"more than {sdf.MAX_LINKS} links \(includes counted in", env)
    tens = "".join(f"<include><uri>model://ten</uri><name>t{k}</name></include>"
                   for k in range(sdf.MAX_MODELS // 11 + 1))
    refused(world(tens), rf"more than {sdf.MAX_MODELS} models \(nested and included ones counted in", env)
    within = "".join(f"<include><uri>model://block</uri><name>b{k}</name></include>" for k in range(3))
    assert len(parse_world(world(within), Path("/tmp/test.world"), env).models) == 3   # within the caps


def test_a_file_include_outside_the_model_path_gets_one_answer_whether_the_folder_exists_or_not(
        tmp_path: Path) -> None:
    (tmp_path / "here").mkdir()
    answers = set()
    for folder in (tmp_path / "here", tmp_path / "absent", Path("/etc")):
        with pytest.raises(WorldError) as caught:
            parse_world(world(f"<include><uri>file://{folder}</uri></include>"),
                        environ={"ZENROID_MODEL_PATH": str(tmp_path / "models")})
        answers.add(str(caught.value).replace(str(folder), "FOLDER"))
    assert len(answers) == 1 and "not in the model path or the world's folder" in answers.pop()
    # inside the model path a folder is read as before
    make_model(tmp_path / "models", "inside", box_model())
    spec = parse_world(world(f"<include><uri>file://{tmp_path / 'models' / 'inside'}</uri></include>"),
                       environ={"ZENROID_MODEL_PATH": str(tmp_path / "models")})
    assert len(spec.models) == 1


def test_a_package_mesh_in_an_sdf_comes_through_the_package_index(tmp_path: Path, monkeypatch) -> None:
    from nodes.packages import refresh

    package = tmp_path / "rpp" / "wedge_description"
    (package / "meshes").mkdir(parents=True)
    (package / "package.xml").write_text("<package format='3'><name>wedge_description</name></package>")
    corners = ["0 0 0", "1 0 0", "0 1 0", "0 0 1"]
    facets = "".join("facet normal 0 0 0\nouter loop\n" + "".join(f"vertex {corners[i]}\n" for i in face)
                     + "endloop\nendfacet\n" for face in ((0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)))
    (package / "meshes" / "wedge.stl").write_text(f"solid w\n{facets}endsolid w\n")
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "rpp"))
    refresh()
    mesh = ("<model name='w'><static>true</static><link name='l'><collision name='c'><geometry><mesh><uri>{}</uri>"
            "</mesh></geometry></collision></link></model>")
    spec = parse_world(world(mesh.format("package://wedge_description/meshes/wedge.stl")))
    assert WorldModel(spec.models[0]).skeleton.getBodyNode(0).getShapeNode(0).getShape().getType() == "MeshShape"
    refused(world(mesh.format("package://wedge_description/../../secret.stl")), r"leaves the model folder")
    refused(world(mesh.format("package://no_such_description/m.stl")),
            r"package 'no_such_description' not found; searched:")
