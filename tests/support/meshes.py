"""Mesh files for tests, written byte by byte (no exporter of ours): good ones in every format, and the hostile
ones an outside probe sends (non-finite vertices, garbage, flat, empty, a header claiming 1.25 M triangles)."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np

# a unit cube centred at the origin, outward winding
CUBE_VERTICES = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])
CUBE_FACES = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                       [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])
BIG_TRIANGLES = 1_250_000    # 62.5 MB as a binary STL


def binary_stl(path: Path, vertices=CUBE_VERTICES, faces=CUBE_FACES, size: tuple[float, float, float] = (1, 1, 1)):
    corners = np.asarray(vertices, dtype=np.float64)[np.asarray(faces)] * np.asarray(size)
    data = b"test".ljust(80, b" ") + struct.pack("<I", len(corners))
    for triangle in corners:
        data += struct.pack("<3f", 0, 0, 0) + struct.pack("<9f", *triangle.ravel()) + b"\0\0"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(data)
    return path


def ascii_stl(path: Path, vertices=CUBE_VERTICES, faces=CUBE_FACES, size=(1, 1, 1)) -> Path:
    corners = np.asarray(vertices, dtype=np.float64)[np.asarray(faces)] * np.asarray(size)
    lines = ["solid t"]
    for triangle in corners:
        lines += ["facet normal 0 0 0", "outer loop", *(f"vertex {x} {y} {z}" for x, y, z in triangle.tolist()),
                  "endloop", "endfacet"]
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join([*lines, "endsolid t", ""]))
    return path


def obj(path: Path, vertices=CUBE_VERTICES, faces=CUBE_FACES, size=(1, 1, 1), rgb=None) -> Path:
    """An OBJ (with an MTL of one diffuse colour when ``rgb`` is given)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    lines = []
    if rgb is not None:
        path.with_suffix(".mtl").write_text(f"newmtl paint\nKd {rgb[0]} {rgb[1]} {rgb[2]}\nd 1\n")
        lines += [f"mtllib {path.with_suffix('.mtl').name}", "usemtl paint"]
    lines += [f"v {x} {y} {z}" for x, y, z in (np.asarray(vertices, dtype=np.float64) * np.asarray(size)).tolist()]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces]
    path.write_text("\n".join(lines) + "\n")
    return path


def dae(path: Path, vertices=CUBE_VERTICES, faces=CUBE_FACES, unit: float = 1.0, up: str = "Z_UP",
        rgb=(0.8, 0.2, 0.2)) -> Path:
    """A minimal Collada file: one triangles element, one phong material, its unit and up axis."""
    positions = " ".join(repr(float(v)) for v in np.asarray(vertices, dtype=np.float64).ravel())
    indices = " ".join(str(int(i)) for i in np.asarray(faces).ravel())
    r, g, b = rgb
    text = f"""<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <asset><unit name="u" meter="{unit}"/><up_axis>{up}</up_axis></asset>
  <library_effects><effect id="e"><profile_COMMON><technique sid="common"><phong>
    <diffuse><color>{r} {g} {b} 1</color></diffuse></phong></technique></profile_COMMON></effect></library_effects>
  <library_materials><material id="m" name="m"><instance_effect url="#e"/></material></library_materials>
  <library_geometries><geometry id="g"><mesh>
    <source id="p"><float_array id="pa" count="{len(vertices) * 3}">{positions}</float_array>
      <technique_common><accessor source="#pa" count="{len(vertices)}" stride="3">
        <param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/>
      </accessor></technique_common></source>
    <vertices id="v"><input semantic="POSITION" source="#p"/></vertices>
    <triangles material="mat" count="{len(faces)}"><input semantic="VERTEX" source="#v" offset="0"/>
      <p>{indices}</p></triangles>
  </mesh></geometry></library_geometries>
  <library_visual_scenes><visual_scene id="s"><node id="n">
    <instance_geometry url="#g"><bind_material><technique_common>
      <instance_material symbol="mat" target="#m"/></technique_common></bind_material></instance_geometry>
  </node></visual_scene></library_visual_scenes>
  <scene><instance_visual_scene url="#s"/></scene>
</COLLADA>
"""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


def with_bad_vertex(value: float = float("inf")) -> np.ndarray:
    vertices = CUBE_VERTICES.astype(np.float64).copy()
    vertices[3, 1] = value
    return vertices


def overflow_obj(path: Path) -> Path:
    """An OBJ with a coordinate written as 1e999 (read as inf by every float parser)."""
    obj(path)
    path.write_text(path.read_text().replace("v 0.5 0.5 0.5", "v 0.5 1e999 0.5"))
    return path


def flat_vertices() -> np.ndarray:
    vertices = CUBE_VERTICES.astype(np.float64).copy()
    vertices[:, 2] = 0.0
    return vertices


def big_stl(path: Path, triangles: int = BIG_TRIANGLES) -> Path:
    """A binary STL whose header counts ``triangles`` and whose size matches (a sparse file: cheap to make)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "wb") as handle:
        handle.write(b"big".ljust(80, b" ") + struct.pack("<I", triangles))
        handle.truncate(84 + 50 * triangles)
    return path


def hostile(folder: Path) -> dict[str, tuple[Path, str]]:
    """name -> (file, a phrase of the reason it must be refused with)."""
    folder.mkdir(parents=True, exist_ok=True)
    garbage = folder / "garbage.obj"
    garbage.write_bytes(b"v 1 2\nf 9 9 9 9\n\x00\xff\xfe this is not a mesh \n" * 20)
    empty = folder / "empty.stl"
    empty.write_bytes(b"e".ljust(80, b" ") + struct.pack("<I", 0))
    return {
        "inf_stl": (binary_stl(folder / "inf.stl", with_bad_vertex()), "is not finite"),
        "nan_ascii_stl": (ascii_stl(folder / "nan_ascii.stl", with_bad_vertex(float("nan"))), "not finite"),
        "nan_obj": (obj(folder / "nan.obj", with_bad_vertex(float("nan"))), "not finite"),
        "overflow_obj": (overflow_obj(folder / "overflow.obj"), "not finite"),
        "inf_dae": (dae(folder / "inf.dae", with_bad_vertex()), "not finite"),
        "garbage_obj": (garbage, "garbage.obj"),
        "empty_stl": (empty, "no triangles"),
        "flat_stl": (binary_stl(folder / "flat.stl", flat_vertices()), "flat"),
        "big_stl": (big_stl(folder / "big.stl"), "1250000 triangles, over the limit of 200000"),
    }
