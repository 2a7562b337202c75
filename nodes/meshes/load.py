"""Reading a mesh file safely: STL (binary and ASCII), OBJ (with its MTL colours) and DAE (Collada, with its
unit and up axis), checked before and after reading.

Before: the file's size and its triangle count are read from what the file declares (a binary STL's header
count, which must match its size; the ``facet`` / ``f`` lines and ``<triangles count>`` of the text formats),
so a file over the caps costs a few bytes of reading, not the memory of loading it. After: every vertex finite,
every index in range, at least one triangle, nothing farther than ``MAX_COORDINATE``. Nothing else in the
project (DART, FCL, Embree, Rerun) reads a mesh file the user named: they get what passed here.
"""

from __future__ import annotations

import hashlib
import math
import re
import stat
import threading
from collections import OrderedDict
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from nodes.core import memory

MAX_MESH_BYTES = 64 * 1024 * 1024        # any mesh file
MAX_TEXT_MESH_BYTES = 16 * 1024 * 1024   # ASCII STL, OBJ, DAE: parsing text costs ~10x its size in memory
MAX_MESH_TRIANGLES = 200_000             # one file (the renderer's per-mesh cap)
MAX_ROBOT_TRIANGLES = 1_000_000          # every mesh of one robot or model together (G1: 499,375)
MAX_ROBOT_MESH_FILES = 256               # distinct mesh files of one robot or model (G1: 51)
MAX_COORDINATE = 1e4                     # m, of any vertex, units and scale applied
MAX_SCALE = 1e3                          # a scale factor's size, and its inverse

FORMATS = {".stl": "stl", ".obj": "obj", ".dae": "dae"}
_STL_RECORD = np.dtype([("normal", "<f4", (3,)), ("corners", "<f4", (3, 3)), ("attribute", "<u2")])
_DAE_COUNTS = re.compile(rb"<(?:triangles|polylist|polygons|trifans|tristrips)\b[^>]*?\bcount\s*=\s*[\"'](\d+)")
# the number lists of the text formats (vertex lines, Collada's float arrays), for the non-finite check: the
# parsers would silently drop a triangle with an "inf" or "nan" corner, or read "1e999" as inf
_NUMBERS = {"stl-ascii": re.compile(rb"(?mi)^[ \t]*vertex[ \t]+([^\n]*)"),
            "obj": re.compile(rb"(?m)^v[ \t]+([^\n#]*)"),
            "dae": re.compile(rb"<float_array\b[^>]*>([^<]*)</float_array>")}
_NON_FINITE = re.compile(rb"(?i)(?<![\w.])[-+]?(?:nan|inf(?:inity)?)(?![\w.])|\d[eE]\+?\d{3,}")
_DAE_UNIT = re.compile(rb"<unit\b[^>]*?\bmeter\s*=\s*[\"']([^\"']+)")
_DAE_UP = re.compile(rb"<up_axis>\s*([XYZ])_UP\s*</up_axis>")
# Collada's up axis turned into ROS's z up, as assimp (RViz) and Gazebo turn it
_UP_ROTATIONS = {b"Y": np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]]),
                 b"X": np.array([[0.0, -1, 0], [1, 0, 0], [0, 0, 1]])}


class MeshError(ValueError):
    """A mesh file refused: the message names the file and the reason."""


@dataclass(frozen=True)
class MeshPart:
    """One material's triangles: ``vertices`` (N, 3) float64 in metres, z up; ``faces`` (M, 3) int64;
    ``rgba`` the file's own colour (0..1), None when the file gives none."""

    vertices: np.ndarray
    faces: np.ndarray
    rgba: tuple[float, float, float, float] | None = None


@dataclass(frozen=True)
class MeshData:
    """A checked mesh file: its parts (one per material), its format and the SHA-256 of its bytes."""

    path: Path
    format: str
    digest: str
    parts: tuple[MeshPart, ...]

    @property
    def triangles(self) -> int:
        return sum(len(part.faces) for part in self.parts)

    def merged(self) -> tuple[np.ndarray, np.ndarray]:
        """Every part's vertices and faces as one mesh."""
        vertices, faces, offset = [], [], 0
        for part in self.parts:
            vertices.append(part.vertices)
            faces.append(part.faces + offset)
            offset += len(part.vertices)
        return np.concatenate(vertices), np.concatenate(faces)


