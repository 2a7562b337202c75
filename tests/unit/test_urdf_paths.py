"""A URDF's file references: package://, model://, file://, absolute and relative, kept inside their package."""

from __future__ import annotations

import pytest

from nodes.urdf.paths import PathError, resolve_uri


@pytest.fixture
def repo(tmp_path):
    """A downloaded description repository: my_robot_description/{urdf,meshes}, with a package.xml."""
    root = tmp_path / "ws" / "my_robot_description"
    (root / "urdf").mkdir(parents=True)
    (root / "meshes").mkdir()
    (root / "package.xml").write_text("<package><name>my_robot_description</name></package>")
    (root / "meshes" / "base.stl").write_text("solid x\nendsolid x\n")
    (tmp_path / "secret.txt").write_text("no")
    return root


def test_package_among_the_urdf_ancestors(repo):
    base = repo / "urdf" / "robot.urdf"
    expected = repo / "meshes" / "base.stl"
    assert resolve_uri("package://my_robot_description/meshes/base.stl", base) == expected
    assert resolve_uri("model://my_robot_description/meshes/base.stl", base.as_uri()) == expected


def test_relative_and_file_paths_inside_the_package(repo):
    base = repo / "urdf" / "robot.urdf"
    expected = repo / "meshes" / "base.stl"
    assert resolve_uri("../meshes/base.stl", base) == expected
    assert resolve_uri(expected.as_uri(), base) == expected
    assert resolve_uri(str(expected), base) == expected


@pytest.mark.parametrize("uri", [
    "package://my_robot_description/../secret.txt",
    "../../../secret.txt",
    "/etc/passwd",
    "file:///etc/passwd",
])
def test_paths_escaping_their_package_are_refused_named(repo, uri):
    with pytest.raises(PathError, match="outside its package root") as info:
        resolve_uri(uri, repo / "urdf" / "robot.urdf")
    assert repr(uri) in str(info.value)


def test_a_package_found_nowhere_lists_where_it_looked(repo):
    with pytest.raises(PathError, match="package 'nowhere_pkg' not found") as info:
        resolve_uri("package://nowhere_pkg/x.stl", repo / "urdf" / "robot.urdf")
    assert "ament_index" in str(info.value) and "folders named 'nowhere_pkg'" in str(info.value)


def test_a_missing_file_is_named(repo):
    with pytest.raises(PathError, match="does not exist"):
        resolve_uri("package://my_robot_description/meshes/gone.stl", repo / "urdf" / "robot.urdf")


def test_the_ament_index_of_pip_installed_robots():
    from importlib.metadata import PackageNotFoundError, distribution

    try:
        distribution("example-robot-data")
    except PackageNotFoundError:
        pytest.skip("example-robot-data (the robots extra) not installed")
    path = resolve_uri("package://example-robot-data/robots/g1_description/meshes/pelvis.STL")
    assert path.is_file() and path.name == "pelvis.STL"
