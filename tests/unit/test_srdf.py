"""Named poses from a robot's SRDF (initial_pose:=), found beside its URDF."""

from __future__ import annotations

import pytest

from nodes.urdf.model import UrdfError
from nodes.urdf.srdf import find_srdf, named_pose

SRDF = """<robot name="bot"><group name="all"/>
<group_state name="crouch" group="all"><joint name="root_joint" value="0 0 1 0 0 0 1"/>
<joint name="knee" value="0.8"/><joint name="hip" value="-0.4"/></group_state></robot>"""


def test_a_group_state_beside_the_urdf(tmp_path):
    (tmp_path / "urdf").mkdir()
    (tmp_path / "srdf").mkdir()
    urdf = tmp_path / "urdf" / "bot.urdf"
    urdf.write_text("<robot name='bot'/>")
    (tmp_path / "srdf" / "other.srdf").write_text("<robot name='other'/>")
    (tmp_path / "srdf" / "bot.srdf").write_text(SRDF)
    assert find_srdf(urdf, "bot") == tmp_path / "srdf" / "bot.srdf"
    assert named_pose(urdf, "bot", "crouch") == {"knee": 0.8, "hip": -0.4}   # the floating base's 7 left out
    with pytest.raises(UrdfError, match="'stand': not a group_state of .* \\(it has: crouch\\)"):
        named_pose(urdf, "bot", "stand")
    with pytest.raises(UrdfError, match="no SRDF of robot 'nobody'"):
        named_pose(urdf, "nobody", "crouch")