@dataclass
class MeshBudget:
    """The caps counted over one robot or model: distinct files and triangles."""

    owner: str
    files: set[Path] = field(default_factory=set)
    triangles: int = 0

    def add(self, mesh: MeshData) -> None:
        if mesh.path in self.files:
            return
        self.files.add(mesh.path)
        self.triangles += mesh.triangles
        if len(self.files) > MAX_ROBOT_MESH_FILES:
            raise MeshError(f"{self.owner}: more than {MAX_ROBOT_MESH_FILES} mesh files (the limit per robot or "
                            f"model), reached at {mesh.path}")
        if self.triangles > MAX_ROBOT_TRIANGLES:
            raise MeshError(f"{self.owner}: its meshes have {self.triangles} triangles, over the limit of "
                            f"{MAX_ROBOT_TRIANGLES} per robot or model (reached at {mesh.path})")


def preload() -> threading.Thread:
    """Import the readers of text meshes and hulls (trimesh, scipy: seconds on a loaded machine) on a thread
    of their own, so that the first mesh a request brings does not stall the caller for the import."""
    def run() -> None:
        import scipy.spatial  # noqa: F401, PLC0415
        import trimesh  # noqa: F401, PLC0415

    thread = threading.Thread(target=run, name="mesh-preload", daemon=True)
    thread.start()
    return thread


def probe(path: Path) -> tuple[str, int, int]:
    """``(format, bytes, triangles)`` of a mesh file from its size and what it declares, reading at most its
    header (binary STL) or its bytes (text formats, under ``MAX_TEXT_MESH_BYTES``); MeshError over a cap.
    For text formats the count is a lower bound (a polygon counts as one triangle)."""
    path = Path(path)
    kind = FORMATS.get(path.suffix.lower())
    if kind is None:
        raise MeshError(f"{path}: {path.suffix or 'a file without a suffix'} is not a mesh format read here "
                        "(STL, OBJ, DAE)")
    try:
        info = path.stat()
    except OSError as exc:
        raise MeshError(f"{path}: cannot be read: {exc.strerror or exc}") from None
    if not stat.S_ISREG(info.st_mode):
        raise MeshError(f"{path}: not a regular file")
    size = info.st_size
    if size > MAX_MESH_BYTES:
        raise MeshError(f"{path}: {size} bytes, over the limit of {MAX_MESH_BYTES} bytes for a mesh file")
    try:
        with open(path, "rb") as handle:
            head = handle.read(84)
    except OSError as exc:
        raise MeshError(f"{path}: cannot be read: {exc.strerror or exc}") from None
    if kind == "stl":
        count = int.from_bytes(head[80:84], "little") if len(head) == 84 else -1
        if count >= 0 and size == 84 + 50 * count:
            _check_count(path, count)
            return "stl-binary", size, count
        if not head.lstrip().lower().startswith(b"solid"):
            declared = f"its header counts {count} triangles ({84 + 50 * count} bytes)" if count >= 0 else \
                "shorter than a binary STL's 84-byte header"
            raise MeshError(f"{path}: neither a binary STL ({size} bytes, {declared}) nor an ASCII STL (it does "
                            "not start with 'solid')")
        kind = "stl-ascii"
    if size > MAX_TEXT_MESH_BYTES:
        raise MeshError(f"{path}: {size} bytes, over the limit of {MAX_TEXT_MESH_BYTES} bytes for a text mesh "
                        f"({kind})")
    data = _read(path)
    count = _text_triangles(kind, data.lower() if kind == "stl-ascii" else data)
    _check_count(path, count)
    return kind, size, count


