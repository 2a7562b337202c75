"""The scene the renderer and the viewer get (nodes/sim/scene.py): every model's links and shapes read from
DART, with kinds, sizes, colours and the visual/collision layers; meshes as triangles; a mesh over the
renderer's triangle cap refused with the model and the link named."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

from nodes.share import robot_file
from nodes.sim.config import parse_gains
from nodes.sim.entity import EntitySpec
from nodes.sim.pose import Pose
from nodes.sim.scene import BOX, CYLINDER, MESH, SPHERE, SceneError, build_scene
from nodes.sim.sdf import load_world, parse_model
from nodes.sim.sdf_model import WorldModel
from nodes.sim.simulation import Simulation
from nodes.sim.world import PhysicsWorld


def lab() -> Simulation:
    sim = Simulation(PhysicsWorld(1000.0), parse_gains({"*": {"p": 2000.0, "d": 20.0}}))
    sim.load_world(load_world("simple_lab"), 50.0, 1.0)
    sim.spawn(EntitySpec(name="humanoid", xml=robot_file("humanoid").read_text(),
                         pose=Pose.from_xyz_rpy(0, 0, 0.93, 0, 0, 0)))
    return sim


def test_the_lab_and_the_humanoid_as_the_renderer_gets_them():
    sim = lab()
    scene, links = build_scene(sim.world, sim.entities, 7)
    assert scene["version"] == 7 and scene["models"][0] == "ground_plane" and scene["models"][-1] == "humanoid"
    assert scene["namespaces"][-1] == "humanoid" and scene["namespaces"][1] == ""
    assert scene["static_models"][scene["models"].index("walls")] and not scene["static_models"][-1]
    assert "<robot" in scene["descriptions"][-1] and scene["descriptions"][1] == ""
    assert "humanoid::camera_optical_frame" in scene["links"] and len(scene["links"]) == len(scene["link_models"])
    kinds = {shape["kind"] for shape in scene["shapes"]}
    assert kinds == {BOX, CYLINDER, SPHERE}
    head = scene["links"].index("humanoid::head")
    head_shapes = [s for s in scene["shapes"] if s["link"] == head]
    assert {(s["visual"], s["collision"]) for s in head_shapes} == {(True, False), (False, True)}
    skin = next(s for s in head_shapes if s["visual"])
    assert (skin["kind"], skin["size"]) == (SPHERE, [0.1]) and skin["color"]["r"] == pytest.approx(0.95)
    poses = np.asarray(links.poses()).reshape(-1, 3, 4)
    assert poses.shape[0] == len(scene["links"])
    assert poses[scene["links"].index("humanoid::pelvis"), 2, 3] == pytest.approx(0.93, abs=1e-6)


def test_meshes_go_as_triangles_and_one_over_the_cap_is_refused(tmp_path: Path, monkeypatch):
    monkeypatch.setattr("nodes.sim.scene.MAX_MESH_TRIANGLES", 1000)   # a small cap: a small mesh to break it
    sim = Simulation(PhysicsWorld(1000.0), parse_gains({"*": {"p": 2000.0, "d": 20.0}}))
    for name, subdivisions in (("small", 2), ("huge", 3)):
        mesh = trimesh.creation.icosphere(subdivisions=subdivisions, radius=0.2)
        path = tmp_path / name / "meshes" / "ball.stl"
        path.parent.mkdir(parents=True)
        mesh.export(path)
        sdf = (f"<?xml version='1.0'?><sdf version='1.7'><model name='{name}'><static>true</static><link name='l'>"
               f"<visual name='v'><geometry><mesh><uri>model://{name}/meshes/ball.stl</uri><scale>2 2 2</scale>"
               f"</mesh></geometry></visual></link></model></sdf>")
        (tmp_path / name / "model.sdf").write_text(sdf)
        sim.add_model(WorldModel(parse_model(sdf, name, environ={"ZENROID_MODEL_PATH": str(tmp_path)})))
        if name == "small":
            scene, _ = build_scene(sim.world, sim.entities, 1)
            (shape,) = [s for s in scene["shapes"] if s["kind"] == MESH]
            vertices = np.frombuffer(shape["vertices"], "<f4").reshape(-1, 3)
            triangles = np.frombuffer(shape["triangles"], "<u4").reshape(-1, 3)
            assert len(triangles) == len(mesh.faces) and triangles.max() < len(vertices)
            assert np.linalg.norm(vertices, axis=1).max() == pytest.approx(0.4, abs=1e-4)   # scale applied
    with pytest.raises(SceneError, match=r"model 'huge' link 'l'.*1280 triangles, over the renderer's cap of 1000"):
        build_scene(sim.world, sim.entities, 2)
