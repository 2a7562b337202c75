"""Writes this package's meshes, as a CAD export would leave them: a binary STL (thigh), an ASCII STL (shin),
a Collada file in millimetres with Y up (torso) and an OBJ with its MTL colour (foot).

    python scripts/make_meshes.py        # from the package folder; rewrites meshes/
"""

from __future__ import annotations

import math
import struct
from pathlib import Path

MESHES = Path(__file__).resolve().parent.parent / "meshes"
Vertex = tuple[float, float, float]
Face = tuple[int, int, int]


def prism(outline: list[tuple[float, float]], bottom: float, top: float) -> tuple[list[Vertex], list[Face]]:
    """A closed prism along z over a convex outline given counter-clockwise (seen from +z)."""
    n = len(outline)
    vertices = [(x, y, bottom) for x, y in outline] + [(x, y, top) for x, y in outline]
    faces: list[Face] = []
    for i in range(1, n - 1):
        faces += [(0, i + 1, i), (n, n + i, n + i + 1)]      # bottom faces down, top faces up
    for i in range(n):
        j = (i + 1) % n
        faces += [(i, j, n + j), (i, n + j, n + i)]
    return vertices, faces


def octagon(width: float, depth: float, chamfer: float) -> list[tuple[float, float]]:
    x, y, c = depth / 2, width / 2, chamfer
    return [(x, -y + c), (x, y - c), (x - c, y), (-x + c, y), (-x, y - c), (-x, -y + c), (-x + c, -y), (x - c, -y)]


def circle(radius: float, sides: int = 16) -> list[tuple[float, float]]:
    return [(radius * math.cos(2 * math.pi * i / sides), radius * math.sin(2 * math.pi * i / sides))
            for i in range(sides)]


def normal(a: Vertex, b: Vertex, c: Vertex) -> Vertex:
    u = [b[k] - a[k] for k in range(3)]
    v = [c[k] - a[k] for k in range(3)]
    n = (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])
    length = math.sqrt(sum(x * x for x in n)) or 1.0
    return (n[0] / length, n[1] / length, n[2] / length)


def binary_stl(path: Path, vertices: list[Vertex], faces: list[Face]) -> None:
    data = b"lab_biped_description binary STL".ljust(80, b" ") + struct.pack("<I", len(faces))
    for face in faces:
        corners = [vertices[i] for i in face]
        data += struct.pack("<3f", *normal(*corners)) + b"".join(struct.pack("<3f", *c) for c in corners) + b"\0\0"
    path.write_bytes(data)


def ascii_stl(path: Path, vertices: list[Vertex], faces: list[Face]) -> None:
    lines = ["solid shin"]
    for face in faces:
        corners = [vertices[i] for i in face]
        lines += ["  facet normal {:.6g} {:.6g} {:.6g}".format(*normal(*corners)), "    outer loop",
                  *("      vertex {:.6g} {:.6g} {:.6g}".format(*c) for c in corners), "    endloop", "  endfacet"]
    path.write_text("\n".join([*lines, "endsolid shin", ""]))


def obj(path: Path, vertices: list[Vertex], faces: list[Face], rgb: Vertex) -> None:
    mtl = path.with_suffix(".mtl")
    mtl.write_text(f"newmtl sole_rubber\nKa 0 0 0\nKd {rgb[0]} {rgb[1]} {rgb[2]}\nKs 0.1 0.1 0.1\nd 1\n")
    lines = [f"mtllib {mtl.name}", "o foot", *("v {:.6g} {:.6g} {:.6g}".format(*v) for v in vertices),
             "usemtl sole_rubber", *(f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces)]
    path.write_text("\n".join(lines) + "\n")


def dae_millimetres_y_up(path: Path, vertices: list[Vertex], faces: list[Face], rgb: Vertex) -> None:
    """Z-up metres in, written as a Y-up file in millimetres (Collada's Y_UP: file (x, y, z) is (x, -z, y) in
    a Z-up world)."""
    converted = [(x * 1000, z * 1000, -y * 1000) for x, y, z in vertices]
    positions = " ".join(f"{c:.6g}" for v in converted for c in v)
    indices = " ".join(str(i) for face in faces for i in face)
    path.write_text(f"""<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <asset><contributor><authoring_tool>lab_biped_description/scripts/make_meshes.py</authoring_tool></contributor>
    <unit name="millimeter" meter="0.001"/><up_axis>Y_UP</up_axis></asset>
  <library_effects><effect id="shell-effect"><profile_COMMON><technique sid="common"><phong>
    <diffuse><color>{rgb[0]} {rgb[1]} {rgb[2]} 1</color></diffuse></phong></technique></profile_COMMON></effect>
  </library_effects>
  <library_materials><material id="shell" name="shell"><instance_effect url="#shell-effect"/></material>
  </library_materials>
  <library_geometries><geometry id="torso" name="torso"><mesh>
    <source id="torso-positions"><float_array id="torso-array" count="{3 * len(vertices)}">{positions}</float_array>
      <technique_common><accessor source="#torso-array" count="{len(vertices)}" stride="3">
        <param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/>
      </accessor></technique_common></source>
    <vertices id="torso-vertices"><input semantic="POSITION" source="#torso-positions"/></vertices>
    <triangles material="shell-material" count="{len(faces)}">
      <input semantic="VERTEX" source="#torso-vertices" offset="0"/><p>{indices}</p></triangles>
  </mesh></geometry></library_geometries>
  <library_visual_scenes><visual_scene id="scene"><node id="torso-node" name="torso">
    <instance_geometry url="#torso"><bind_material><technique_common>
      <instance_material symbol="shell-material" target="#shell"/></technique_common></bind_material>
    </instance_geometry></node></visual_scene></library_visual_scenes>
  <scene><instance_visual_scene url="#scene"/></scene>
</COLLADA>
""")


def main() -> None:
    MESHES.mkdir(exist_ok=True)
    # torso shell: 0.24 m deep (x), 0.30 m wide (y), 0.36 m tall (z), centred on the pelvis frame
    dae_millimetres_y_up(MESHES / "torso.dae", *prism(octagon(0.30, 0.24, 0.04), -0.18, 0.18), (0.9, 0.45, 0.1))
    # thigh and shin: round links 0.25 m long, hanging from their joint (z = 0) down
    binary_stl(MESHES / "thigh.stl", *prism(circle(0.045), -0.25, 0.0))
    ascii_stl(MESHES / "shin.stl", *prism(circle(0.04), -0.25, 0.0))
    # foot: a flat sole 0.22 m long, 0.12 m wide, 0.04 m thick, its top 0.02 m under the ankle
    obj(MESHES / "foot.obj", *prism(octagon(0.12, 0.22, 0.02), -0.06, -0.02), (0.1, 0.6, 0.25))


if __name__ == "__main__":
    main()