def _check_count(path: Path, count: int) -> None:
    if count > MAX_MESH_TRIANGLES:
        raise MeshError(f"{path}: {count} triangles, over the limit of {MAX_MESH_TRIANGLES} for one mesh")


def _read(path: Path) -> bytes:
    try:
        return path.read_bytes()
    except OSError as exc:
        raise MeshError(f"{path}: cannot be read: {exc.strerror or exc}") from None


def _text_triangles(kind: str, data: bytes) -> int:
    if kind == "stl-ascii":
        return data.count(b"endloop")
    if kind == "obj":
        return data.count(b"\nf ") + data.startswith(b"f ")
    return sum(int(n) for n in _DAE_COUNTS.findall(data))


_CACHE: OrderedDict[tuple, MeshData] = OrderedDict()
# the meshes read last, kept while they fit: a scene rebuilt on every spawn re-reads its files, but a big
# robot's meshes must not stay in the simulator's memory after it is gone
_CACHE_BYTES = 32 * 1024 * 1024
_LOCK = threading.Lock()


def load_mesh(path: Path | str) -> MeshData:
    """The checked mesh of a file (MeshError naming it otherwise); the same unchanged file is read once."""
    path = Path(path)
    kind, size, _ = probe(path)
    key = (str(path), size, path.stat().st_mtime_ns)
    with _LOCK:
        if key in _CACHE:
            _CACHE.move_to_end(key)
            return _CACHE[key]
    data = _read(path)
    try:
        if kind == "stl-binary":
            parts = [_binary_stl(data)]
        else:
            parts = _with_trimesh(path, kind, data)
        mesh = MeshData(path=path, format=kind, digest=hashlib.sha256(data).hexdigest(), parts=tuple(parts))
        _check(mesh)
    finally:
        memory.release_soon()   # a parser's temporaries (a refused file's above all) go back to the system
    with _LOCK:
        _CACHE[key] = mesh
        while len(_CACHE) > 1 and sum(_nbytes(m) for m in _CACHE.values()) > _CACHE_BYTES:
            _CACHE.popitem(last=False)
    return mesh


def _nbytes(mesh: MeshData) -> int:
    return sum(part.vertices.nbytes + part.faces.nbytes for part in mesh.parts)


def _binary_stl(data: bytes) -> MeshPart:
    count = int.from_bytes(data[80:84], "little")
    records = np.frombuffer(data, dtype=_STL_RECORD, count=count, offset=84)
    vertices = records["corners"].reshape(-1, 3).astype(np.float64)
    return MeshPart(vertices, np.arange(len(vertices), dtype=np.int64).reshape(-1, 3))


def _with_trimesh(path: Path, kind: str, data: bytes) -> list[MeshPart]:
    import trimesh  # noqa: PLC0415 - only a robot or world with text meshes pays for importing it

    upper = data[:4096].upper()
    if kind == "dae" and (b"<!DOCTYPE" in upper or b"<!ENTITY" in upper):
        raise MeshError(f"{path}: a Collada file with a DOCTYPE or entities is not read")
    for numbers in _NUMBERS[kind].finditer(data):
        bad = _NON_FINITE.search(numbers.group(1))
        if bad is not None:
            line = data.count(b"\n", 0, numbers.start(1) + bad.start()) + 1
            raise MeshError(f"{path}: line {line}: a vertex coordinate is not finite "
                            f"({bad.group(0).decode(errors='replace')})")
    try:
        scene = trimesh.load(str(path), file_type=kind.removeprefix("stl-").replace("ascii", "stl"),
                             force="scene", process=False)
    except Exception as exc:   # trimesh raises many kinds for a file it cannot parse
        raise MeshError(f"{path}: cannot be read as {kind.upper()}: {str(exc)[:200] or type(exc).__name__}") \
            from None
    transform = np.eye(4)
    if kind == "dae":
        unit = _DAE_UNIT.search(data)
        if unit is not None:
            try:
                factor = float(unit.group(1))
            except ValueError:
                raise MeshError(f"{path}: <unit meter={unit.group(1)[:40]!r}> is not a number") from None
            if not (math.isfinite(factor) and 1e-6 <= factor <= 1e6):
                raise MeshError(f"{path}: <unit meter='{factor:g}'> is outside [1e-6, 1e6]")
            transform[:3, :3] *= factor
        up = _DAE_UP.search(data)
        if up is not None and up.group(1) in _UP_ROTATIONS:
            transform[:3, :3] = _UP_ROTATIONS[up.group(1)] @ transform[:3, :3]
    parts = []
    for node in scene.graph.nodes_geometry:
        matrix, name = scene.graph[node]
        geometry = scene.geometry.get(name)
        faces = getattr(geometry, "faces", None)
        if faces is None or len(faces) == 0:
            continue   # points and lines draw nothing and collide with nothing
        matrix = transform @ np.asarray(matrix, dtype=np.float64)
        vertices = np.asarray(geometry.vertices, dtype=np.float64)
        faces = np.asarray(faces, dtype=np.int64)
        if vertices.ndim != 2 or vertices.shape[1] != 3 or faces.ndim != 2 or faces.shape[1] != 3:
            raise MeshError(f"{path}: not a triangle mesh (vertices {vertices.shape}, faces {faces.shape})")
        vertices = vertices @ matrix[:3, :3].T + matrix[:3, 3]
        parts.append(MeshPart(vertices, faces, _colour(geometry)))
    return parts


