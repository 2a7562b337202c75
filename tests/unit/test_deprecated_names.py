"""Old names kept as warned aliases after issue 24's "one way per concept" renames: they still work, and the
warning names the new spelling."""

from __future__ import annotations

import pytest


def test_visualiser_is_the_viewer_under_its_old_name() -> None:
    from nodes.viz import node

    assert node.Viewer.default_name == "viewer"
    with pytest.warns(DeprecationWarning, match=r"Visualiser is deprecated: use nodes\.viz\.node\.Viewer"):
        assert node.Visualiser is node.Viewer
    with pytest.raises(AttributeError):
        node.NoSuchThing  # noqa: B018 - the module's __getattr__ still refuses unknown names
