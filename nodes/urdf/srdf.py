"""Named poses of a robot from its SRDF (MoveIt's semantic description): ``<group_state name=...>``.

A robot's SRDF sits beside its URDF the way description packages lay it out (``srdf/<robot>.srdf`` next to
``urdf/`` or ``robots/``); the one whose ``<robot name>`` is the URDF's is taken. Multi-value joints (a
floating base's 7 numbers) are not joint positions and are left out.
"""

from __future__ import annotations

from pathlib import Path

from nodes.urdf.model import UrdfError
from nodes.urdf.xml_safety import parse_xml

MAX_SRDF_BYTES = 4 * 1024 * 1024


def find_srdf(urdf: Path, robot: str) -> Path | None:
    """The SRDF of robot ``robot`` near its URDF file: in the URDF's folder or a ``srdf`` folder beside it."""
    folder = urdf.resolve().parent
    candidates = [*sorted(folder.glob("*.srdf")), *sorted((folder.parent / "srdf").glob("*.srdf"))]
    for path in sorted(candidates, key=lambda p: p.stem != robot):   # <robot>.srdf first
        try:
            if path.stat().st_size <= MAX_SRDF_BYTES and parse_xml(path.read_bytes()).get("name") == robot:
                return path
        except (OSError, ValueError):
            continue
    return None


def group_states(path: Path) -> dict[str, dict[str, float]]:
    """Every ``<group_state>`` of an SRDF: name -> {joint: position}."""
    try:
        root = parse_xml(path.read_bytes())
    except (OSError, ValueError) as exc:
        raise UrdfError(f"SRDF {path}: {exc}") from None
    states: dict[str, dict[str, float]] = {}
    for state in root.findall("group_state"):
        joints: dict[str, float] = {}
        for joint in state.findall("joint"):
            values = (joint.get("value") or "").split()
            if len(values) != 1:
                continue
            try:
                joints[joint.get("name", "")] = float(values[0])
            except ValueError:
                raise UrdfError(f"SRDF {path} line {joint.sourceline}: group_state '{state.get('name')}' joint "
                                f"'{joint.get('name')}' value {values[0]!r} is not a number") from None
        states.setdefault(state.get("name", ""), {}).update(joints)
    return states


def named_pose(urdf: Path, robot: str, name: str) -> dict[str, float]:
    """The joint positions of pose ``name`` in the robot's SRDF; raises UrdfError naming what is missing."""
    srdf = find_srdf(urdf, robot)
    if srdf is None:
        raise UrdfError(f"initial pose {name!r}: no SRDF of robot {robot!r} beside {urdf} (looked in "
                        f"{urdf.resolve().parent} and {urdf.resolve().parent.parent / 'srdf'})")
    states = group_states(srdf)
    if name not in states:
        raise UrdfError(f"initial pose {name!r}: not a group_state of {srdf} (it has: "
                        f"{', '.join(states) or 'none'})")
    return states[name]
