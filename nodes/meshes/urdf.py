"""A URDF's meshes made ready for the physics: every ``<mesh filename>`` found, checked and replaced by the
converted files (``convert``), before DART's loader, which would read any file and crash on bad numbers, sees
the description.

- a visual mesh becomes one ``<visual>`` per material, each coloured with the file's own colour (a mesh's
  colours win over the URDF's ``<material>``, as RViz and Gazebo draw them); a missing visual mesh is a
  warning naming the file, and the link is drawn without it, as Gazebo does;
- a collision mesh becomes its hull, its convex parts or itself (``CollisionPolicy``); a missing one is an
  error naming the file;
- files and triangles are counted for the whole robot (``MeshBudget``).
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
from pathlib import Path

from lxml import etree

from nodes.meshes.convert import CollisionPolicy, collision_files, visual_files
from nodes.meshes.load import MeshBudget, MeshError, check_scale, load_mesh
from nodes.meshes.paths import MissingMesh, resolve_mesh
from nodes.urdf.xml_safety import parse_xml


@dataclass
class PreparedUrdf:
    xml: str
    warnings: list[str] = field(default_factory=list)
    meshes: int = 0           # mesh elements converted
    cached: int = 0           # of which the cache had the conversion


def base_path(base_uri: str) -> Path | None:
    """The robot file a ``file://`` base URI names (None for a description sent without a file)."""
    if base_uri.startswith("file://"):
        from urllib.parse import unquote, urlparse  # noqa: PLC0415

        return Path(unquote(urlparse(base_uri).path))
    return Path(base_uri) if base_uri else None


def prepare_urdf(xml: str, base: Path | None, owner: str, policy: CollisionPolicy | None = None, *,
                 resolved: bool = False) -> PreparedUrdf:
    """``xml`` with every mesh replaced by checked, converted files; MeshError names the link, the file and
    the reason. A URDF without meshes comes back unchanged. ``resolved``: its absolute mesh paths were
    resolved and checked by ``nodes.urdf.paths`` already (the simulator's ``RobotInfo.physics``)."""
    if "<mesh" not in xml:
        return PreparedUrdf(xml)
    policy = policy or CollisionPolicy()
    root = parse_xml(xml.encode() if isinstance(xml, str) else xml)
    budget = MeshBudget(owner)
    out = PreparedUrdf(xml)
    for link in root.iter("link"):
        name = link.get("name", "")
        for element in list(link):
            if element.tag not in ("visual", "collision"):
                continue
            mesh_element = element.find("geometry/mesh")
            if mesh_element is None:
                continue
            _convert(link, name, element, mesh_element, base, policy, budget, out, resolved)
    out.xml = etree.tostring(root, encoding="unicode")
    return out


def _convert(link, name: str, element, mesh_element, base: Path | None, policy: CollisionPolicy,
             budget: MeshBudget, out: PreparedUrdf, resolved: bool) -> None:
    visual = element.tag == "visual"
    filename = mesh_element.get("filename", "")
    where = f"link {name!r} {element.tag} mesh {filename[:200]!r}"
    try:
        try:
            path = Path(filename) if resolved and Path(filename).is_absolute() else resolve_mesh(filename, base)
        except MissingMesh as exc:
            if not visual:
                raise
            out.warnings.append(f"{owner_of(budget)}: {where}: {exc}; the link is drawn without it")
            link.remove(element)
            return
        scale = mesh_element.get("scale")
        if scale is not None:
            check_scale(scale.split(), "scale")
        mesh = load_mesh(path)
        budget.add(mesh)
        if visual:
            files, hit = visual_files(mesh)
        else:
            paths, hit = collision_files(mesh, policy.mode(name))
            files = [(p, None) for p in paths]
    except (MeshError, ValueError) as exc:
        raise MeshError(f"{owner_of(budget)}: {where}: {exc}") from None
    out.meshes += 1
    out.cached += hit
    anchor = element
    for i, (file, rgba) in enumerate(files):
        target = element if i == 0 else copy.deepcopy(element)
        target.find("geometry/mesh").set("filename", file.as_uri())
        if visual and rgba is not None:
            _colour(target, rgba)
        if i:
            anchor.addnext(target)
            anchor = target
        if target.get("name") and i:
            target.set("name", f"{target.get('name')}_{i}")


def _colour(visual, rgba) -> None:
    """The visual's material as the mesh's own colour (DART's loader reads ``<material><color>``)."""
    for material in visual.findall("material"):
        visual.remove(material)
    # urdfdom requires a material's name; one per colour keeps its table of materials consistent
    values = [min(max(int(round(c * 255)), 0), 255) for c in rgba]
    material = etree.SubElement(visual, "material", name="mesh_colour_" + "".join(f"{v:02x}" for v in values))
    etree.SubElement(material, "color", rgba=" ".join(f"{v / 255:.4g}" for v in values))


def owner_of(budget: MeshBudget) -> str:
    return budget.owner
