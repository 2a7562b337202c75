"""SDF world and model files (Gazebo Classic ``.world``, SDF 1.4-1.7, and new Gazebo ``.sdf``, 1.8+) read into
plain descriptions: physics, gravity, the ground, models with their links, shapes, colours and joints.

Why our own reader and not ``dartpy.utils.SdfParser.readWorld`` (measured on dartpy 6.20): it ignores
``<gravity>`` under ``<world>`` (SDF >= 1.6), ``<static>`` (a static table falls), every ``<include>`` and
``real_time_factor``, and fails a whole world on an ``<inertia>`` without its zero off-diagonal terms, which
SDF allows. Reading the XML here (through the project's XML safety check: entity declarations and external
DTDs refused) lets every error name the file, the line and the reason, and lets the limits be counted
before anything is parsed. No DART here: ``sdf_model`` builds the skeletons.
"""

from __future__ import annotations

import math
import os
import re
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from lxml import etree

from nodes.core import names as ros_names
from nodes.packages.index import PackageNotFoundError, find_share
from nodes.share import WORLDS_DIR
from nodes.share import world_file as shared_world_file
from nodes.urdf.model import rpy_matrix
from nodes.urdf.xml_safety import UnsafeXmlError, parse_xml

# Counted before parsing, so a hostile file costs a stat and a regex scan, never a parse or a DART build.
MAX_FILE_BYTES = 8 * 1024 * 1024          # a world or model.sdf file
MAX_MESH_BYTES = 64 * 1024 * 1024         # one mesh file
MAX_MODELS = 1000                          # <model> and <include> elements of a world, includes counted in
MAX_LINKS = 5000                           # links of a world, all models together
# links of one model, nested and included ones counted in: DART's cost of adding a link grows with the links
# already in the skeleton (measured: 128 free links 0.45 s, 256 links 3.1 s, 500 links 32 s, during which the
# simulator serves nothing); the same figure as a URDF robot's
MAX_MODEL_LINKS = 128
MAX_INCLUDE_DEPTH = 8
# Plausible values (DART integrates anything: a 1e300 kg box or a 1e-300 inertia ends in NaN, not an error).
MAX_COORDINATE = 1e4                       # m, of any pose
MAX_SIZE = 1e4                             # m, of a shape
MAX_MASS = 1e6                             # kg
MIN_MASS = 1e-6                            # kg, of a dynamic link
MAX_INERTIA = 1e6                          # kg m^2
MAX_SCALE = 1e3
MODEL_PATH_VARIABLES = ("ZENROID_MODEL_PATH", "GAZEBO_MODEL_PATH", "GZ_SIM_RESOURCE_PATH")
BUILTIN_MODELS = ("ground_plane", "sun")
JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "ball")
DEFAULT_GRAVITY = (0.0, 0.0, -9.8)         # SDF's default
# Gazebo Classic's material scripts by name (Gazebo/*.material diffuse colours) for worlds that use them.
SCRIPT_COLOURS = {
    "Gazebo/White": (1.0, 1.0, 1.0, 1.0), "Gazebo/Grey": (0.7, 0.7, 0.7, 1.0),
    "Gazebo/DarkGrey": (0.35, 0.35, 0.35, 1.0), "Gazebo/Black": (0.1, 0.1, 0.1, 1.0),
    "Gazebo/Red": (1.0, 0.0, 0.0, 1.0), "Gazebo/Green": (0.0, 1.0, 0.0, 1.0),
    "Gazebo/Blue": (0.0, 0.0, 1.0, 1.0), "Gazebo/Yellow": (1.0, 1.0, 0.0, 1.0),
    "Gazebo/Orange": (1.0, 0.5, 0.09, 1.0), "Gazebo/Purple": (1.0, 0.0, 1.0, 1.0),
    "Gazebo/Wood": (0.6, 0.4, 0.2, 1.0), "Gazebo/WoodFloor": (0.6, 0.45, 0.3, 1.0),
}

# What each element holds that we read; anything else is listed once in the log as not simulated.
_WORLD_READ = {"physics", "gravity", "include", "model", "gui"}
_MODEL_READ = {"static", "pose", "link", "joint", "include", "model"}
_LINK_READ = {"pose", "inertial", "collision", "visual", "gravity"}


class WorldError(ValueError):
    """A world or model file (or a spawn request) that cannot be used: the message names the file, the line
    and the reason."""


class _MissingMesh(WorldError):
    """A mesh path inside its model's folder with no file there: an error for a collision, a note for a
    visual (the link is drawn without it, as Gazebo does)."""