def _colour(geometry) -> tuple[float, float, float, float] | None:
    """The colour a part is drawn with: its material's main colour, or the mean of its face colours."""
    visual = getattr(geometry, "visual", None)
    material = getattr(visual, "material", None)
    rgba = None
    if material is not None:
        try:
            rgba = np.asarray(material.main_color, dtype=np.float64)
        except Exception:   # a material without a colour (a texture that cannot be read)
            rgba = None
    elif visual is not None and getattr(visual, "defined", False):
        rgba = np.asarray(visual.face_colors, dtype=np.float64).mean(axis=0)
    if rgba is None or rgba.shape != (4,) or not np.isfinite(rgba).all():
        return None
    return tuple(float(min(max(c / 255.0, 0.0), 1.0)) for c in rgba)   # type: ignore[return-value]


def _check(mesh: MeshData) -> None:
    path = mesh.path
    count = 0
    for part in mesh.parts:
        vertices, faces = part.vertices, part.faces
        if vertices.ndim != 2 or vertices.shape[1] != 3 or faces.ndim != 2 or faces.shape[1] != 3:
            raise MeshError(f"{path}: not a triangle mesh")
        finite = np.isfinite(vertices).all(axis=1)
        if not finite.all():
            index = int(np.argmin(finite))
            raise MeshError(f"{path}: vertex {index} is not finite ({', '.join(f'{v:g}' for v in vertices[index])})")
        if len(faces) and (int(faces.min()) < 0 or int(faces.max()) >= len(vertices)):
            raise MeshError(f"{path}: a triangle's vertex index is out of range of the {len(vertices)} vertices")
        if len(vertices) and float(np.abs(vertices).max()) > MAX_COORDINATE:
            raise MeshError(f"{path}: a vertex is farther than {MAX_COORDINATE:g} m from the origin "
                            f"({float(np.abs(vertices).max()):g})")
        count += len(faces)
    if count == 0:
        raise MeshError(f"{path}: no triangles (an empty mesh, or not a {mesh.format.split('-')[0].upper()} file)")
    _check_count(path, count)


def check_scale(scale, where: str) -> tuple[float, float, float]:
    """A mesh's scale: three finite factors whose sizes are within [1/MAX_SCALE, MAX_SCALE]."""
    values = tuple(float(v) for v in scale)
    if len(values) != 3 or not all(math.isfinite(v) and 1.0 / MAX_SCALE <= abs(v) <= MAX_SCALE for v in values):
        raise MeshError(f"{where}: scale {values} must be three finite factors within [{1.0 / MAX_SCALE:g}, "
                        f"{MAX_SCALE:g}] in size")
    return values   # type: ignore[return-value]