@dataclass
class ShapeSpec:
    """One ``<collision>`` or ``<visual>``: kind box / cylinder / sphere / plane / mesh, in metres."""

    kind: str
    pose: np.ndarray                                         # 4x4 in the link frame
    size: tuple[float, ...] = ()                             # box (x, y, z); cylinder (radius, length);
                                                             # sphere (radius,); plane (size x, size y)
    normal: tuple[float, float, float] = (0.0, 0.0, 1.0)     # plane
    mesh: Path | None = None
    scale: tuple[float, float, float] = (1.0, 1.0, 1.0)      # mesh
    colour: tuple[float, float, float, float] | None = None  # visuals: material diffuse
    friction: float | None = None                            # collisions: surface/friction/ode/mu


@dataclass
class InertialSpec:
    mass: float
    pose: np.ndarray                                         # centre of mass frame in the link frame
    moments: np.ndarray                                      # 3x3 about the centre of mass


@dataclass
class LinkSpec:
    name: str
    pose: np.ndarray                                         # 4x4 in the model frame
    inertial: InertialSpec | None = None
    collisions: list[ShapeSpec] = field(default_factory=list)
    visuals: list[ShapeSpec] = field(default_factory=list)
    fixed_to_world: bool = False                             # a link of a static nested model
    gravity: bool = True


@dataclass
class JointSpec:
    name: str
    type: str
    parent: str                                              # a link name or "world"
    child: str
    pose: np.ndarray                                         # joint frame in the child link frame
    axis: tuple[float, float, float] = (0.0, 0.0, 1.0)       # in the joint frame (or the model's)
    axis_in_model: bool = False                              # use_parent_model_frame / expressed_in __model__
    lower: float = -math.inf
    upper: float = math.inf
    effort: float = math.inf
    velocity: float = math.inf
    damping: float = 0.0
    friction: float = 0.0


@dataclass
class ModelSpec:
    name: str
    pose: np.ndarray                                         # 4x4 in the world
    static: bool = False
    links: list[LinkSpec] = field(default_factory=list)
    joints: list[JointSpec] = field(default_factory=list)
    source: str = ""                                         # the file it came from (error messages)


@dataclass
class PhysicsSpec:
    max_step_size: float = 0.001
    real_time_factor: float = 1.0
    real_time_update_rate: float = 1000.0


@dataclass
class WorldSpec:
    name: str
    path: Path | None
    version: str
    physics: PhysicsSpec
    gravity: tuple[float, float, float]
    ground: np.ndarray | None = None                         # pose of the built-in ground_plane, if included
    models: list[ModelSpec] = field(default_factory=list)
    not_simulated: Counter = field(default_factory=Counter)   # element path -> count (listed once in the log)
    camera_pose: np.ndarray | None = None                    # <gui><camera><pose>

    def summary(self) -> str:
        static = sum(m.static for m in self.models)
        return (f"world {self.name!r} from {self.path or 'text'} (SDF {self.version}): {len(self.models)} models "
                f"({static} static), ground {'on' if self.ground is not None else 'off'}, gravity "
                f"{list(self.gravity)}, step {self.physics.max_step_size:g} s, real_time_factor "
                f"{self.physics.real_time_factor:g}, real_time_update_rate {self.physics.real_time_update_rate:g}")

    def not_simulated_line(self) -> str:
        """One log line naming every element accepted but not simulated ('' when there are none)."""
        if not self.not_simulated:
            return ""
        items = ", ".join(f"{name}" + (f" x{n}" if n > 1 else "") for name, n in sorted(self.not_simulated.items()))
        return f"world {self.name!r}: accepted but not simulated: {items}"


# ----------------------------------------------------------------------------------------------- lookup
def world_file(name: str) -> Path:
    """A world as a path, or a name in ``worlds/`` (``simple_lab``, ``simple_lab.world``, ``empty.sdf``)."""
    try:
        return shared_world_file(name).resolve()
    except FileNotFoundError as exc:
        shipped = ", ".join(sorted(p.name for p in WORLDS_DIR.glob("*.world"))) or "none"
        raise WorldError(f"{exc} (shipped: {shipped})") from None


def model_path(environ: dict[str, str] | None = None) -> list[Path]:
    """The folders ``model://NAME`` is looked up in: ZENROID_MODEL_PATH, GAZEBO_MODEL_PATH, GZ_SIM_RESOURCE_PATH."""
    env = os.environ if environ is None else environ
    folders: list[Path] = []
    for variable in MODEL_PATH_VARIABLES:
        for entry in env.get(variable, "").split(os.pathsep):
            if entry.strip():
                folders.append(Path(entry.strip()).expanduser())
    return folders


# ----------------------------------------------------------------------------------------------- reading
def read_limited(path: Path, limit: int, what: str) -> bytes:
    """A file's bytes, refused by its size before it is read."""
    try:
        size = path.stat().st_size
    except OSError as exc:
        raise WorldError(f"{path}: cannot read {what}: {exc.strerror or exc}") from None
    if size > limit:
        raise WorldError(f"{path}: {what} is {size} bytes, more than the limit of {limit} bytes")
    try:
        return path.read_bytes()
    except OSError as exc:
        raise WorldError(f"{path}: cannot read {what}: {exc.strerror or exc}") from None


_ELEMENT_COUNT = re.compile(rb"<\s*(model|include|link)\b")


def _count_elements(data: bytes, where: str) -> Counter:
    counts = Counter(match.group(1).decode() for match in _ELEMENT_COUNT.finditer(data))
    if counts["model"] + counts["include"] > MAX_MODELS:
        raise WorldError(f"{where}: {counts['model'] + counts['include']} <model>/<include> elements, more than "
                         f"the limit of {MAX_MODELS}")
    if counts["link"] > MAX_LINKS:
        raise WorldError(f"{where}: {counts['link']} <link> elements, more than the limit of {MAX_LINKS}")
    return counts


def _parse(data: bytes | str, where: str) -> etree._Element:
    raw = data.encode("utf-8") if isinstance(data, str) else data
    _count_elements(raw, where)
    try:
        root = parse_xml(raw)
    except UnsafeXmlError as exc:
        raise WorldError(f"{where}: {exc}") from None
    except ValueError as exc:
        raise WorldError(f"{where}: {exc}") from None
    if root.tag != "sdf":
        raise WorldError(f"{where}: line {root.sourceline}: the root element is <{root.tag}>, expected <sdf>")
    version = root.get("version", "")
    if not re.fullmatch(r"1\.\d+", version):
        raise WorldError(f"{where}: line {root.sourceline}: <sdf version={version!r}>: expected a version 1.x "
                         "(1.4 to 1.7: Gazebo Classic; 1.8 and later: new Gazebo)")
    return root


def load_world(name: str, environ: dict[str, str] | None = None) -> WorldSpec:
    """Read a world file (a path or a name in ``worlds/``); raises WorldError naming file, line and reason."""
    path = world_file(name)
    data = read_limited(path, MAX_FILE_BYTES, "world file")
    return parse_world(data, path, environ)


def parse_world(data: bytes | str, path: Path | None = None, environ: dict[str, str] | None = None) -> WorldSpec:
    where = str(path) if path else "world"
    root = _parse(data, where)
    worlds = root.findall("world")
    if len(worlds) != 1:
        raise WorldError(f"{where}: expected exactly one <world>, found {len(worlds)}")
    reader = _Reader(where, path.parent if path else Path.cwd(), model_path(environ))
    world = reader.world(worlds[0], root.get("version"))
    world.path = path
    return world


def parse_model(text: str, where: str = "request", environ: dict[str, str] | None = None) -> ModelSpec:
    """An SDF model as a spawn request carries it (``<sdf><model>``); relative mesh paths have no folder to
    resolve in and are refused, ``model://`` URIs resolve through the model path."""
    root = _parse(text, where)
    models = root.findall("model")
    if len(models) != 1:
        raise WorldError(f"{where}: expected exactly one <model> under <sdf>, found {len(models)}")
    reader = _Reader(where, None, model_path(environ))
    return reader.model(models[0], np.eye(4), None, [])


def is_sdf(text: str) -> bool:
    """Whether a spawn request's text is SDF (an ``<sdf>`` root) rather than URDF."""
    head = re.sub(r"^\s*(<\?xml[^>]*\?>\s*)?((<!--.*?-->|<!DOCTYPE[^\[>]*(\[.*?\])?\s*>)\s*)*", "",
                  text[:4096], flags=re.DOTALL)
    return head.startswith("<sdf")


# ----------------------------------------------------------------------------------------------- elements
def _line(element: etree._Element) -> str:
    return f"line {element.sourceline}"


class _Budget:
    """Models and links of one whole reading (a world or a spawned model, every include expanded), counted as
    each is read: a file whose includes fan out (eight small files, each including the next ten times, are
    10^7 links) is refused at the first link over the cap, not after expanding all of it."""

    def __init__(self, where: str) -> None:
        self.where = where
        self.models = 0
        self.links = 0
        self.model_links = 0          # of the top-level model being read

    def next_model(self) -> None:
        """A top-level model of the world starts."""
        self.model_links = 0

    def model(self, where: str) -> None:
        self.models += 1
        if self.models > MAX_MODELS:
            raise WorldError(f"{self.where}: more than {MAX_MODELS} models (nested and included ones counted in; "
                             f"the limit was passed in {where})")

    def link(self, where: str) -> None:
        self.links += 1
        self.model_links += 1
        if self.model_links > MAX_MODEL_LINKS:
            raise WorldError(f"{self.where}: a model has more than {MAX_MODEL_LINKS} links (nested and included "
                             f"ones counted in; the limit was passed in {where})")
        if self.links > MAX_LINKS:
            raise WorldError(f"{self.where}: more than {MAX_LINKS} links (includes counted in; the limit was "
                             f"passed in {where})")


class _Reader:
    """One world's reading: where relative paths resolve, the model path, what was not simulated."""

    def __init__(self, where: str, folder: Path | None, models: list[Path], budget: _Budget | None = None) -> None:
        self.where = where
        self.folder = folder
        self.model_path = models
        # where file:// and local includes may point: the model path and the world file's folder
        self.roots = [Path(os.path.realpath(p)) for p in [*models, *([folder] if folder else [])]]
        self.not_simulated: Counter = Counter()
        self.budget = budget if budget is not None else _Budget(where)

    def error(self, element: etree._Element, message: str, where: str | None = None) -> WorldError:
        return WorldError(f"{where or self.where}: {_line(element)}: <{element.tag}>: {message}")

    # -- numbers ------------------------------------------------------------------------------------------
    def numbers(self, element: etree._Element, count: int, where: str) -> list[float]:
        words = (element.text or "").split()
        if len(words) != count:
            raise self.error(element, f"expected {count} number(s), got {' '.join(words)[:80]!r}", where)
        try:
            values = [float(w) for w in words]
        except ValueError:
            raise self.error(element, f"not a number: {' '.join(words)[:80]!r}", where) from None
        if not all(math.isfinite(v) for v in values):
            raise self.error(element, f"must be finite, got {' '.join(words)[:80]!r}", where)
        return values

    def number(self, parent: etree._Element, tag: str, default: float, where: str, *, low: float = -math.inf,
               high: float = math.inf, low_open: bool = False) -> float:
        element = parent.find(tag)
        if element is None:
            return default
        (value,) = self.numbers(element, 1, where)
        if value > high or value < low or (low_open and value == low):
            bound = "(" if low_open else "["
            raise self.error(element, f"{value:g} is outside {bound}{low:g}, {high:g}]", where)
        return value

    def flag(self, parent: etree._Element, tag: str, default: bool, where: str) -> bool:
        element = parent.find(tag)
        if element is None:
            return default
        text = (element.text or "").strip().lower()
        if text in ("1", "true"):
            return True
        if text in ("0", "false"):
            return False
        raise self.error(element, f"expected true or false, got {text[:40]!r}", where)

    def pose(self, parent: etree._Element, where: str) -> np.ndarray:
        element = parent.find("pose")
        if element is None:
            return np.eye(4)
        frame = element.get("relative_to", element.get("frame", ""))
        if frame:
            raise self.error(element, f"poses relative to another frame ({frame!r}) are not supported: give the "
                             "pose in its default frame", where)
        values = self.numbers(element, 6, where)
        if any(abs(v) > MAX_COORDINATE for v in values[:3]):
            raise self.error(element, f"position {values[:3]} is farther than {MAX_COORDINATE:g} m", where)
        angles = values[3:]
        if element.get("degrees", "").strip().lower() in ("1", "true"):
            angles = [math.radians(a) for a in angles]
        matrix = np.eye(4)
        matrix[:3, :3] = rpy_matrix(*angles)
        matrix[:3, 3] = values[:3]
        return matrix

    def note(self, path: str) -> None:
        self.not_simulated[path] += 1

    def note_unread(self, element: etree._Element, known: set[str], prefix: str) -> None:
        for child in element:
            if isinstance(child.tag, str) and child.tag not in known:
                self.note(f"{prefix}/{child.tag}" if prefix else child.tag)

    # -- world --------------------------------------------------------------------------------------------
    def world(self, element: etree._Element, version: str) -> WorldSpec:
        name = element.get("name", "default")
        physics_elements = element.findall("physics")
        physics_element = next((p for p in physics_elements if p.get("default", "").lower() in ("1", "true")),
                               physics_elements[0] if physics_elements else None)
        physics = PhysicsSpec()
        gravity = DEFAULT_GRAVITY
        if physics_element is not None:
            where = self.where
            physics = PhysicsSpec(
                max_step_size=self.number(physics_element, "max_step_size", 0.001, where, low=1e-5, high=0.01),
                real_time_factor=self.number(physics_element, "real_time_factor", 1.0, where, low=0.0, high=1000.0),
                real_time_update_rate=self.number(physics_element, "real_time_update_rate", 1000.0, where,
                                                  low=0.0, high=1e6))
            self.note_unread(physics_element, {"max_step_size", "real_time_factor", "real_time_update_rate",
                                               "gravity"}, "physics")
            if physics_element.find("gravity") is not None:   # SDF < 1.6
                gravity = self.gravity(physics_element.find("gravity"))
        if element.find("gravity") is not None:               # SDF >= 1.6
            gravity = self.gravity(element.find("gravity"))
        world = WorldSpec(name=name, path=None, version=version, physics=physics, gravity=gravity)
        camera = element.find("gui/camera")
        if camera is not None and camera.find("pose") is not None:
            world.camera_pose = self.pose(camera, self.where)
        for child in element:
            if not isinstance(child.tag, str):
                continue
            self.budget.next_model()
            if child.tag == "model":
                world.models.append(self.model(child, np.eye(4), None, []))
            elif child.tag == "include":
                included = self.include(child, [])
                if isinstance(included, str):
                    if included == "ground_plane":
                        world.ground = self.pose(child, self.where)
                    else:
                        self.note("light (model://sun)")
                else:
                    world.models.append(included)
            elif child.tag == "gui":
                self.note_unread(child, {"camera"}, "gui")
            elif child.tag not in _WORLD_READ:
                self.note(child.tag)
        names = Counter(m.name for m in world.models)
        duplicate = next((n for n, c in names.items() if c > 1), None)
        if duplicate:
            raise WorldError(f"{self.where}: two models are named {duplicate!r}")
        if "ground_plane" in names and world.ground is not None:
            raise WorldError(f"{self.where}: a model named 'ground_plane' beside the built-in ground_plane")
        world.not_simulated = self.not_simulated
        return world

    def gravity(self, element: etree._Element) -> tuple[float, float, float]:
        values = self.numbers(element, 3, self.where)
        if any(abs(v) > 100.0 for v in values):
            raise self.error(element, f"{values} m/s^2: each axis must be within [-100, 100]")
        return (values[0], values[1], values[2])

    # -- includes -----------------------------------------------------------------------------------------
    def include(self, element: etree._Element, stack: list[Path]) -> ModelSpec | str:
        """The included model (its name, pose and static overridden by the include's), or the name of a
        built-in model."""
        uri_element = element.find("uri")
        uri = (uri_element.text or "").strip() if uri_element is not None else ""
        if not uri:
            raise self.error(element, "missing <uri>")
        builtin = _builtin(uri)
        if builtin:
            if stack:
                raise self.error(element, f"model://{builtin} is a world-level built-in, not a nested model")
            return builtin
        folder = self.model_folder(uri, element, self.folder)
        if folder in stack:
            chain = " -> ".join(str(p) for p in [*stack, folder])
            raise self.error(element, f"cyclic include: {chain}")
        if len(stack) >= MAX_INCLUDE_DEPTH:
            raise self.error(element, f"includes nested deeper than {MAX_INCLUDE_DEPTH}")
        sdf_path = self.model_sdf(folder, element)
        data = read_limited(sdf_path, MAX_FILE_BYTES, "model file")
        root = _parse(data, str(sdf_path))
        models = root.findall("model")
        if len(models) != 1:
            raise WorldError(f"{sdf_path}: expected exactly one <model> under <sdf>, found {len(models)}")
        inner = _Reader(str(sdf_path), folder, self.model_path, self.budget)
        inner.not_simulated = self.not_simulated
        inner.roots = self.roots
        name_element = element.find("name")
        name = (name_element.text or "").strip() if name_element is not None else None
        model = inner.model(models[0], np.eye(4), name, [*stack, folder],
                            override_pose=self.pose(element, self.where) if element.find("pose") is not None
                            else None)
        if element.find("static") is not None:
            model.static = self.flag(element, "static", False, self.where)
        self.note_unread(element, {"uri", "name", "pose", "static"}, "include")
        return model

    def model_folder(self, uri: str, element: etree._Element, base: Path | None) -> Path:
        """The folder of a model URI: ``model://NAME`` through the model path, ``file://`` or a plain path."""
        if uri.startswith("model://"):
            name = uri[len("model://"):].strip("/")
            if not name or "/" in name or name in (".", ".."):
                raise self.error(element, f"{uri!r}: expected model://NAME")
            for folder in self.model_path:
                candidate = folder / name
                if (candidate / "model.config").is_file() or (candidate / "model.sdf").is_file():
                    return candidate.resolve()
            searched = ", ".join(str(p) for p in self.model_path) or "nothing: set ZENROID_MODEL_PATH"
            raise self.error(element, f"{uri!r}: no model {name!r} in the model path (searched {searched}; "
                             f"built in: {', '.join(BUILTIN_MODELS)})")
        if "://" in uri and not uri.startswith("file://"):
            raise self.error(element, f"{uri!r}: only model://, file:// and local paths are read (nothing is "
                             "fetched from the network)")
        path = Path(uri[len("file://"):] if uri.startswith("file://") else uri).expanduser()
        if not path.is_absolute():
            if base is None:
                raise self.error(element, f"{uri!r}: a relative path has no folder to resolve in here")
            path = base / path
        # outside its roots, one answer whether the host has that folder or not: nothing about the host leaks
        outside = self.error(element, f"{uri!r}: not in the model path or the world's folder (a file:// or local "
                             "include is read only there)")
        path = Path(os.path.normpath(path))
        if not any(path.is_relative_to(root) for root in self.roots):
            raise outside
        resolved = Path(os.path.realpath(path))
        if not any(resolved.is_relative_to(root) for root in self.roots):   # a symbolic link out of them
            raise outside
        if not resolved.is_dir():
            raise self.error(element, f"{uri!r}: no model folder at {path}")
        return resolved

    def model_sdf(self, folder: Path, element: etree._Element) -> Path:
        """The model file a ``model.config`` names (the newest SDF version listed), else ``model.sdf``."""
        config = folder / "model.config"
        name = "model.sdf"
        if config.is_file():
            root = _parse_config(read_limited(config, MAX_FILE_BYTES, "model.config"), config)
            entries = [(e.get("version", "0"), (e.text or "").strip()) for e in root.findall("sdf")]
            entries = [e for e in entries if e[1]]
            if entries:
                name = max(entries, key=lambda e: _version_key(e[0]))[1]
        path = (folder / name).resolve()
        if not path.is_relative_to(folder):
            raise self.error(element, f"{config}: model file {name!r} leaves the model folder {folder}")
        if not path.is_file():
            raise self.error(element, f"{folder}: no model file {name!r}")
        return path

    # -- models -------------------------------------------------------------------------------------------
    def model(self, element: etree._Element, parent_pose: np.ndarray, name: str | None, stack: list[Path],
              override_pose: np.ndarray | None = None) -> ModelSpec:
        model_name = name or element.get("name", "")
        if (problem := ros_names.node_name_problem(model_name)) is not None:
            raise self.error(element, f"model name {ros_names.shown(model_name)}: {problem}")
        where = self.where
        self.budget.model(f"{where}: {_line(element)}")
        pose = parent_pose @ (override_pose if override_pose is not None else self.pose(element, where))
        model = ModelSpec(name=model_name, pose=pose, static=self.flag(element, "static", False, where),
                          source=where)
        for child in element:
            if not isinstance(child.tag, str):
                continue
            if child.tag == "link":
                model.links.append(self.link(child, where))
            elif child.tag == "joint":
                model.joints.append(self.joint(child, where))
            elif child.tag in ("model", "include"):
                # a nested model: its links and joints join this model, scoped "nested::name" (SDF 1.5+)
                if child.tag == "model":
                    nested = self.model(child, np.eye(4), None, stack)
                else:
                    included = self.include(child, stack)
                    if isinstance(included, str):
                        raise self.error(child, f"model://{included} cannot be nested in a model")
                    nested = included
                self.merge(model, nested, child)
            elif child.tag not in _MODEL_READ:
                self.note(f"model/{child.tag}")
        if not model.links:
            raise self.error(element, f"model {model_name!r} has no <link>")
        names = Counter(link.name for link in model.links)
        duplicate = next((n for n, c in names.items() if c > 1), None)
        if duplicate:
            raise self.error(element, f"model {model_name!r} has two links named {duplicate!r}")
        for link in model.links:
            if not model.static and not link.fixed_to_world:
                self.check_dynamic(link, model_name, element)
        return model

    def merge(self, model: ModelSpec, nested: ModelSpec, element: etree._Element) -> None:
        prefix = nested.name + "::"
        for link in nested.links:
            link.name = prefix + link.name
            link.pose = nested.pose @ link.pose
            link.fixed_to_world = link.fixed_to_world or nested.static
            model.links.append(link)
        for joint in nested.joints:
            joint.name = prefix + joint.name
            joint.child = prefix + joint.child
            if joint.parent != "world":
                joint.parent = prefix + joint.parent
            model.joints.append(joint)

    def check_dynamic(self, link: LinkSpec, model: str, element: etree._Element) -> None:
        if link.inertial is None:
            return   # SDF's default: 1 kg, unit inertia
        if link.inertial.mass < MIN_MASS:
            raise self.error(element, f"link {model}::{link.name}: mass {link.inertial.mass:g} kg of a dynamic "
                             f"link must be at least {MIN_MASS:g} kg (make the model <static> instead)")
        eigenvalues = np.linalg.eigvalsh(link.inertial.moments)
        if eigenvalues[0] <= 0:
            raise self.error(element, f"link {model}::{link.name}: inertia is not positive definite (principal "
                             f"moments {[float(f'{v:.6g}') for v in eigenvalues]}): a dynamic link needs "
                             "positive moments of inertia")

    def link(self, element: etree._Element, where: str) -> LinkSpec:
        name = element.get("name", "")
        if not name or "::" in name:
            raise self.error(element, f"link name {name!r}: required, without '::'", where)
        self.budget.link(f"{where}: {_line(element)}")
        link = LinkSpec(name=name, pose=self.pose(element, where),
                        gravity=self.flag(element, "gravity", True, where))
        inertial = element.find("inertial")
        if inertial is not None:
            link.inertial = self.inertial(inertial, where)
        for child in element:
            if not isinstance(child.tag, str):
                continue
            if child.tag == "collision":
                link.collisions.append(self.shape(child, where, visual=False))
            elif child.tag == "visual":
                try:
                    link.visuals.append(self.shape(child, where, visual=True))
                except _MissingMesh as exc:
                    self.note(f"visual {str(exc)}: drawn without it")
            elif child.tag not in _LINK_READ:
                self.note(f"link/{child.tag}")
        return link

    def inertial(self, element: etree._Element, where: str) -> InertialSpec:
        mass = self.number(element, "mass", 1.0, where, low=0.0, high=MAX_MASS)
        moments = np.eye(3)
        inertia = element.find("inertia")
        if inertia is not None:
            value = {tag: self.number(inertia, tag, 1.0 if tag in ("ixx", "iyy", "izz") else 0.0, where,
                                      low=-MAX_INERTIA, high=MAX_INERTIA)
                     for tag in ("ixx", "iyy", "izz", "ixy", "ixz", "iyz")}
            moments = np.array([[value["ixx"], value["ixy"], value["ixz"]],
                                [value["ixy"], value["iyy"], value["iyz"]],
                                [value["ixz"], value["iyz"], value["izz"]]])
        return InertialSpec(mass=mass, pose=self.pose(element, where), moments=moments)

    def shape(self, element: etree._Element, where: str, *, visual: bool) -> ShapeSpec:
        geometry = element.find("geometry")
        if geometry is None:
            raise self.error(element, "missing <geometry>", where)
        kinds = [child for child in geometry if isinstance(child.tag, str)]
        if len(kinds) != 1:
            raise self.error(geometry, f"expected one shape, found {[k.tag for k in kinds]}", where)
        shape_element = kinds[0]
        kind = shape_element.tag
        spec = ShapeSpec(kind=kind, pose=self.pose(element, where))

        def size(tag: str) -> float:
            sub = shape_element.find(tag)
            if sub is None:
                raise self.error(shape_element, f"missing <{tag}>", where)
            (value,) = self.numbers(sub, 1, where)
            if not 0 < value <= MAX_SIZE:
                raise self.error(sub, f"{value:g} m is outside (0, {MAX_SIZE:g}]", where)
            return value

        if kind == "box":
            sub = shape_element.find("size")
            if sub is None:
                raise self.error(shape_element, "missing <size>", where)
            values = self.numbers(sub, 3, where)
            if not all(0 < v <= MAX_SIZE for v in values):
                raise self.error(sub, f"{values} m: each side must be in (0, {MAX_SIZE:g}]", where)
            spec.size = tuple(values)
        elif kind == "cylinder":
            spec.size = (size("radius"), size("length"))
        elif kind == "sphere":
            spec.size = (size("radius"),)
        elif kind == "plane":
            normal = shape_element.find("normal")
            values = self.numbers(normal, 3, where) if normal is not None else [0.0, 0.0, 1.0]
            length = math.sqrt(sum(v * v for v in values))
            if length < 1e-9:
                raise self.error(normal, "the plane's normal is a zero vector", where)
            spec.normal = tuple(v / length for v in values)
            sub = shape_element.find("size")
            sides = self.numbers(sub, 2, where) if sub is not None else [100.0, 100.0]
            if not all(0 < v <= MAX_SIZE for v in sides):
                raise self.error(sub, f"{sides} m: each side must be in (0, {MAX_SIZE:g}]", where)
            spec.size = tuple(sides)
        elif kind == "mesh":
            uri_element = shape_element.find("uri")
            uri = (uri_element.text or "").strip() if uri_element is not None else ""
            if not uri:
                raise self.error(shape_element, "missing <uri>", where)
            spec.mesh = self.mesh_file(uri, shape_element, where)
            scale = shape_element.find("scale")
            if scale is not None:
                values = self.numbers(scale, 3, where)
                if not all(1.0 / MAX_SCALE <= abs(v) <= MAX_SCALE for v in values):
                    raise self.error(scale, f"{values}: each factor must be within [1e-3, 1e3] in size", where)
                spec.scale = tuple(values)
            if shape_element.find("submesh") is not None:
                self.note("mesh/submesh")
        else:
            raise self.error(shape_element, "unsupported geometry (read: box, cylinder, sphere, plane, mesh)",
                             where)
        if visual:
            spec.colour = self.colour(element.find("material"), where)
        else:
            mu = element.find("surface/friction/ode/mu")
            if mu is not None:
                (value,) = self.numbers(mu, 1, where)
                if value < 0:
                    raise self.error(mu, f"friction {value:g} must be >= 0", where)
                spec.friction = value
        return spec

    def colour(self, material: etree._Element | None, where: str) -> tuple[float, float, float, float] | None:
        if material is None:
            return None
        for tag in ("diffuse", "ambient"):
            element = material.find(tag)
            if element is not None:
                words = (element.text or "").split()
                values = self.numbers(element, len(words) if len(words) in (3, 4) else 4, where)
                if len(values) == 3:
                    values.append(1.0)
                return (min(max(values[0], 0.0), 1.0), min(max(values[1], 0.0), 1.0),
                        min(max(values[2], 0.0), 1.0), min(max(values[3], 0.0), 1.0))
        script = material.find("script/name")
        if script is not None:
            name = (script.text or "").strip()
            if name in SCRIPT_COLOURS:
                return SCRIPT_COLOURS[name]
            self.note(f"material script {name}")
        return None

    def mesh_file(self, uri: str, element: etree._Element, where: str) -> Path:
        """A mesh inside the folder of its model: ``model://NAME/...`` in NAME's folder, a relative path or
        ``file://`` in the folder of the file that names it. Its size is checked here, before DART reads it."""
        if uri.startswith("model://"):
            name, _, rest = uri[len("model://"):].partition("/")
            folder = self.model_folder(f"model://{name}", element, None)
            path = folder / rest
        elif uri.startswith("package://"):
            package, _, rest = uri[len("package://"):].partition("/")
            try:
                folder = find_share(package).resolve()   # the package index, as for URDF meshes
            except PackageNotFoundError as exc:
                raise self.error(element, f"mesh {uri[:200]!r}: {exc}", where) from None
            path = folder / rest
        else:
            if "://" in uri and not uri.startswith("file://"):
                raise self.error(element, f"mesh {uri[:200]!r}: only model://, package://, file:// and paths in "
                                 "the model's folder are read", where)
            if self.folder is None:
                raise self.error(element, f"mesh {uri[:200]!r}: a mesh in a spawn request must be a model:// URI "
                                 "(there is no folder for a path to resolve in)", where)
            folder = self.folder.resolve()
            raw = Path(uri[len("file://"):] if uri.startswith("file://") else uri)
            path = raw if raw.is_absolute() else folder / raw
        resolved = path.resolve()
        if not resolved.is_relative_to(folder):
            raise self.error(element, f"mesh {uri[:200]!r} leaves the model folder {folder}", where)
        if not resolved.is_file():
            raise _MissingMesh(self.error(element, f"mesh {uri[:200]!r}: no file at {resolved}", where))
        size = resolved.stat().st_size
        if size > MAX_MESH_BYTES:
            raise self.error(element, f"mesh {uri[:200]!r} is {size} bytes, more than the limit of "
                             f"{MAX_MESH_BYTES} bytes", where)
        return resolved

    # -- joints -------------------------------------------------------------------------------------------
    def joint(self, element: etree._Element, where: str) -> JointSpec:
        name = element.get("name", "")
        kind = element.get("type", "")
        if not name:
            raise self.error(element, "missing name", where)
        if kind not in JOINT_TYPES:
            raise self.error(element, f"joint {name!r}: type {kind!r} is not supported (read: "
                             f"{', '.join(JOINT_TYPES)})", where)
        ends = {}
        for tag in ("parent", "child"):
            sub = element.find(tag)
            if sub is None or not (sub.text or "").strip():
                raise self.error(element, f"joint {name!r}: missing <{tag}>", where)
            ends[tag] = (sub.text or "").strip()
        joint = JointSpec(name=name, type=kind, parent=ends["parent"], child=ends["child"],
                          pose=self.pose(element, where))
        axis = element.find("axis")
        if kind in ("revolute", "continuous", "prismatic"):
            xyz = axis.find("xyz") if axis is not None else None
            if xyz is not None:
                values = np.array(self.numbers(xyz, 3, where))
                length = float(np.linalg.norm(values))
                if length < 1e-9:
                    raise self.error(xyz, f"joint {name!r}: the axis is a zero vector", where)
                joint.axis_in_model = (self.flag(axis, "use_parent_model_frame", False, where)
                                       or xyz.get("expressed_in", "") == "__model__")
                joint.axis = tuple(float(v) for v in values / length)
            if axis is not None:
                limit = axis.find("limit")
                if limit is not None and kind != "continuous":
                    joint.lower = self.number(limit, "lower", -math.inf, where)
                    joint.upper = self.number(limit, "upper", math.inf, where)
                    if joint.lower > joint.upper:
                        raise self.error(limit, f"joint {name!r}: lower {joint.lower:g} > upper {joint.upper:g}",
                                         where)
                if limit is not None:
                    effort = self.number(limit, "effort", -1.0, where)
                    velocity = self.number(limit, "velocity", -1.0, where)
                    joint.effort = effort if effort >= 0 else math.inf
                    joint.velocity = velocity if velocity >= 0 else math.inf
                dynamics = axis.find("dynamics")
                if dynamics is not None:
                    joint.damping = self.number(dynamics, "damping", 0.0, where, low=0.0, high=1e6)
                    joint.friction = self.number(dynamics, "friction", 0.0, where, low=0.0, high=1e6)
        return joint


def _builtin(uri: str) -> str:
    for name in BUILTIN_MODELS:
        if uri.rstrip("/") == f"model://{name}":
            return name
    return ""


def _parse_config(data: bytes, path: Path) -> etree._Element:
    try:
        return parse_xml(data)
    except ValueError as exc:
        raise WorldError(f"{path}: {exc}") from None


def _version_key(version: str) -> tuple[int, ...]:
    try:
        return tuple(int(p) for p in version.split("."))
    except ValueError:
        return (0,)
